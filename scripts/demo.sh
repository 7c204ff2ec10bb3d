#!/usr/bin/env bash
# Set up, then inspect the bundled belly-fairing sample and issue its signed certificate with a
# DEMONSTRATION identity (made on first use in results/demo-identity/), then verify it.
# Prints the verdict, where the results are, and the verification. The exit code is the
# verdict's (0 ACCEPT, 1 REJECT, 2 INCONCLUSIVE), or 1 if the certificate does not verify.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
# A demonstration passphrase; real identities' passphrases are asked for, or passed the same way.
export QA_DEMO_PASSPHRASE=${QA_DEMO_PASSPHRASE:-demonstration-only}
id=results/demo-identity
if [ ! -f "$id/inspector.p12" ]; then
    .venv/bin/qa-inspect keygen --name "Demo Inspector" --organisation "qa-inspect demonstration" \
        --out "$id" --pass-env QA_DEMO_PASSPHRASE
fi
set +e
.venv/bin/qa-inspect inspect \
    samples/belly_fairing/nominal.csv samples/belly_fairing/measured.csv --tol 0.25 \
    --json results/belly_fairing.json --csv results/belly_fairing.csv \
    --report results/belly_fairing_certificate.pdf \
    --sign "$id/inspector.p12" --sign-pass-env QA_DEMO_PASSPHRASE \
    --part-number "BF-2231-001" --part-name "Belly fairing (sample)" --revision A \
    --serial "SN-0001" --order "DEMO" --inspector "Demo Inspector" \
    --organisation "qa-inspect demonstration" --device "CMM (simulated sample)"
verdict=$?
set -e
case $verdict in 0|1|2) ;; *) exit $verdict ;; esac
.venv/bin/qa-inspect verify results/belly_fairing_certificate.pdf --trust "$id/ca.pem" \
    --nominal samples/belly_fairing/nominal.csv --measured samples/belly_fairing/measured.csv
exit $verdict
