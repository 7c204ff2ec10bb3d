"""Section 1 of the certificate, identification: the part, the inspection and the
traceability of the measurement."""

from __future__ import annotations

from ..results import SOFTWARE_NAME, software_version
from .layout import DEMONSTRATION_NOTE, Layout
from .policy import TRACEABILITY, CertificateInfo, same_person


def identification(c: Layout) -> list:
    """1  Identification: the part (left) and the inspection (right)."""
    from reportlab.lib.units import mm
    from reportlab.platypus import Paragraph as P

    info, identity = c.info, c.identity
    left = c.kv([("Organisation", info.organisation),
                 ("Part number", _stated(c, info.part_number, "number")),
                 ("Part name", _stated(c, info.part_name, "name")),
                 ("Revision", _stated(c, info.revision, "revision")),
                 ("Serial number", info.serial), ("Order", info.order)], [28 * mm, 58 * mm])
    right = c.kv([("Inspector", identity.common_name if identity else info.inspector),
                  ("Date and time", f"{c.issued:%Y-%m-%d %H:%M:%S} UTC"),
                  ("Software", f"{SOFTWARE_NAME} {software_version()}"),
                  ("Certificate No.", c.number),
                  ("Status", "signed (PAdES)" if identity else "UNSIGNED DRAFT")],
                 [28 * mm, 56 * mm])
    return [P("1  Identification", c.styles["h"]), *_demonstration(c),
            _two_columns(c, left, right), *_traceability(c)]


def _demonstration(c: Layout) -> list:
    """Signed with a demonstration identity: said on the first page, in a box, in the words
    of section 11 (layout.DEMONSTRATION_NOTE); nothing otherwise."""
    from reportlab.lib.units import mm
    from reportlab.platypus import Paragraph as P
    from reportlab.platypus import Spacer, Table

    if c.identity is None or not c.identity.demonstration:
        return []
    box = Table([[P(f"<b>{DEMONSTRATION_NOTE}</b>", c.styles["base"])]], colWidths=[c.width],
                style=[("BOX", (0, 0), (-1, -1), 1.0, (0.60, 0.30, 0.0)),
                       ("BACKGROUND", (0, 0), (-1, -1), (1.0, 0.96, 0.86)),
                       ("TOPPADDING", (0, 0), (-1, -1), 3),
                       ("BOTTOMPADDING", (0, 0), (-1, -1), 4)])
    return [box, Spacer(1, 2 * mm)]


def _two_columns(c: Layout, left, right):
    """Two flowables side by side, each half the text width."""
    from reportlab.platypus import Table

    return Table([[left, right]], colWidths=[c.width / 2, c.width / 2],
                 style=[("VALIGN", (0, 0), (-1, -1), "TOP"),
                        ("LEFTPADDING", (0, 0), (-1, -1), 0),
                        ("RIGHTPADDING", (0, 0), (-1, -1), 0)])


def _traceability(c: Layout) -> list:
    """The traceability block of section 1: how the part was measured (device, serial,
    calibration, probe, temperature, program) and against which drawing and CAD revision;
    a field not stated reads "—" (an auditor sees what is missing)."""
    from reportlab.lib.units import mm
    from reportlab.platypus import Paragraph as P
    from reportlab.platypus import Spacer

    info = c.info
    pairs = [(label, _traceability_value(info, key)) for key, label in TRACEABILITY]
    half = (len(pairs) + 1) // 2
    return [Spacer(1, 2 * mm), P("Traceability", c.styles["cellb"]), Spacer(1, 1 * mm),
            _two_columns(c, c.kv(pairs[:half], [28 * mm, 58 * mm]),
                         c.kv(pairs[half:], [28 * mm, 56 * mm]))]


def _traceability_value(info: CertificateInfo, key: str) -> str | None:
    value = getattr(info, key)
    if key == "temperature_c" and value is not None:
        return f"{value:g} °C"
    return value


def _stated(c: Layout, value: str | None, field: str) -> str | None:
    """A part field as the inspector stated it, and the inspection plan's beside it when the
    plan states another (:func:`plan_info`)."""
    planned = "" if c.run.plan is None else getattr(c.run.plan.part, field).strip()
    if planned and not same_person(value, planned):
        return f"{value} (the inspection plan states {planned})"
    return value
