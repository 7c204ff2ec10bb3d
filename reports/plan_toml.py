"""An inspection plan (engine.gdt.plan.Plan, read from TOML or QIF) written as a TOML plan
(``qa-inspect plan SOURCE --toml OUT.toml``): the same contract as a hand-written plan
(engine.io.plan), so that an inspector can review and edit it, and reading it back with
engine.io.plan.read_plan gives the same characteristics, zones, datums and regions.

* A region of a QIF plan (``group = "qif:ID"``, resolved on the STEP nominal by geometry) is
  written with the STEP faces its features match: ``group = ["face:12", "face:13"]``
  (``faces``); any other region keeps its own selector.
* Numbers are written as Python's shortest repr of the float, which TOML reads back to the
  same float: a zone, a limit or a nominal is not rounded on the way. A ``direction`` is
  written as a vector the reader normalises back to exactly the same unit vector
  (:func:`unit_preimage`; the reader normalises every direction).
* Only what the plan judges can be a ``[[characteristic]]``: each characteristic the source
  holds but the plan cannot judge (``Plan.not_judged``) is a ``[[not_judged]]`` table with its
  id, kind, name and reason, so nothing is dropped silently and the plan read back keeps the
  part from ACCEPT as its source does.
"""

from __future__ import annotations

import json
import math
import re
from collections.abc import Sequence

from engine.gdt.plan import (DIMENSIONS, ORIENTATION, Characteristic, Measurement, Plan,
                             Region, implied_feature)

_CONTROL = re.compile("[\x00-\x1f\x7f-\x9f\u2028\u2029]")


def _value(v) -> str:
    """A TOML value: a string (JSON's escapes are TOML's), a float as its shortest repr, a
    bool, an int, an array of those."""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        return repr(v)
    if isinstance(v, str):
        return json.dumps(v, ensure_ascii=False)
    return "[" + ", ".join(_value(x) for x in v) + "]"


def comment(text: str) -> str:
    """``text`` as one TOML comment line (a line break or control character in it, read from
    a file, becomes a space: it must not end the comment and start a line of the plan)."""
    return "# " + _CONTROL.sub(" ", text)


def _table(name: str, items: Sequence[tuple[str, object]], array: bool = True) -> list[str]:
    head = f"[[{name}]]" if array else f"[{name}]"
    return [head, *(f"{k} = {_value(v)}" for k, v in items)]


def _region(r: Region, faces: dict[str, tuple[int, ...]]) -> list[str]:
    items: list[tuple[str, object]] = [("name", r.name)]
    if r.name in faces:
        items.append(("group", [f"face:{i}" for i in faces[r.name]]))
    elif r.box is not None:
        items.append(("box", [[float(v) for v in corner] for corner in r.box]))
    elif r.labels is not None:
        items.append(("labels", r.labels))
    else:
        group = r.group
        items.append(("group", group if isinstance(group, str) else list(group or ())))
    if r.measured_labels is not None:
        items.append(("measured_labels", r.measured_labels))
    return _table("region", items)


def _unit(d) -> tuple[float, ...]:
    """d made a unit vector as engine.io.plan reads a ``direction``."""
    norm = math.sqrt(sum(v * v for v in d))
    return tuple(v / norm for v in d)


def unit_preimage(d) -> list[float]:
    """A vector that the plan reader's normalisation turns into unit vector ``d`` exactly
    (normalising (0.7071067811865475, 0.7071067811865475, 0) again gives ...476): ``d``
    itself or the first of 2d, 3d … 64d that does (all but about 1 % of directions); else
    ``d``, read back within a unit in the last place."""
    d = tuple(float(v) for v in d)
    for scale in range(1, 65):
        candidate = tuple(scale * v for v in d)
        if _unit(candidate) == d:
            return list(candidate)
    return list(d)


def characteristic_items(c: Characteristic) -> list[tuple[str, object]]:
    """The keys of one [[characteristic]] (engine.io.plan's contract), defaults left out."""
    items: list[tuple[str, object]] = [("id", c.id), ("type", c.type)]
    items += [("regions", list(c.regions))] if c.regions else [("region", c.region)]
    if c.type in ("size",) + DIMENSIONS:
        items += [("nominal", float(c.nominal or 0.0)), ("lower", float(c.lower)),
                  ("upper", float(c.upper))]
    elif c.type in ("profile", "line_profile"):
        items += [("lower", float(c.lower)), ("upper", float(c.upper))]
    else:
        items.append(("zone", float(c.upper)))
    if c.datums:
        items.append(("datums", list(c.datums)))
    if c.type in ("profile", "line_profile") and not c.datums and c.fit != "lsq":
        items.append(("fit", c.fit))
    if c.direction is not None:
        items.append(("direction", unit_preimage(c.direction)))
    if c.sections is not None:
        items.append(("sections", int(c.sections)))
    if c.diametral and (c.type == "straightness" or c.type in ORIENTATION):
        items.append(("diametral", True))
    if c.angle is not None:
        items.append(("angle", float(c.angle)))
    if c.kind is not None and c.kind != "cylinder":
        items.append(("feature", c.kind))
    if c.type == "size" and c.method != "lsq":
        items.append(("method", c.method))
    if c.modifier != "RFS":
        items.append(("modifier", c.modifier))
    if c.spacing is not None:
        items.append(("spacing", float(c.spacing)))
    if c.all_around:
        items.append(("all_around", True))
    if c.features and tuple(c.features) != ("plane", "plane"):
        items.append(("features", list(c.features)))
    items += [(k, getattr(c, k)) for k in ("name", "designator", "source") if getattr(c, k)]
    return items


def _measurement(m: Measurement) -> list[tuple[str, object]]:
    items: list[tuple[str, object]] = [(k, getattr(m, k)) for k in (
        "device", "device_serial", "calibration_date", "probe", "program") if getattr(m, k)]
    if m.temperature_c is not None:
        items.append(("temperature_c", float(m.temperature_c)))
    if m.instrument is not None:
        for k in ("uncertainty_mm", "mpe_a_um", "mpe_l_per_um", "probing_um",
                  "expansion_per_k"):
            v = getattr(m.instrument, k)
            if v is not None:
                items.append((k, float(v)))
    return items


def plan_toml(plan: Plan, faces: dict[str, tuple[int, ...]], header: list[str],
              names: dict[str, str] | None = None,
              region_notes: dict[str, str] | None = None) -> str:
    """The TOML text of ``plan``.

    faces : region name -> the STEP face ids it selects, written as its ``group`` (a QIF
        plan's regions; every region whose group is a ``qif:`` one must be here).
    header : lines of the opening comment (where the plan comes from).
    names : characteristic id -> its name in the source (a QIF designator), written as a
        comment above it; region_notes : region name -> a comment above it (what it is in
        the source)."""
    names, region_notes = names or {}, region_notes or {}
    missing = [r.name for r in plan.regions
               if isinstance(r.group, str) and r.group.startswith("qif:") and r.name not in faces]
    if missing:
        raise ValueError(f"no STEP faces for the QIF region(s) {', '.join(missing)}")
    lines = [comment(h) for h in header]
    part = [(k, getattr(plan.part, k)) for k in ("number", "name", "revision", "drawing",
                                                  "cad_revision") if getattr(plan.part, k)]
    if part:
        lines += ["", *_table("part", part, array=False)]
    measurement = _measurement(plan.measurement)
    if measurement:
        lines += ["", *_table("measurement", measurement, array=False)]
    for r in plan.regions:
        note = region_notes.get(r.name)
        lines += ["", *([comment(note)] if note else []), *_region(r, faces)]
    for d in plan.datums:
        lines += ["", *_table("datum", [("label", d.label), ("region", d.region),
                                        ("feature", d.feature), ("fit", d.fit)])]
    a = plan.alignment
    align: list[tuple[str, object]] = [("method", a.method)]
    if a.method == "datums":
        align.append(("reference", list(a.reference)))
        if a.best_fit_regions:
            align.append(("best_fit_regions", list(a.best_fit_regions)))
    lines += ["", *_table("alignment", align, array=False)]
    for p in plan.rps:
        lines += ["", *_table("rps", [("label", p.label), ("nominal", [float(v) for v in
                                                                       p.nominal]),
                                      ("lock", list(p.lock))])]
    for c in plan.characteristics:
        name = names.get(c.id, names.get(c.id.split(".")[0], ""))
        lines += ["", *([comment(f"{name}: {_feature_words(c)}")] if name else []),
                  *_table("characteristic", characteristic_items(c))]
    if plan.not_judged:
        lines += ["", comment(plan.not_judged_summary),
                  comment("each is listed, with its reason, and keeps the part from ACCEPT:")]
        for n in plan.not_judged:
            lines += ["", *_table("not_judged", [("id", n.id), ("type", n.type)]
                                  + ([("name", n.name)] if n.name else [])
                                  + [("reason", n.reason)])]
    return "\n".join(lines) + "\n"


def _feature_words(c: Characteristic) -> str:
    """What a characteristic is judged on, in words: "flatness of a plane"."""
    if c.features:
        return f"{c.type} between a {c.features[0]} and a {c.features[1]}"
    feature = implied_feature(c.type, c.direction is not None, c.diametral, c.kind)
    return (f"{c.type.replace('_', ' ')} of a {'surface' if feature == 'freeform' else feature}"
            + (f", a pattern of {len(c.regions)}" if c.regions else ""))
