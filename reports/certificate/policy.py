"""What a certificate states and when it may not be made: the inspector's fields
(:class:`CertificateInfo`), the signer as inspector, the plan's part and traceability fields, the
certificate number, and the refusal to certify an ACCEPT the result does not support."""

from __future__ import annotations

import datetime as dt
import hashlib
import json
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from engine.choices import DecisionRule
from engine.errors import QAError, SettingsError
from engine.pipeline import Run
from engine.verdict import ACCEPT

from ..signing import Identity


@dataclass(frozen=True)
class CertificateInfo:
    """What the inspector states about the part and the inspection (all optional text)."""

    part_number: str | None = None
    part_name: str | None = None
    revision: str | None = None
    serial: str | None = None
    order: str | None = None
    inspector: str | None = None
    organisation: str | None = None
    device: str | None = None
    notes: str | None = None
    device_serial: str | None = None
    calibration_date: str | None = None
    """The device's last calibration, YYYY-MM-DD."""
    probe: str | None = None
    """The probe and stylus."""
    temperature_c: float | None = None
    """The part's temperature during the measurement, °C."""
    program: str | None = None
    """The measurement program (its name or file)."""
    drawing: str | None = None
    """The drawing number (its revision is ``revision``)."""
    cad_revision: str | None = None
    """The revision of the CAD model (the nominal)."""


TRACEABILITY = (("device", "Device"), ("device_serial", "Device serial"),
                ("calibration_date", "Calibrated on"), ("probe", "Probe / stylus"),
                ("temperature_c", "Temperature"), ("program", "Program"),
                ("drawing", "Drawing"), ("cad_revision", "CAD revision"))
"""The certificate's traceability fields (CertificateInfo) and their labels, in print order."""


class CertificationError(SettingsError):
    """What the certificate would state contradicts its signature (a usage error: nothing is
    written)."""


class CertificateError(QAError, RuntimeError):
    """No certificate can be made from this run: it would certify what the result does not
    support, or its layout failed. A bug, never the user's doing (unlike
    :class:`CertificationError`): nothing is written."""


def same_person(a: str | None, b: str | None) -> bool:
    """Whether two spellings of a name are the same name (case and spacing aside)."""
    def norm(s):
        return " ".join(str(s or "").split()).casefold()

    return bool(norm(a)) and norm(a) == norm(b)


def check_inspector(info: CertificateInfo, identity: Identity | None) -> None:
    """Raise CertificationError when the inspector named is not the signer (known as soon as
    the identity is loaded, before any inspection)."""
    if identity is not None and info.inspector and info.inspector.strip() and not same_person(
            info.inspector, identity.common_name):
        raise CertificationError(
            f"the inspector named, '{info.inspector}', is not the signer: the signing identity "
            f"{identity.path} belongs to '{identity.common_name}'. A certificate names the "
            "person who signs it: leave the inspector out (--inspector), or sign with that "
            "inspector's own identity")


def certified_info(info: CertificateInfo, identity: Identity | None,
                   verdict: str) -> CertificateInfo:
    """``info`` as a certificate of ``verdict`` states it: signed, its inspector is the signer
    (the subject's common name of the signing certificate).

    Raises CertificationError when the inspector named is another person, or when a signed
    ACCEPTED certificate does not identify its part by part number and serial number (an
    unsigned draft may lack them).
    """
    check_inspector(info, identity)
    if identity is None:
        return info
    if verdict == ACCEPT:
        missing = [what for what, v in (("its part number (--part-number)", info.part_number),
                                        ("its serial number (--serial)", info.serial))
                   if not (v and v.strip())]
        if missing:
            raise CertificationError(
                f"the part is ACCEPTED, but a signed ACCEPTED certificate must identify the "
                f"part it accepts: give {' and '.join(missing)}; nothing was written")
    return replace(info, inspector=identity.common_name)


def plan_info(info: CertificateInfo, run: Run) -> CertificateInfo:
    """``info`` with the part number, name, revision, drawing and CAD revision of the run's
    inspection plan (``[part]``) and its traceability fields (``[measurement]``: device, serial,
    calibration date, probe, program, temperature) where the inspector gave none.

    Given ones win: the inspector states which part is on the table (one plan may serve several
    dash numbers, or a revision whose change does not touch the characteristics). An auditor
    must still see a plan written for another part or revision, so section 1 prints the plan's
    value beside any that differs, and results.json keeps it (``certificate.plan_part``).
    A temperature given that differs from the plan's, when the plan's instrument uses it for
    the thermal term of the uncertainty budget, raises CertificationError.
    """
    if run.plan is None:
        return info
    part, how = run.plan.part, run.plan.measurement
    ins = how.instrument
    if (info.temperature_c is not None and ins is not None and ins.expansion_per_k is not None
            and run.settings.instrument is None and info.temperature_c != how.temperature_c):
        raise CertificationError(
            f"the part temperature given, {info.temperature_c:g} °C, is not the inspection "
            f"plan's [measurement] temperature_c = {how.temperature_c:g} °C that its "
            "uncertainty budget uses (thermal expansion): correct one of them")
    planned: dict[str, Any] = {"part_number": part.number, "part_name": part.name, "revision": part.revision,
               "drawing": part.drawing, "cad_revision": part.cad_revision,
               "device": how.device, "device_serial": how.device_serial,
               "calibration_date": how.calibration_date, "probe": how.probe,
               "program": how.program, "temperature_c": how.temperature_c}
    return replace(info, **{k: v for k, v in planned.items()
                            if _given(v) and not _given(getattr(info, k))})


def _given(v) -> bool:
    return v is not None and (not isinstance(v, str) or bool(v.strip()))


def certificate_number(run: Run, issued: dt.datetime) -> str:
    """QA-YYYYMMDD-XXXXXXXX: the date and a hash of the inputs, settings and issue time."""
    h = hashlib.sha256()
    for r in run.inputs:
        h.update(r.sha256.encode())
    h.update(json.dumps(run.settings.to_json(), sort_keys=True).encode())
    h.update(issued.isoformat().encode())
    return f"QA-{issued:%Y%m%d}-{h.hexdigest()[:8].upper()}"


def check_trustworthy(run: Run) -> None:
    """A certificate may say ACCEPTED only from a converged registration whose pose the
    judge trusted; anything else here is a bug upstream, and no certificate is made."""
    res = run.result
    if res.plan is not None:
        # A plan's verdict is its characteristics': each inside its limits, on a registration
        # whose regions can be trusted (the per-point zone is only the statistics').
        within = all(r.verdict == ACCEPT and _within(r) for r in res.plan.characteristics)
        if res.verdict == ACCEPT and not (registration_trusted(res) and within):
            raise CertificateError("refusing to certify ACCEPTED: the registration is not "
                                   "trustworthy or a characteristic is not within its limits")
        return
    # Weak or free directions and a runner-up pose are facts; the verdict is trusted when it
    # is the same at every pose they allow (engine.pose_sensitivity).
    sens = res.pose_sensitivity
    trusted = (registration_trusted(res) and res.conditioning is not None and sens is not None
               and sens.verdict_stable)
    d, tol = res.deviations.signed, res.tolerance
    # The guarded rule's guard band: U, or the sampling margin alone (older sessions).
    m: float | np.ndarray = 0.0
    if res.decision_rule == DecisionRule.GUARDED:
        guard = res.margin if res.uncertainty is None else res.uncertainty.expanded
        if guard is None:
            raise CertificateError("refusing to certify: a guarded inspection without its "
                                   "guard band (no uncertainty, no sampling margin)")
        m = guard
    inside = bool(np.all((d >= tol.lower + m) & (d <= tol.upper - m)))
    if res.verdict == ACCEPT and not (trusted and inside):
        raise CertificateError("refusing to certify ACCEPTED: the registration is not "
                               "trustworthy or a point is not inside its zone")


def _within(r) -> bool:
    """Whether a characteristic's own numbers lie inside its limits: every deviation of a
    profile, the value of the others (about the nominal of a size)."""
    c = r.characteristic
    if r.value is None:
        return False
    if c.type == "profile":
        return r.deviations is not None and bool(np.all((r.deviations >= c.lower) &
                                                        (r.deviations <= c.upper)))
    return (c.nominal or 0.0) + c.lower <= r.value <= (c.nominal or 0.0) + c.upper


def registration_trusted(res) -> bool:
    from engine.verdict import pose_trusted

    return pose_trusted(res.registration)
