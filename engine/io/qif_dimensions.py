"""A QIF 3.0 MBD's dimensions -> plan dimensions (engine.gdt.dimensions), or why not
(engine.io.qif_characteristics reads the other characteristics):

* ``Radius`` of cylinders (``Cylinder``, ``CylindricalSegment``: a fillet's quarter cylinder) or
  spheres, ``SphericalRadius`` of spheres -> ``radius``, one per feature (``ID.1``, ``ID.2`` …
  when it applies to several);
* ``Angle`` between the two faces of one ``OppositeAngledPlanes`` feature (a region per face,
  ``qif:FEATURE/FACE``), or between two plane or cylinder features -> ``angle`` (degrees, the
  file's angular unit);
* ``DistanceBetween`` two planes, cylinders (their axes) or spheres (their centres) ->
  ``distance``: the pairs its ``FeatureNominalPairs`` state; two features: one pair; more
  features without pairs (NIST's "4X" dimensions): parallel planes at two levels (their
  offsets along the common normal), one plane at one level and several at the other (each of
  those paired with it), or as many at each (each paired with the nearest of the other
  level): one ``distance`` per pair (``ID.1``, ``ID.2`` …).

A dimension without tolerance (``NonTolerance``: a basic or reference dimension) is
informational; a ``Length`` (a line feature's: an edge's length, which surface points do not
give) and a dimension on other features (a torus, a circle or a line, which are edges) stay
not judged with the reason.
"""

from __future__ import annotations

import numpy as np

from engine.errors import InputError
from engine.gdt.plan import Characteristic

from .qif_names import words

KINDS = ("Radius", "SphericalRadius", "Angle", "DistanceBetween", "Length")
"""The QIF characteristic kinds this module reads."""
ROUND = {"Cylinder": "cylinder", "CylindricalSegment": "cylinder", "Sphere": "sphere",
         "SphericalSegment": "sphere"}
ELEMENTS = {"Plane": "plane", **ROUND}
"""QIF feature kinds a dimension is taken on, and the plan's feature for each."""
PARALLEL = np.cos(np.radians(0.5))
"""Planes whose normals agree within 0.5° are parallel (engine.gdt.orientation.AGREES)."""
LENGTH = ("a length (of a line feature: an edge) is not judged: the plan's features are "
          "faces, and points measured on faces do not give an edge's length")


def read_dimension(reader, kind: str, cid: str, name: str, definition, e,
                   ids: list[str]) -> list[Characteristic] | str:
    """The plan characteristics of a dimension, or why it is not judged (``reader``: the
    engine.io.qif_characteristics.CharacteristicReader reading the file)."""
    what = f"characteristic {cid} ({name})"
    feats = [reader.features[i] for i in ids]
    if definition.find("{*}Tolerance") is None:
        if definition.find("{*}NonTolerance") is not None:
            return (f"informational: a {words(kind)} with no tolerance "
                    f"({(definition.findtext('{*}NonTolerance') or '').strip().lower()}), "
                    "so there is nothing to judge")
        raise InputError(f"{what}: its definition has no Tolerance", reader.path)
    if kind == "Length":
        return LENGTH
    if not feats or any(not f.faces for f in feats):
        edges = sorted({words(f.kind) for f in feats if not f.faces})
        return ("it applies to no feature with faces of the model" + (
            f" (its {' and '.join(edges)} features are the model's edges, not faces)"
            if edges else ""))
    read = reader.units.angle if kind == "Angle" else reader.units.length
    nominal, low, high = _limits(reader, kind, what, definition, e, read)
    if low == high == 0.0:
        return "informational: it has no tolerance (0 .. 0), so there is nothing to judge"
    if kind in ("Radius", "SphericalRadius"):
        allowed = ROUND if kind == "Radius" else {k: v for k, v in ROUND.items()
                                                  if v == "sphere"}
        bad = [f for f in feats if f.kind not in allowed]
        if bad:
            return (f"{len(bad)} of its {len(feats)} features are "
                    f"{' and '.join(sorted({words(f.kind) for f in bad}))} features: a radius "
                    f"is judged on {'a cylinder or ' if kind == 'Radius' else ''}a sphere "
                    "(the plan fits no torus)")
        if not nominal > 0.0 or nominal + low <= 0.0:
            raise InputError(f"{what}: a {words(kind)} of {nominal:g} mm with limits "
                             f"{low:+g} / {high:+g} mm is no radius tolerance", reader.path)
        return [Characteristic(cid if len(ids) == 1 else f"{cid}.{k}", "radius", f"qif:{i}",
                               low, high, nominal=nominal,
                               kind="sphere" if ROUND[reader.features[i].kind] == "sphere"
                               else None)
                for k, i in enumerate(ids, start=1)]
    if kind == "Angle":
        return _angle(reader, cid, feats, nominal, low, high)
    return _distances(reader, cid, e, feats, nominal, low, high)


def _limits(reader, kind: str, what: str, definition, e, read) -> tuple[float, float, float]:
    """(nominal, lower, upper) of a dimension: its TargetValue and its Tolerance about it."""
    target = e.find("{*}TargetValue")
    if target is None:
        raise InputError(f"{what}: TargetValue is missing", reader.path)
    nominal = read(target, f"{what}: TargetValue")
    tol = definition.find("{*}Tolerance")
    limits = []
    for tag in ("MinValue", "MaxValue"):
        found = tol.find("{*}" + tag)
        if found is None:
            raise InputError(f"{what}: {tag} is missing", reader.path)
        limits.append(read(found, f"{what}: {tag}"))
    low, high = limits
    if (tol.findtext("{*}DefinedAsLimit") or "").strip() == "true":
        low, high = low - nominal, high - nominal
    low, high = round(low, 12), round(high, 12)
    if not low <= high:
        raise InputError(f"{what}: limits {low:+g} / {high:+g} are no tolerance", reader.path)
    return nominal, low, high


def _angle(reader, cid: str, feats, nominal: float, low: float,
           high: float) -> list[Characteristic] | str:
    if len(feats) == 1 and feats[0].kind == "OppositeAngledPlanes" and len(feats[0].faces) == 2:
        regions: tuple[str, ...] = tuple(f"qif:{feats[0].id}/{face}" for face in feats[0].faces)
        kinds: tuple[str, ...] = ("plane", "plane")
    elif len(feats) == 2 and all(ELEMENTS.get(f.kind) in ("plane", "cylinder") for f in feats):
        regions = tuple(f"qif:{f.id}" for f in feats)
        kinds = tuple(ELEMENTS[f.kind] for f in feats)
    else:
        return (f"an angle of {len(feats)} {', '.join(sorted({words(f.kind) for f in feats}))} "
                "feature(s) is not judged: an angle is judged between two planes or axes (two "
                "features, or the two faces of one opposite angled planes feature)")
    if not 0.0 < nominal < 180.0 or nominal + low < 0.0 or nominal + high > 180.0:
        raise InputError(f"characteristic {cid}: an angle of {nominal:g}° with limits "
                         f"{low:+g} / {high:+g}° is no angle tolerance", reader.path)
    return [Characteristic(cid, "angle", regions[0], low, high, nominal=nominal,
                           regions=regions, features=kinds)]


def _distances(reader, cid: str, e, feats, nominal: float, low: float,
               high: float) -> list[Characteristic] | str:
    bad = sorted({words(f.kind) for f in feats if f.kind not in ELEMENTS})
    if bad:
        return (f"a distance between {', '.join(bad)} features is not judged: a distance is "
                "judged between planes, axes and centres")
    if nominal < 0.0 or nominal + high <= 0.0:
        raise InputError(f"characteristic {cid}: a distance of {nominal:g} mm with limits "
                         f"{low:+g} / {high:+g} mm is no distance tolerance", reader.path)
    pairs = _pairs(reader, e, feats)
    if isinstance(pairs, str):
        return pairs
    by_id = {f.id: f for f in feats}
    return [Characteristic(cid if len(pairs) == 1 else f"{cid}.{k}", "distance", f"qif:{a}",
                           low, high, nominal=nominal, regions=(f"qif:{a}", f"qif:{b}"),
                           features=(ELEMENTS[by_id[a].kind], ELEMENTS[by_id[b].kind]))
            for k, (a, b) in enumerate(pairs, start=1)]


def _pairs(reader, e, feats) -> list[tuple[str, str]] | str:
    """The pairs of feature ids a DistanceBetween relates (module docstring), or why not."""
    pairs = [((p.findtext("{*}FirstFeature") or "").strip(),
              (p.findtext("{*}SecondFeature") or "").strip())
             for p in e.iterfind("{*}FeatureNominalPairs/{*}FeaturePair")]
    if pairs:
        ids = {f.id for f in feats}
        if any(a not in ids or b not in ids or a == b for a, b in pairs):
            raise InputError(f"characteristic {e.get('id')}: a FeaturePair names a feature "
                             "that is not one of its FeatureNominalIds", reader.path)
        return pairs
    if len(feats) == 2:
        return [(feats[0].id, feats[1].id)]
    if any(f.kind != "Plane" for f in feats):
        return (f"a distance between {len(feats)} features without FeatureNominalPairs is "
                "judged between parallel planes only")
    at = {f.id: _plane(reader, f.id) for f in feats}
    normal = at[feats[0].id][1]
    if any(abs(n @ normal) < PARALLEL for _, n in at.values()):
        return (f"its {len(feats)} planes are not parallel, and no FeatureNominalPairs say "
                "which it relates")
    offsets = {i: float(p @ normal) for i, (p, _) in at.items()}
    levels: list[list[str]] = []
    for i in sorted(offsets, key=offsets.__getitem__):
        if levels and offsets[i] - offsets[levels[-1][-1]] < 1e-6 * max(1.0, abs(offsets[i])):
            levels[-1].append(i)
        else:
            levels.append([i])
    if len(levels) != 2:
        return (f"its {len(feats)} parallel planes lie at {len(levels)} levels, and no "
                "FeatureNominalPairs say which it relates")
    one, other = sorted(levels, key=len)
    if len(one) == 1:
        return [(one[0], i) for i in other]
    if len(one) != len(other):
        return (f"its planes lie {len(one)} at one level and {len(other)} at the other, and no "
                "FeatureNominalPairs say which it relates")

    def across(a: str, b: str) -> float:
        w = at[a][0] - at[b][0]
        return float(np.linalg.norm(w - (w @ normal) * normal))

    nearest = {a: min(other, key=lambda b: across(a, b)) for a in one}
    if len(set(nearest.values())) != len(one):
        return (f"its planes lie {len(one)} at each of two levels, and no FeatureNominalPairs "
                "say which it relates (they do not pair off as nearest neighbours)")
    return [(a, nearest[a]) for a in one]


def _plane(reader, fid: str) -> tuple[np.ndarray, np.ndarray]:
    """(a point, the unit normal) of a plane feature nominal, mm (its Location and Normal)."""
    e = reader.index[fid]
    try:
        point = np.array((e.findtext("{*}Location") or "").split(), float)
        normal = np.array((e.findtext("{*}Normal") or "").split(), float)
        if point.shape != (3,) or normal.shape != (3,) or not np.linalg.norm(normal) > 0:
            raise ValueError
    except ValueError:
        raise InputError(f"plane feature {fid}: its Location and Normal are not two points "
                         "x y z", reader.path) from None
    return point * reader.units.mm_per_unit / reader.units.scale, normal / np.linalg.norm(normal)
