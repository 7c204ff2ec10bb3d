"""The location family of a plan (ASME Y14.5 §7 / ISO 1101 §18.12-18.14, ISO 5458 for
patterns): position, coaxiality (concentricity) and symmetry of a feature of size, relative to
datums, at the pose the characteristic's datums give (engine.gdt.datums: their frame is then the
nominal frame).

Values, the drawing's convention:

* position of a cylinder (hole or pin): the diameter of the smallest cylinder coaxial with the
  true position (the nominal axis) holding the feature's least-squares axis over the extent of
  its points; of a circle (2D) or sphere: twice the distance of the least-squares centre from
  the true position (a circular / spherical zone); of a width (``feature = "width"``): the
  width of the smallest zone of two planes centred on the true median plane, parallel to it,
  holding the least-squares median plane over the extent of the feature's points (ASME takes
  the actual mating envelope's axis or centre plane, ISO the least-squares feature's; for a
  feature of perfect form they coincide);
* a pattern (``regions = [...]``): every feature located at the same pose, that of one datum
  reference frame; each is reported and the pattern takes the worst (the least margin);
* coaxiality (ISO) / concentricity: the diameter of the smallest cylinder about the datum axis
  (the primary datum's cylinder) holding the feature's least-squares axis over the extent of
  its points; ASME Y14.5-2009's concentricity of derived median points is judged the same way
  (Y14.5-2018 dropped it for position, runout or profile);
* symmetry (ISO): the width of the smallest zone of two planes parallel to the datum plane,
  centred on the width's true median plane, holding its derived median surface: the midpoints
  of the two-point pairs (engine.gdt.size.two_point).

Material condition (``modifier``, position only): at MMC the tolerance grows by the bonus, the
departure of the feature's actual mating size (the largest inscribed feature of a hole or slot,
the smallest circumscribed of a pin or tab: engine.gdt.size.mating_size) from its MMC size
(a hole's smallest, a pin's largest size: the limits of the size characteristic on the same
region); at LMC by the departure of its actual minimum material size from its LMC size (ASME
Y14.5-2018 §7.3.3, ISO 2692). allowed = zone + bonus.

Shapes: points (n, 3) (a 2D template: (n, 2)), mm, nominal frame at the datums' pose.
"""

from __future__ import annotations

from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np

from ..errors import InputError
from ..verdict import ACCEPT, INCONCLUSIVE, REJECT
from .decision import by_value, own, untrusted, value_guard
from .features import position_value
from .plan import Characteristic
from .region_features import nominal_cylinder, region_nominal
from .results import CharacteristicResult, Geometry
from .size import measured_feature, mating_size, median_points, region_nominal_width

if TYPE_CHECKING:
    from .datums import FreeDirection

AGREES = 0.5
"""Degrees: how far a feature's nominal may turn from its datum's (a coaxiality's axis, a
symmetry's plane) and still be at the basic angle 0 to it."""
COAXIAL = 1e-3
"""How far (mm per mm of radius) a coaxiality's nominal axis may lie off its datum axis."""


def judge_location(c: Characteristic, idx: np.ndarray, geo: Geometry, shared, T_part):
    """A position (of one feature or a pattern), coaxiality, concentricity or symmetry at the
    pose its datums give (``shared``: engine.gdt.judgement.Shared; ``T_part``: the plan's
    alignment the free motions start from)."""
    al = shared.placed(tuple(c.datums), (), T_part)
    if not al.complete:
        return untrusted(c, idx, al)
    results = []
    for region in c.all_regions:
        one = replace(c, region=region)
        got = shared.once(("location", c.type, region, tuple(c.datums), c.kind),
                          lambda: _locate(one, shared.members[region], geo, shared, al))
        if isinstance(got, CharacteristicResult):
            results.append(own(got, c))
            continue
        value, facts, what, guard = got
        facts = {**facts, "region": region, "free": [f.describe() for f in al.free]}
        if c.type == "position":
            extra = _material(one, shared.members[region], geo, shared)
            size_guard = extra.pop("_size_guard", 0.0)
            facts.update(extra)
            guard = None if guard is None else guard + size_guard
            one = replace(one, upper=facts["allowed"])
        results.append(replace(by_value(one, shared.members[region], value, facts, what,
                                        guard), characteristic=c))
    if len(results) == 1:
        return results[0]
    return _pattern(c, idx, results)


def _pattern(c: Characteristic, idx: np.ndarray, results: list) -> CharacteristicResult:
    """A pattern's result: its worst feature's (REJECT over INCONCLUSIVE over ACCEPT, then
    the least margin to its allowed tolerance), with every feature's in ``features``."""
    rank = {REJECT: 2, INCONCLUSIVE: 1, ACCEPT: 0}

    def badness(r):
        margin = -np.inf if r.value is None else r.value - r.facts.get("allowed", c.upper)
        return rank[r.verdict], margin

    worst = max(results, key=badness)
    features = [{"region": r.facts.get("region", "?"), "value": r.value,
                 "verdict": r.verdict, "reason": r.reason,
                 **{k: r.facts[k] for k in ("bonus", "allowed", "actual_mating_size")
                    if k in r.facts}} for r in results]
    return CharacteristicResult(
        c, worst.value, worst.verdict, f"worst of {len(results)} features located together: "
        f"region '{worst.facts.get('region', c.region)}': {worst.reason}", idx,
        facts={**worst.facts, "features": features, "worst_region": worst.facts.get("region")})


def _locate(c: Characteristic, idx: np.ndarray, geo: Geometry, shared, al):
    """(value, facts, what it is, its uncertainty bound) of one feature's location at the
    datums' pose ``al``, or an INCONCLUSIVE result when its points do not determine it."""
    from .features import FeatureError

    T = al.T_nominal_measured
    try:
        m = measured_feature(c, idx, geo, shared, T)
    except FeatureError as e:
        return CharacteristicResult(c, None, INCONCLUSIVE, f"region '{c.region}': "
                                    f"{e.message}", idx)
    if isinstance(m, CharacteristicResult):
        return m
    guard = value_guard(geo, idx, T, form_only=False)
    if c.type in ("coaxiality", "concentricity"):
        value, facts = _coaxiality(c, m, geo, shared)
        return value, facts, "diameter of the smallest cylinder about the datum axis " \
            "holding the axis", guard
    if c.type == "symmetry":
        value, facts = _symmetry(c, m, geo, shared)
        return value, facts, "width of the zone about the true median plane holding the " \
            "derived median surface", guard
    nominal = _true_position(c, geo, shared)
    _check_located(c, shared.once(("loose", c.region, tuple(c.datums)),
                                  lambda: _loose(al, nominal, geo)))
    if m.kind == "width":
        value = _plane_zone(_median_extent(m), nominal["point"], nominal["normal"])
        return value, {"median_point": m.lsq.point, "median_normal": m.lsq.direction,
                       "nominal_point": nominal["point"],
                       "nominal_normal": nominal["normal"]}, \
            "position (width of the zone of two planes)", guard
    if m.kind == "round":
        value = position_value(m.lsq.point, nominal["centre"]).value
        return value, {"centre": m.lsq.point, "nominal_centre": nominal["centre"]}, \
            "position (diameter)", guard
    ends = _axis_ends(m)
    value = position_value(ends, nominal["point"], nominal["direction"]).value
    return value, {"axis_ends": ends, "nominal_point": nominal["point"],
                   "nominal_direction": nominal["direction"]}, "position (diameter)", guard


def _axis_ends(m) -> np.ndarray:
    """(2, 3) the measured axis' points at the extent of the feature's points along it."""
    t = (m.X - m.lsq.point) @ m.lsq.direction
    return m.lsq.point + np.array([t.min(), t.max()])[:, None] * m.lsq.direction


def _median_extent(m) -> np.ndarray:
    """(n, dim) the width's points projected on its least-squares median plane: the extent of
    the plane the zone must hold."""
    return m.X - np.outer((m.X - m.lsq.point) @ m.lsq.direction, m.lsq.direction)


def _plane_zone(points: np.ndarray, point: np.ndarray, normal: np.ndarray) -> float:
    """The width of the zone of two planes normal to ``normal`` centred on the plane through
    ``point`` holding ``points``: twice their largest distance from it."""
    return 2.0 * float(np.max(np.abs((points - point) @ normal)))


def _true_position(c: Characteristic, geo: Geometry, shared) -> dict:
    """The nominal feature (the true position) of ``c``'s region: a width's median plane
    {point, normal}, a sphere's or circle's {centre}, a cylinder's axis {point, direction}."""
    mask = geo.nominal_masks[c.region]
    if c.feature == "width":
        fit = region_nominal_width(c, geo, shared)[1]
        return {"point": fit.point, "normal": fit.direction}
    if c.feature == "sphere" and geo.nominal_points.shape[1] == 3:
        sphere = region_nominal("sphere", geo, mask)
        if sphere is None:  # as measured_feature, which has refused it already
            raise InputError(f"[[characteristic]] '{c.id}': region '{c.region}' is no sphere")
        return {"centre": sphere["centre"]}
    nom = nominal_cylinder(c, geo, shared)[0]
    if geo.nominal_points.shape[1] == 2:
        return {"centre": nom.centre}
    return {"point": nom.point, "direction": nom.direction}


def _datum_nominal(c: Characteristic, geo: Geometry, shared, kind: str) -> dict:
    primary = shared.datums[c.datums[0]]
    # A width's datum is its median plane.
    feature = "plane" if primary.feature == "width" else primary.feature
    got = shared.datum_nominal(primary.label)
    if feature != kind or got is None:
        raise InputError(f"[[characteristic]] '{c.id}': a {c.type} is relative to a datum "
                         f"{'axis' if kind == 'cylinder' else 'plane'}; datum "
                         f"{primary.label} is no {kind} on the nominal")
    return got


def _coaxiality(c: Characteristic, m, geo: Geometry, shared) -> tuple[float, dict]:
    """(the coaxiality value, facts): the measured axis' ends about the datum axis."""
    if m.kind != "cylinder":
        raise InputError(f"[[characteristic]] '{c.id}': a {c.type} is judged on a cylinder's "
                         "axis (3D)")
    axis = _datum_nominal(c, geo, shared, "cylinder")
    nom = nominal_cylinder(c, geo, shared)[0]
    turn = np.degrees(np.arccos(np.clip(abs(nom.direction @ axis["direction"]), 0.0, 1.0)))
    off = position_value(nom.point, axis["point"], axis["direction"]).value / 2.0
    if turn > AGREES or off > COAXIAL * max(nom.radius, 1.0):
        raise InputError(f"[[characteristic]] '{c.id}': region '{c.region}' is not coaxial "
                         f"with datum {c.datums[0]} on the nominal (its axis lies {off:.3g} mm "
                         f"off and {turn:.2f}° from the datum axis)")
    ends = _axis_ends(m)
    value = position_value(ends, axis["point"], axis["direction"]).value
    return value, {"axis_ends": ends, "datum_point": axis["point"],
                   "datum_direction": axis["direction"]}


def _symmetry(c: Characteristic, m, geo: Geometry, shared) -> tuple[float, dict]:
    """(the symmetry value, facts): the derived median points about the true median plane,
    in planes parallel to the datum plane."""
    plane = _datum_nominal(c, geo, shared, "plane")
    fit = region_nominal_width(c, geo, shared)[1]
    n = plane["normal"]
    turn = np.degrees(np.arccos(np.clip(abs(fit.direction @ n), 0.0, 1.0)))
    if turn > AGREES:
        raise InputError(f"[[characteristic]] '{c.id}': the median plane of region "
                         f"'{c.region}' stands {turn:.2f}° from datum plane {c.datums[0]} on "
                         "the nominal; a symmetry's zone is parallel to its datum plane")
    return _plane_zone(median_points(m), fit.point, n), {"datum_normal": n,
                                               "nominal_point": fit.point}


def _material(c: Characteristic, idx: np.ndarray, geo: Geometry, shared) -> dict:
    """The material condition's facts: modifier, bonus, allowed (zone + bonus), the actual
    mating size (MMC) or actual minimum material size (LMC) and the size it departs from; a
    ``_size_guard`` (the size's uncertainty bound, which moves the bonus)."""
    if c.modifier == "RFS":
        return {"modifier": "RFS", "bonus": 0.0, "allowed": c.upper,
                "actual_mating_size": None}
    size = shared.sizes[c.region]
    m = shared.once(("at T0", c.region), lambda: measured_feature(c, idx, geo, shared,
                                                                  geo.T0))
    if isinstance(m, CharacteristicResult):  # its size is unknown: no bonus is proven
        return {"modifier": c.modifier, "bonus": 0.0, "allowed": c.upper,
                "actual_mating_size": None}
    least = c.modifier == "LMC"
    actual = shared.once(("mating", c.region, least), lambda: mating_size(m, least))
    # MMC: a hole's (slot's) smallest size, a pin's (tab's) largest; LMC the other.
    smallest = m.internal != least
    limit = size.nominal + (size.lower if smallest else size.upper)
    bonus = max(0.0, actual - limit if smallest else limit - actual)
    return {"modifier": c.modifier, "bonus": bonus, "allowed": c.upper + bonus,
            "actual_mating_size": actual,
            ("mmc_size" if not least else "lmc_size"): limit,
            "_size_guard": value_guard(geo, idx, geo.T0, form_only=True) or 0.0}


def _loose(al, nominal: dict, geo: Geometry) -> tuple[FreeDirection, ...]:
    """The motions the datums of ``al`` leave free that move the nominal feature."""
    from .datums import invariant_motions, moving

    planar = geo.nominal_points.shape[1] == 2
    if "normal" in nominal:
        kind = "line" if planar else "plane"
    else:
        kind = "circle" if planar else ("cylinder" if "direction" in nominal else "sphere")
    return moving(al.free_basis, invariant_motions(kind, nominal, geo.centre, geo.length),
                  geo.centre, geo.length)


def _check_located(c: Characteristic, loose: tuple[FreeDirection, ...]) -> None:
    """A position is relative to datums that locate the feature: none of the motions they
    leave free (``loose``: :func:`_loose`) may move the nominal feature."""
    if loose:
        raise InputError(f"[[characteristic]] '{c.id}': its datums {'|'.join(c.datums)} leave "
                         f"the feature free to move ({'; '.join(f.describe() for f in loose)}): "
                         "a position needs datums that locate it")
