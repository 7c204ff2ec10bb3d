"""Dimensions of a plan (ASME Y14.5 §1.4 / ISO 14405-2): a radius, the angle between two
features and the distance between two features, each with limits about its nominal, relative
to no datum: a rigid motion changes none of them, so each is taken at the registration's pose
on the least-squares fit of each feature's measured points (engine.gdt.features):

* ``radius`` (a cylinder, e.g. a fillet's quarter cylinder, or a sphere): half the
  least-squares diameter (engine.gdt.size), mm;
* ``angle`` (two planes, a plane and an axis, or two axes): the angle between the fitted
  planes (their normals) or axes, or 90° less the angle between a plane's normal and an axis,
  in degrees; of the two angles two lines make (a and 180° - a) the one the nominal model's
  features make with the plan's nominal, which must agree with the model within AGREES;
* ``distance`` (planes, cylinders' axes, spheres' centres): two planes (parallel on the model
  within AGREES): the distance of the smaller one's centroid (its points') from the larger
  one's fitted plane (larger: the wider across its narrowest way, whose normal its points fix
  best: a pad 2 mm wide tilted by its points' noise must not swing a lever of 200 mm); a plane
  and an axis or a centre: from the axis' middle (the axis point nearest its points' centroid)
  or the centre to the fitted plane; two axes (parallel on the model): the shorter's middle
  from the longer's line; an axis and a centre: the centre's distance from the axis; two
  centres: their distance. mm.

Under the guarded decision rule a radius or a distance is guarded by its points' uncertainty
as a size is (engine.gdt.decision.value_guard; half of it for a radius); an angle by the tilt
that uncertainty can give each fitted feature over its narrowest width (an axis: its length),
2U / extent, the two added, in degrees.

Shapes: points (n, 3), unit vectors (3,), mm, nominal frame.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..errors import InputError
from ..verdict import INCONCLUSIVE
from .decision import by_value, value_guard
from .features import FeatureError, fit_plane_lsq, fit_sphere_lsq
from .orientation import AGREES
from .plan import Characteristic
from .region_features import FACING, measured_hole, nominal_cylinder, region_nominal
from .results import CharacteristicResult, Geometry
from .size import measured_feature


@dataclass(frozen=True)
class Element:
    """A feature as a dimension sees it: a plane (``point``: its points' centroid,
    ``direction``: its normal), a cylinder's axis (``point``: its middle, ``direction``) or a
    sphere's centre (``direction`` None); ``extent``: a plane's narrowest width across it
    (:func:`narrowest`), an axis' length, mm (0 for a centre)."""

    kind: str
    point: np.ndarray
    direction: np.ndarray | None
    extent: float = 0.0


def judge_dimension(c: Characteristic, idx: np.ndarray, geo: Geometry, shared):
    """A radius, angle or distance (module docstring)."""
    if geo.nominal_points.shape[1] != 3:
        raise InputError(f"[[characteristic]] '{c.id}': a {c.type} is judged on a 3D nominal")
    if c.type == "radius":
        return _radius(c, idx, geo, shared)
    got = []
    for region, kind in c.region_features:
        nominal = _nominal(c, region, kind, geo, shared)
        measured = _measured(c, region, kind, nominal, geo, shared)
        if isinstance(measured, CharacteristicResult):
            return replace(measured, characteristic=c, indices=idx)
        got.append((nominal, measured))
    (n1, m1), (n2, m2) = got
    if c.type == "angle":
        branch = _branch(c, angle_between(n1, n2))
        value = _on_branch(angle_between(m1, m2), branch)
        facts = {"model_value": _on_branch(angle_between(n1, n2), branch)}
        return by_value(c, idx, value, facts, "angle between the least-squares features",
                        _angle_guard(geo, idx, (m1, m2)), unit="degree")
    _parallel(c, n1, n2)
    value = distance_between(m1, m2)
    facts = {"model_value": distance_between(n1, n2)}
    return by_value(c, idx, value, facts, "distance between the least-squares features",
                    value_guard(geo, idx, geo.T0, form_only=True))


def _radius(c: Characteristic, idx: np.ndarray, geo: Geometry, shared):
    m = measured_feature(c, idx, geo, shared, geo.T0)
    if isinstance(m, CharacteristicResult):
        return m
    guard = value_guard(geo, idx, geo.T0, form_only=True)
    facts = {"internal": m.internal, "fit": "least squares",
             "diameter": m.lsq.size}
    if m.form_error is not None:
        facts["form_error"] = m.form_error
    return by_value(c, idx, 0.5 * m.lsq.size, facts, "least-squares radius",
                    None if guard is None else 0.5 * guard)


def _nominal(c: Characteristic, region: str, kind: str, geo: Geometry, shared) -> Element:
    """A region's feature on the nominal model (its exact surface where it has one)."""
    mask = geo.nominal_masks[region]
    if kind == "cylinder":
        nom = nominal_cylinder(replace(c, region=region), geo, shared)[0]
        return Element(kind, nom.point, nom.direction)
    got = region_nominal(kind, geo, mask)
    if got is None:
        raise InputError(f"[[characteristic]] '{c.id}': region '{region}' is no {kind}")
    if kind == "plane":
        return Element(kind, np.asarray(got["point"]), np.asarray(got["normal"]))
    return Element(kind, np.asarray(got["centre"]), None)


def _measured(c: Characteristic, region: str, kind: str, nominal: Element, geo: Geometry,
              shared) -> Element | CharacteristicResult:
    """A region's feature fitted to its measured points, or an INCONCLUSIVE result when they
    do not determine it."""
    idx = shared.members[region]
    X, _, _ = geo.evaluate(geo.T0, idx)
    try:
        if kind == "cylinder":
            one = replace(c, region=region)
            nom, normals = nominal_cylinder(one, geo, shared)
            fit = measured_hole(one, idx, X, normals, nom)
            if isinstance(fit, CharacteristicResult):
                return fit
            length = float(np.ptp((X - fit.point) @ fit.direction))
            return Element(kind, fit.point, fit.direction, length)
        if kind == "sphere":
            return Element(kind, fit_sphere_lsq(X).centre, None)
        plane = fit_plane_lsq(X, nominal.direction)
    except FeatureError as e:
        return CharacteristicResult(c, None, INCONCLUSIVE, f"region '{region}': {e.message}",
                                    idx)
    if nominal.direction is not None and plane.normal @ nominal.direction < np.cos(FACING):
        return CharacteristicResult(c, None, INCONCLUSIVE, f"the {idx.size} points of region "
                                    f"'{region}' do not determine its plane (their fit stands "
                                    "more than 10° from the nominal face)", idx)
    return Element(kind, plane.centroid, plane.normal, narrowest(X - plane.centroid,
                                                                 plane.normal))


def narrowest(q: np.ndarray, normal: np.ndarray) -> float:
    """The smallest width of points ``q`` (n, 3) across a plane of unit ``normal``: the least
    extent of their projections on the in-plane directions, one every degree, mm."""
    u = np.cross(normal, [1.0, 0.0, 0.0] if abs(normal[0]) < 0.9 else [0.0, 1.0, 0.0])
    u /= np.linalg.norm(u)
    v = np.cross(normal, u)
    t = np.radians(np.arange(180.0))
    return float(np.min(np.ptp(q @ (np.outer(np.cos(t), u) + np.outer(np.sin(t), v)).T,
                               axis=0)))


def angle_between(a: Element, b: Element) -> float:
    """The angle (degrees, 0 .. 90) between two planes, a plane and an axis, or two axes."""
    u, v = a.direction, b.direction
    if u is None or v is None:
        raise ValueError("an angle is between planes and axes, not centres")
    line = float(np.degrees(np.arctan2(np.linalg.norm(np.cross(u, v)), abs(float(u @ v)))))
    return 90.0 - line if (a.kind == "plane") != (b.kind == "plane") else line


def _branch(c: Characteristic, model: float) -> bool:
    """Whether the plan's angle is the supplement (180° - a) of the model's angle ``model``
    (0 .. 90°); InputError when neither is within AGREES of the plan's nominal."""
    nominal = c.nominal or 0.0
    for supplement in (False, True):
        if abs(_on_branch(model, supplement) - nominal) <= AGREES:
            return supplement
    raise InputError(f"[[characteristic]] '{c.id}': regions '{c.all_regions[0]}' and "
                     f"'{c.all_regions[1]}' stand at {model:.4f}° (or {180.0 - model:.4f}°) on "
                     f"the nominal, not the {nominal:g}° the plan states")


def _on_branch(angle: float, supplement: bool) -> float:
    return 180.0 - angle if supplement else angle


def _parallel(c: Characteristic, a: Element, b: Element) -> None:
    """A distance between two planes, or two axes, needs them parallel on the model."""
    if a.direction is None or b.direction is None or (a.kind == "plane") != (b.kind == "plane"):
        return
    off = angle_between(a, b)
    if off > AGREES:
        raise InputError(f"[[characteristic]] '{c.id}': regions '{c.all_regions[0]}' and "
                         f"'{c.all_regions[1]}' are no parallel {a.kind}s on the nominal (they "
                         f"stand at {off:.4f}°): the distance between them is not defined")


def distance_between(a: Element, b: Element) -> float:
    """The distance between two features (module docstring), mm: of ``a``'s point from ``b``
    (a plane, or the larger of two planes or the longer of two axes)."""
    if (a.kind == "plane") != (b.kind == "plane"):
        a, b = (b, a) if a.kind == "plane" else (a, b)
    elif a.extent > b.extent:
        a, b = b, a
    w = a.point - b.point
    d = b.direction if b.direction is not None else a.direction
    if d is None:  # two centres
        return float(np.linalg.norm(w))
    if b.kind == "plane":
        return float(abs(w @ d))
    return float(np.linalg.norm(w - (w @ d) * d))


def _angle_guard(geo: Geometry, idx: np.ndarray, elements) -> float | None:
    """An angle's uncertainty bound, degrees: the tilt 2U / extent the points' largest
    expanded U can give each feature, the two added (None: the simple rule)."""
    guard = value_guard(geo, idx, geo.T0, form_only=True)
    if guard is None:
        return None
    return float(sum(np.degrees(guard / max(e.extent, 1e-9)) for e in elements))
