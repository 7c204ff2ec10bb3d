"""An inspection plan (engine.gdt.plan.Plan, from TOML or QIF) as ``qa-inspect plan`` prints
it: a heading, the datums, then one row per characteristic of the source: id, name, type and
symbol, tolerance, modifiers, datum reference frame, features -> STEP face ids, and whether the
product judges it (``yes``, or ``no:`` and the reason the plan reader recorded)."""

from __future__ import annotations

import os

from engine.gdt.plan import LOCATION, ORIENTATION, SYMBOLS, Characteristic, Plan
from reports.messages import printable

COLUMNS = ("id", "name", "type", "tolerance (mm)", "modifiers", "datums", "features -> faces",
           "supported")


def _g(v: float) -> str:
    return f"{v:.6g}"


def tolerance_words(c: Characteristic) -> str:
    """The zone as a drawing writes it: "⌀0.1" (a cylindrical zone), "0.05", a profile's
    "0.1 (-0.05/+0.05)", a size's "⌀35 -0.2/+0" (a width without ⌀, a sphere S⌀)."""
    if c.type == "size":
        mark = {"width": "", "sphere": "S⌀"}.get(c.kind or "cylinder", "⌀")
        return f"{mark}{_g(c.nominal or 0.0)} {c.lower:+.6g}/{c.upper:+.6g}"
    if c.type == "angle":  # degrees, whatever the column says
        return f"{_g(c.nominal or 0.0)}° {c.lower:+.6g}°/{c.upper:+.6g}°"
    if c.type in ("radius", "distance"):
        mark = {"radius": "SR" if c.kind == "sphere" else "R"}.get(c.type, "")
        return f"{mark}{_g(c.nominal or 0.0)} {c.lower:+.6g}/{c.upper:+.6g}"
    if c.type in ("profile", "line_profile"):
        return f"{_g(c.width)} ({c.lower:+.6g}/{c.upper:+.6g})"
    cylindrical = c.diametral or c.type in ("coaxiality", "concentricity") or (
        c.type == "position" and c.kind in (None, "cylinder"))
    return ("⌀" if cylindrical else "S⌀" if c.type == "position" and c.kind == "sphere"
            else "") + _g(c.upper)


def modifier_words(c: Characteristic) -> str:
    """The modifiers and options a characteristic states, in words ("-" for none)."""
    out = []
    if c.modifier != "RFS":
        out.append(c.modifier)
    if c.regions and not c.features:  # (an angle's, a distance's two: not a pattern)
        out.append(f"pattern of {len(c.regions)}")
    if c.type in ORIENTATION or c.type == "straightness":
        out.append("axis" if c.diametral else "median plane of a width"
                   if c.kind == "width" else "plane")
    if c.angle is not None:
        out.append(f"angle {c.angle:g}°")
    if c.features:
        out.append(" and ".join(c.features))
    if c.type in LOCATION + ("size", "radius") and c.kind not in (None, "cylinder"):
        out.append(c.kind)
    if c.type == "size" and c.method != "lsq":
        out.append(c.method)
    if c.type in ("profile", "line_profile") and not c.datums and c.fit != "lsq":
        out.append(f"fit {c.fit}")
    if c.all_around:
        out.append("all around")
    if c.direction is not None:
        out.append("direction (" + ", ".join(_g(v) for v in c.direction) + ")")
    if c.sections is not None:
        out.append(f"{c.sections} sections")
    if c.spacing is not None:
        out.append(f"spacing {_g(c.spacing)}")
    return ", ".join(out) or "-"


def face_list(ids) -> str:
    """Face ids as runs: "3, 7-9"."""
    ids = sorted(ids)
    runs: list[list[int]] = []
    for i in ids:
        if runs and i == runs[-1][-1] + 1:
            runs[-1].append(i)
        else:
            runs.append([i])
    return ", ".join(str(r[0]) if len(r) == 1 else f"{r[0]}-{r[-1]}" for r in runs)


def region_words(plan: Plan, name: str, faces: dict[str, tuple[int, ...]]) -> str:
    """A region and what it selects: "qif:2154 -> faces 98", "slot (box)", "hole1 -> faces
    12-13"."""
    if name in faces:
        ids = faces[name]
        return f"{name} -> face{'s' if len(ids) > 1 else ''} {face_list(ids)}"
    r = plan.region(name)
    if r.box is not None:
        return f"{name} (box)"
    if r.labels is not None:
        return f"{name} (labels {r.labels})"
    groups = (r.group,) if isinstance(r.group, str) else tuple(r.group or ())
    if isinstance(r.group, str) and r.group.startswith("qif:"):
        return f"{name} (not mapped: give --nominal PART.stp)"
    return f"{name} (group {', '.join(groups)})"


def region_faces(plan: Plan, qif_groups: dict | None = None) -> dict[str, tuple[int, ...]]:
    """Region name -> STEP face ids, where known: a QIF region's (``qif_groups``, its group ->
    the faces its features match, engine.io.qif_plan.qif_face_groups), a region whose groups
    are all ``face:N``."""
    out = {}
    for r in plan.regions:
        groups = (r.group,) if isinstance(r.group, str) else tuple(r.group or ())
        if qif_groups is not None and isinstance(r.group, str) and r.group in qif_groups:
            out[r.name] = tuple(qif_groups[r.group])
        elif groups and all(g.startswith("face:") and g[5:].isdigit() for g in groups):
            out[r.name] = tuple(sorted(int(g[5:]) for g in groups))
    return out


def _rows(plan: Plan, faces: dict, names: dict[str, str], order: list[str] | None) -> list:
    judged: dict[str, list[Characteristic]] = {}
    for c in plan.characteristics:
        judged.setdefault(c.id if order is None else c.id.split(".")[0], []).append(c)
    missing = {n.id: n for n in plan.not_judged}
    rows = []
    # Without the source's order (a TOML plan), its characteristics, then those it does not judge.
    for cid in order if order is not None else [*judged, *(n for n in missing
                                                          if n not in judged)]:
        for c in judged.get(cid, []):
            rows.append((c.id, names.get(cid, ""), f"{SYMBOLS.get(c.type, '')} {c.type}",
                         tolerance_words(c), modifier_words(c),
                         "|".join(c.datums) or "-",
                         "; ".join(region_words(plan, r, faces) for r in c.all_regions), "yes"))
        if cid in missing:
            n = missing[cid]
            rows.append((n.id, n.name or names.get(cid, ""), n.type, "-", "-", "-", "-",
                         f"no: {n.reason}"))
    return rows


def plan_table(plan: Plan, faces: dict[str, tuple[int, ...]], heading: list[str],
               names: dict[str, str] | None = None, order: list[str] | None = None) -> str:
    """The plan as text for the terminal.

    faces : region name -> STEP face ids (:func:`region_faces`); heading : lines above (the
    source, its unit); names : characteristic id -> its name in the source; order : the
    source's characteristic ids in its order (a QIF's; judged ones split per feature,
    ``ID.1`` …, follow their id), None: the plan's own order."""
    names = names or {}
    total = plan.n_stated
    lines = [*heading,
             f"{total} characteristics in {os.path.basename(plan.path)}: "
             f"{total - len(plan.not_judged)} supported, {len(plan.not_judged)} not"
             + (f" (judged as {len(plan.characteristics)} plan characteristics)"
                if len(plan.characteristics) != total - len(plan.not_judged) else ""),
             f"alignment: {plan.alignment.method}"
             + (f" on {'|'.join(plan.alignment.reference)}" if plan.alignment.reference
                else ""), ""]
    if plan.datums:
        lines.append("datums:")
        lines += [f"  {d.label}: {d.feature} ({d.fit}), {region_words(plan, d.region, faces)}"
                  for d in plan.datums]
        lines.append("")
    rows = [COLUMNS, *_rows(plan, faces, names, order)]
    rows = [tuple(printable(v) for v in row) for row in rows]
    widths = [max(len(row[i]) for row in rows) for i in range(len(COLUMNS) - 1)]
    for row in rows:
        lines.append("  ".join(v.ljust(w) for v, w in zip(row, widths)) + "  " + row[-1])
    return "\n".join(lines) + "\n"
