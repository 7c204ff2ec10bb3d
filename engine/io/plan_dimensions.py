"""The dimensions of a plan's [[characteristic]] (engine.gdt.dimensions): ``radius``,
``angle`` and ``distance``, each a nominal with lower and upper limits about it, relative to no
datum (engine.io.plan reads the other types)::

    radius:   region; nominal (the radius, mm), lower and upper (offsets about it, mm);
              feature = "cylinder" (default) | "sphere"
    angle:    regions = [a, b] (two features); nominal (degrees, 0 .. 180), lower and upper
              (offsets about it, degrees); features = ["plane", "plane"] (default), each
              "plane" or "cylinder" (its axis)
    distance: regions = [a, b]; nominal (mm), lower and upper (mm); features =
              ["plane", "plane"] (default), each "plane", "cylinder" (its axis) or "sphere"
              (its centre)
"""

from __future__ import annotations

from engine.gdt.plan import DIMENSION_FEATURES, Characteristic
from engine.tolerance import ZONE_LIMIT_MM

from .plan_tables import Table, known, show

UNIT_WORDS = {"radius": "mm", "angle": "degrees", "distance": "mm"}
NAMES = ("name", "designator", "source")
"""Keys every characteristic may hold: where it comes from and its balloon."""
KEYS_OF_DIMENSIONS = {"radius": ("id", "type", "region", "nominal", "lower", "upper", "feature",
                                 *NAMES),
                      **{k: ("id", "type", "regions", "nominal", "lower", "upper", "features",
                             *NAMES) for k in ("angle", "distance")}}
"""The keys of each dimension's [[characteristic]]."""


def dimension(t: Table, ident: str, kind: str, regions: list[str]) -> Characteristic:
    """A radius, angle or distance [[characteristic]] (module docstring)."""
    for key in t.data:
        if key not in KEYS_OF_DIMENSIONS[kind]:
            raise t.fail(key, _why_not(key, kind))
    unit = UNIT_WORDS[kind]
    nominal, lower, upper = (t.number(k) for k in ("nominal", "lower", "upper"))
    if nominal is None:
        raise t.fail("nominal", f"is missing (the nominal {kind}, {unit})")
    for key, value in (("lower", lower), ("upper", upper)):
        if value is None:
            raise t.fail(key, f"is missing: {_a(kind)} has 'lower' and 'upper' limits about its "
                         f"nominal ({unit})")
    assert lower is not None and upper is not None  # for mypy: refused above
    if not lower < upper:
        raise t.fail("upper", f"must be above 'lower', got lower {lower:g}, upper {upper:g}")
    if kind == "angle":
        if not 0.0 < nominal < 180.0:
            raise t.fail("nominal", f"must be an angle between 0 and 180 degrees, got "
                         f"{show(t.data['nominal'])}")
        if nominal + lower < 0.0 or nominal + upper > 180.0:
            raise t.fail("lower" if nominal + lower < 0.0 else "upper",
                         f"takes the angle beyond 0 .. 180 degrees: nominal {nominal:g}, lower "
                         f"{lower:g}, upper {upper:g}")
    else:
        least = "> 0" if kind == "radius" else ">= 0"
        if not (nominal > 0.0 if kind == "radius" else nominal >= 0.0):
            raise t.fail("nominal", f"must be {least} ({_a(kind)}, mm), got "
                         f"{show(t.data['nominal'])}")
        if nominal > ZONE_LIMIT_MM:
            raise t.fail("nominal", f"is {_a(kind)} of {nominal:g} mm, beyond 1e6 mm (1 km): no "
                         "part has such a feature")
        if kind == "radius" and nominal + lower <= 0.0:
            raise t.fail("lower", f"leaves no radius: nominal {nominal:g} + lower {lower:g} "
                         "must be > 0")
    if kind == "radius":
        if "regions" in t:
            raise t.fail("regions", "applies to angle and distance (two features); a radius "
                         "gives 'region'")
        region = _region(t, regions)
        feature = t.text("feature", choices=DIMENSION_FEATURES["radius"], default="cylinder")
        return Characteristic(ident, kind, region, lower, upper, nominal=nominal,
                              kind=None if feature == "cylinder" else feature)
    pair = _pair(t, kind, regions)
    features = _features(t, kind)
    return Characteristic(ident, kind, pair[0], lower, upper, nominal=nominal, regions=pair,
                          features=features)


def _a(kind: str) -> str:
    return ("an " if kind[0] in "aeiou" else "a ") + kind


def _why_not(key: str, kind: str) -> str:
    if key == "zone":
        return (f"does not apply to {kind}: give 'nominal' and 'lower' and 'upper' (offsets "
                f"about it, {UNIT_WORDS[kind]})")
    if key == "datums":
        return f"must not be given: {_a(kind)} is a dimension, relative to no datum"
    if key in ("region", "regions"):
        return ("is not how a radius names its feature: give 'region'" if kind == "radius"
                else f"is not how {_a(kind)} names its features: give regions = [\"a\", \"b\"] "
                "(two features)")
    if key in ("feature", "features"):
        other = "features" if key == "feature" else "feature"
        return f"does not apply to {kind}: give '{other}'"
    return f"does not apply to {kind} (its keys are {', '.join(KEYS_OF_DIMENSIONS[kind])})"


def _region(t: Table, regions: list[str]) -> str:
    value = t.text("region", required=True)
    if value not in regions:
        raise t.fail("region", f"{show(value)} is not the name of any [[region]]"
                     f"{known(regions)}")
    return value


def _pair(t: Table, kind: str, regions: list[str]) -> tuple[str, str]:
    if "regions" not in t:
        raise t.fail("regions", f"is missing: {_a(kind)} is between two features, e.g. "
                     "regions = [\"face_a\", \"face_b\"]")
    pair = t.texts("regions", '["face_a", "face_b"]')
    if len(pair) != 2:
        raise t.fail("regions", f"names {len(pair)} region{'' if len(pair) == 1 else 's'}; "
                     f"{_a(kind)} is between two features")
    for name in pair:
        if name not in regions:
            raise t.fail("regions", f"names {show(name)}, which is not the name of any "
                         f"[[region]]{known(regions)}")
    return pair[0], pair[1]


def _features(t: Table, kind: str) -> tuple[str, str]:
    choices = DIMENSION_FEATURES[kind]
    if "features" not in t:
        return "plane", "plane"
    got = t.data["features"]
    if not isinstance(got, list) or len(got) != 2 or any(f not in choices for f in got):
        raise t.fail("features", f"must be two of {', '.join(choices)} (one per region, e.g. "
                     f"[\"plane\", \"cylinder\"]), got {show(t.data['features'])}")
    return got[0], got[1]
