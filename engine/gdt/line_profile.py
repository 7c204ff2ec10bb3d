"""The profile of a line (ASME Y14.5-2018 §11 / ISO 1101 §18.4): a region cut by planes normal to
``direction``, every ``spacing`` mm, each cross-section judged as a profile.

Section k is the plane ``x . direction = k * spacing`` (nominal frame, k an integer): the
drawing's sections at fixed positions, not at the points' extent; a measured point belongs to
the section nearest it (the slab of ``spacing`` about the plane), so every point of the region
is judged once. A section with fewer than SECTION_POINTS points is left out (reported).

* With datums, every section is at the pose the datums give (the profile's: the zone is located
  by them, each line element within it).
* Form only (no datums), each section is refitted alone within its own plane (the turn about
  ``direction`` and the two translations across it): ``fit = "lsq"`` least squares of its
  deviations, ``"minimax"`` the smallest largest excursion from the zone's centre (a one-sided
  minimum zone, engine.gdt.form.chebyshev). Both standards let each line element's zone float
  when no datum locates it; the region's own refit (a surface profile's) starts each.

The section's value is the profile's (engine.gdt.judgement): twice the largest |d - zone
centre|; the characteristic's value is the largest, and the verdict is point by point over the
judged sections' points (the decision rule's guard band too), as a profile's.
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError
from ..pose import apply_update, pose_jacobian
from ..tolerance import Tolerance
from ..verdict import INCONCLUSIVE, pointwise_verdict
from .features import complement
from .form import SECTION_POINTS, chebyshev
from .plan import Characteristic
from .results import WORST, CharacteristicResult, Geometry

REFIT_STEPS = 20
"""Gauss-Newton steps of a section's least-squares refit (it converges in a few)."""


def sections_of(X: np.ndarray, direction, spacing: float) -> np.ndarray:
    """(n,) the section (integer k: the plane x . direction = k spacing) nearest each point of
    X (n, 3)."""
    return np.rint((X @ np.asarray(direction, float)) / spacing).astype(np.int64)


def section_refit(geo: Geometry, T: np.ndarray, idx: np.ndarray, direction: np.ndarray,
                  centre: float, minimax: bool) -> np.ndarray:
    """The pose refitting the points ``idx`` from T within the plane normal to ``direction``
    (turn about it, translations across it): least squares of their deviations, or
    ``minimax`` of |d - centre|."""
    X0 = geo.evaluate(T, idx)[0]
    c = X0.mean(axis=0)
    lever = float(np.sqrt(np.mean(np.sum((X0 - c) ** 2, axis=1)))) or 1.0
    B = np.zeros((6, 3))
    B[:3, 0] = direction / lever  # x in mm of travel at the lever's distance
    B[3:, 1:] = complement(direction).T

    def fun(x):
        X, d, n = geo.evaluate(apply_update(T, B @ x, c), idx)
        return d, pose_jacobian(X, n, c) @ B

    if minimax:
        def excess(x):
            d, J = fun(x)
            s = np.sign(d - centre)
            return np.abs(d - centre), s[:, None] * J

        x = chebyshev(excess, np.zeros(3), two_sided=False).x
    else:
        x = np.zeros(3)
        for _ in range(REFIT_STEPS):
            d, J = fun(x)
            step = np.linalg.lstsq(J, -d, rcond=None)[0]
            x = x + step
            if np.max(np.abs(step)) < 1e-12:
                break
    return apply_update(T, B @ x, c)


def judge_line_profile(c: Characteristic, idx: np.ndarray, geo: Geometry, T: np.ndarray,
                       facts: dict) -> CharacteristicResult:
    """The line profile of the region's points ``idx`` from the profile's pose T (its datums',
    or its form-only refit: module docstring)."""
    tol = Tolerance(c.lower, c.upper)
    centre = 0.5 * (c.lower + c.upper)
    if c.direction is None or c.spacing is None:
        raise InputError(f"[[characteristic]] '{c.id}': a line profile needs a 'direction' "
                         "(the normal of its section planes) and a 'spacing' (mm)")
    direction = np.asarray(c.direction, float)
    k = sections_of(geo.evaluate(T, idx)[0], direction, c.spacing)
    names, counts = np.unique(k, return_counts=True)
    d = np.full(idx.size, np.nan)
    margin = None
    values: list[float | None] = []
    for name, count in zip(names, counts):
        rows = np.flatnonzero(k == name)
        if count < SECTION_POINTS:
            values.append(None)
            continue
        Tk = T if c.datums else section_refit(geo, T, idx[rows], direction, centre,
                                              c.fit == "minimax")
        d[rows] = geo.evaluate(Tk, idx[rows])[1]
        m = geo.margin(idx[rows], Tk)
        if m is not None:
            margin = np.zeros(idx.size) if margin is None else margin
            margin[rows] = m
        values.append(float(2.0 * np.max(np.abs(d[rows] - centre))))
    judged = ~np.isnan(d)
    facts = {**facts, "direction": direction, "spacing": c.spacing,
             "section_positions": (names * c.spacing).tolist(),
             "section_points": counts.tolist(), "section_values": values,
             "sections_judged": int(sum(v is not None for v in values)),
             "T_nominal_measured": T}
    if not judged.any():
        return CharacteristicResult(c, None, INCONCLUSIVE, f"no section of region "
                                    f"'{c.region}' every {c.spacing:g} mm holds "
                                    f"{SECTION_POINTS} points or more", idx, facts=facts)
    used = idx[judged]
    verdict, reason = pointwise_verdict(d[judged], tol,
                                        None if margin is None else margin[judged])
    ex = tol.excess(d[judged])
    worst = tuple(int(used[i]) for i in np.argsort(-ex, kind="stable")[:WORST])
    value = max(v for v in values if v is not None)
    return CharacteristicResult(c, value, verdict, f"{reason} ({facts['sections_judged']} "
                                "sections)", used, d[judged], worst, facts)
