"""The orientation family of a plan (ASME Y14.5 §6 / ISO 1101 §18.9-18.11): parallelism,
perpendicularity and angularity of a plane or of a cylinder's axis, relative to datums.

The part is placed by the characteristic's datums (engine.gdt.datums: their frame is then the
nominal frame). The zone's required orientation is the basic angle (0 for parallelism, 90 for
perpendicularity, ``angle`` for angularity) to the primary datum's feature (a plane's normal or
a cylinder's axis), on the side the nominal feature lies (its normal or axis, from the model):
:func:`required_direction`. A nominal that stands at another angle (by more than AGREES
degrees) is a plan that does not fit its part, refused. Where the datums leave a rotation free
(a primary datum alone leaves the turn about its normal or axis), the zone turns about it to
the orientation that makes it smallest (ASME Y14.5-2018 §6.3: the zone is oriented to the
datums only); with a secondary datum the zone is fixed.

Values, the drawing's convention (ASME and ISO agree here):

* a plane (:func:`plane_orientation`): the distance between the two parallel planes at the
  required orientation closest together that hold every point;
* a width's median plane (``feature = "width"``: a slot or tab): the distance between the two
  parallel planes at the required orientation closest together that hold the width's derived
  median plane, the midpoints of its two-point pairs (engine.gdt.size.median_points, as a
  symmetry's): the centres of the segments across the feature where its walls were probed. A
  median plane tilted by theta over the extent L of those midpoints gives L tan(theta); one
  wall turned by theta, about half of it; walls bowed alike, their bow. (The bisector of the
  walls' own planes over all the points' feet was tried: a wall probed in a narrow band tilts
  its plane by its noise, 8 mm on a perfect slot probed along one line. The least-squares
  width's common normal is pulled toward the wall with more points.)
* an axis (``diametral``, :func:`axis_orientation`): the diameter of the smallest cylinder at the
  required orientation that holds the feature's least-squares axis between the two planes,
  normal to the zone's axis, that bound the feature's points: L tan(theta) for an axis tilted
  by theta over the length L of the feature along the zone's axis. (ASME Y14.5-2018 takes the
  axis of the unrelated actual mating envelope, ISO 1101 the derived median line; both equal
  the least-squares axis for a feature of perfect form.)

Shapes: points (n, 3) and unit vectors (3,), mm, nominal frame at the datums' pose.
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError
from .decision import by_value, own, untrusted, value_guard
from .features import complement
from .plan import ORIENTATION_ANGLE, Characteristic
from .region_features import measured_hole, nominal_cylinder, region_nominal
from .results import CharacteristicResult, Geometry

AGREES = 0.5
"""Degrees: how far the nominal feature may stand from the basic angle to its primary datum
(a sampled or meshed nominal's fitted plane or axis is exact to far less)."""
SEARCH = 0.2
"""Radians: how far the zone is turned about a free rotation from the nominal orientation in
search of the smallest (the part sits within a few degrees of it at the datums' pose)."""


def required_direction(feature: np.ndarray, datum: np.ndarray, angle: float) -> np.ndarray:
    """The unit direction (3,) at exactly ``angle`` degrees from the datum's direction
    ``datum`` (its sign taken to the side of ``feature``), in the plane of the two and on the
    side of ``feature`` (a unit normal or axis, the nominal's)."""
    a = datum if feature @ datum >= 0.0 else -datum
    t = feature - (feature @ a) * a
    norm = float(np.linalg.norm(t))
    t = t / norm if norm > 1e-12 else complement(a)[0]
    beta = np.radians(angle)
    return np.cos(beta) * a + np.sin(beta) * t


def turned(n: np.ndarray, axis: np.ndarray, phi: float) -> np.ndarray:
    """``n`` turned by ``phi`` rad about the unit ``axis`` (Rodrigues)."""
    return (n * np.cos(phi) + np.cross(axis, n) * np.sin(phi)
            + axis * (axis @ n) * (1.0 - np.cos(phi)))


def _smallest(value, n: np.ndarray, axis: np.ndarray | None) -> tuple[float, np.ndarray]:
    """(the smallest value(direction), that direction) over ``n`` turned about ``axis`` within
    +-SEARCH (bounded Brent: the value is unimodal there); just value(n) when axis is None."""
    if axis is None:
        return value(n), n
    from scipy.optimize import minimize_scalar

    best = minimize_scalar(lambda phi: value(turned(n, axis, phi)), bounds=(-SEARCH, SEARCH),
                           method="bounded", options={"xatol": 1e-13})
    m = turned(n, axis, float(best.x))
    return (value(m), m) if value(m) < value(n) else (value(n), n)


def plane_orientation(points: np.ndarray, normal: np.ndarray,
                      axis: np.ndarray | None = None) -> tuple[float, np.ndarray]:
    """(the width of the zone between two planes normal to ``normal`` (turned about ``axis``
    where the datums leave that free) holding ``points`` (n, 3), mm; the zone's normal)."""
    q = points - points.mean(axis=0)
    return _smallest(lambda n: float(np.ptp(q @ n)), normal, axis)


def axis_orientation(points: np.ndarray, direction: np.ndarray, zone_axis: np.ndarray,
                     axis: np.ndarray | None = None) -> tuple[float, np.ndarray]:
    """(the diameter of the smallest cylinder along ``zone_axis`` (turned about ``axis`` where
    the datums leave that free) holding the feature's axis of unit ``direction`` between the
    planes normal to the zone's axis that bound the feature's ``points`` (n, 3), mm; the zone's
    axis)."""
    def value(n):
        along = float(direction @ n)
        if abs(along) < 1e-12:
            return np.inf
        return float(np.ptp(points @ n) * np.linalg.norm(direction - along * n) / abs(along))

    return _smallest(value, zone_axis, axis)


def judge_orientation(c: Characteristic, idx: np.ndarray, geo: Geometry, shared, T_part):
    """A parallelism, perpendicularity or angularity at the pose its datums give (``shared``:
    engine.gdt.judgement.Shared; ``T_part``: the plan's alignment the free motions start
    from)."""
    if geo.nominal_points.shape[1] != 3:
        raise InputError(f"[[characteristic]] '{c.id}': a {c.type} is judged on a 3D nominal")
    al = shared.placed(tuple(c.datums), (), T_part)
    if not al.complete:
        return untrusted(c, idx, al)
    got = shared.once(("orientation", c.type, c.region, tuple(c.datums), c.diametral,
                       c.kind, c.angle), lambda: _orientation(c, idx, geo, shared, al))
    if isinstance(got, CharacteristicResult):
        return own(got, c)
    value, facts, what, guard = got
    return by_value(c, idx, value, facts, what, guard)


def _orientation(c: Characteristic, idx: np.ndarray, geo: Geometry, shared, al):
    """(value, facts, what it is, its uncertainty bound), or an INCONCLUSIVE result when the
    points do not determine the axis."""
    primary = shared.datum(c.datums[0])
    if primary.feature not in ("plane", "cylinder", "width"):  # a width: its median plane
        raise InputError(f"[[characteristic]] '{c.id}': a {c.type} is relative to a plane or "
                         f"an axis; its primary datum {primary.label} is a {primary.feature}")
    datum = shared.datum_nominal(c.datums[0])
    turns = [np.asarray(f.along) for f in al.free if f.type == "rotation"]
    if datum is None or len(turns) > 1:
        raise InputError(f"[[characteristic]] '{c.id}': its datums {'|'.join(c.datums)} do "
                         f"not orient the feature")
    a = datum["direction" if primary.feature == "cylinder" else "normal"]
    if c.diametral and c.kind == "width":
        raise InputError(f"[[characteristic]] '{c.id}': a width's {c.type} is of its median "
                         "plane, in a zone of two planes: it is not diametral")
    X = geo.evaluate(al.T_nominal_measured, idx)[0]
    if c.diametral:
        nom, normals = nominal_cylinder(c, geo, shared)
        fit = measured_hole(c, idx, X, normals, nom)
        if isinstance(fit, CharacteristicResult):
            return fit
        feature = nom.direction
    elif c.kind == "width":  # its derived median surface
        from .size import measured_feature, median_points, region_nominal_width

        width = measured_feature(c, idx, geo, shared, al.T_nominal_measured)
        if isinstance(width, CharacteristicResult):
            return width
        feature = region_nominal_width(c, geo, shared)[0].normal
    else:
        plane = region_nominal("plane", geo, geo.nominal_masks[c.region])
        if plane is None:
            raise InputError(f"[[characteristic]] '{c.id}': region '{c.region}' is no plane")
        feature = plane["normal"]
    basic = ORIENTATION_ANGLE.get(c.type, c.angle)
    if basic is None:
        raise InputError(f"[[characteristic]] '{c.id}': an angularity states its basic angle "
                         f"to the primary datum, degrees (angle)")
    basic = min(basic, 180.0 - basic)  # the angle between two planes or lines
    # Between directions: a plane's normal and an axis stand at 90 degrees minus the angle.
    beta = basic if c.diametral == (primary.feature == "cylinder") else 90.0 - basic
    n = required_direction(feature, a, beta)
    off = float(np.degrees(np.arccos(np.clip(n @ feature, -1.0, 1.0))))
    if off > AGREES:
        raise InputError(f"[[characteristic]] '{c.id}': region '{c.region}' stands "
                         f"{off:.2f}° from the {basic:g}° its {c.type} asks to datum "
                         f"{primary.label} on the nominal")
    free = turns[0] if turns else None
    if c.diametral:
        value, zone = axis_orientation(X, fit.direction, n, free)
        what = "diameter of the smallest cylinder at the required orientation holding the axis"
    elif c.kind == "width":
        value, zone = plane_orientation(median_points(width), n, free)
        what = ("width of the smallest zone of two planes at the required orientation holding "
                "the derived median plane")
    else:
        value, zone = plane_orientation(X, n, free)
        what = "width of the smallest zone of two planes at the required orientation"
    facts = {"angle": basic, "zone_direction": zone, "datum_direction": a,
             "free": [f.describe() for f in al.free]}
    return value, facts, what, value_guard(geo, idx, al.T_nominal_measured, form_only=False)
