"""Signing and verifying inspection certificates (PAdES baseline B-B through pyHanko).

* :func:`make_demo_identity` writes a demonstration CA (``ca.pem``, the trust anchor verifiers are
  given) and an inspector identity signed by it (``inspector.p12``): ECDSA P-256, SHA-256,
  keyUsage digitalSignature + nonRepudiation. Real users bring their own PKCS#12.
* :func:`load_identity` reads a PKCS#12 once (pyHanko's stock path re-parses it per signature).
* :func:`finish_pdf` embeds the evidence files, adds the signature fields and, given an identity,
  signs: a certification signature that still allows form filling, so that an approver can add a
  second signature to the empty ``Approver`` field without invalidating the first.
* :func:`verify_pdf` validates every signature against explicitly given trust roots only; the
  document is valid when every signature is intact and trusted, the latest one covers the whole
  file and earlier ones saw nothing but the addition of signatures. Any exception is a failure.
"""

from __future__ import annotations

import datetime as dt
import hashlib
import io
import logging
import os
from dataclasses import dataclass, field, replace

from engine.errors import InputError, QAError
from engine.io.points import read_bytes

from .outputs import Output, write_all

# pyHanko logs what it finds wrong with a document (with tracebacks); verify_pdf reports the
# same findings itself, so the log stays quiet unless an application configures logging.
logging.getLogger("pyhanko").addHandler(logging.NullHandler())

INSPECTOR_FIELD, APPROVER_FIELD = "Inspector", "Approver"
DEMO_MARK = "DEMONSTRATION identity made by qa-inspect keygen - not for production use"


class OutputExistsError(QAError, FileExistsError):
    """An output that must not be overwritten (a signing identity) is already there.

    A ``FileExistsError`` too (with one argument: ``str(error)`` is the message, ``errno`` is
    None), so callers that treat "cannot create the output" as ``OSError`` keep doing so.
    """

    def __init__(self, path: str):
        super().__init__(f"{path} already exists; not overwritten")
        self.path = path


@dataclass(frozen=True)
class Attachment:
    """A file embedded in the certificate (covered by the signature)."""

    name: str
    data: bytes
    mime_type: str
    description: str


@dataclass
class Identity:
    """A signer loaded from a PKCS#12 file.

    ca_fingerprint : SHA-256 (hex, colon-separated) of the issuing CA's certificate when the file
        carries it, else None.
    """

    path: str
    common_name: str
    organisation: str
    issuer: str
    ca_fingerprint: str | None
    demonstration: bool
    _p12: bytes = field(repr=False, default=b"")
    _passphrase: bytes | None = field(repr=False, default=None)
    _signer: object = field(repr=False, default=None)

    def public(self) -> "Identity":
        """This identity without its key (and passphrase): what a certificate's layout needs
        (names, issuer, CA fingerprint), safe to hand to another process."""
        return replace(self, _p12=b"", _passphrase=None, _signer=None)

    @property
    def signer(self):
        """pyHanko's signer, made once (importing pyHanko costs 0.4 s, so not before needed)."""
        if self._signer is None:
            from pyhanko.sign import signers

            self._signer = signers.SimpleSigner.load_pkcs12_data(self._p12, [],
                                                                 passphrase=self._passphrase)
        return self._signer


def fingerprint(der: bytes) -> str:
    h = hashlib.sha256(der).hexdigest().upper()
    return ":".join(h[i:i + 2] for i in range(0, len(h), 2))


def _name(cn: str, org: str, ou: str | None = None):
    from cryptography import x509
    from cryptography.x509.oid import NameOID

    attrs = [x509.NameAttribute(NameOID.COMMON_NAME, cn)]
    if org:
        attrs.append(x509.NameAttribute(NameOID.ORGANIZATION_NAME, org))
    if ou:
        attrs.append(x509.NameAttribute(NameOID.ORGANIZATIONAL_UNIT_NAME, ou))
    return x509.Name(attrs)


def _key_usage(sign_docs: bool):
    from cryptography import x509

    return x509.KeyUsage(digital_signature=sign_docs, content_commitment=sign_docs,
                         key_encipherment=False, data_encipherment=False, key_agreement=False,
                         key_cert_sign=not sign_docs, crl_sign=not sign_docs,
                         encipher_only=False, decipher_only=False)


def make_demo_identity(name: str, organisation: str, out_dir: str,
                       passphrase: bytes) -> tuple[str, str]:
    """Write ``out_dir/ca.pem`` and ``out_dir/inspector.p12``; return their paths.

    Refuses to overwrite either file (an identity in use must not be lost by a typo).
    """
    from cryptography import x509
    from cryptography.hazmat.primitives import hashes, serialization
    from cryptography.hazmat.primitives.asymmetric import ec
    from cryptography.hazmat.primitives.serialization import pkcs12

    ca_path = os.path.join(out_dir, "ca.pem")
    p12_path = os.path.join(out_dir, "inspector.p12")
    for p in (ca_path, p12_path):
        if os.path.exists(p):
            raise OutputExistsError(p)
    now = dt.datetime.now(dt.timezone.utc).replace(microsecond=0)
    ca_key = ec.generate_private_key(ec.SECP256R1())
    ca_name = _name(f"{organisation or name} DEMONSTRATION CA", organisation, DEMO_MARK)
    ca = (x509.CertificateBuilder().subject_name(ca_name).issuer_name(ca_name)
          .public_key(ca_key.public_key()).serial_number(x509.random_serial_number())
          .not_valid_before(now - dt.timedelta(hours=1))
          .not_valid_after(now + dt.timedelta(days=5 * 365))
          .add_extension(x509.BasicConstraints(ca=True, path_length=0), critical=True)
          .add_extension(_key_usage(False), critical=True)
          .add_extension(x509.SubjectKeyIdentifier.from_public_key(ca_key.public_key()),
                         critical=False)
          .sign(ca_key, hashes.SHA256()))
    key = ec.generate_private_key(ec.SECP256R1())
    cert = (x509.CertificateBuilder().subject_name(_name(name, organisation, DEMO_MARK))
            .issuer_name(ca_name).public_key(key.public_key())
            .serial_number(x509.random_serial_number())
            .not_valid_before(now - dt.timedelta(hours=1))
            .not_valid_after(now + dt.timedelta(days=2 * 365))
            .add_extension(x509.BasicConstraints(ca=False, path_length=None), critical=True)
            .add_extension(_key_usage(True), critical=True)
            .add_extension(x509.AuthorityKeyIdentifier.from_issuer_public_key(
                ca_key.public_key()), critical=False)
            .add_extension(x509.SubjectKeyIdentifier.from_public_key(key.public_key()),
                           critical=False)
            .sign(ca_key, hashes.SHA256()))
    p12 = pkcs12.serialize_key_and_certificates(
        name.encode("utf-8"), key, cert, [ca],
        serialization.BestAvailableEncryption(passphrase))
    write_all([Output(p12_path, p12, private=True),
               Output(ca_path, ca.public_bytes(serialization.Encoding.PEM))])
    return ca_path, p12_path


def load_identity(path: str, passphrase: bytes | None) -> Identity:
    """Read a PKCS#12 signing identity. Raises InputError naming the file and the problem."""
    from cryptography import x509
    from cryptography.hazmat.primitives.serialization import Encoding, pkcs12
    from cryptography.x509.oid import NameOID

    data = read_bytes(path)
    try:
        key, cert, others = pkcs12.load_key_and_certificates(data, passphrase)
    except ValueError as e:
        raise InputError("cannot open the PKCS#12 signing identity: wrong passphrase or not a "
                         f"PKCS#12 file ({e})", path) from e
    if key is None or cert is None:
        raise InputError("the PKCS#12 file holds no private key and certificate", path)
    now = dt.datetime.now(dt.timezone.utc)
    if not cert.not_valid_before_utc <= now <= cert.not_valid_after_utc:
        raise InputError(f"the signing certificate is not valid now (valid "
                         f"{cert.not_valid_before_utc:%Y-%m-%d} to "
                         f"{cert.not_valid_after_utc:%Y-%m-%d})", path)
    try:
        ku = cert.extensions.get_extension_for_class(x509.KeyUsage).value
    except x509.ExtensionNotFound:
        ku = None
    if ku is None or not (ku.digital_signature and ku.content_commitment):
        # Validators (pyHanko, Adobe) want nonRepudiation on a document signature, and read a
        # certificate without the key-usage extension as having none: such a certificate
        # would sign here and then fail every verification.
        raise InputError("the signing certificate's key usage must allow digitalSignature and "
                         "nonRepudiation (content commitment) to sign certificates; it "
                         + ("has no key-usage extension" if ku is None else "allows " + (
                             ", ".join(n for n, on in (
                                 ("digitalSignature", ku.digital_signature),
                                 ("nonRepudiation", ku.content_commitment),
                                 ("keyEncipherment", ku.key_encipherment),
                                 ("keyAgreement", ku.key_agreement),
                                 ("keyCertSign", ku.key_cert_sign),
                                 ("cRLSign", ku.crl_sign)) if on) or "nothing")), path)

    def attr(n, oid):
        v = n.get_attributes_for_oid(oid)
        return str(v[0].value) if v else ""

    issuer_ca = next((c for c in others if c.subject == cert.issuer), None)
    return Identity(
        path=path, common_name=attr(cert.subject, NameOID.COMMON_NAME),
        organisation=attr(cert.subject, NameOID.ORGANIZATION_NAME),
        issuer=cert.issuer.rfc4514_string(),
        ca_fingerprint=None if issuer_ca is None else fingerprint(
            issuer_ca.public_bytes(Encoding.DER)),
        demonstration=DEMO_MARK in attr(cert.subject, NameOID.ORGANIZATIONAL_UNIT_NAME),
        _p12=data, _passphrase=passphrase)


@dataclass(frozen=True)
class SignatureSlot:
    """Where a visible signature goes: 0-based page and box (x1, y1, x2, y2) in PDF points."""

    page: int
    box: tuple[float, float, float, float]


def finish_pdf(pdf: bytes, attachments: list[Attachment], slots: dict[str, SignatureSlot],
               identity: Identity | None, reason: str, location: str = "") -> bytes:
    """Embed ``attachments``, add the signature fields of ``slots`` and sign the
    ``INSPECTOR_FIELD`` with ``identity`` (None: leave every field empty, an unsigned draft)."""
    from pyhanko.pdf_utils import embed
    from pyhanko.pdf_utils.incremental_writer import IncrementalPdfFileWriter
    from pyhanko.sign import fields, signers
    from pyhanko.stamp import TextStampStyle

    w = IncrementalPdfFileWriter(io.BytesIO(pdf))
    for a in attachments:
        ef = embed.EmbeddedFileObject.from_file_data(w, data=a.data, mime_type=a.mime_type)
        embed.embed_file(w, embed.FileSpec(file_spec_string=a.name, file_name=a.name,
                                           embedded_data=ef, description=a.description))

    def spec(name):
        s = slots[name]
        return fields.SigFieldSpec(name, on_page=s.page, box=tuple(int(round(v)) for v in s.box))

    for name in slots:
        if name != INSPECTOR_FIELD or identity is None:
            fields.append_signature_field(w, spec(name))
    if identity is None:
        out = io.BytesIO()
        w.write(out)
        return out.getvalue()
    meta = signers.PdfSignatureMetadata(
        field_name=INSPECTOR_FIELD, md_algorithm="sha256",
        subfilter=fields.SigSeedSubFilter.PADES, certify=True,
        docmdp_permissions=fields.MDPPerm.FILL_FORMS, reason=reason, location=location or None,
        name=identity.common_name)
    style = TextStampStyle(
        stamp_text="Digitally signed by %(signer)s\nOrganisation: %(org)s\nTime: %(ts)s\n"
                   "CA SHA-256: %(ca)s",
        timestamp_format="%Y-%m-%d %H:%M:%S %Z", border_width=1)
    ca = identity.ca_fingerprint or "issuer certificate not in the PKCS#12"
    ps = signers.PdfSigner(meta, identity.signer, stamp_style=style,
                           new_field_spec=spec(INSPECTOR_FIELD))
    out = ps.sign_pdf(w, appearance_text_params={
        "org": identity.organisation or "-", "ca": ca[:47] + "..." if len(ca) > 50 else ca})
    return out.getvalue()


@dataclass
class SignatureReport:
    field: str
    signer: str
    organisation: str
    signed_at: dt.datetime | None
    intact: bool
    trusted: bool
    coverage: str
    problems: list[str]


@dataclass
class Verification:
    """Outcome of :func:`verify_pdf`: ``valid`` is the one answer that matters."""

    valid: bool
    problems: list[str] = field(default_factory=list)
    signatures: list[SignatureReport] = field(default_factory=list)
    attachments: dict[str, bytes] = field(default_factory=dict)


def read_trust_roots(path: str) -> list:
    """Certificates (PEM, one or more, or DER) to trust; InputError if there are none."""
    from asn1crypto import pem, x509

    data = read_bytes(path)
    try:
        if pem.detect(data):
            certs = [x509.Certificate.load(der) for kind, _, der in pem.unarmor(data, True)
                     if kind == "CERTIFICATE"]
        else:
            certs = [x509.Certificate.load(data)]
            certs[0].native  # parse now, so a non-certificate fails here
    except Exception as e:  # asn1crypto raises several types for garbage
        raise InputError(f"not a certificate file (PEM or DER): {e}", path) from e
    if not certs:
        raise InputError("holds no CERTIFICATE block", path)
    return certs


def verify_pdf(pdf: bytes, trust_roots: list) -> Verification:
    """Validate every signature of ``pdf`` against ``trust_roots`` (asn1crypto certificates)."""
    try:
        return _verify(pdf, trust_roots)
    except Exception as e:  # any failure to validate is a failed validation
        return Verification(False, [f"the document could not be validated: "
                                    f"{type(e).__name__}: {e}"])


def _verify(pdf: bytes, trust_roots: list) -> Verification:
    from pyhanko.pdf_utils.reader import PdfFileReader
    from pyhanko.sign.validation import read_certification_data, validate_pdf_signature
    from pyhanko.sign.validation.status import ModificationLevel, SignatureCoverageLevel
    from pyhanko_certvalidator import ValidationContext

    reader = PdfFileReader(io.BytesIO(pdf), strict=True)
    sigs = sorted(reader.embedded_signatures, key=lambda s: s.signed_revision)
    v = Verification(True)
    if not sigs:
        return Verification(False, ["the document carries no signature (an unsigned draft)"])
    for k, s in enumerate(sigs):
        vc = ValidationContext(trust_roots=list(trust_roots), allow_fetching=False)
        st = validate_pdf_signature(s, vc)
        cert = st.signing_cert
        subject = cert.subject.native
        problems = []
        if not st.intact:
            problems.append("the signed bytes were changed (digest mismatch)")
        if not st.valid:
            problems.append("the signature value does not verify")
        if not st.trusted:
            why = getattr(st, "trust_problem_indic", None)
            problems.append("the signer's certificate is not trusted for document signatures "
                            "by the given trust anchor"
                            + (f" ({getattr(why, 'name', why)})" if why else ""))
        last = k == len(sigs) - 1
        if last and st.coverage != SignatureCoverageLevel.ENTIRE_FILE:
            # pyHanko leaves the coverage None when it could not determine it.
            coverage = "undetermined" if st.coverage is None else st.coverage.name
            problems.append("the file was changed after the last signature "
                            f"(coverage: {coverage})")
        if not last and (st.modification_level is None
                         or st.modification_level > ModificationLevel.FORM_FILLING
                         or not st.docmdp_ok):
            problems.append("changes other than further signatures were made after this "
                            "signature")
        if st.md_algorithm not in ("sha256", "sha384", "sha512", "sha3_256", "sha3_384",
                                   "sha3_512"):
            problems.append(f"digest algorithm {st.md_algorithm} is weaker than SHA-256")
        v.signatures.append(SignatureReport(
            s.field_name, subject.get("common_name", ""), subject.get("organization_name", ""),
            st.signer_reported_dt, bool(st.intact and st.valid), bool(st.trusted),
            st.coverage.name if st.coverage else "NONE", problems))
        v.problems += [f"signature '{s.field_name}': {p}" for p in problems]
    # The certificate is the inspector's certification signature; an approver can only add to
    # it. A document whose first signature is anything else (an approver's signature on an
    # unsigned draft, say) is not a certificate.
    first = sigs[0]
    if first.field_name != INSPECTOR_FIELD:
        v.problems.append(f"the first signature is '{first.field_name}', not the inspector's "
                          f"certification signature ('{INSPECTOR_FIELD}')")
    elif read_certification_data(reader) is None:
        v.problems.append("the inspector's signature is not a certification signature")
    v.attachments = embedded_files(reader)
    v.valid = not v.problems
    return v



def embedded_files(reader) -> dict[str, bytes]:
    """The document's embedded files by name (flat name tree, as :func:`finish_pdf` writes)."""
    root = reader.root
    try:
        names = root["/Names"]["/EmbeddedFiles"]["/Names"]
    except KeyError:
        return {}
    out = {}
    for i in range(0, len(names), 2):
        spec = names[i + 1].get_object()
        out[str(names[i])] = spec["/EF"]["/F"].get_object().data
    return out
