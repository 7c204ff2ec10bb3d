"""The size and location keys of a plan's [[characteristic]] (``feature``, also an
orientation's: a width's median plane; ``method``,
``modifier``) and the checks that need the whole plan (a position at MMC needs a size on its
region; a coaxiality's primary datum is an axis, a symmetry's a plane; a region is one feature
for all that use it): engine.io.plan reads the rest."""

from __future__ import annotations

from engine.gdt.plan import (MODIFIERS, ORIENTATION, SIZE_FEATURES, SIZE_METHODS,
                             Characteristic, Datum, implied_feature, known_datum_parts)

from .plan_tables import Table, show


def size_options(t: Table, kind: str) -> dict:
    """``feature``, ``method`` and ``modifier``, each where its type takes it
    (engine.gdt.plan.Characteristic)."""
    out: dict = {}
    if "feature" in t and kind in ORIENTATION:  # a plane (the default), a width's median plane
        out["kind"] = t.text("feature", choices=("plane", "width"))
        if t.data.get("diametral"):  # an axis: a cylinder's
            raise t.fail("feature", f"a {out['kind']}'s {kind} is held between two planes: "
                         "'diametral' (an axis) does not go with it")
        if out["kind"] == "plane":
            out["kind"] = None
    elif "feature" in t:
        if kind not in ("size", "position", "symmetry", "coaxiality", "concentricity"):
            raise t.fail("feature", f"applies to size, location and orientation only, not "
                         f"{kind}")
        out["kind"] = t.text("feature", choices=SIZE_FEATURES)
        needs = {"symmetry": "width", "coaxiality": "cylinder", "concentricity": "cylinder"}
        if kind in needs and out["kind"] != needs[kind]:
            raise t.fail("feature", f"must be {show(needs[kind])} for a {kind}, got "
                         f"{show(out['kind'])}")
        if out["kind"] == "cylinder":
            out["kind"] = None  # the default feature of size
    if "method" in t and kind != "size":
        raise t.fail("method", f"applies to size only, not {kind}")
    out["method"] = t.text("method", choices=SIZE_METHODS, default="lsq")
    modifier = t.text("modifier", choices=MODIFIERS, default="RFS")
    if modifier != "RFS":
        feature = implied_feature(kind, "direction" in t, bool(t.data.get("diametral")),
                                  out.get("kind"))
        if feature in ("plane", "freeform"):
            raise t.fail("modifier", f"{show(modifier)} applies to a feature of size (a hole, "
                         f"pin, width or sphere); a {kind} here is judged on a "
                         f"{'plane' if feature == 'plane' else 'surface'}, which has no size")
        if kind != "position":
            raise t.fail("modifier", f"{show(modifier)} is supported on position only, not "
                         f"{kind}")
    out["modifier"] = modifier
    return out


def datum_kind(t: Table, c: Characteristic, datums: tuple[Datum, ...]) -> None:
    """A coaxiality or concentricity is relative to a datum axis, a symmetry to a datum
    plane: their primary datum must be one."""
    needs = {"coaxiality": "cylinder", "concentricity": "cylinder", "symmetry": "plane"}
    if c.type not in needs:
        return
    primary = next(d for d in datums if d.label == c.datums[0])
    if primary.feature != needs[c.type]:
        what = "an axis (a cylinder datum)" if needs[c.type] == "cylinder" else \
            "a plane (a plane datum)"
        raise t.fail("datums", f"names {show(primary.label)} first, a {primary.feature}: a "
                     f"{c.type} is relative to {what}")


def material_sizes(tables: list[Table], characteristics) -> None:
    """A position at MMC or LMC needs its feature's size limits: a size characteristic on
    each of its regions."""
    sized = {c.region for c in characteristics if c.type == "size"}
    for t, c in zip(tables, characteristics):
        missing = [r for r in c.all_regions if r not in sized]
        if c.modifier != "RFS" and missing:
            raise t.fail("modifier", f"{show(c.modifier)} needs the size limits of region "
                         f"{show(missing[0])}: add a [[characteristic]] of type \"size\" on "
                         "it (its nominal, lower and upper give the MMC and LMC sizes)")


def about_an_axis(t: Table, kind: str, refs: tuple[str, ...], datums: tuple[Datum, ...]):
    """A runout turns its feature about one datum axis: a cylinder datum, or a common datum
    "A-B" of two cylinders (ASME Y14.5 §9 / ISO 1101 §18.16)."""
    if len(refs) != 1:
        raise t.fail("datums", f"must name one datum axis for a {kind} (a cylinder datum, or a "
                     f"common datum such as \"A-B\"), got {show(list(refs))}")
    for part in known_datum_parts(refs[0], [d.label for d in datums]):
        feature = next(d for d in datums if d.label == part).feature
        if feature != "cylinder":
            raise t.fail("datums", f"names datum {show(part)}, a {feature}: a {kind} is about "
                         "a datum axis (a cylinder datum, or a common datum \"A-B\" of two)")


def one_feature_per_region(tables: list[Table], characteristics, datums) -> None:
    """Refuse a characteristic that takes its region for another feature than its datum or an
    earlier characteristic does (a circularity on a datum plane, a flatness on a hole)."""
    as_3d = {"line": "plane", "circle": "cylinder"}
    seen = {d.region: (as_3d.get(d.feature, d.feature), f"datum {show(d.label)} is a "
                       f"{d.feature}") for d in datums}
    for t, c in zip(tables, characteristics):
        for region, feature in c.region_features:
            if feature == "freeform":
                continue
            other, why = seen.setdefault(region, (feature, f"characteristic {show(c.id)} "
                                                  f"({c.type}) takes it for a {feature}"))
            if other != feature:
                raise t.fail("type", f"{show(c.type)} is judged on a {feature} and region "
                             f"{show(region)} is no {feature}: {why}")
