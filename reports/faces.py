"""The faces of a STEP nominal as ``qa-inspect faces`` lists them: one row per face with the id
a plan's region names (``group = "face:N"``, engine.step_model.face_groups; the same ids a QIF
plan's features are matched to), its surface's kind and exact geometry, its area and its name.

Numbers come from engine.io.step (:class:`~engine.io.step.StepFace`, its ``geometry`` and
:meth:`~engine.io.step.StepNominal.face_area`), in mm and the nominal's frame: OpenCascade
converts the file's unit (inch, metre …) to mm on reading.

Columns of the CSV (:data:`CSV_COLUMNS`):

* ``point_x/y/z``: a plane's point (its surface's origin), a cylinder's point on its axis, a
  cone's apex, a sphere's or a torus' centre;
* ``dir_x/y/z``: a plane's outward unit normal, the unit axis of a cylinder or torus, a cone's
  unit axis from its apex into the cone;
* ``diameter``: a cylinder's or sphere's diameter, a torus' major diameter; ``minor_diameter``:
  a torus' tube diameter; ``half_angle_deg``: a cone's half-angle, degrees;
* ``hole``: a cylinder or sphere whose outward normal points to its axis or centre (a hole,
  a socket), ``false`` for a pin or a ball;
* empty where a kind has no such value (B-spline and other surfaces have no closed form).
"""

from __future__ import annotations

import csv
import io
import math
import os

from reports.messages import printable, spreadsheet_text

CSV_COLUMNS = ("id", "type", "name", "part", "area_mm2", "point_x", "point_y", "point_z",
               "dir_x", "dir_y", "dir_z", "diameter", "minor_diameter", "half_angle_deg", "hole")


def face_values(face) -> dict:
    """A face's geometry in the CSV's columns (see the module): {column: float | bool}, only
    those its kind has."""
    g = face.geometry
    out: dict = {}
    at = g.get("point", g.get("centre", g.get("apex")))
    if at is not None:
        out.update(zip(("point_x", "point_y", "point_z"), map(float, at)))
    direction = g.get("normal", g.get("axis"))
    if direction is not None:
        out.update(zip(("dir_x", "dir_y", "dir_z"), map(float, direction)))
    if "radius" in g:
        out["diameter"] = 2.0 * float(g["radius"])
    if "major" in g:
        out["diameter"], out["minor_diameter"] = 2.0 * float(g["major"]), 2.0 * float(g["minor"])
    if "half_angle" in g:
        out["half_angle_deg"] = math.degrees(float(g["half_angle"]))
    if "hole" in g:
        out["hole"] = bool(g["hole"])
    return out


def _mm(v: float) -> str:
    """A length or a direction's component to 1e-6, without trailing zeros ("45", "-0.5")."""
    text = f"{v:.6f}".rstrip("0").rstrip(".")
    return "0" if text == "-0" else text


def _xyz(values: dict, prefix: str) -> str:
    return "(" + ", ".join(_mm(values[f"{prefix}_{a}"]) for a in "xyz") + ")"


def geometry_words(face) -> str:
    """A face's geometry on one line, mm: "point (0, 0, 10) normal (0, 0, 1)",
    "⌀25 hole, axis (0, 0, -1) through (-160, 45, 0)" …; "" for a surface without closed
    form."""
    v = face_values(face)
    kind = face.surface
    if kind == "plane":
        return f"point {_xyz(v, 'point')} normal {_xyz(v, 'dir')}"
    hole = v.get("hole")
    if kind == "cylinder":
        side = "" if hole is None else (" hole" if hole else " pin")
        return f"⌀{_mm(v['diameter'])}{side}, axis {_xyz(v, 'dir')} through {_xyz(v, 'point')}"
    if kind == "sphere":
        side = "" if hole is None else (" socket" if hole else " ball")
        return f"⌀{_mm(v['diameter'])}{side}, centre {_xyz(v, 'point')}"
    if kind == "cone":
        return (f"apex {_xyz(v, 'point')} axis {_xyz(v, 'dir')} half-angle "
                f"{v['half_angle_deg']:.6g}°")
    if kind == "torus":
        return (f"centre {_xyz(v, 'point')} axis {_xyz(v, 'dir')} ⌀{_mm(v['diameter'])} "
                f"tube ⌀{_mm(v['minor_diameter'])}")
    return ""


def faces_csv(step, areas: list[float]) -> str:
    """One CSV row per face of ``step`` (engine.io.step.StepNominal), id order; ``areas`` mm²
    per face. Full precision (Python's shortest round-tripping repr)."""
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(CSV_COLUMNS)
    for face, area in zip(step.faces, areas):
        v = face_values(face)
        cells = [repr(v[c]) if isinstance(v.get(c), float) else "" for c in CSV_COLUMNS[5:-1]]
        hole = "" if "hole" not in v else ("true" if v["hole"] else "false")
        w.writerow([face.id, face.surface, spreadsheet_text(face.name or ""),
                    spreadsheet_text(face.part or ""), repr(area),
                    *cells, hole])
    return buf.getvalue()


def faces_table(step, areas: list[float]) -> str:
    """The faces as a table for the terminal: a heading (the file, its unit, how many faces of
    which kinds), then id, type, area, name and geometry per face."""
    kinds: dict[str, int] = {}
    for f in step.faces:
        kinds[f.surface] = kinds.get(f.surface, 0) + 1
    parts = sorted({f.part for f in step.faces if f.part})
    lines = [printable(f"{os.path.basename(step.path)}: {step.n_faces} faces ("
                       + ", ".join(f"{n} {k}" for k, n in kinds.items())
                       + f"); values in mm (the file's unit: {step.unit or 'not stated'})"
                       + (f"; part {', '.join(parts)}" if parts else "")),
             "a plan's region selects face N with group = \"face:N\"", ""]
    names = [printable(f.name) if f.name else "-" for f in step.faces]
    width_id = max(2, len(str(step.n_faces)))
    width_name = max(4, *map(len, names))
    lines.append(f"{'id':>{width_id}}  {'type':<10} {'area mm²':>14}  {'name':<{width_name}}  "
                 "geometry (mm)")
    for f, area, name in zip(step.faces, areas, names):
        lines.append(f"{f.id:>{width_id}}  {f.surface:<10} {area:>14.4f}  "
                     f"{name:<{width_name}}  {geometry_words(f)}".rstrip())
    return "\n".join(lines) + "\n"
