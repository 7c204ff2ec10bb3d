"""A characteristic judged by its value: against its limits, guarded by the value's uncertainty
bound under the guarded decision rule (ISO 14253-1); and the results shared between the
characteristics of one region."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..verdict import ACCEPT, INCONCLUSIVE, REJECT
from .datums import Alignment
from .plan import ZONE_ONLY, Characteristic
from .results import CharacteristicResult, Geometry


def untrusted(c, idx, al: Alignment):
    return CharacteristicResult(c, None, INCONCLUSIVE,
                                f"its datums cannot place the part: {al.message}", idx,
                                facts={"datums": [f.label for f in al.datums]})


def own(shared_result: CharacteristicResult, c: Characteristic) -> CharacteristicResult:
    """A result computed for another characteristic on the same region, as ``c``'s: its
    reason names only the region, its points and its datums, which they share."""
    return replace(shared_result, characteristic=c)


def value_guard(geo: Geometry, idx: np.ndarray, T, form_only: bool) -> float | None:
    """Under the guarded rule, how far the points' uncertainty can move a value computed from
    them: twice the largest expanded U among the points ``idx`` at pose T (each point's error
    within its U moves a minimum-zone width, a least-squares diameter or a position diameter by
    at most that), without the registration's pose term for a value no rigid motion changes
    (``form_only``: a flatness, a diameter); None under the simple rule."""
    m = geo.margin(idx, T, form_only=form_only)
    return None if m is None or len(m) == 0 else 2.0 * float(np.max(m))


ON_THE_LIMIT = 5e-5
"""A value closer than this to a limit (half the 0.0001 mm it is reported to) is said to lie on
it: a nominal exactly on a size limit (NIST CTC-01's ⌀35 −0.2/+0) measured on the true part
falls either side of it with the noise, and '35.0000 outside [34.8000, 35.0000]' says
nothing."""


def by_value(c: Characteristic, idx, value: float, facts: dict, what: str,
              guard: float | None = None, unit: str = "mm"):
    """The characteristic judged by its value against its limits; with ``guard`` (the value's
    uncertainty bound, :func:`value_guard`) by ISO 14253-1: ACCEPT inside the limits shrunk
    by it, REJECT outside them grown by it, else INCONCLUSIVE. The form and
    orientation types and position have an upper limit only (their value cannot be below 0): no guard on the lower side.
    ``unit``: "mm", or "degree" (an angle: its value, limits and guard in degrees)."""
    lo, hi = (c.nominal or 0.0) + c.lower, (c.nominal or 0.0) + c.upper
    inside = lo <= value <= hi
    u = " mm" if unit == "mm" else "°"
    reason = (f"{what} {value:.4f}{u} {'within' if inside else 'outside'} "
              f"[{lo:.4f}, {hi:.4f}]{u}")
    verdict = ACCEPT if inside else REJECT
    edge = min((lo, hi), key=lambda limit: abs(value - limit))
    if abs(value - edge) < ON_THE_LIMIT and not (c.type in ZONE_ONLY and edge == lo):
        reason += (f": on its {'lower' if edge == lo else 'upper'} limit ({value - edge:+.2g}"
                   f"{u} from it, less than the {2 * ON_THE_LIMIT:g}{u} it is reported to)")
    if guard is not None:
        g_lo = 0.0 if c.type in ZONE_ONLY else guard
        facts = {**facts, "uncertainty_bound": guard}
        if value > hi + guard or value < lo - g_lo:
            verdict = REJECT
            reason += f", by more than its uncertainty ±{guard:.4f}{u}"
        elif not lo + g_lo <= value <= hi - guard:
            verdict = INCONCLUSIVE
            basis = "twice the largest U of its points" if unit == "mm" else \
                "the tilt the largest U of its points can give its features"
            reason += (f", within its uncertainty ±{guard:.4f}{u} ({basis}) of a limit: "
                       "conformance is not proven either way (ISO 14253-1)")
        else:
            reason += f" by more than its uncertainty ±{guard:.4f}{u}"
    return CharacteristicResult(c, float(value), verdict, reason, idx, facts=facts)
