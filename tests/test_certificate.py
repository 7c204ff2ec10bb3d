"""Signed inspection certificates, end to end through the command line.

One demonstration PKI and one signed ACCEPT certificate of the bundled belly-fairing sample are
made once for the module and reused. What the tests hold against is independent of reports/:
poppler's pdfsig (with an NSS trust database built by certutil), pdftotext, pdfdetach and pdfinfo,
pyHanko used directly for the approver signature and the incremental edits, hashlib for the input
fingerprints, lxml with the official QIF 3.0 schema, and a separate command-line run of the same
inspection. pdfsig/certutil/pdftotext are required (poppler-utils, libnss3-tools): a machine
without them fails here instead of silently skipping the signature checks.
"""

import contextlib
import csv
import gc
import hashlib
import io
import json
import os
import re
import shutil
import subprocess
import warnings
from types import SimpleNamespace

import numpy as np
import pytest

from qa_app.cli import main

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BELLY_NOMINAL = os.path.join(ROOT, "samples", "belly_fairing", "nominal.csv")
BELLY_MEASURED = os.path.join(ROOT, "samples", "belly_fairing", "measured.csv")
FRAME_TEMPLATE = os.path.join(ROOT, "samples", "fuselage_frame", "template.dxf")
FRAME_MEASURED = os.path.join(ROOT, "samples", "fuselage_frame", "measured.csv")
BRACKET_NOMINAL = os.path.join(ROOT, "samples", "seat_bracket", "nominal.xyz")
XSD = os.path.join(ROOT, "tests", "data", "qif-3.0-xsd", "QIFDocument.xsd")

PASS_VAR = "QA_TEST_CERTIFICATE_PASSPHRASE"
PASSPHRASE = "Kalibrier-Passwort 42!"
INSPECTOR = "Ann Inspector"
APPROVER = "Bob Approver"
ORGANISATION = "ACME Aero QA"
INFO = {"--part-number": "D52-1100-7", "--serial": "SN-0815-X", "--inspector": INSPECTOR,
        "--organisation": ORGANISATION, "--device": "Laser tracker LT-3"}
INFO_ARGS = [a for kv in INFO.items() for a in kv]
CSV_COLUMNS = ["point", "label", "x", "y", "z", "x_reg", "y_reg", "z_reg", "deviation",
               "in_tolerance", "excluded_from_alignment"]


# ---------------------------------------------------------------------------- helpers
def tool(name: str) -> str:
    path = shutil.which(name)
    if path is None:
        pytest.fail(f"{name} is not installed. The certificate tests need poppler-utils (pdfsig, "
                    "pdftotext, pdfdetach, pdfinfo) and libnss3-tools (certutil): run "
                    "scripts/setup.sh as root, or 'sudo apt-get install poppler-utils "
                    "libnss3-tools' (CI installs them).", pytrace=False)
    return path


def run_tool(name: str, *args) -> str:
    p = subprocess.run([tool(name), *map(str, args)], capture_output=True, text=True,
                       timeout=60)
    assert p.returncode == 0, f"{name} {args} failed ({p.returncode}): {p.stderr}"
    return p.stdout


def pdfsig(pdf, nssdir=None) -> str:
    args = ([] if nssdir is None else ["-nssdir", f"sql:{nssdir}"]) + [pdf]
    p = subprocess.run([tool("pdfsig"), *map(str, args)], capture_output=True, text=True,
                       timeout=60)
    return p.stdout + p.stderr


def page_texts(pdf, layout=True) -> list[str]:
    """The text of each page (pdftotext), checked against the page count pdfinfo reports."""
    n = int(re.search(r"^Pages:\s+(\d+)", run_tool("pdfinfo", pdf), re.M).group(1))
    text = run_tool("pdftotext", *(["-layout"] if layout else ["-raw"]), pdf, "-")
    pages = text.split("\f")
    if pages and not pages[-1].strip():
        pages.pop()
    assert len(pages) == n
    return pages


def squeeze(text: str) -> str:
    return " ".join(text.split())


def cli(*args):
    """Run the command line outside capsys (fixtures): (exit code, stdout, stderr)."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main([str(a) for a in args])
    return code, out.getvalue(), err.getvalue()


def verify(capsys, pdf, *args):
    capsys.readouterr()
    code = main(["verify", str(pdf), *map(str, args)])
    cap = capsys.readouterr()
    return code, cap.out, cap.err


def byte_range(pdf: bytes) -> tuple[int, int, int, int]:
    found = re.findall(rb"/ByteRange\s*\[\s*(\d+)\s+(\d+)\s+(\d+)\s+(\d+)\s*\]", pdf)
    assert len(found) == 1, f"expected one signature, found {len(found)} /ByteRange entries"
    r = tuple(int(v) for v in found[0])
    assert r[0] == 0 and r[2] + r[3] == len(pdf)  # covers everything but /Contents
    return r


def read_text(path) -> str:
    with open(path) as f:
        return f.read()


def sha256_file(path) -> str:
    with open(path, "rb") as f:
        return hashlib.sha256(f.read()).hexdigest()


def make_identity(ca_cert, ca_key, name: str, path, passphrase: bytes,
                  non_repudiation: bool = True, digital_signature: bool = True,
                  key_usage: bool = True) -> None:
    """A document-signing PKCS#12 issued by ``ca_cert`` (written with cryptography directly);
    ``key_usage=False``: without the key-usage extension."""
    import datetime as dt

    from cryptography import x509
    from cryptography.hazmat.primitives import hashes, serialization
    from cryptography.hazmat.primitives.asymmetric import ec
    from cryptography.hazmat.primitives.serialization import pkcs12
    from cryptography.x509.oid import NameOID

    now = dt.datetime.now(dt.timezone.utc)
    key = ec.generate_private_key(ec.SECP256R1())
    subject = x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, name),
                         x509.NameAttribute(NameOID.ORGANIZATION_NAME, ORGANISATION)])
    b = (x509.CertificateBuilder().subject_name(subject).issuer_name(ca_cert.subject)
         .public_key(key.public_key()).serial_number(x509.random_serial_number())
         .not_valid_before(now - dt.timedelta(hours=1))
         .not_valid_after(now + dt.timedelta(days=30))
         .add_extension(x509.BasicConstraints(ca=False, path_length=None), critical=True)
         .add_extension(x509.AuthorityKeyIdentifier.from_issuer_public_key(
             ca_key.public_key()), critical=False))
    if key_usage:
        b = b.add_extension(x509.KeyUsage(digital_signature=digital_signature,
                                          content_commitment=non_repudiation,
                                          key_encipherment=False, data_encipherment=False,
                                          key_agreement=False, key_cert_sign=False,
                                          crl_sign=False, encipher_only=False,
                                          decipher_only=False), critical=True)
    cert = b.sign(ca_key, hashes.SHA256())
    with open(path, "wb") as f:
        f.write(pkcs12.serialize_key_and_certificates(
            name.encode(), key, cert, [ca_cert],
            serialization.BestAvailableEncryption(passphrase)))


def incremental_edit(pdf: bytes, text: bytes = b"REJECTED BY QA") -> bytes:
    """Append a revision that draws ``text`` in red on page 1 and retitles the document."""
    from pyhanko.pdf_utils import generic
    from pyhanko.pdf_utils.incremental_writer import IncrementalPdfFileWriter

    w = IncrementalPdfFileWriter(io.BytesIO(pdf))
    font = w.add_object(generic.DictionaryObject({
        generic.NameObject("/Type"): generic.NameObject("/Font"),
        generic.NameObject("/Subtype"): generic.NameObject("/Type1"),
        generic.NameObject("/BaseFont"): generic.NameObject("/Helvetica")}))
    stream = generic.StreamObject(stream_data=b"q 1 0 0 rg BT /QaForge 40 Tf 150 450 Td ("
                                  + text + b") Tj ET Q")
    w.add_stream_to_page(0, w.add_object(stream), resources=generic.DictionaryObject({
        generic.NameObject("/Font"): generic.DictionaryObject({
            generic.NameObject("/QaForge"): font})}))
    w.document_meta.title = "Forged"
    out = io.BytesIO()
    w.write(out)
    return out.getvalue()


# ---------------------------------------------------------------------------- fixtures
@pytest.fixture(scope="module")
def signed(tmp_path_factory):
    """keygen (the inspector's demonstration PKI), a second unrelated PKI, an approver issued by
    the inspector's CA, and one signed ACCEPT certificate of the belly-fairing sample."""
    from cryptography import x509
    from cryptography.hazmat.primitives import serialization
    from cryptography.hazmat.primitives.asymmetric import ec

    for name in ("pdfsig", "pdftotext", "pdfinfo", "pdfdetach", "certutil"):
        tool(name)
    d = tmp_path_factory.mktemp("certificate")
    with pytest.MonkeyPatch.context() as env:
        env.setenv(PASS_VAR, PASSPHRASE)
        # keygen keeps no CA key; record the keys it makes so that the test can issue the
        # approver's certificate from the same CA.
        made = []
        with pytest.MonkeyPatch.context() as mp:
            real = ec.generate_private_key

            def recording(*a, **k):
                made.append(real(*a, **k))
                return made[-1]

            mp.setattr(ec, "generate_private_key", recording)
            code, out, err = cli("keygen", "--name", INSPECTOR, "--organisation", ORGANISATION,
                                 "--out", d / "id", "--pass-env", PASS_VAR)
        assert code == 0, err
        assert os.path.isfile(d / "id" / "ca.pem") and os.path.isfile(d / "id" / "inspector.p12")
        assert "DEMONSTRATION" in out and str(d / "id" / "ca.pem") in out
        code, _, err = cli("keygen", "--name", "Mallory", "--organisation", "Other Org",
                           "--out", d / "other", "--pass-env", PASS_VAR)
        assert code == 0, err

        ca_cert = x509.load_pem_x509_certificate((d / "id" / "ca.pem").read_bytes())

        def spki(k):
            return k.public_bytes(serialization.Encoding.DER,
                                  serialization.PublicFormat.SubjectPublicKeyInfo)

        ca_key = next((k for k in made if spki(k.public_key()) == spki(ca_cert.public_key())),
                      None)
        assert ca_key is not None, "could not capture the demonstration CA's key from keygen"
        make_identity(ca_cert, ca_key, APPROVER, d / "approver.p12", PASSPHRASE.encode())

        pdf = d / "cert.pdf"
        code, out, err = cli("inspect", BELLY_NOMINAL, BELLY_MEASURED, "--tol", "0.25",
                             "--report", pdf, "--sign", d / "id" / "inspector.p12",
                             "--sign-pass-env", PASS_VAR, *INFO_ARGS)
        assert code == 0, out + err
        assert out.startswith("ACCEPT") and os.path.isfile(pdf)
        yield SimpleNamespace(dir=d, pdf=pdf, bytes=pdf.read_bytes(), ca=d / "id" / "ca.pem",
                              p12=d / "id" / "inspector.p12", other_ca=d / "other" / "ca.pem",
                              approver_p12=d / "approver.p12", ca_cert=ca_cert, ca_key=ca_key)


@pytest.fixture(scope="module")
def evidence(signed):
    """The certificate's attachments, read by reports.signing against the CA."""
    from reports.signing import read_trust_roots, verify_pdf

    v = verify_pdf(signed.bytes, read_trust_roots(str(signed.ca)))
    assert v.valid, v.problems
    return v.attachments


@pytest.fixture(scope="module")
def number(evidence):
    return json.loads(evidence["results.json"])["certificate"]["number"]


@pytest.fixture(scope="module")
def nss(tmp_path_factory, signed):
    """Two NSS databases: one trusting the demonstration CA, one empty."""
    trusted = tmp_path_factory.mktemp("nss-trusted")
    empty = tmp_path_factory.mktemp("nss-empty")
    for db in (trusted, empty):
        run_tool("certutil", "-N", "-d", f"sql:{db}", "--empty-password")
    run_tool("certutil", "-A", "-d", f"sql:{trusted}", "-n", "qa-demo-ca", "-t", "CT,C,C",
             "-i", signed.ca)
    return SimpleNamespace(trusted=trusted, empty=empty)


@pytest.fixture(scope="module")
def tampered(signed):
    """Forged copies of the signed certificate: (a) one byte, (b) verdict, (c) new revision."""
    pdf = signed.bytes
    _, end1, _, _ = byte_range(pdf)
    d = signed.dir / "tampered"
    d.mkdir()
    # (a) one digit of a text position in page 1's content, just before the verdict is drawn.
    verdict = pdf.find(b"(ACCEPTED) Tj")
    assert 0 < verdict < end1, "no uncompressed '(ACCEPTED) Tj' in the signed page content"
    at = max(i for i in range(verdict - 200, verdict) if pdf[i:i + 1].isdigit())
    assert 10_000 < at < end1 - 10_000
    a = bytearray(pdf)
    a[at] ^= 0x01  # a digit stays a digit: a silent, well-formed change
    # (b) the verdict word in every page content stream, same length.
    hits = [m.start() for m in re.finditer(rb"\(ACCEPTED\) Tj", pdf)]
    assert hits and all(h < end1 for h in hits)
    b = bytearray(pdf)
    for h in hits:
        b[h:h + 10] = b"(REJECTED)"
    # (c) an incremental revision after the signature.
    c = incremental_edit(pdf)
    paths = {}
    for key, data in (("a", a), ("b", b), ("c", c)):
        paths[key] = d / f"tamper_{key}.pdf"
        paths[key].write_bytes(bytes(data))
    return SimpleNamespace(**paths)


# ---------------------------------------------------------------------------- 1. verify
def test_verify_signed_certificate(signed, number, capsys):
    code, out, err = verify(capsys, signed.pdf, "--trust", signed.ca)
    assert code == 0, out + err
    lines = out.splitlines()
    assert lines[0] == f"VALID: {signed.pdf}"
    sig = [ln for ln in lines if ln.strip().startswith("signature ")]
    assert len(sig) == 1
    assert "'Inspector'" in sig[0] and INSPECTOR in sig[0] and ORGANISATION in sig[0]
    assert "intact, trusted" in sig[0]
    assert f"certificate {number}: ACCEPTED" in out
    assert "problem" not in out and "INVALID" not in out


def test_verify_with_the_input_files_reruns(signed, capsys):
    code, out, err = verify(capsys, signed.pdf, "--trust", signed.ca,
                            "--nominal", BELLY_NOMINAL, "--measured", BELLY_MEASURED)
    assert code == 0, out + err
    assert out.startswith("VALID")
    for role, path in (("nominal", BELLY_NOMINAL), ("measured", BELLY_MEASURED)):
        assert any(f"{role} file matches" in ln and ln.endswith(path) for ln in out.splitlines())
    assert re.search(r"re-run: ACCEPT, max \|deviation\| \d+\.\d{6} mm, as certified", out)


def test_verify_rejects_a_different_measured_file(signed, tmp_path, capsys):
    lines = read_text(BELLY_MEASURED).splitlines(keepends=True)
    row = lines[2].rstrip("\n").split(",")  # first data row: id,x,y,z
    row[1] = f"{float(row[1]) + 0.001:.4f}"
    lines[2] = ",".join(row) + "\n"
    changed = tmp_path / "measured.csv"
    changed.write_text("".join(lines))
    assert sha256_file(changed) != sha256_file(BELLY_MEASURED)
    code, out, err = verify(capsys, signed.pdf, "--trust", signed.ca,
                            "--nominal", BELLY_NOMINAL, "--measured", changed)
    assert code == 1
    assert out.startswith("INVALID")
    problem = [ln for ln in out.splitlines() if "problem:" in ln]
    assert len(problem) == 1 and "measured" in problem[0] and "SHA-256" in problem[0]
    assert sha256_file(changed)[:16] in problem[0]
    assert "re-run" not in out


def test_verify_certificate_is_a_typed_outcome(signed, tampered):
    """reports.verify, what ``verify`` prints and the desktop app shows: a frozen result whose
    checks each say what was checked, whether it passed and why."""
    import dataclasses

    from reports.verify import RerunFilesError, outcome_lines, verify_certificate

    v = verify_certificate(str(signed.pdf), [str(signed.ca)], BELLY_NOMINAL, BELLY_MEASURED)
    assert v.valid and v.problems == ()
    assert [(c.subject, c.passed) for c in v.checks] == [
        ("signatures", True), ("issue", True), ("nominal", True), ("measured", True),
        ("re-run", True)]
    assert v.checks[-1].message.startswith("re-run: ACCEPT")
    assert v.certified.verdict == "ACCEPT" and v.signatures[0].signer == INSPECTOR
    with pytest.raises(dataclasses.FrozenInstanceError):
        v.path = "another.pdf"
    assert outcome_lines(v)[0] == f"VALID: {signed.pdf}"
    flipped = verify_certificate(str(tampered.a), [str(signed.ca)])
    assert not flipped.valid and flipped.certified is None
    assert {c.subject for c in flipped.checks} == {"signatures"}
    assert outcome_lines(flipped)[0] == f"INVALID: {tampered.a}"
    with pytest.raises(RerunFilesError, match="give both --nominal and --measured"):
        verify_certificate(str(signed.pdf), [str(signed.ca)], BELLY_NOMINAL)


# ---------------------------------------------------------------------------- 2. tampering
def test_verify_detects_one_flipped_byte(signed, tampered, capsys):
    code, out, err = verify(capsys, tampered.a, "--trust", signed.ca)
    assert code == 1 and out.startswith("INVALID")
    assert "digest mismatch" in out or "NOT INTACT" in out


def test_verify_detects_a_rewritten_verdict(signed, tampered, capsys):
    # The forgery is visible: page 1's header and verdict block now say REJECTED.
    head = page_texts(tampered.b)[0]
    assert head.count("REJECTED") >= 2 and "ACCEPTED" not in head.split("Certificate No.")[0]
    code, out, err = verify(capsys, tampered.b, "--trust", signed.ca)
    assert code == 1 and out.startswith("INVALID")
    assert "NOT INTACT" in out


def test_verify_detects_an_incremental_revision(signed, tampered, capsys):
    assert "REJECTED BY QA" in page_texts(tampered.c)[0]  # the change is visible
    code, out, err = verify(capsys, tampered.c, "--trust", signed.ca)
    assert code == 1 and out.startswith("INVALID")
    assert "changed after the last signature" in out


def test_verify_with_another_ca_is_not_trusted(signed, capsys):
    code, out, err = verify(capsys, signed.pdf, "--trust", signed.other_ca)
    assert code == 1 and out.startswith("INVALID")
    assert "not trusted" in out and "NOT TRUSTED" in out


@pytest.mark.parametrize("kind", ["truncated", "not-a-pdf"])
def test_verify_broken_files_fail_cleanly(signed, tmp_path, capsys, kind):
    path = tmp_path / "broken.pdf"
    data = signed.bytes
    path.write_bytes(data[:len(data) // 2] if kind == "truncated"
                     else b"id,x,y,z\nP1,1,2,3\n")
    code, out, err = verify(capsys, path, "--trust", signed.ca)
    assert code == 1 and out.startswith("INVALID")
    assert "Traceback" not in out + err


# ---------------------------------------------------------------------------- 3. pdfsig
def test_pdfsig_agrees(signed, tampered, nss):
    plain = pdfsig(signed.pdf)
    assert "Signature is Valid" in plain and "Total document signed" in plain
    assert f"Common Name: {INSPECTOR}" in plain
    assert "Certificate is Trusted" in pdfsig(signed.pdf, nss.trusted)
    assert "Certificate is Trusted" not in pdfsig(signed.pdf, nss.empty)  # control
    a = pdfsig(tampered.a)
    assert ("Digest Mismatch" in a or "Signature is Invalid" in a) and "Signature is Valid" not in a
    b = pdfsig(tampered.b)
    assert ("Digest Mismatch" in b or "Signature is Invalid" in b) and "Signature is Valid" not in b
    assert "Not total document signed" in pdfsig(tampered.c)


# ---------------------------------------------------------------------------- 4. attachments
def test_attachments_are_the_evidence(signed, evidence, number, tmp_path):
    assert set(evidence) == {"points.csv", "results.qif", "results.json"}
    # pdfdetach extracts the same bytes.
    run_tool("pdfdetach", "-saveall", "-o", tmp_path, signed.pdf)
    for name, data in evidence.items():
        assert (tmp_path / name).read_bytes() == data
    # A separate run of the same inspection.
    code, out, err = cli("inspect", BELLY_NOMINAL, BELLY_MEASURED, "--tol", "0.25",
                         "--json", tmp_path / "r.json", "--csv", tmp_path / "r.csv")
    assert code == 0, out + err
    separate = json.loads((tmp_path / "r.json").read_text())
    with open(tmp_path / "r.csv", newline="") as f:
        separate_rows = list(csv.DictReader(f))

    rows = list(csv.DictReader(io.StringIO(evidence["points.csv"].decode())))
    assert list(rows[0]) == CSV_COLUMNS
    assert len(rows) == 1100 == len(read_text(BELLY_MEASURED).splitlines()) - 2
    assert [r["label"] for r in rows] == [f"P{i:04d}" for i in range(1, 1101)]
    assert [r["deviation"] for r in rows] == [r["deviation"] for r in separate_rows]
    assert all(r["in_tolerance"] == "true" for r in rows)
    dev = np.array([float(r["deviation"]) for r in rows])

    doc = json.loads(evidence["results.json"])
    assert doc["verdict"] == "ACCEPT"
    st = doc["deviations"]
    assert st["count"] == 1100 and st["n_out"] == 0
    for key, value in (("min", dev.min()), ("max", dev.max()),
                       ("max_abs", np.abs(dev).max()), ("mean", dev.mean()),
                       ("rms", np.sqrt(np.mean(dev ** 2)))):
        assert st[key] == pytest.approx(value, abs=1e-6), key
    for w in st["worst"]:
        row = rows[w["point"] - 1]  # numbered from 1, with the file's label
        assert row["point"] == str(w["point"]) and row["label"] == w["label"]
        assert float(row["deviation"]) == pytest.approx(w["deviation"], abs=5e-7)
    for key in ("count", "min", "max", "mean", "rms", "max_abs", "n_out"):
        assert st[key] == pytest.approx(separate["deviations"][key], abs=1e-9), key
    assert {r["role"]: r["sha256"] for r in doc["inputs"]} == {
        "nominal": sha256_file(BELLY_NOMINAL), "measured": sha256_file(BELLY_MEASURED)}
    cert = doc["certificate"]
    assert (cert["part_number"], cert["serial"], cert["inspector"], cert["device"],
            cert["signed_by"]) == (INFO["--part-number"], INFO["--serial"], INSPECTOR,
                                   INFO["--device"], INSPECTOR)
    assert re.fullmatch(r"QA-\d{8}-[0-9A-F]{8}", number)
    assert number in run_tool("pdftotext", signed.pdf, "-")


def test_attached_qif_is_valid(evidence):
    from lxml import etree

    schema = etree.XMLSchema(etree.parse(XSD))
    qif = etree.fromstring(evidence["results.qif"])
    assert schema.validate(qif), schema.error_log


# ---------------------------------------------------------------------------- 5. page content
def test_every_page_identifies_the_certificate(signed, number):
    pages = page_texts(signed.pdf)
    n = len(pages)
    assert n >= 2
    for k, page in enumerate(pages, 1):
        assert f"Page {k} of {n}" in page, k
        assert number in page, k
        assert "ACCEPTED" in page, k
    assert "End of certificate" in pages[-1]
    assert all("End of certificate" not in p for p in pages[:-1])
    text = "\n".join(pages)
    for value in INFO.values():
        assert value in text, value
    assert "T_nominal_measured" in text
    assert "UNSIGNED DRAFT" not in text
    raw = "".join("".join(page_texts(signed.pdf, layout=False)).split())
    for path in (BELLY_NOMINAL, BELLY_MEASURED):
        assert sha256_file(path) in raw, path


# ---------------------------------------------------------------------------- 6. draft
def test_unsigned_draft(signed, tmp_path, capsys):
    draft = tmp_path / "draft.pdf"
    code, out, err = cli("inspect", BELLY_NOMINAL, BELLY_MEASURED, "--tol", "0.25",
                         "--report", draft, *INFO_ARGS)
    assert code == 0, out + err
    pages = page_texts(draft)
    assert all("UNSIGNED DRAFT" in p for p in pages)
    code, out, err = verify(capsys, draft, "--trust", signed.ca)
    assert code == 1 and out.startswith("INVALID")
    assert "no signature" in out


# ---------------------------------------------------------------------------- 7. reject, 2D
def test_reject_certificate_never_says_accepted(tmp_path):
    pdf = tmp_path / "reject.pdf"
    code, out, err = cli("inspect", BELLY_NOMINAL, BELLY_MEASURED, "--tol", "0.05",
                         "--report", pdf, *INFO_ARGS)
    assert code == 1 and out.startswith("REJECT"), out + err
    pages = page_texts(pdf)
    for page in pages:
        assert "REJECTED" in page
    text = squeeze("\n".join(pages))
    assert "ACCEPTED" not in text
    assert "does not conform" in text
    # Its failing points were fitted like every other: none is called an outlier.
    assert "outlier, d =" not in text and "none: every point was fitted" in text


def test_a_mis_probed_point_is_named_excluded_from_the_alignment(tmp_path):
    """One CMM point 10 mm off the part (a mis-probe): the certificate says it was excluded from
    the alignment as a gross outlier, with its deviation, states the rule, and rejects."""
    with open(BELLY_MEASURED) as f:
        lines = f.read().splitlines()
    k = next(i for i, line in enumerate(lines) if line.startswith("P0500,"))
    label, x, y, z = lines[k].split(",")
    lines[k] = f"{label},{x},{y},{float(z) + 10.0:.4f}"
    measured = tmp_path / "mis_probed.csv"
    measured.write_text("\n".join(lines) + "\n")
    pdf = tmp_path / "mis_probed.pdf"
    code, out, err = cli("inspect", BELLY_NOMINAL, measured, "--tol", "0.25", "--report", pdf,
                         "--json", tmp_path / "r.json")
    assert code == 1, out + err
    doc = json.loads((tmp_path / "r.json").read_text())
    gross = doc["registration"]["gross_outliers"]
    assert gross["n_excluded"] == 1
    text = squeeze("\n".join(page_texts(pdf, layout=False)))
    assert "P0500" in text and "excluded from the alignment (gross outlier, d =" in text
    assert "is excluded from the alignment only as a gross outlier" in text  # the rule
    assert "1 point(s) (gross outliers), judged like every other point" in text


def test_signed_2d_certificate(signed, tmp_path, capsys):
    pdf = tmp_path / "frame.pdf"
    with pytest.MonkeyPatch.context() as env:
        env.setenv(PASS_VAR, PASSPHRASE)
        code, out, err = cli("inspect", FRAME_TEMPLATE, FRAME_MEASURED, "--tol", "0.05",
                             "--report", pdf, "--sign", signed.p12, "--sign-pass-env", PASS_VAR,
                             "--part-number", "FR-12", "--serial", "SN-2D")
    assert code == 0 and out.startswith("ACCEPT"), out + err
    pages = page_texts(pdf)
    for k, page in enumerate(pages, 1):
        assert f"Page {k} of {len(pages)}" in page
        assert "ACCEPTED" in page
    assert "Line profile" in squeeze("\n".join(pages))
    code, out, err = verify(capsys, pdf, "--trust", signed.ca,
                            "--nominal", FRAME_TEMPLATE, "--measured", FRAME_MEASURED)
    assert code == 0, out + err
    assert out.startswith("VALID") and "ACCEPTED" in out and "as certified" in out


# ---------------------------------------------------------------------------- 8. inconclusive
def test_inconclusive_certificate(tmp_path):
    pdf = tmp_path / "wrong_part.pdf"
    code, out, err = cli("inspect", BRACKET_NOMINAL, BELLY_MEASURED, "--tol", "0.25",
                         "--report", pdf, "--json", tmp_path / "r.json")
    assert code == 2, out + err
    assert json.loads((tmp_path / "r.json").read_text())["verdict"] == "INCONCLUSIVE"
    pages = page_texts(pdf)
    for page in pages:
        assert "INCONCLUSIVE" in page
    text = squeeze("\n".join(pages))
    assert "ACCEPTED" not in text and "REJECTED" not in text
    assert "No statement of conformity" in text


def test_a_form_check_with_free_directions_is_certified_in_plain_words(signed, tmp_path,
                                                                        capsys):
    """A cylinder measured all round: position along and orientation about its axis are not
    fixed, and the deviations do not change along them, so the ACCEPT is certified (signed and
    verified) and the certificate says in words what the measurement leaves open."""
    rng = np.random.default_rng(4)
    a = np.linspace(0, 2 * np.pi, 160, endpoint=False)
    z = np.linspace(-100.0, 100.0, 80)
    A, Z = np.meshgrid(a, z)
    nominal = np.column_stack([40 * np.cos(A.ravel()), 40 * np.sin(A.ravel()), Z.ravel(),
                               np.cos(A.ravel()), np.sin(A.ravel()), np.zeros(A.size)])
    t = rng.uniform(0, 2 * np.pi, 300)
    r = 40 + rng.uniform(-0.012, 0.012, 300)
    # Measured in a machine frame: turned about x by 90 degrees and shifted.
    q = np.column_stack([r * np.cos(t), r * np.sin(t), rng.uniform(-60, 60, 300)])
    q = q @ np.array([[1.0, 0, 0], [0, 0, -1.0], [0, 1.0, 0]]).T + [300.0, -20.0, 55.0]
    np.savetxt(tmp_path / "cyl_nominal.csv", nominal, fmt="%.6f", delimiter=",",
               header="x,y,z,i,j,k", comments="")
    np.savetxt(tmp_path / "cyl_measured.csv", q, fmt="%.5f", delimiter=",", header="x,y,z",
               comments="")
    pdf = tmp_path / "cylinder.pdf"
    with pytest.MonkeyPatch.context() as env:
        env.setenv(PASS_VAR, PASSPHRASE)
        code, out, err = cli("inspect", tmp_path / "cyl_nominal.csv",
                             tmp_path / "cyl_measured.csv", "--tol", "0.05", "--report", pdf,
                             "--sign", signed.p12, "--sign-pass-env", PASS_VAR,
                             "--part-number", "PIN-40", "--serial", "SN-C1")
    assert code == 0 and out.startswith("ACCEPT"), out + err
    text = squeeze("\n".join(page_texts(pdf)))
    assert "ACCEPTED" in text and "What the measurement does not fix" in text
    assert "Position along" in text and "Orientation about the axis" in text
    assert text.count("the verdict is about form and holds for every such") == 2
    assert "over the poses the measurement allows, deviations change by up to" in text
    code, out, err = verify(capsys, pdf, "--trust", signed.ca)
    assert code == 0 and out.startswith("VALID"), out + err


# ---------------------------------------------------------------------------- 9. approver
def test_approver_signature(signed, nss, tmp_path, capsys):
    from pyhanko.pdf_utils.incremental_writer import IncrementalPdfFileWriter
    from pyhanko.sign import fields, signers

    from reports.signing import load_identity

    approver = load_identity(str(signed.approver_p12), PASSPHRASE.encode())
    w = IncrementalPdfFileWriter(io.BytesIO(signed.bytes))
    meta = signers.PdfSignatureMetadata(field_name="Approver", md_algorithm="sha256",
                                        subfilter=fields.SigSeedSubFilter.PADES)
    both = tmp_path / "approved.pdf"
    both.write_bytes(signers.PdfSigner(meta, approver.signer).sign_pdf(w).getvalue())

    code, out, err = verify(capsys, both, "--trust", signed.ca)
    assert code == 0, out + err
    sig = [ln for ln in out.splitlines() if ln.strip().startswith("signature ")]
    assert len(sig) == 2
    assert "'Inspector'" in sig[0] and INSPECTOR in sig[0] and "intact, trusted" in sig[0]
    assert "'Approver'" in sig[1] and APPROVER in sig[1] and "intact, trusted" in sig[1]
    assert pdfsig(both, nss.trusted).count("Signature is Valid") == 2

    later = tmp_path / "approved_then_edited.pdf"
    later.write_bytes(incremental_edit(both.read_bytes(), b"VOID"))
    code, out, err = verify(capsys, later, "--trust", signed.ca)
    assert code == 1 and out.startswith("INVALID")
    assert "changed after the last signature" in out


# ---------------------------------------------------------------------------- 10. bad inputs
def test_wrong_passphrase(signed, tmp_path, monkeypatch, capsys):
    monkeypatch.setenv(PASS_VAR, "not the passphrase")
    pdf = tmp_path / "c.pdf"
    code = main(["inspect", BELLY_NOMINAL, BELLY_MEASURED, "--tol", "0.25", "--report", str(pdf),
                 "--sign", str(signed.p12), "--sign-pass-env", PASS_VAR])
    err = capsys.readouterr().err
    assert code == 65
    assert str(signed.p12) in err and "passphrase" in err
    assert not pdf.exists() and os.listdir(tmp_path) == []


def test_report_closes_the_render_pipe(signed, tmp_path, monkeypatch):
    """A --report run (here stopped early by a wrong passphrase, after the 3D render worker has
    started) leaves no open file behind: the desktop app makes many certificates per process."""
    monkeypatch.setenv(PASS_VAR, "not the passphrase")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", ResourceWarning)
        code, _, _ = cli("inspect", BELLY_NOMINAL, BELLY_MEASURED, "--tol", "0.25",
                         "--report", tmp_path / "c.pdf", "--sign", signed.p12,
                         "--sign-pass-env", PASS_VAR)
        gc.collect()
    assert code == 65
    leaks = [str(w.message) for w in caught if issubclass(w.category, ResourceWarning)]
    assert leaks == []


def test_missing_identity(tmp_path, monkeypatch, capsys):
    monkeypatch.setenv(PASS_VAR, PASSPHRASE)
    pdf = tmp_path / "c.pdf"
    missing = tmp_path / "nobody.p12"
    code = main(["inspect", BELLY_NOMINAL, BELLY_MEASURED, "--tol", "0.25", "--report", str(pdf),
                 "--sign", str(missing), "--sign-pass-env", PASS_VAR])
    err = capsys.readouterr().err
    assert code == 66 and str(missing) in err
    assert not pdf.exists()


def test_sign_needs_report(signed, monkeypatch, capsys):
    monkeypatch.setenv(PASS_VAR, PASSPHRASE)
    code = main(["inspect", BELLY_NOMINAL, BELLY_MEASURED, "--tol", "0.25",
                 "--sign", str(signed.p12), "--sign-pass-env", PASS_VAR])
    assert code == 64
    assert "--report" in capsys.readouterr().err


def test_keygen_does_not_overwrite(signed, tmp_path, monkeypatch, capsys):
    monkeypatch.setenv(PASS_VAR, PASSPHRASE)
    shutil.copy(signed.ca, tmp_path / "ca.pem")
    before = (tmp_path / "ca.pem").read_bytes()
    code = main(["keygen", "--name", "X", "--out", str(tmp_path), "--pass-env", PASS_VAR])
    err = capsys.readouterr().err
    assert code == 73 and "ca.pem" in err
    assert (tmp_path / "ca.pem").read_bytes() == before
    assert os.listdir(tmp_path) == ["ca.pem"]


def test_verify_trust_file_errors(signed, tmp_path, capsys):
    code, out, err = verify(capsys, signed.pdf, "--trust", tmp_path / "missing.pem")
    assert code == 66 and "missing.pem" in err and "VALID" not in out
    garbage = tmp_path / "garbage.pem"
    garbage.write_bytes(b"not a certificate \x00\x01\x02 just bytes\n")
    code, out, err = verify(capsys, signed.pdf, "--trust", garbage)
    assert code == 65 and "garbage.pem" in err and "VALID" not in out


def _sign_approver(pdf_bytes: bytes, p12) -> bytes:
    from pyhanko.pdf_utils.incremental_writer import IncrementalPdfFileWriter
    from pyhanko.sign import fields, signers

    from reports.signing import load_identity

    approver = load_identity(str(p12), PASSPHRASE.encode())
    w = IncrementalPdfFileWriter(io.BytesIO(pdf_bytes))
    meta = signers.PdfSignatureMetadata(field_name="Approver", md_algorithm="sha256",
                                        subfilter=fields.SigSeedSubFilter.PADES)
    return signers.PdfSigner(meta, approver.signer).sign_pdf(w).getvalue()


def test_a_draft_signed_by_an_approver_is_not_a_certificate(signed, tmp_path, capsys):
    draft = tmp_path / "draft.pdf"
    assert main(["inspect", BELLY_NOMINAL, BELLY_MEASURED, "--tol", "0.25", "--report",
                 str(draft)]) == 0
    approved = tmp_path / "draft_approved.pdf"
    approved.write_bytes(_sign_approver(draft.read_bytes(), signed.approver_p12))
    code, out, err = verify(capsys, approved, "--trust", signed.ca)
    assert code == 1 and out.startswith("INVALID")
    assert "not the inspector's certification signature" in out


def test_identity_without_non_repudiation_is_refused_before_signing(signed, tmp_path,
                                                                    monkeypatch, capsys):
    weak = tmp_path / "ds_only.p12"
    make_identity(signed.ca_cert, signed.ca_key, "Dee Signer", weak, PASSPHRASE.encode(),
                  non_repudiation=False)
    monkeypatch.setenv(PASS_VAR, PASSPHRASE)
    pdf = tmp_path / "c.pdf"
    code = main(["inspect", BELLY_NOMINAL, BELLY_MEASURED, "--tol", "0.25", "--report",
                 str(pdf), "--sign", str(weak), "--sign-pass-env", PASS_VAR])
    err = capsys.readouterr().err
    assert code == 65 and "nonRepudiation" in err and str(weak) in err
    assert not pdf.exists()


def test_identity_files_and_folders(signed, tmp_path, monkeypatch, capsys):
    # The private key is the owner's alone; the trust anchor is for everyone.
    assert os.stat(signed.p12).st_mode & 0o777 == 0o600
    assert os.stat(signed.ca).st_mode & 0o044 == 0o044
    monkeypatch.setenv(PASS_VAR, PASSPHRASE)
    code = main(["inspect", BELLY_NOMINAL, BELLY_MEASURED, "--tol", "0.25", "--report",
                 str(tmp_path / "c.pdf"), "--sign", str(tmp_path), "--sign-pass-env",
                 PASS_VAR])
    err = capsys.readouterr().err
    assert code == 66 and "is a folder" in err and "cannot write" not in err
    code = main(["verify", str(tmp_path), "--trust", str(signed.ca)])
    assert code == 66 and "is a folder" in capsys.readouterr().err


# ---------------------------------------------------------------------------- 11. who signed
FRAME_ID = ["--part-number", "FR-12", "--serial", "SN-2D"]


def sign_frame(signed, out_dir, *args, p12=None, tol="0.05"):
    """Sign a certificate of the 2D frame sample (fast: no 3D renders) into ``out_dir``."""
    with pytest.MonkeyPatch.context() as env:
        env.setenv(PASS_VAR, PASSPHRASE)
        return cli("inspect", FRAME_TEMPLATE, FRAME_MEASURED, "--tol", tol,
                   "--report", out_dir / "c.pdf", "--json", out_dir / "r.json",
                   "--sign", p12 or signed.p12, "--sign-pass-env", PASS_VAR, *args)


def test_an_inspector_who_is_not_the_signer_is_refused(signed, tmp_path):
    code, out, err = sign_frame(signed, tmp_path, *FRAME_ID, "--inspector", "Carol Other")
    assert code == 64, out + err
    assert "'Carol Other'" in err and f"'{INSPECTOR}'" in err and "Traceback" not in err
    assert os.listdir(tmp_path) == []


@pytest.mark.parametrize("named", [None, "ann  INSPECTOR"])
def test_the_certificate_names_its_signer_as_inspector(signed, tmp_path, named):
    from reports.signing import read_trust_roots, verify_pdf

    code, out, err = sign_frame(signed, tmp_path, *FRAME_ID,
                                *([] if named is None else ["--inspector", named]))
    assert code == 0, out + err
    v = verify_pdf((tmp_path / "c.pdf").read_bytes(), read_trust_roots(str(signed.ca)))
    assert v.valid, v.problems
    cert = json.loads(v.attachments["results.json"])["certificate"]
    assert cert["inspector"] == cert["signed_by"] == v.signatures[0].signer == INSPECTOR
    first = page_texts(tmp_path / "c.pdf")[0]
    assert re.search(rf"Inspector\s+{INSPECTOR}\b", first)


def test_verify_fails_a_certificate_naming_another_inspector(signed, tmp_path, capsys):
    """Made the way a certificate was made before the signer was checked: Ann's signature over a
    certificate that names Carol as its inspector (reports' own building blocks, so that every
    other part of it is right)."""
    import datetime as dt
    from dataclasses import asdict

    from engine.pipeline import run_files
    from engine.settings import InspectionSettings
    from reports.certificate import CertificateInfo, build_pdf, certificate_number
    from reports.results import result_json, run_document
    from reports.signing import Attachment, finish_pdf, load_identity

    run = run_files(FRAME_TEMPLATE, FRAME_MEASURED, InspectionSettings(-0.05, 0.05))
    assert run.result.verdict == "ACCEPT"
    identity = load_identity(str(signed.p12), PASSPHRASE.encode())
    info = CertificateInfo(part_number="FR-12", serial="SN-2D", inspector="Carol Other")
    issued = dt.datetime.now(dt.timezone.utc).replace(microsecond=0)
    number = certificate_number(run, issued)
    doc = dict(run_document(run), certificate=dict(asdict(info), number=number,
                                                   issued=issued.isoformat(),
                                                   signed_by=identity.common_name))
    attachments = [Attachment("results.json", result_json(doc).encode(), "application/json",
                              "results")]
    pdf, slots = build_pdf(run, info, number, issued, identity, attachments, None)
    forged = tmp_path / "forged.pdf"
    forged.write_bytes(finish_pdf(pdf, attachments, slots, identity, reason="test"))
    code, out, err = verify(capsys, forged, "--trust", signed.ca)
    assert code == 1 and out.startswith("INVALID")
    assert "intact, trusted" in out  # the signature itself is sound: the statement is not
    problem = [ln for ln in out.splitlines() if "problem:" in ln]
    assert len(problem) == 1 and "'Carol Other'" in problem[0] and INSPECTOR in problem[0]


@pytest.mark.parametrize("usage", ["no key-usage extension", "nonRepudiation only"])
def test_an_identity_that_cannot_sign_certificates_is_refused_before_any_work(signed, tmp_path,
                                                                              usage):
    weak = tmp_path / "weak.p12"
    make_identity(signed.ca_cert, signed.ca_key, "Dee Signer", weak, PASSPHRASE.encode(),
                  key_usage=usage == "nonRepudiation only", digital_signature=False)
    out_dir = tmp_path / "out"
    out_dir.mkdir()
    code, out, err = sign_frame(signed, out_dir, *FRAME_ID, p12=weak)
    assert code == 65, out + err
    assert str(weak) in err and "digitalSignature" in err and "nonRepudiation" in err
    assert os.listdir(out_dir) == [] and out == ""


@pytest.mark.parametrize("missing", ["--part-number", "--serial"])
def test_a_signed_accepted_certificate_identifies_the_part(signed, tmp_path, missing):
    given = {"--part-number": "FR-12", "--serial": "SN-2D"}
    del given[missing]
    code, out, err = sign_frame(signed, tmp_path, *[a for kv in given.items() for a in kv])
    assert code == 64, out + err
    assert f"({missing})" in err and "ACCEPTED" in err and "nothing was written" in err
    assert os.listdir(tmp_path) == []


def test_a_signed_rejected_certificate_may_lack_part_and_serial(signed, tmp_path):
    code, out, err = sign_frame(signed, tmp_path, tol="0.001")
    assert code == 1 and out.startswith("REJECT"), out + err
    assert sorted(os.listdir(tmp_path)) == ["c.pdf", "r.json"]


def test_no_signed_certificate_is_left_when_another_output_fails(signed, tmp_path):
    """The issue's case: the JSON cannot be written, so neither the signed PDF (which would
    verify as VALID on its own) nor the CSV is left behind."""
    (tmp_path / "blocker").write_text("")
    with pytest.MonkeyPatch.context() as env:
        env.setenv(PASS_VAR, PASSPHRASE)
        code, out, err = cli("inspect", FRAME_TEMPLATE, FRAME_MEASURED, "--tol", "0.05",
                             "--report", tmp_path / "c.pdf", "--csv", tmp_path / "c.csv",
                             "--json", tmp_path / "blocker" / "x.json", "--sign", signed.p12,
                             "--sign-pass-env", PASS_VAR, *FRAME_ID)
    assert code == 73, out + err
    assert "x.json" in err and "Traceback" not in err
    assert os.listdir(tmp_path) == ["blocker"]


def test_make_certificate_keeps_the_rules_for_every_caller(signed):
    """The desktop app calls make_certificate directly: the same rules hold there."""
    from engine.pipeline import run_files
    from engine.settings import InspectionSettings
    from reports.certificate import CertificateInfo, CertificationError, make_certificate
    from reports.signing import load_identity

    run = run_files(FRAME_TEMPLATE, FRAME_MEASURED, InspectionSettings(-0.05, 0.05))
    assert run.result.verdict == "ACCEPT"
    identity = load_identity(str(signed.p12), PASSPHRASE.encode())
    with pytest.raises(CertificationError, match="'Carol Other', is not the signer"):
        make_certificate(run, CertificateInfo(part_number="FR-12", serial="SN-2D",
                                              inspector="Carol Other"), identity)
    with pytest.raises(CertificationError, match=r"serial number \(--serial\)"):
        make_certificate(run, CertificateInfo(part_number="FR-12", serial=" "), identity)
    # An unsigned draft may name anyone and lack both.
    assert make_certificate(run, CertificateInfo(inspector="Carol Other"), None)[:5] == b"%PDF-"


def test_the_first_page_says_when_the_signer_is_a_demonstration_identity(signed, tmp_path):
    """Signed with keygen's demonstration identity, page 1 says so in section 11's own words
    (reports.certificate.layout.DEMONSTRATION_NOTE); signed by an identity of a real CA (one
    without keygen's mark), neither page says it."""
    from reports.certificate.layout import DEMONSTRATION_NOTE
    from reports.signing import load_identity

    demo = load_identity(str(signed.p12), PASSPHRASE.encode())
    real = load_identity(str(signed.approver_p12), PASSPHRASE.encode())
    assert demo.demonstration and not real.demonstration
    pages = [squeeze(p) for p in page_texts(signed.pdf)]
    assert DEMONSTRATION_NOTE in pages[0]
    assert DEMONSTRATION_NOTE in next(p for p in pages if "Statement of conformity" in p)
    code, out, err = sign_frame(signed, tmp_path, *FRAME_ID, p12=signed.approver_p12)
    assert code == 0, out + err
    pages = [squeeze(p) for p in page_texts(tmp_path / "c.pdf")]
    assert f"Inspector {APPROVER}" in pages[0]
    assert not any("emonstration" in p for p in pages)


def test_an_accept_the_result_does_not_support_is_never_certified(tmp_path, monkeypatch):
    """A bug upstream that calls a run with out-of-tolerance points ACCEPT: make_certificate
    refuses with an error of the product's family (a RuntimeError too), and the command line
    writes nothing and exits EX_SOFTWARE with one line, no traceback."""
    from dataclasses import replace

    import engine.pipeline
    from engine.errors import QAError
    from engine.settings import InspectionSettings
    from reports.certificate import CertificateInfo, make_certificate

    run = engine.pipeline.run_files(FRAME_TEMPLATE, FRAME_MEASURED,
                                    InspectionSettings(-0.02, 0.02))
    d, tol = run.result.deviations.signed, run.result.tolerance
    assert run.result.verdict == "REJECT" and ((d < tol.lower) | (d > tol.upper)).any()
    wrong = replace(run, result=replace(run.result, verdict="ACCEPT"))
    with pytest.raises(QAError, match="refusing to certify ACCEPTED") as caught:
        make_certificate(wrong, CertificateInfo(), None)
    assert isinstance(caught.value, RuntimeError)

    monkeypatch.delenv("QA_DEBUG", raising=False)
    monkeypatch.setattr(engine.pipeline, "run_files", lambda *a, **k: wrong)
    code, out, err = cli("inspect", FRAME_TEMPLATE, FRAME_MEASURED, "--tol", "0.02",
                         "--report", tmp_path / "c.pdf", "--json", tmp_path / "r.json")
    assert code == 70, out + err
    assert "refusing to certify ACCEPTED" in err and "Traceback" not in err
    assert len(err.strip().splitlines()) == 1
    assert os.listdir(tmp_path) == []


# ---------------------------------------------------------------------------- 12. plans
BRACKET_DIR = os.path.join(ROOT, "samples", "seat_bracket")
BRACKET_MEASURED = os.path.join(BRACKET_DIR, "measured.csv")
BRACKET_PLAN = os.path.join(BRACKET_DIR, "plan.toml")
WORD = {"ACCEPT": "ACCEPTED", "REJECT": "REJECTED", "INCONCLUSIVE": "INCONCLUSIVE"}


def read_toml(path) -> dict:
    import tomllib

    with open(path, "rb") as f:
        return tomllib.load(f)


@pytest.fixture(scope="module")
def bracket(signed, tmp_path_factory):
    """A signed certificate of the seat bracket's plan run (its skin 0.012 mm proud: rejected
    by the profile relative to A|B|C), with the --json document of the same run. The plan is
    given as a copy that is gone afterwards (a re-run must use the plan handed to verify), and
    the part number given is a dash number of the plan's."""
    d = tmp_path_factory.mktemp("bracket")
    (d / "drawing").mkdir()
    plan = d / "drawing" / "plan.toml"
    shutil.copyfile(BRACKET_PLAN, plan)
    with pytest.MonkeyPatch.context() as env:
        env.setenv(PASS_VAR, PASSPHRASE)
        code, out, err = cli("inspect", BRACKET_NOMINAL, BRACKET_MEASURED, "--plan", plan,
                             "--report", d / "c.pdf", "--json", d / "r.json",
                             "--sign", signed.p12, "--sign-pass-env", PASS_VAR,
                             "--part-number", "SB-1020-1", "--serial", "SN-B7")
    assert code == 1 and out.startswith("REJECT"), out + err
    shutil.rmtree(d / "drawing")
    pages = page_texts(d / "c.pdf")
    return SimpleNamespace(pdf=d / "c.pdf", doc=json.loads((d / "r.json").read_text()),
                           plan=read_toml(BRACKET_PLAN), pages=pages,
                           text=squeeze("\n".join(pages)))


def test_a_plan_certificate_lists_its_characteristics_after_the_result(bracket):
    """Each characteristic of the plan file on its own row of section 2, right after the
    verdict: balloon number, requirement, datums (or form), the measured value to 4 decimals,
    the points and its verdict in words; the planted excess rejects only the datum-referenced
    profile of the skin."""
    first = bracket.pages[0]
    table = first[first.index("Characteristics of the inspection plan"):
                  re.search(r"3\s+Requirement", first).start()]
    assert first.index("REJECTED") < first.index("Characteristics of the inspection plan")
    got = {c["id"]: c for c in bracket.doc["characteristics"]}
    assert [c["id"] for c in bracket.plan["characteristic"]] == list(got) == list("12345")
    assert [got[i]["verdict"] for i in "12345"] == ["REJECT"] + ["ACCEPT"] * 4
    for c in bracket.plan["characteristic"]:
        r = got[c["id"]]
        datums = "|".join(c.get("datums", [])) or ("—" if c["type"] == "size" else "form")
        limits = (f"Ø{c['nominal']:.4f} {c['lower']:+.4f}/{c['upper']:+.4f} mm"
                  if c["type"] == "size" else f"zone {c['zone']:.4f} mm")
        row = (rf"^\s*{re.escape(c['id'])}\s+{re.escape(limits)}\s+{re.escape(datums)}\s+"
               rf"{r['value']:.4f}\s+{r['n_points']}\s+{WORD[r['verdict']]}\s*$")
        assert re.search(row, table, re.M), (row, table)
    assert table.count("region skin") == 2 and table.count("region hole1") == 2
    assert "84 of 100 points lie outside the tolerance zone" in squeeze(
        page_texts(bracket.pdf, layout=False)[0])


def test_a_plan_certificate_states_its_alignment_and_datums_in_words(bracket):
    """The 3-2-1 frame on the three tangent datum planes in one sentence, and each datum's
    feature, fit, points (the sample's probed faces, truth.json) and form error."""
    with open(os.path.join(BRACKET_DIR, "truth.json")) as f:
        faces = json.load(f)["datum_faces"]
    text = bracket.text
    assert "Registration and alignment" in text
    assert "3-2-1 on datums A|B|C, tangent planes; remaining freedom: none." in text
    fits = {d["label"]: d for d in bracket.doc["alignment"]["datums"]}
    for label, taken in zip("ABC", (3, 2, 1)):
        region = next(d["region"] for d in bracket.plan["datum"] if d["label"] == label)
        assert re.search(rf"{label} plane tangent {region} {len(faces[label]['labels'])} "
                         rf"{taken} of 6 {fits[label]['form_error']:.4f}", text), label


def test_a_plan_certificate_names_the_plan_and_its_part(bracket, signed):
    """The plan among the inputs (its SHA-256 from the file) and in the requirement; the part's
    name and revision from the plan's [part], the part number given winning but printed beside
    the plan's, and kept in results.json."""
    from reports.signing import read_trust_roots, verify_pdf

    sha = sha256_file(BRACKET_PLAN)
    assert f"plan.toml (SHA-256 {sha[:16]}…" in bracket.text
    raw = page_texts(bracket.pdf, layout=False)
    assert "plan plan.toml 5 characteristics" in squeeze(raw[1])
    assert f"5characteristics{sha}" in "".join(raw[1].split())  # the SHA-256 wraps in its cell
    part = bracket.plan["part"]
    first = squeeze(raw[0])
    assert (f"Part number SB-1020-1 (the inspection plan states {part['number']}) Part name "
            f"{part['name']}") in first
    assert f"Revision {part['revision']} " in first
    v = verify_pdf(bracket.pdf.read_bytes(), read_trust_roots(str(signed.ca)))
    cert = json.loads(v.attachments["results.json"])["certificate"]
    assert (cert["part_number"], cert["part_name"], cert["revision"]) == (
        "SB-1020-1", part["name"], part["revision"])
    assert cert["plan_part"] == part


def test_a_plan_certificate_carries_the_plan_results(bracket, signed):
    """The results.json embedded in the certificate holds the same plan, alignment and
    characteristics as the --json document of the run."""
    from reports.signing import read_trust_roots, verify_pdf

    v = verify_pdf(bracket.pdf.read_bytes(), read_trust_roots(str(signed.ca)))
    assert v.valid, v.problems
    attached = json.loads(v.attachments["results.json"])
    for key in ("plan", "alignment", "characteristics",
                "tolerance_in_verdict", "characteristic_value_definition"):
        assert attached[key] == bracket.doc[key], key
    assert attached["plan"]["sha256"] == sha256_file(BRACKET_PLAN)
    assert attached == dict(bracket.doc, certificate=attached["certificate"])


def test_a_plan_certificate_states_which_characteristic_does_not_conform(bracket):
    assert ("does not conform to the inspection plan plan.toml: characteristic 1 (surface "
            "profile of region skin) lies outside its tolerance (section 2; 5 characteristics "
            "in all)") in bracket.text
    assert "--measured FILE --plan FILE]" in bracket.text
    # The point list is no second list of characteristics: the zone it uses is the statistics'.
    assert "9 Measured points" in bracket.text and "Characteristic accountability" not in \
        bracket.text
    assert "That zone is not part of the verdict" in bracket.text


def test_verify_reruns_a_plan_certificate_with_its_plan(bracket, signed, tmp_path, capsys):
    """verify --plan: the plan's SHA-256 checked like the other files and the inspection re-run
    with it (the path the certificate recorded is gone); another plan, or none, is refused."""
    files = ["--nominal", BRACKET_NOMINAL, "--measured", BRACKET_MEASURED]
    code, out, err = verify(capsys, bracket.pdf, "--trust", signed.ca, *files,
                            "--plan", BRACKET_PLAN)
    assert code == 0, out + err
    assert any("plan file matches" in ln and ln.endswith(BRACKET_PLAN)
               for ln in out.splitlines())
    assert re.search(r"re-run: REJECT, max \|deviation\| \d+\.\d{6} mm, as certified", out)

    changed = tmp_path / "plan.toml"
    changed.write_text(read_text(BRACKET_PLAN).replace("zone = 0.02\n", "zone = 0.05\n", 1))
    assert sha256_file(changed) != sha256_file(BRACKET_PLAN)
    code, out, err = verify(capsys, bracket.pdf, "--trust", signed.ca, *files,
                            "--plan", changed)
    assert code == 1 and out.startswith("INVALID"), out + err
    problem = [ln for ln in out.splitlines() if "problem:" in ln]
    assert len(problem) == 1 and f"plan file {changed}" in problem[0]
    assert sha256_file(changed)[:16] in problem[0] and "re-run" not in out

    code, out, err = verify(capsys, bracket.pdf, "--trust", signed.ca, *files)
    assert code == 64 and "Traceback" not in err
    assert f"inspection plan plan.toml (SHA-256 {sha256_file(BRACKET_PLAN)[:16]}" in err
    assert "--plan FILE" in err
    code, out, err = verify(capsys, signed.pdf, "--trust", signed.ca, "--nominal",
                            BELLY_NOMINAL, "--measured", BELLY_MEASURED, "--plan", BRACKET_PLAN)
    assert code == 64 and "made without an inspection plan" in err
    code, out, err = verify(capsys, bracket.pdf, "--trust", signed.ca, "--plan", BRACKET_PLAN)
    assert code == 64 and "--plan re-runs the inspection with --nominal and --measured" in err


def test_verify_compares_each_characteristic_of_the_re_run(signed, tmp_path, capsys):
    """A certificate whose flatness value is not what the files and the plan give (made, signed,
    by a doctored run: same verdict, same deviations) fails verify, naming the characteristic."""
    from dataclasses import replace

    from engine.pipeline import run_files
    from engine.settings import InspectionSettings
    from reports.certificate import CertificateInfo, make_certificate
    from reports.signing import load_identity

    run = run_files(BRACKET_NOMINAL, BRACKET_MEASURED,
                    InspectionSettings(-0.015, 0.015, plan=BRACKET_PLAN, zone_in_verdict=False))
    plan = run.result.plan
    flat = next(r for r in plan.characteristics if r.characteristic.type == "flatness")
    assert flat.verdict == "ACCEPT" and flat.value < 0.009
    doctored = tuple(replace(r, value=r.value + 0.001) if r is flat else r
                     for r in plan.characteristics)
    run = replace(run, result=replace(run.result, plan=replace(plan, characteristics=doctored)))
    pdf = tmp_path / "c.pdf"
    pdf.write_bytes(make_certificate(run, CertificateInfo(serial="SN-B9"),
                                     load_identity(str(signed.p12), PASSPHRASE.encode())))
    code, out, err = verify(capsys, pdf, "--trust", signed.ca, "--nominal", BRACKET_NOMINAL,
                            "--measured", BRACKET_MEASURED, "--plan", BRACKET_PLAN)
    assert code == 1 and out.startswith("INVALID"), out + err
    problem = [ln for ln in out.splitlines() if "problem:" in ln]
    assert problem == [f"  problem: re-run characteristic(s) {flat.characteristic.id} differ "
                       "from the certified value or verdict"]


def test_a_signed_accepted_plan_certificate_takes_its_part_number_from_the_plan(signed,
                                                                               tmp_path):
    """Datum A alone, the freedom it leaves best-fitted on the skin, and a profile zone the
    skin's excess fits: ACCEPTED, signed with only --serial given (the plan's [part] names the
    part)."""
    plan = tmp_path / "plan.toml"
    text = read_text(BRACKET_PLAN).replace('reference = ["A", "B", "C"]',
                                           'reference = ["A"]\nbest_fit_regions = ["skin"]')
    text = text.replace('zone = 0.02\ndatums = ["A", "B", "C"]', 'zone = 0.1\ndatums = ["A"]')
    plan.write_text(text)
    pdf = tmp_path / "c.pdf"
    with pytest.MonkeyPatch.context() as env:
        env.setenv(PASS_VAR, PASSPHRASE)
        code, out, err = cli("inspect", BRACKET_NOMINAL, BRACKET_MEASURED, "--plan", plan,
                             "--report", pdf, "--sign",
                             signed.p12, "--sign-pass-env", PASS_VAR, "--serial", "SN-B8")
    assert code == 0 and out.startswith("ACCEPT"), out + err
    text = squeeze("\n".join(page_texts(pdf, layout=False)))
    number = read_toml(plan)["part"]["number"]
    assert f"Part number {number} Part name" in text and "the inspection plan states" not in text
    assert ("Datum A (plane, tangent); the freedom it leaves (shift along +x, shift along +y, "
            "turn about +z through (") in text and ") best-fitted on regions skin." in text
    assert ("conforms to the inspection plan plan.toml: all 5 characteristics lie within their "
            "tolerances") in text
    assert "REJECTED" not in text


def test_a_plan_accept_rests_on_its_characteristics_not_the_statistics_zone(tmp_path):
    """A plan's ACCEPT is certified though points lie outside the zone of the statistics (which
    is not part of its verdict); a bug upstream that calls the seat bracket's rejected plan run
    ACCEPT is refused."""
    from dataclasses import replace

    from engine.errors import QAError
    from engine.pipeline import run_files
    from engine.settings import InspectionSettings
    from engine.tolerance import Tolerance
    from reports.certificate import CertificateInfo, make_certificate

    plan = tmp_path / "plan.toml"
    plan.write_text(read_text(BRACKET_PLAN).replace("zone = 0.02\n", "zone = 0.1\n", 1))
    run = run_files(BRACKET_NOMINAL, BRACKET_MEASURED,
                    InspectionSettings(-0.001, 0.001, plan=str(plan), zone_in_verdict=False))
    d = run.result.deviations.signed
    assert run.result.verdict == "ACCEPT" and (np.abs(d) > 0.001).any()
    assert make_certificate(run, CertificateInfo(), None)[:5] == b"%PDF-"

    run = run_files(BRACKET_NOMINAL, BRACKET_MEASURED,
                    InspectionSettings(-0.015, 0.015, plan=BRACKET_PLAN, zone_in_verdict=False))
    assert run.plan is not None and run.plan.part.number == "SB-1020"
    assert run.result.verdict == "REJECT"
    wrong = replace(run, result=replace(run.result, verdict="ACCEPT",
                                        tolerance=Tolerance(-1.0, 1.0)))
    with pytest.raises(QAError, match="a characteristic is not within its limits"):
        make_certificate(wrong, CertificateInfo(), None)


def test_the_same_run_issued_at_the_same_time_lays_out_to_the_same_bytes():
    """The laid-out certificate (reportlab's PDF, before pyHanko embeds the evidence) depends on
    the run and the issue time only: reportlab's invariant mode takes the file's ID from its
    content, and its creation date is the issue time, not the clock's."""
    import datetime as dt

    from engine.pipeline import run_files
    from engine.settings import InspectionSettings
    from reports.certificate import CertificateInfo, draft_certificate

    run = run_files(str(BELLY_NOMINAL), str(BELLY_MEASURED), InspectionSettings(-0.25, 0.25))
    info = CertificateInfo(part_number="BF-1", serial="SN-1")
    issued = dt.datetime(2024, 5, 1, 12, 0, 0, tzinfo=dt.timezone.utc)
    first = draft_certificate(run, info, None, issued).pdf
    assert draft_certificate(run, info, None, issued).pdf == first
    assert b"/CreationDate (D:20240501120000+00'00')" in first
    later = draft_certificate(run, info, None, issued + dt.timedelta(seconds=1)).pdf
    assert later != first  # the issue time is in it (the number, the date)
