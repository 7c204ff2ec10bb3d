"""The runout family of a plan (ASME Y14.5-2018 §9 / ISO 1101 §18.16): circular and total runout
of a feature turned about a datum axis, the full indicator movement (FIM).

The datum axis (:func:`datum_axis`) is established from the datum features' measured points:

* one cylinder datum: its ``fit``: ``lsq`` the least-squares axis; ``tangent`` (the default) the
  axis of the smallest circumscribed cylinder of a shaft / the largest inscribed of a hole (the
  datum simulator of ASME Y14.5 §7 and ISO 5459's default association for a size feature);
* a common datum ``"A-B"`` (ASME Y14.5-2018 §7.12 coaxial datum features, ISO 5459 common datum):
  one axis for both features at once, each with its own radius: the least squares of both
  features' radial residuals together (:func:`coaxial_lsq`), whatever their ``fit`` (ISO 5459
  associates a common datum to both features simultaneously; ASME's simulator of two coaxial
  tangent cylinders would need a choice between the two sizes that the standard does not make).

The toleranced feature is, by its nominal, either a surface of revolution about the datum axis
(a cylinder coaxial with it: the indicator reads radially) or a face normal to the axis (the
indicator reads axially); anything else is refused. Values, both standards alike:

* ``circular_runout``: the feature cut into ``sections`` slabs of equal thickness along the axis
  (radial) or annuli of equal width about it (axial), as circularity cuts; each section's
  indicator movement is the spread (max - min) of its points' distances from the axis (radial)
  or of their coordinates along it (axial): the value is the largest over the sections;
* ``total_runout``: the same spread over the whole feature at once (the indicator moved along
  the feature while it turns: two coaxial cylinders, or two planes normal to the axis).

Runout needs no pose: the datum axis and the feature are measured in one frame (the
registration's). Shapes: points (n, 3), mm; unit vectors (3,).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..errors import InputError
from ..verdict import INCONCLUSIVE
from .decision import by_value, own, value_guard
from .features import axis_distances, complement, cylinder_axis
from .form import SECTION_POINTS, Sections, chebyshev, section_of
from .plan import DEFAULT_SECTIONS, MIN_POINTS, Characteristic, known_datum_parts
from .region_features import FACING, HOLE_FORM, measured_hole, nominal_hole, region_nominal
from .results import CharacteristicResult, Geometry

MAX_STEPS = 50
"""Gauss-Newton steps of a common datum's least-squares axis (it converges in a few)."""


@dataclass(frozen=True)
class Axis:
    """A datum axis through ``point`` along unit ``direction`` (mm, the points' frame) and
    how it was established."""

    point: np.ndarray
    direction: np.ndarray
    how: str


def coaxial_lsq(parts: list[np.ndarray], point: np.ndarray, direction: np.ndarray) -> Axis:
    """The least-squares axis of coaxial cylinders, each part (n_k, 3) with its own radius:
    sum over all points of (distance from the axis - its part's radius)^2, minimised by
    Gauss-Newton from the axis through ``point`` along ``direction``."""
    frame = np.vstack([complement(direction), direction])
    q = [(P - point) @ frame.T for P in parts]
    scale = float(np.sqrt(np.mean(np.concatenate([np.sum(p[:, :2] ** 2, axis=1) for p in q]))))
    q = [p / scale for p in q]
    x = np.zeros(4 + len(q))
    x[4:] = [np.mean(axis_distances(p, x)[0]) for p in q]
    for _ in range(MAX_STEPS):
        rows, res = [], []
        for k, p in enumerate(q):
            rho, J = axis_distances(p, x)
            e = np.zeros((len(p), len(q)))
            e[:, k] = -1.0
            rows.append(np.hstack([J, e]))
            res.append(rho - x[4 + k])
        step = np.linalg.lstsq(np.vstack(rows), -np.concatenate(res), rcond=None)[0]
        x += step
        if np.max(np.abs(step)) < 1e-14:
            break
    p, d = cylinder_axis(point, frame, x, scale)
    return Axis(p, d, "least squares of the coaxial features together, each its own radius")


def tangent_axis(points: np.ndarray, point: np.ndarray, direction: np.ndarray,
                 internal: bool) -> Axis:
    """The axis of the smallest cylinder holding ``points`` (n, 3) (a shaft), or of the
    largest cylinder they hold (``internal``: a hole), from the axis through ``point`` along
    ``direction`` (e.g. their least-squares one): one-sided minimum zones (engine.gdt.form)."""
    frame = np.vstack([complement(direction), direction])
    q = (points - point) @ frame.T
    scale = float(np.sqrt(np.mean(np.sum(q[:, :2] ** 2, axis=1))))
    q = q / scale
    if internal:  # the largest min distance: the smallest max of (c - distance), c > every one
        c = 2.0 * float(np.max(axis_distances(q, np.zeros(4))[0]))

        def fun(x):
            rho, J = axis_distances(q, x)
            return c - rho, -J
    else:
        def fun(x):
            return axis_distances(q, x)
    z = chebyshev(fun, np.zeros(4), two_sided=False)
    p, d = cylinder_axis(point, frame, z.x, scale)
    return Axis(p, d, "the largest inscribed cylinder's axis" if internal else
                "the smallest circumscribed cylinder's axis")


def runout(points: np.ndarray, axis: Axis, axial: bool, sections: int | None) -> Sections:
    """The indicator movement of ``points`` (n, 3) turned about ``axis``: radial (distances
    from it) or ``axial`` (coordinates along it); per section (``sections`` slabs along the
    axis, or annuli about it when axial: circular runout) or over all points (sections None:
    total runout, one section)."""
    w = points - axis.point
    along = w @ axis.direction
    radius = np.linalg.norm(w - np.outer(along, axis.direction), axis=1)
    reading, across = (along, radius) if axial else (radius, along)
    where = section_of(across, sections) if sections else np.zeros(len(points), dtype=int)
    n = sections or 1
    counts = np.bincount(where, minlength=n)
    values = np.full(n, np.nan)
    for k in np.flatnonzero(counts >= (SECTION_POINTS if sections else 2)):
        values[k] = float(np.ptp(reading[where == k]))
    return Sections(values, counts)


def judge_runout(c: Characteristic, idx: np.ndarray, geo: Geometry, shared):
    """A circular or total runout of the region's measured points about its datum axis
    (``shared``: engine.gdt.judgement.Shared)."""
    if geo.nominal_points.shape[1] != 3:
        raise InputError(f"[[characteristic]] '{c.id}': a {c.type} is judged on a 3D nominal")
    got = shared.once((c.type, c.region, c.datums[0], c.sections),
                      lambda: _runout(c, idx, geo, shared))
    if isinstance(got, CharacteristicResult):
        return own(got, c)
    value, facts, what, guard = got
    return by_value(c, idx, value, facts, what, guard)


def _runout(c: Characteristic, idx: np.ndarray, geo: Geometry, shared):
    """(value, facts, what it is, its uncertainty bound), or an INCONCLUSIVE result."""
    axis = shared.once(("datum axis", c.datums[0]), lambda: _datum_axis(c, geo, shared))
    if isinstance(axis, CharacteristicResult):
        return CharacteristicResult(c, None, INCONCLUSIVE, axis.reason, idx)
    axis, nominal = axis
    axial = _reads_axially(c, geo, nominal)
    X, _, n = geo.evaluate(geo.T0, idx)
    # Strips of neighbouring faces a box takes in are not of the feature.
    keep = np.abs(n @ nominal["direction"]) >= np.cos(FACING) if axial else \
        np.abs(n @ nominal["direction"]) <= np.sin(FACING)
    sections = None if c.type == "total_runout" else c.sections or DEFAULT_SECTIONS
    s = runout(X[keep], axis, axial, sections)
    if s.judged < 1:
        return CharacteristicResult(c, None, INCONCLUSIVE, f"no section of region "
                                    f"'{c.region}' holds {SECTION_POINTS} points or more of "
                                    "the feature", idx)
    datum_idx = np.concatenate([shared.members[shared.datums[p].region] for p in
                                known_datum_parts(c.datums[0], shared.datums)])
    facts = {"reading": "axial" if axial else "radial", "datum_axis_point": axis.point,
             "datum_axis_direction": axis.direction, "datum_axis_fit": axis.how,
             "n_points_judged": int(keep.sum())}
    if sections:
        facts.update({"sections": sections, "sections_judged": s.judged,
                      "section_points": s.n_points.tolist(),
                      "section_values": s.values.tolist()})
    what = (f"largest full indicator movement ({'axial' if axial else 'radial'}) of "
            f"{s.judged} sections" if sections else
            f"full indicator movement ({'axial' if axial else 'radial'}) over the surface")
    return s.value, facts, what, value_guard(geo, np.union1d(idx, datum_idx), geo.T0,
                                             form_only=True)


def _datum_axis(c: Characteristic, geo: Geometry, shared):
    """(the measured datum axis, the first datum's nominal cylinder) of the
    characteristic's datum (a cylinder or a common datum of two), or an INCONCLUSIVE result
    naming why its points do not establish it."""
    parts = [shared.datums[p] for p in known_datum_parts(c.datums[0], shared.datums)]
    fits, clouds = [], []
    for d in parts:
        members = shared.members[d.region]
        if members.size < MIN_POINTS["cylinder"]:
            return CharacteristicResult(c, None, INCONCLUSIVE, f"datum {d.label} has "
                                        f"{members.size} measured points; its cylinder needs "
                                        f"at least {MIN_POINTS['cylinder']}", members)
        nom, normals = nominal_hole(geo, d.region)
        X = geo.evaluate(geo.T0, members)[0]
        fit = measured_hole(replace(c, region=d.region), members, X, normals, nom)
        if isinstance(fit, CharacteristicResult):
            return CharacteristicResult(c, None, INCONCLUSIVE, f"datum {d.label}: "
                                        f"{fit.reason}", members)
        fits.append(fit)
        clouds.append(X)
    nominal = region_nominal("cylinder", geo, geo.nominal_masks[parts[0].region])
    if nominal is None:
        raise InputError(f"[[characteristic]] '{c.id}': datum {parts[0].label}'s region is "
                         "no cylinder")
    if len(parts) > 1:
        axis = coaxial_lsq(clouds, fits[0].point, fits[0].direction)
    elif parts[0].fit == "lsq":
        axis = Axis(fits[0].point, fits[0].direction, "least squares")
    else:
        axis = tangent_axis(clouds[0], fits[0].point, fits[0].direction,
                            bool(nominal.get("internal")))
    return axis, nominal


def _reads_axially(c: Characteristic, geo: Geometry, datum: dict) -> bool:
    """Whether the region's nominal is a face normal to the datum's nominal axis (axial
    runout) rather than a cylinder coaxial with it (radial); refused when it is neither."""
    mask = geo.nominal_masks[c.region]
    P = geo.nominal_points[mask]
    a = datum["direction"]
    cos = np.abs(geo.nominal_normals(np.flatnonzero(mask)) @ a)
    w = P - datum["point"]
    along = w @ a
    radius = np.linalg.norm(w - np.outer(along, a), axis=1)
    face, round_ = cos >= np.cos(FACING), cos <= np.sin(FACING)
    if face.sum() >= round_.sum() and face.sum() >= 3:
        if np.ptp(along[face]) <= HOLE_FORM * max(float(np.max(radius[face])), 1e-9):
            return True
    elif round_.sum() >= 3 and np.ptp(radius[round_]) <= HOLE_FORM * float(
            np.mean(radius[round_])):
        return False
    raise InputError(f"[[characteristic]] '{c.id}': region '{c.region}' is neither a "
                     f"surface of revolution about the axis of datum {c.datums[0]} nor a face "
                     f"normal to it: a {c.type} turns its feature about the datum axis")
