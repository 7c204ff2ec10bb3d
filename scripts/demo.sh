#!/usr/bin/env bash
# Set up, then inspect the bundled belly-fairing sample: prints the verdict and where the results
# are. The exit code is the verdict's (0 ACCEPT, 1 REJECT, 2 INCONCLUSIVE).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
exec .venv/bin/qa-inspect inspect \
    samples/belly_fairing/nominal.csv samples/belly_fairing/measured.csv --tol 0.25 \
    --json results/belly_fairing.json --csv results/belly_fairing.csv
