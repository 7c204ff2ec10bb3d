"""2D contour templates from files: DXF drawings (ezdxf), chained into contours, and airfoil
ordinates (Selig ``.dat``).

Geometry taken (model space, INSERTed blocks expanded): LINE, ARC, CIRCLE, LWPOLYLINE and 2D
POLYLINE with bulges of either sign, SPLINE (control points, knots, weights, or fit points only),
ELLIPSE (full and partial). Lines and circular arcs stay exact; splines and ellipses are flattened
to a chord error of at most ``FLATTEN_MM`` (0.1 µm). Annotation (TEXT, MTEXT, DIMENSION, HATCH,
POINT, …) is ignored and counted. Entities whose plane is not the drawing's XY plane are refused.

Units come from ``$INSUNITS`` and are converted to millimetres; a unitless drawing is taken as
millimetres and the result says so. Damaged files are read through ezdxf's recover mode.

Absurd values are refused, naming the entity's handle: a coordinate or radius beyond
``COORD_LIMIT_MM`` (1e9 mm) after unit conversion. Entities without extent (a LINE whose ends
coincide, a polyline or spline whose points all coincide) carry no contour: they are skipped and
counted in ``ignored`` as e.g. ``"LINE (zero length)"``; a drawing with nothing else is refused.

Chaining: entity ends closer than ``chain_tol`` are joined, whatever the order and direction the
entities are stored in; each chain becomes a contour, closed when it returns to its start.

Layers: every primitive keeps the layer of the entity it comes from (``Template2D.layer``,
``layers``), spelled as the drawing's layer table spells it (DXF layer names compare without
case); an inspection plan's ``group = "NAME"`` selects a layer's contours. An entity inside an
INSERTed block keeps its own layer (as ``--layer`` sees it), layer ``0`` included.
"""

from __future__ import annotations

import math
import os
from collections import Counter, defaultdict
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from engine.contour import Template2D, arc, build_template, segment
from engine.errors import InputError
from . import formats
from .points import COORD_LIMIT_MM, UNIT_SCALE_TO_MM, read_bytes, text_lines

FLATTEN_MM = 1e-4
GEOMETRY = {"LINE", "ARC", "CIRCLE", "LWPOLYLINE", "POLYLINE", "SPLINE", "ELLIPSE"}


@dataclass(frozen=True)
class TemplateFile:
    """A 2D template read from a file (DXF drawing or airfoil ordinates).

    template : the contours (mm, drawing XY plane).
    units : the drawing's unit name; ``unitless`` is True when $INSUNITS was unset (taken as mm).
    ignored : entity type -> count of entities that carry no contour geometry (annotation,
        and e.g. ``"LINE (zero length)"`` for geometry without extent).
    flattened : number of splines and ellipses flattened to segments (chord error <= 0.1 µm).
    mm_per_unit : the millimetres one of the file's numbers was read as (the drawing's unit;
        an airfoil's chord), so that a size found wrong by a unit's factor can say which unit
        would read it right (engine.units).
    """

    path: str
    template: Template2D
    units: str
    unitless: bool
    ignored: dict = field(default_factory=dict)
    flattened: int = 0
    recovered: bool = False
    mm_per_unit: float = 1.0


def read_template(path: str | os.PathLike, layers: Sequence[str] | None = None,
                  units: str | None = None, scale: float | None = None) -> TemplateFile:
    """A 2D template file of either kind (see :mod:`engine.io.formats`): a DXF drawing (``layers``,
    ``units``) or airfoil ordinates (``scale`` = chord length, mm)."""
    if formats.kind_of(path) == formats.DXF:
        return read_dxf_template(path, layers=layers, units=units)
    if scale is None:
        raise InputError("an airfoil ordinate template needs its chord length (scale, mm)",
                         os.fspath(path))
    return read_airfoil_template(path, scale)


def read_dxf_template(path: str | os.PathLike, layers: Sequence[str] | None = None,
                      chain_tol: float | None = None, units: str | None = None) -> TemplateFile:
    """Read the contours of a DXF drawing.

    layers : names of the layers to take (default: every layer).
    chain_tol : largest gap (drawing units after conversion, mm) joined when chaining; default
        1e-6 x the drawing's extent.
    units : override the drawing's $INSUNITS (``mm``, ``cm``, ``m``, ``in``), for files whose
        header is wrong (exporters often write metres for millimetre drawings).
    """
    path = os.fspath(path)
    formats.check_file(path)
    doc, recovered = _open_dxf(path)
    scale, unit_name, unitless = _drawing_units(doc, units, path)
    wanted = _wanted_layers(doc, layers, path)
    prims, ignored, flattened = _drawing_primitives(doc, wanted, scale, path)
    if not prims:
        degenerate = sum(n for k, n in ignored.items() if k.endswith("(zero length)"))
        raise InputError("the drawing holds no contour geometry (lines, arcs, circles, "
                         "polylines, splines or ellipses)" + ("" if wanted is None else
                                                              " on the selected layers")
                         + (f"; {degenerate} entities of zero length were ignored"
                            if degenerate else ""), path)
    extent = _extent(prims)
    tol = chain_tol if chain_tol is not None else max(1e-6 * extent, 1e-9)
    contours = chain(prims, tol)
    return TemplateFile(path, build_template(contours), unit_name, unitless, dict(ignored),
                       flattened, recovered, scale)


def _open_dxf(path: str):
    """The ezdxf document of the file at ``path``, and True when it had to be read in recover
    mode (a damaged structure that recover mode mends without errors)."""
    import ezdxf
    from ezdxf import recover

    recovered = False
    try:
        doc = ezdxf.readfile(path)
    except IOError as e:
        raise InputError(f"cannot be read ({e})", path) from e
    except ezdxf.DXFStructureError:
        try:
            doc, auditor = recover.readfile(path)
        except (IOError, ezdxf.DXFStructureError) as e:
            raise InputError(f"not a readable DXF file, even in recover mode ({e})", path) from e
        if auditor.has_errors:
            raise InputError("damaged DXF: " + "; ".join(str(err.message)
                                                         for err in auditor.errors[:3]), path)
        recovered = True
    return doc, recovered


def _drawing_units(doc, units: str | None, path: str) -> tuple[float, str, bool]:
    """(scale, unit name, unitless): the factor from drawing units to mm, from ``units`` when
    given, else from $INSUNITS (unset: taken as mm, and ``unitless`` is True)."""
    import ezdxf

    code = int(doc.header.get("$INSUNITS", 0) or 0)
    unitless = code == 0 and units is None
    if units is not None:
        if units.lower() not in UNIT_SCALE_TO_MM:
            raise InputError(f"unknown unit '{units}' (expected one of mm, cm, m, in)", path)
        scale = UNIT_SCALE_TO_MM[units.lower()]
        unit_name = f"{units} (given; the file says {ezdxf.units.unit_name(code) or 'none'})"
    else:
        try:
            # ezdxf types the units as InsertUnits; the header's int is one (an IntEnum).
            scale = 1.0 if unitless else ezdxf.units.conversion_factor(
                code, ezdxf.units.MM)  # type: ignore[arg-type]
        except (KeyError, ValueError, ZeroDivisionError, TypeError):
            raise InputError(f"$INSUNITS {code} is not a length unit", path) from None
        unit_name = "unitless (taken as mm)" if unitless else ezdxf.units.unit_name(code)
    return scale, unit_name, unitless


def _wanted_layers(doc, layers: Sequence[str] | None, path: str) -> set[str] | None:
    """The lower-cased names of the layers to take (None: every layer); a name the drawing does
    not have is refused, listing the layers it has."""
    wanted = None if layers is None else {name.lower() for name in layers}
    if wanted is not None:
        known = {layer.dxf.name.lower() for layer in doc.layers}
        missing = sorted(wanted - known)
        if missing:
            raise InputError(f"no layer named {', '.join(missing)} (layers: "
                             f"{', '.join(sorted(known))})", path)
    return wanted


def _drawing_primitives(doc, wanted: set[str] | None, scale: float,
                        path: str) -> tuple[list[dict], Counter, int]:
    """The primitives (mm, WCS XY) of the model space's geometry on the ``wanted`` layers
    (INSERTed blocks expanded), each with its ``"layer"`` name, the count of ignored entities
    by type, and the number of entities flattened."""
    from ezdxf.disassemble import recursive_decompose

    prims: list[dict] = []
    ignored: Counter = Counter()
    flattened = 0
    spelled = {layer.dxf.name.lower(): layer.dxf.name for layer in doc.layers}
    for e in recursive_decompose(doc.modelspace()):
        kind = e.dxftype()
        if kind not in GEOMETRY:
            ignored[kind] += 1
            continue
        layer = e.dxf.get("layer", "0")
        if wanted is not None and layer.lower() not in wanted:
            continue
        try:
            _check_entity_range(e, scale)
            # Overflow in a damaged entity becomes inf/NaN, refused just below, not a warning.
            with np.errstate(all="ignore"):
                got, flat = _primitives(e, scale)
            _check_primitive_range(e, got)
        except InputError as err:
            raise InputError(err.message, path) from None
        except Exception as err:  # ezdxf raises assorted errors for broken entities
            raise InputError(f"{kind} entity (handle {e.dxf.get('handle', '?')}) cannot be "
                             f"read: {err}", path) from err
        if not got:
            ignored[f"{kind} (zero length)"] += 1
            continue
        layer = spelled.setdefault(layer.lower(), layer)
        prims.extend({**p, "layer": layer} for p in got)
        flattened += flat
    return prims, ignored, flattened


def _entity_values(e) -> list[float]:
    """The raw numbers (drawing units) that place an entity: coordinates and radii."""
    kind = e.dxftype()
    d = e.dxf
    if kind == "LINE":
        return [*d.start, *d.end]
    if kind in ("ARC", "CIRCLE"):
        return [*d.center, d.radius]
    if kind == "LWPOLYLINE":
        return [v for p in e.get_points("xy") for v in p]
    if kind == "POLYLINE":
        return [v for vertex in e.vertices for v in vertex.dxf.location]
    if kind == "SPLINE":
        return [v for p in list(e.control_points) + list(e.fit_points) for v in p]
    if kind == "ELLIPSE":
        return [*d.center, *d.major_axis]
    return []


def _check_entity_range(e, scale: float) -> None:
    """Refuse an entity placed beyond ``COORD_LIMIT_MM`` before anything is computed from it
    (a spline 1e300 across would be flattened into endless pieces)."""
    vals = np.asarray(_entity_values(e), dtype=np.float64)
    with np.errstate(over="ignore"):
        bad = ~np.isfinite(vals) | (np.abs(vals) * scale > COORD_LIMIT_MM)
    if bad.any():
        raise InputError(f"{e.dxftype()} (handle {e.dxf.get('handle', '?')}) has a coordinate "
                         f"or radius of {vals[bad][0]:g} drawing units, beyond ±1e9 mm; it is "
                         "not a part's geometry")


def _check_primitive_range(e, prims: list[dict]) -> None:
    for p in prims:
        vals = [*p["start"], *p["end"], *p.get("centre", ()), p.get("radius", 0.0)]
        if not all(math.isfinite(v) and abs(v) <= COORD_LIMIT_MM for v in vals):
            raise InputError(f"{e.dxftype()} (handle {e.dxf.get('handle', '?')}) gives a "
                             "coordinate or radius beyond ±1e9 mm; it is not a part's geometry")


def _primitives(e, scale: float) -> tuple[list[dict], int]:
    """Exact primitives (mm, WCS XY) of one DXF entity, and 1 if it was flattened."""
    kind = e.dxftype()
    ext = e.dxf.get("extrusion", (0.0, 0.0, 1.0))
    if kind in ("ARC", "CIRCLE", "LWPOLYLINE", "ELLIPSE") or (kind == "POLYLINE"):
        nz = float(ext[2]) / max(math.hypot(*ext), 1e-300)
        if abs(abs(nz) - 1.0) > 1e-9:
            raise InputError(f"{kind} (handle {e.dxf.get('handle', '?')}) does not lie in the "
                             "drawing's XY plane; a 2D template must")
        mirror = nz < 0  # OCS seen from below: x is mirrored, turning directions reverse
    else:
        mirror = False
    if kind == "LINE":
        a, b = e.dxf.start, e.dxf.end
        if a.x == b.x and a.y == b.y:
            return [], 0  # no extent (in the drawing's plane): nothing to chain
        return [segment((a.x * scale, a.y * scale), (b.x * scale, b.y * scale))], 0
    if kind in ("ARC", "CIRCLE"):
        c = e.dxf.center
        r = e.dxf.radius * scale
        if not r > 0:
            raise InputError(f"{kind} (handle {e.dxf.get('handle', '?')}) has radius "
                             f"{e.dxf.radius:g}; it must be positive")
        if kind == "CIRCLE":
            a0, sweep = 0.0, 2 * math.pi
        else:
            a0 = math.radians(e.dxf.start_angle)
            sweep = math.radians((e.dxf.end_angle - e.dxf.start_angle) % 360.0) or 2 * math.pi
        cx, cy = c.x, c.y
        if mirror:
            cx, a0, sweep = -cx, math.pi - a0, -sweep
        return [arc((cx * scale, cy * scale), r, a0, sweep)], 0
    if kind == "LWPOLYLINE":
        pts = [(x, y, b) for x, y, b in e.get_points("xyb")]
        return _bulge_chain(pts, e.closed, scale, mirror), 0
    if kind == "POLYLINE":
        if not e.is_2d_polyline:
            if e.is_3d_polyline:
                pts = [(v.dxf.location.x, v.dxf.location.y, 0.0) for v in e.vertices]
                return _bulge_chain(pts, e.is_closed, scale, False), 0
            raise InputError(f"POLYLINE (handle {e.dxf.get('handle', '?')}) is a mesh, not a "
                             "contour")
        pts = [(v.dxf.location.x, v.dxf.location.y, v.dxf.get("bulge", 0.0)) for v in e.vertices]
        return _bulge_chain(pts, e.is_closed, scale, mirror), 0
    if kind in ("SPLINE", "ELLIPSE"):
        # Both construction tools work in WCS. ezdxf checks its flattening distance at the
        # middle of each piece only, so ask for a quarter of FLATTEN_MM to stay within it.
        tool = e.construction_tool()
        flat = list(tool.flattening(FLATTEN_MM / 4.0 / scale, segments=16))
        z = [p.z for p in flat]
        if max(z) - min(z) > FLATTEN_MM / scale:
            raise InputError(f"{kind} (handle {e.dxf.get('handle', '?')}) is not flat in the "
                             "drawing's XY plane; a 2D template must be")
        v = [(p.x * scale, p.y * scale) for p in flat]
        return [segment(v[i], v[i + 1]) for i in range(len(v) - 1)
                if math.dist(v[i], v[i + 1]) > 0], 1
    raise InputError(f"{kind} is not contour geometry")


def _bulge_chain(pts, closed: bool, scale: float, mirror: bool) -> list[dict]:
    """Segments and arcs of a polyline given as (x, y, bulge) vertices (bulge of the segment that
    starts at the vertex; positive = counter-clockwise)."""
    out = []
    n = len(pts)
    last = n if closed else n - 1
    for i in range(last):
        x0, y0, b = pts[i]
        x1, y1, _ = pts[(i + 1) % n]
        if mirror:
            x0, x1, b = -x0, -x1, -b
        a = np.array([x0, y0]) * scale
        c = np.array([x1, y1]) * scale
        if np.allclose(a, c):
            continue
        if abs(b) < 1e-12:
            out.append(segment(a, c))
            continue
        theta = 4.0 * math.atan(b)
        chord = c - a
        L = math.hypot(*chord)
        r = L / (2.0 * abs(math.sin(theta / 2.0)))
        left = np.array([-chord[1], chord[0]]) / L
        centre = (a + c) / 2.0 + (L / 2.0) / math.tan(theta / 2.0) * left
        a0 = math.atan2(a[1] - centre[1], a[0] - centre[0])
        out.append(arc(centre, r, a0, theta))
        out[-1]["end"] = c  # keep the drawing's vertex exactly
    return out


def _extent(prims) -> float:
    pts = np.array([p["start"] for p in prims] + [p["end"] for p in prims])
    return float(np.linalg.norm(pts.max(axis=0) - pts.min(axis=0)))


def _reverse(p: dict) -> dict:
    q = dict(p)
    q["start"], q["end"] = p["end"], p["start"]
    if p["kind"] == 1:  # arc
        q["angle0"] = p["angle0"] + p["sweep"]
        q["sweep"] = -p["sweep"]
    return q


def _end_nodes(prims: list[dict], tol: float) -> np.ndarray:
    """(2 n,) int: the node of each primitive end, start of primitive k at 2 k, its end at
    2 k + 1. Ends within ``tol`` (mm) of each other share a node, numbered by its lowest end."""
    from scipy.spatial import cKDTree

    ends = np.array([q for p in prims for q in (p["start"], p["end"])])
    # Ends within tol become one node (connected components of the "close" relation).
    pairs = cKDTree(ends).query_pairs(tol, output_type="ndarray")
    parent = np.arange(len(ends))

    def find(i):
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    for i, j in pairs:
        ri, rj = find(i), find(j)
        if ri != rj:
            parent[max(ri, rj)] = min(ri, rj)
    return np.array([find(i) for i in range(len(ends))])


def chain(prims: list[dict], tol: float) -> list[tuple[list[dict], bool]]:
    """Join primitives whose ends lie within ``tol`` into contours (primitives in order, closed).

    Full circles are contours on their own. Where more than two ends meet, chains stop there.
    """
    contours: list[tuple[list[dict], bool]] = []
    rest = []
    for p in prims:
        if p["kind"] == 1 and abs(abs(p["sweep"]) - 2 * math.pi) < 1e-12:
            contours.append(([p], True))
        else:
            rest.append(p)
    if not rest:
        return contours
    node = _end_nodes(rest, tol)
    incident = defaultdict(list)  # node -> [(primitive, which end: 0 start / 1 end)]
    for k in range(len(rest)):
        incident[node[2 * k]].append((k, 0))
        incident[node[2 * k + 1]].append((k, 1))
    used = np.zeros(len(rest), dtype=bool)

    def walk(k, forward):
        """Follow the chain from primitive k (in the given direction) through degree-2 nodes."""
        seq = [rest[k] if forward else _reverse(rest[k])]
        used[k] = True
        tail = node[2 * k + (1 if forward else 0)]
        while len(incident[tail]) == 2:
            nxt = [(j, w) for j, w in incident[tail] if not used[j]]
            if not nxt:
                break
            j, w = nxt[0]
            used[j] = True
            seq.append(rest[j] if w == 0 else _reverse(rest[j]))
            tail = node[2 * j + (1 - w)]
        return seq, tail

    # Open chains start at nodes that are not simple joints; what is left are closed loops.
    for start_node in sorted(incident, key=lambda nd: nd):
        if len(incident[start_node]) == 2:
            continue
        for k, w in incident[start_node]:
            if not used[k]:
                seq, _ = walk(k, w == 0)
                contours.append((seq, False))
    for k in range(len(rest)):
        if not used[k]:
            seq, tail = walk(k, True)
            contours.append((seq, tail == node[2 * k]))
    return contours


def read_airfoil_template(path: str | os.PathLike, chord_mm: float) -> TemplateFile:
    """An airfoil ordinate file (Selig format: a name line, then ``x y`` pairs from the trailing
    edge over the upper surface to the leading edge and back, chord 1) as a closed polygon
    template through its ordinates, scaled to ``chord_mm``. A blunt trailing edge is closed by
    a straight segment."""
    path = os.fspath(path)
    formats.check_file(path)
    if not (chord_mm > 0 and math.isfinite(chord_mm)):
        raise InputError(f"--scale (chord length, mm) must be positive, got {chord_mm:g}", path)
    if chord_mm > COORD_LIMIT_MM:
        raise InputError(f"--scale (chord length) {chord_mm:g} mm is beyond 1e9 mm", path)
    pts = []
    lines = text_lines(read_bytes(path), path, "text ordinate file")
    for ln, raw in enumerate(lines[1:], start=2):
        s = raw.strip()
        if not s or s.startswith("#"):
            continue
        tok = s.split()
        if len(tok) != 2:
            raise InputError(f"{len(tok)} values where an ordinate file has 2 (x y)", path, ln)
        try:
            x, y = float(tok[0]), float(tok[1])
        except ValueError:
            raise InputError(f"'{s}' is not a pair of numbers", path, ln) from None
        if not (math.isfinite(x) and math.isfinite(y)):
            raise InputError("NaN or infinity is not an ordinate", path, ln)
        if max(abs(x), abs(y)) * chord_mm > COORD_LIMIT_MM:
            raise InputError(f"ordinate {max(abs(x), abs(y)):g} x chord {chord_mm:g} mm lies "
                             "beyond ±1e9 mm", path, ln)
        pts.append((x * chord_mm, y * chord_mm))
    if len(pts) < 3:
        raise InputError(f"only {len(pts)} ordinates; an airfoil needs at least 3", path)
    prims = [segment(pts[i], pts[i + 1]) for i in range(len(pts) - 1)
             if math.dist(pts[i], pts[i + 1]) > 0]
    if math.dist(pts[-1], pts[0]) > 0:
        prims.append(segment(pts[-1], pts[0]))
    return TemplateFile(path, build_template([(prims, True)]), "chord 1 scaled to mm", False,
                        mm_per_unit=chord_mm)
