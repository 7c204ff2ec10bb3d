"""Verifying a certificate again: its signatures (:func:`reports.signing.verify_pdf`,
pyHanko), the certificate as it was issued (signed by the inspector it names), and, given the
input files, their SHA-256 against the certified ones and a re-run of the inspection with the
certified settings.

No Qt and no front end here: ``qa-inspect verify`` prints :func:`outcome_lines` of
:func:`verify_certificate`'s result, and the desktop app (File → Verify certificate…) runs it in
its worker and shows the same lines.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass

from engine.errors import SettingsError

from .signing import SignatureReport

RERUN_SUBJECTS = ("nominal", "measured", "plan", "re-run")
"""The checks made with the input files: their SHA-256s and the re-run."""


class RerunFilesError(SettingsError):
    """The files given for the re-run do not go together, or not with the certificate (made
    with an inspection plan and none given, or the other way round). The command line words it
    as a usage error (exit 64)."""


@dataclass(frozen=True)
class Check:
    """One check of a verification and its outcome."""

    subject: str
    """What was checked: "signatures", "issue" (the certificate as issued: a signed
    certificate, signed by the inspector it names), a file's role ("nominal", "measured",
    "plan": its SHA-256 against the certified one) or "re-run"."""
    passed: bool
    message: str
    """What was found: a confirmation when it passed, else the problem (the command line's
    words)."""


@dataclass(frozen=True)
class Certified:
    """What the certificate's embedded ``results.json`` states."""

    number: str | None
    verdict: str | None
    """ACCEPT, REJECT or INCONCLUSIVE."""
    reasons: tuple[str, ...]


@dataclass(frozen=True)
class CertificateVerification:
    """The outcome of :func:`verify_certificate`: ``valid`` is the one answer that matters."""

    path: str
    """The certificate verified (PDF)."""
    signatures: tuple[SignatureReport, ...]
    certified: Certified | None
    """What the certificate states; None when its signatures do not hold or it carries no
    readable results."""
    checks: tuple[Check, ...]
    """Every check made, in order: the signatures, the issue, each file, the re-run."""

    @property
    def valid(self) -> bool:
        """Every check passed."""
        return all(c.passed for c in self.checks)

    @property
    def problems(self) -> tuple[str, ...]:
        return tuple(c.message for c in self.checks if not c.passed)


def check_files(nominal: str | None, measured: str | None, plan: str | None) -> None:
    """Raise RerunFilesError unless the files for a re-run go together: the nominal and the
    measured points both or neither, a plan only with them."""
    if (nominal is None) != (measured is None):
        raise RerunFilesError("give both --nominal and --measured, or neither")
    if plan is not None and nominal is None:
        raise RerunFilesError("--plan re-runs the inspection with --nominal and --measured; "
                              "give them too")


def verify_certificate(path: str, trust: Sequence[str], nominal: str | None = None,
                       measured: str | None = None, plan: str | None = None,
                       progress: Callable[[str, float], None] | None = None
                       ) -> CertificateVerification:
    """Verify the certificate ``path`` against the trust anchors in the files ``trust`` (PEM
    or DER; nothing else is trusted) and, given ``nominal`` and ``measured`` (and ``plan`` for a
    certificate made with one), re-run its inspection on them (:func:`recheck`; ``progress``
    goes to the run).

    A certificate that fails a check is a value (``valid`` False, the failed checks say why),
    an unreadable or broken PDF included. Raises RerunFilesError when the files given do not go
    together or not with the certificate, InputError (InputNotFoundError) for a trust anchor or
    a file that cannot be read.
    """
    import json

    from engine.io.points import read_bytes

    from .signing import read_trust_roots, verify_pdf

    check_files(nominal, measured, plan)
    roots = [c for p in trust for c in read_trust_roots(p)]
    v = verify_pdf(read_bytes(path), roots)
    checks = [Check("signatures", False, p) for p in v.problems]
    if not checks:
        checks.append(Check("signatures", True, "every signature is intact and trusted, and "
                                                "nothing but signatures was added after signing"))
    doc = None
    if v.valid:
        try:
            doc = json.loads(v.attachments["results.json"])
            cert = doc["certificate"]
        except (KeyError, ValueError, TypeError) as e:
            doc = None
            checks.append(Check("issue", False,
                                f"the certificate carries no readable results.json ({e})"))
        else:
            checks.append(_issue_check(cert, v.signatures))
    if doc is not None and nominal:
        checks += recheck(doc, {"nominal": nominal, "measured": measured, "plan": plan},
                          progress)
    certified = None if doc is None else Certified(
        cert.get("number"), doc.get("verdict"), tuple(doc.get("reasons", [])))
    return CertificateVerification(path, tuple(v.signatures), certified, tuple(checks))


def _issue_check(cert: dict, signatures: list[SignatureReport]) -> Check:
    """The certificate as issued: made to be signed by the inspector it names, and so signed."""
    from .certificate import same_person

    # The PDF was made to be signed by the inspector it names: a draft signed later,
    # or by someone else, is not that certificate.
    if cert.get("signed_by") is None:
        return Check("issue", False, "the certificate was issued as an UNSIGNED DRAFT; a "
                                     "signature added afterwards does not make it a certificate")
    if signatures and signatures[0].signer != cert["signed_by"]:
        return Check("issue", False, f"the inspector's signature is by {signatures[0].signer}, "
                                     f"but the certificate was issued for {cert['signed_by']}")
    # The inspector named must be the signer (an older certificate may name none:
    # its page then named the signer).
    if signatures and cert.get("inspector") and not same_person(cert["inspector"],
                                                                signatures[0].signer):
        return Check("issue", False, f"the certificate names the inspector "
                                     f"'{cert.get('inspector')}', but its certification "
                                     f"signature is by {signatures[0].signer}")
    return Check("issue", True, f"issued for and signed by {cert['signed_by']}")


def outcome_lines(v: CertificateVerification) -> list[str]:
    """The verification in words, a line each (as ``qa-inspect verify`` prints them, before
    they are made printable): VALID or INVALID, each signature, what the certificate states,
    what the files and the re-run confirmed, and each problem."""
    lines = [f"{'VALID' if v.valid else 'INVALID'}: {v.path}"]
    lines += [f"  {signature_line(s)}" for s in v.signatures]
    if v.certified is not None:
        lines.append(f"  {certified_line(v.certified)}")
    lines += [f"  {k.message}" for k in v.checks if k.passed and k.subject in RERUN_SUBJECTS]
    return lines + [f"  problem: {p}" for p in v.problems]


def signature_line(s: SignatureReport) -> str:
    """One signature: its field, signer, time, and whether it is intact and trusted."""
    when = s.signed_at.strftime("%Y-%m-%d %H:%M:%S %Z") if s.signed_at else "time unknown"
    return (f"signature '{s.field}': {s.signer}"
            f"{' (' + s.organisation + ')' if s.organisation else ''}, {when}; "
            f"{'intact' if s.intact else 'NOT INTACT'}, "
            f"{'trusted' if s.trusted else 'NOT TRUSTED'}")


def certified_line(c: Certified) -> str:
    """What the certificate states: its number, verdict and reasons."""
    from .messages import VERDICT_WORD

    # (the certificate's verdict is the word as written: equal to its Verdict, or unknown)
    word = next((w for v, w in VERDICT_WORD.items() if v == c.verdict), "?")
    return (f"certificate {c.number}: "
            f"{word} — "
            f"{'; '.join(c.reasons)}")


def recheck(doc: dict, files: dict[str, str | None],
            progress: Callable[[str, float], None] | None = None) -> list[Check]:
    """Compare the files (by role: nominal, measured, plan) with the certificate's SHA-256s and
    re-run the inspection; return the checks, one a file and (when every file matched) the
    re-run's. The plan is required when the certificate was made with one, and refused
    otherwise (RerunFilesError)."""
    import dataclasses

    from engine.io import sha256_of
    from engine.pipeline import run_files
    from engine.settings import InspectionSettings

    from .results import run_document

    planned = next((r for r in doc["inputs"] if r["role"] == "plan"), None)
    if planned is not None and files["plan"] is None:
        raise RerunFilesError(f"the certificate was made with the inspection plan "
                              f"{os.path.basename(planned['path'])} (SHA-256 "
                              f"{planned['sha256'][:16]}…): give it with --plan FILE to re-run "
                              "the inspection")
    if planned is None and files["plan"] is not None:
        raise RerunFilesError("the certificate was made without an inspection plan; --plan "
                              "does not apply")
    checks = []
    for role, path in files.items():
        if path is None:
            continue
        want = next((r["sha256"] for r in doc["inputs"] if r["role"] == role), None)
        got = sha256_of(path)
        if got != want:
            checks.append(Check(role, False, f"{role} file {path} is not the certified one "
                                             f"(SHA-256 {got[:16]}… ≠ {str(want)[:16]}…)"))
        else:
            checks.append(Check(role, True,
                                f"{role} file matches the certified SHA-256: {path}"))
    if not all(c.passed for c in checks):
        return checks
    # The settings name the plan's path at the time of the inspection; the re-run reads the
    # plan given here, whose SHA-256 was just checked.
    settings = dataclasses.replace(InspectionSettings.from_json(doc["settings"]),
                                   plan=files["plan"])
    nominal, measured = files["nominal"], files["measured"]
    if nominal is None or measured is None:
        raise RerunFilesError("give both the nominal and the measured file to re-run the "
                              "inspection")
    run = run_files(nominal, measured, settings, progress)
    return checks + [_rerun_check(doc, run, run_document(run))]


def _rerun_check(doc: dict, run, rerun: dict) -> Check:
    """The re-run ``run`` (its document ``rerun``) against the certified document ``doc``: the
    same verdict, max |deviation| (to 1e-6 mm) and characteristics."""
    got = rerun["deviations"]["max_abs"]
    want = doc["deviations"]["max_abs"]
    changed = _changed_characteristics(doc.get("characteristics", []),
                                       rerun.get("characteristics", []))
    if run.result.verdict != doc["verdict"]:
        return Check("re-run", False, f"re-run verdict {run.result.verdict} differs from the "
                                      f"certified {doc['verdict']}")
    if want is None or abs(got - want) > 1e-6:
        return Check("re-run", False, f"re-run max |deviation| {got:.6f} mm differs from the "
                                      f"certified {want} mm")
    if changed:
        return Check("re-run", False, f"re-run characteristic(s) {', '.join(changed)} differ "
                                      "from the certified value or verdict")
    return Check("re-run", True, f"re-run: {run.result.verdict}, max |deviation| {got:.6f} mm, "
                                 "as certified")


def _changed_characteristics(certified: list[dict], rerun: list[dict]) -> list[str]:
    """The ids of the plan's characteristics whose re-run value (to 1e-6 mm) or verdict
    differs from the certified one (each id once, the certified order)."""
    again = {c["id"]: c for c in rerun}
    changed = [c["id"] for c in certified if c["id"] not in again or again[c["id"]]["verdict"]
               != c["verdict"] or (c["value"] is None) != (again[c["id"]]["value"] is None)
               or (c["value"] is not None and abs(c["value"] - again[c["id"]]["value"]) > 1e-6)]
    return changed + [i for i in again if i not in {c["id"] for c in certified}]
