"""The form family of a plan (ASME Y14.5 §5 / ISO 1101 §17-18): straightness, circularity and
cylindricity, judged on a region's measured points alone (no datum, no pose: a rigid motion
changes none of them). Flatness is engine.gdt.features.flatness, judged by engine.gdt.judgement.

Every value is a minimum zone (Chebyshev), the drawing's convention:

* :func:`cylindricity`: the radial separation of the two coaxial cylinders closest together
  that hold every point (the axis free: 4 parameters);
* :func:`circularity`: the feature cut into ``sections`` slabs of equal thickness along the
  least-squares axis; each slab's points, projected on the plane normal to the axis, held
  between two concentric circles (the centre free) of the least radial separation; the value
  is the largest over the sections;
* :func:`median_line_straightness`: the derived median line (ISO 12180: the centres of the
  least-squares circles of the same sections) held in the smallest cylinder (diametral zone,
  its axis free): its diameter;
* :func:`line_straightness`: a plane's line elements along ``direction``: the face cut into
  ``sections`` slabs across that direction; each slab's points, seen in the plane spanned by
  the direction and the face's normal, held between two parallel lines: the largest width.

Each minimum zone is :func:`chebyshev`: a sequence of linear programs (scipy's HiGHS) on the
exact residuals linearised about the current parameters, in a trust region, from the least
squares fit. Each program gives the step that minimises the linearised zone; the step is taken
when the exact zone narrows, else the region shrinks; it stops when the program predicts no
narrower zone (the first-order condition of the minimax: at a strongly unique minimum, as
these are for points spread over the feature, the steps converge quadratically). The value
reported is recomputed exactly from the final parameters.

Shapes: points (n, 3), mm, in one frame (the plan passes them in the nominal frame).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from ..verdict import INCONCLUSIVE
from .decision import by_value, own, value_guard
from .features import (axis_distances, complement, cylinder_axis, fit_circle_lsq,
                       fit_cylinder_lsq, flatness)
from .plan import DEFAULT_SECTIONS, Characteristic
from .region_features import FACING, measured_hole, nominal_cylinder
from .results import CharacteristicResult, Geometry

SECTION_POINTS = 4
"""Fewest points a cross-section needs to be judged (three lie on a circle or two on a line
whatever the form)."""


@dataclass(frozen=True)
class Zone:
    """What :func:`chebyshev` found: the parameters, the zone there and the programs solved."""

    x: np.ndarray
    value: float
    """max - min of the residuals (a two-sided zone), or their max (one-sided)."""
    programs: int


def chebyshev(fun: Callable, x0: np.ndarray, two_sided: bool = True, radius: float = 0.1,
              max_programs: int = 100) -> Zone:
    """The parameters x minimising the zone of the residuals ``fun(x) -> (f (n,), J (n, k))``:
    max f - min f (``two_sided``: a minimum zone) or max f (one-sided: an enclosing radius),
    from x0 (module docstring). radius : the first trust region, in x's units (every component
    of a step stays within it).

    Only residuals near the zone's edges can bound it: each program takes those within
    ``band`` of the zone's width from an edge (all of a few hundred), and the band widens when
    a step the program offered narrows them but not the whole zone. Every step is judged on
    all residuals, and a program over fewer rows predicts a zone no wider than over all, so
    the stop (no narrower zone predicted) is the one all rows give."""
    from scipy.optimize import linprog

    x = np.array(x0, dtype=np.float64)
    f, J = fun(x)
    value = _zone(f, two_sided)
    programs, band = 0, 0.02 if f.size > FEW_ROWS else np.inf
    while programs < max_programs and value > 0.0 and radius > 1e-15:
        rows = _near_edges(f, band, two_sided)
        step, predicted = _zone_program(linprog, f[rows], J[rows], radius, two_sided)
        programs += 1
        if step is None or not predicted < value * (1.0 - 1e-12):
            break  # no narrower zone to first order: the minimax
        f_new, J_new = fun(x + step)
        new = _zone(f_new, two_sided)
        if new < value:
            gain = value - new
            x, f, J, value = x + step, f_new, J_new, new
            if gain <= 1e-14 * value:
                break
        elif _zone(f_new[rows], two_sided) < value:
            band *= 4.0  # rows left out of the program bound the zone: take more
        else:
            radius = 0.25 * float(np.max(np.abs(step)))
    return Zone(x, value, programs)


FEW_ROWS = 300
"""Up to this many residuals every program takes them all."""


def _near_edges(f: np.ndarray, band: float, two_sided: bool) -> np.ndarray:
    """Indices of the residuals within ``band`` x the zone's width of its edges."""
    if not np.isfinite(band):
        return np.arange(f.size)
    hi = float(f.max())
    lo = float(f.min()) if two_sided else 0.0
    w = band * (hi - lo)
    return np.flatnonzero((f >= hi - w) | (f <= lo + w)) if two_sided else \
        np.flatnonzero(f >= hi - w)


def _zone(f: np.ndarray, two_sided: bool) -> float:
    return float(np.ptp(f)) if two_sided else float(np.max(f))


def _zone_program(linprog, f: np.ndarray, J: np.ndarray, radius: float, two_sided: bool):
    """(step, the zone it predicts) minimising the linearised zone of f + J step over
    |step_i| <= radius, or (None, None) when the solver fails. The residuals are taken about
    the middle of the current zone and in units of its width, so that the solver's absolute
    tolerances (1e-10) are relative to the zone."""
    m, k = J.shape
    mid = 0.5 * (f.max() + f.min()) if two_sided else 0.0
    w = _zone(f, two_sided) if two_sided else float(f.max())
    fs, G = (f - mid) / w, J / w
    one, zero = np.ones((m, 1)), np.zeros((m, 1))
    if two_sided:  # variables [step, lo, hi]: lo <= fs + G step <= hi, minimise hi - lo
        A = np.block([[G, zero, -one], [-G, one, zero]])
        b = np.concatenate([-fs, fs])
        cost = np.concatenate([np.zeros(k), [-1.0, 1.0]])
    else:  # variables [step, hi]: fs + G step <= hi, minimise hi
        A, b = np.hstack([G, -one]), -fs
        cost = np.concatenate([np.zeros(k), [1.0]])
    bounds = [(-radius, radius)] * k + [(None, None)] * (2 if two_sided else 1)
    sol = linprog(cost, A_ub=A, b_ub=b, bounds=bounds, method="highs",
                  options={"primal_feasibility_tolerance": 1e-10,
                           "dual_feasibility_tolerance": 1e-10})
    if sol.status != 0:
        return None, None
    return sol.x[:k], w * float(sol.fun)


@dataclass(frozen=True)
class CylinderZone:
    """The minimum zone of a cylinder: two coaxial cylinders about the axis through ``point``
    along ``direction``, of radii ``inner`` and ``outer`` (mm); ``width`` = outer - inner."""

    point: np.ndarray
    direction: np.ndarray
    inner: float
    outer: float
    width: float
    programs: int


def cylindricity(points: np.ndarray, axis_hint: np.ndarray, start=None) -> CylinderZone:
    """The minimum-zone cylinder of ``points`` (n, 3), mm, from their least-squares cylinder
    (``start``, their engine.gdt.features.CylinderFit if already fitted; else fitted, started
    along ``axis_hint``)."""
    fit = start if start is not None else fit_cylinder_lsq(points, axis_hint)
    frame = np.vstack([complement(fit.direction), fit.direction])
    scale = fit.radius
    q = ((points - fit.point) @ frame.T) / scale
    z = chebyshev(lambda x: axis_distances(q, x), np.zeros(4))
    point, direction = cylinder_axis(fit.point, frame, z.x, scale)
    rho = axis_distances(((points - point) @ np.vstack([complement(direction),
                                                        direction]).T), np.zeros(4))[0]
    return CylinderZone(point, direction, float(rho.min()), float(rho.max()),
                        float(np.ptp(rho)), z.programs)


def round_zone(points2d: np.ndarray) -> tuple[float, np.ndarray]:
    """(the minimum-zone radial separation, mm; its centre (2,)) of points (n, 2) about a
    circle: two concentric circles, the centre free, from the least-squares circle's."""
    fit = fit_circle_lsq(points2d)
    scale = fit.radius
    p = (points2d - fit.centre) / scale

    def radii(x):
        w = p - x
        r = np.linalg.norm(w, axis=1)
        return r, -w / r[:, None]

    z = chebyshev(radii, np.zeros(2))
    centre = fit.centre + scale * z.x
    return float(np.ptp(np.linalg.norm(points2d - centre, axis=1))), centre


def section_of(t: np.ndarray, sections: int) -> np.ndarray:
    """(n,) the slab, 0 .. sections - 1, of each coordinate t (n,): the extent of t cut into
    ``sections`` slabs of equal thickness (the largest t in the last)."""
    lo, span = float(t.min()), float(np.ptp(t))
    if span == 0.0:
        return np.zeros(t.size, dtype=int)
    return np.clip(np.floor((t - lo) / span * sections).astype(int), 0, sections - 1)


@dataclass(frozen=True)
class Sections:
    """A value per cross-section (nan: fewer than SECTION_POINTS points in it) and their
    largest, the characteristic's value."""

    values: np.ndarray
    n_points: np.ndarray
    centres: np.ndarray | None = None
    """(sections, 3): each section's least-squares centre (nan where it has too few points)."""

    @property
    def value(self) -> float:
        return float(np.nanmax(self.values))

    @property
    def judged(self) -> int:
        return int(np.sum(~np.isnan(self.values)))


def circularity(points: np.ndarray, point: np.ndarray, direction: np.ndarray,
                sections: int = DEFAULT_SECTIONS) -> Sections:
    """The circularity of each of ``sections`` slabs of a cylinder's points (n, 3) along its
    axis (through ``point`` along unit ``direction``, e.g. the least-squares axis): the
    minimum-zone radial separation of the slab's points projected on the plane normal to the
    axis (module docstring); each slab's least-squares centre (3D, at the slab's mean axial
    coordinate) too."""
    frame = np.vstack([complement(direction), direction])
    q = (points - point) @ frame.T
    where = section_of(q[:, 2], sections)
    values, counts = np.full(sections, np.nan), np.bincount(where, minlength=sections)
    centres = np.full((sections, 3), np.nan)
    for k in np.flatnonzero(counts >= SECTION_POINTS):
        s = q[where == k]
        values[k] = round_zone(s[:, :2])[0]
        c = fit_circle_lsq(s[:, :2]).centre
        centres[k] = point + np.array([c[0], c[1], s[:, 2].mean()]) @ frame
    return Sections(values, counts, centres)


def median_line_straightness(centres: np.ndarray) -> float:
    """The diameter (mm) of the smallest cylinder holding the points ``centres`` (k, 3) of a
    derived median line (:func:`circularity`'s centres): its axis free (4 parameters), from
    their least-squares line."""
    g = centres.mean(axis=0)
    axis = np.linalg.svd(centres - g)[2][0]
    frame = np.vstack([complement(axis), axis])
    length = float(np.ptp((centres - g) @ axis)) or 1.0
    q = ((centres - g) @ frame.T) / length
    spread = float(np.max(axis_distances(q, np.zeros(4))[0]))
    if spread == 0.0:
        return 0.0
    z = chebyshev(lambda x: axis_distances(q, x), np.zeros(4), two_sided=False,
                  radius=10.0 * spread)
    return 2.0 * length * z.value


def line_straightness(points: np.ndarray, normal: np.ndarray, direction: np.ndarray,
                      sections: int = DEFAULT_SECTIONS) -> Sections:
    """The straightness of a plane's line elements along ``direction`` (3,): ``points`` (n, 3)
    cut into ``sections`` slabs across it; each slab's minimum zone of two parallel lines in
    the plane of the direction (made normal to ``normal``, the face's unit normal) and the
    normal (engine.gdt.features.flatness in 2D). The direction must not lie along the normal."""
    u = direction - (direction @ normal) * normal
    u /= np.linalg.norm(u)
    across = np.cross(normal, u)
    where = section_of(points @ across, sections)
    values, counts = np.full(sections, np.nan), np.bincount(where, minlength=sections)
    for k in np.flatnonzero(counts >= SECTION_POINTS):
        s = points[where == k]
        values[k] = flatness(np.column_stack([s @ u, s @ normal]), np.array([0.0, 1.0])).width
    return Sections(values, counts)


def judge_form(c: Characteristic, idx: np.ndarray, geo: Geometry, shared):
    """A straightness, circularity or cylindricity of the region's measured points at the
    registration's pose (no pose changes them); ``shared``: engine.gdt.judgement.Shared."""
    if geo.nominal_points.shape[1] != 3:
        raise InputError(f"[[characteristic]] '{c.id}': a {c.type} is judged on a 3D nominal; "
                         "on a 2D template a line's straightness is its flatness")
    sections = c.sections or DEFAULT_SECTIONS
    if c.direction is not None:
        got = shared.once(("straightness", c.region, c.direction, sections),
                          lambda: _line_elements(c, idx, geo, sections))
    else:
        nom, normals = nominal_cylinder(c, geo, shared)
        fit = shared.once(("cylinder at T0", c.region), lambda: measured_hole(
            c, idx, geo.evaluate(geo.T0, idx)[0], normals, nom))
        if isinstance(fit, CharacteristicResult):
            return own(fit, c)
        got = shared.once((c.type, c.region, sections), lambda: _on_cylinder(
            c, idx, geo, fit, nom.direction, sections))
    if isinstance(got, CharacteristicResult):
        return own(got, c)
    value, facts, what, guard = got
    return by_value(c, idx, value, facts, what, guard)


def _on_cylinder(c: Characteristic, idx: np.ndarray, geo: Geometry, fit, hint: np.ndarray,
                 sections: int):
    """(value, facts, what it is, its uncertainty bound) of a cylinder's form, or an
    INCONCLUSIVE result when no section has the points it needs."""
    X = geo.evaluate(geo.T0, idx)[0]
    guard = value_guard(geo, idx, geo.T0, form_only=True)
    if c.type == "cylindricity":
        z = cylindricity(X, hint, start=fit)
        return z.width, {"axis_point": z.point, "axis_direction": z.direction,
                         "inner_radius": z.inner, "outer_radius": z.outer}, \
            "minimum-zone radial separation", guard
    s = circularity(X, fit.point, fit.direction, sections)
    least = 3 if c.type == "straightness" else 1
    if s.judged < least:
        return _too_few(c, idx, s, least)
    facts = {"sections": sections, "sections_judged": s.judged,
             "section_points": s.n_points.tolist()}
    if c.type == "circularity":
        return s.value, {**facts, "section_values": s.values.tolist()}, \
            f"largest minimum-zone radial separation of {s.judged} sections", guard
    if s.centres is None:  # circularity() gives every section's centre
        raise ValueError("circularity() returned no section centres")
    centres = s.centres[~np.isnan(s.values)]
    return median_line_straightness(centres), {**facts, "median_line": centres}, \
        f"diameter of the smallest cylinder holding the median line ({s.judged} sections)", \
        guard


def _line_elements(c: Characteristic, idx: np.ndarray, geo: Geometry, sections: int):
    """(value, facts, what, its uncertainty bound) of a plane's line elements along the
    characteristic's direction, or an INCONCLUSIVE result."""
    if c.direction is None:  # the caller's branch: a direction is set
        raise ValueError(f"{c.id}: line elements run along a direction; none is set")
    X, _, n = geo.evaluate(geo.T0, idx)
    normal = n.mean(axis=0) / np.linalg.norm(n.mean(axis=0))
    direction = np.asarray(c.direction)
    if abs(direction @ normal) > np.cos(FACING):
        raise InputError(f"[[characteristic]] '{c.id}': 'direction' {list(c.direction)} lies "
                         f"along the normal of region '{c.region}': line elements run along "
                         "its face")
    s = line_straightness(X, normal, direction, sections)
    if s.judged < 1:
        return _too_few(c, idx, s, 1)
    return s.value, {"sections": sections, "sections_judged": s.judged,
                     "section_points": s.n_points.tolist(),
                     "section_values": s.values.tolist(), "normal": normal}, \
        f"largest minimum-zone width of {s.judged} line elements", \
        value_guard(geo, idx, geo.T0, form_only=True)


def _too_few(c: Characteristic, idx: np.ndarray, s: Sections, least: int):
    return CharacteristicResult(
        c, None, INCONCLUSIVE, f"{s.judged} of the {s.values.size} sections of region "
        f"'{c.region}' hold {SECTION_POINTS} points or more; {c.type} needs {least}", idx)
