"""STEP nominals: the CAD model itself (ISO 10303-21; AP203, AP214, AP242), read with OpenCascade.

:func:`read_step` returns a :class:`StepNominal`: every face of every solid, shell and placed
assembly instance with an id (1..F, in the file's reading order) and, where the file gives them,
its name and its part's name; a tessellation for registration (a :class:`~engine.pointset.PointSet`
of points, outward unit normals and triangles, with the face id of every point); and
:meth:`StepNominal.deviations`, the exact signed distance from points to the B-rep.

This is the only module of the product that imports OpenCascade (``OCP``, the
``cadquery-ocp-novtk`` wheel: OpenCascade without a VTK of its own, so pyvista's stays intact),
and only inside functions: a run without a STEP file never loads it (about half a second).

Reading
    The file is checked before OpenCascade sees it: not empty, at most ``MAX_BYTES``, text that
    begins ``ISO-10303-21;``, has ``HEADER;`` … ``ENDSEC;`` then ``DATA;`` and ends with
    ``END-ISO-10303-21;`` (a file cut short is refused here). Then the references of the
    entities the B-rep uses are walked in the file's text (``BREP_ROOTS``, iteratively): a
    reference cycle (an oriented edge of itself, two of each other) or an oriented edge, face,
    shell or path of another of its kind is refused, naming the entities, before OpenCascade's
    parser follows them until the process dies; so is a DIRECTION of the B-rep whose ratios are
    all zero (OpenCascade translates it into a shape without extent). OpenCascade's parser then
    reports syntax errors and unresolved references (the model's global check) and per-entity errors: a
    file with any of the former, or with an error on an entity the shape is made of (everything
    reached from its shape representations and product structure, ``BREP_ROOTS``: topology,
    geometry, placements, contexts, units; a face bound that is no loop would crash
    OpenCascade's translation), is refused as damaged; errors on entities the shape does not
    use (PMI, presentation, properties: the NIST AP242 files have hundreds) are let pass with a
    warning (:attr:`StepNominal.warnings`).
    A file that transfers to no shape, or to a shape without faces, is refused. Every refusal is
    an :class:`~engine.errors.InputError` (exit 65) naming the file and the problem.

    OpenCascade's shape healing runs as part of its STEP translation: among other things it turns
    a face written the wrong way round in a closed shell (or a whole shell inside out) outward.

Units
    Lengths are converted to millimetres by OpenCascade; the file's own length unit is kept in
    :attr:`StepNominal.unit` (as the file names it: ``millimetre``, ``INCH``, ``metre`` …).

Faces
    Assemblies are walked through OpenCascade's XDE document: every placed instance of every part
    contributes all its faces, moved by the product of the placements above it. A face's ``name``
    is its own name in the file (``ADVANCED_FACE('MOUNTING_FACE', …)``; the placeholders ``''``
    and ``NONE`` are no name); ``part`` is the name of the solid (or shell) it belongs to when the
    file names that, else the name of its product (``PRODUCT('bracket', …)``), else that of the
    instance or assembly above it.

Tessellation
    ``BRepMesh_IncrementalMesh`` with the chordal deflection :func:`deflection_for` (2.5e-5 of the
    model's diagonal, at least 1 µm and at most 10 µm) and 0.5 rad angular deflection. Points are
    the mesh nodes of each face (a node shared by two faces appears once per face, with each
    face's normal); a point's normal is the face's outward unit normal at the node's (u, v): the
    surface normal, reversed for a face whose orientation is ``TopAbs_REVERSED``.

Exact deviations
    See :meth:`StepNominal.deviations`. Measured on the three NIST test parts (2 cores):
    about 20-50 µs a point (CTC-01: 2,000 points 0.06 s, 200,000 points 4 s).
"""

from __future__ import annotations

import functools
import os
import re
from dataclasses import dataclass, field

import numpy as np

from engine.errors import InputError, InputNotFoundError, NoDistanceError
from engine.neighbours import query_workers
from engine.nominal import surface_tree
from engine.pointset import PointSet

from .points import COORD_LIMIT_MM

MAX_BYTES = 1 << 30
"""The largest STEP file read (1 GiB): OpenCascade holds the whole model in memory, several
times the file's size."""

K_NEAREST = 8
"""Tessellation points whose faces are the first candidates of a measured point."""
UPPER_MARGIN_MM = 1e-6
"""The distance to the nearest tessellation node, plus this or the model's largest tolerance,
bounds the distance to the B-rep from above (nodes on edges lie on the edges' curves, which
stray from the faces' surfaces by up to the edges' tolerances)."""
TIE_MM = 1e-9
"""A face whose lower bound is within this of the best distance found is not measured: it could
improve the distance by no more."""

TRIM_DEFLECTION = 2e-4
"""A face's trim is drawn in its (u, v) domain as polylines within this fraction of the domain
box's diagonal of the boundary curves; a foot farther than ``TRIM_BAND`` x that from every
polyline is classified by them (even-odd), the others by OpenCascade's classifier."""
TRIM_BAND = 4.0
TRIM_CHECKS = 32
"""Seeded random (u, v) points on which the polylines must classify as OpenCascade does before
they are used for a face (else that face keeps OpenCascade's classifier)."""

MAX_DEFLECTION_MM = 0.01
MIN_DEFLECTION_MM = 0.001
ANGULAR_DEFLECTION = 0.5

_END = "END-ISO-10303-21;"
_HEAD_BYTES = 1 << 20
_SCHEMA_RE = re.compile(r"FILE_SCHEMA\s*\(\s*\(\s*'([^']*)'", re.IGNORECASE)
_NO_NAMES = ("", "NONE")
_SHAPE_PACKAGES = ("StepShape", "StepGeom", "StepRepr", "StepBasic")
"""OpenCascade's packages of the entities the shape is made of (topology, geometry,
representations and placements, products and units): an error on one of these refuses the file
(OpenCascade's translation can crash on a face bound that is no loop); errors on presentation
and PMI entities (StepVisual, StepDimTol …) do not."""

_SI_PREFIX = {"": 1e3, "milli": 1.0, "centi": 10.0, "deci": 100.0, "kilo": 1e6, "micro": 1e-3,
              "nano": 1e-6}
_CONVERSION_UNITS = {"inch": 25.4, "in": 25.4, "foot": 304.8, "ft": 304.8, "mil": 0.0254,
                     "thou": 0.0254, "yard": 914.4, "micron": 1e-3}


@dataclass(frozen=True)
class StepFace:
    """One face of the B-rep.

    id : 1..F, the face's place in the file's reading order (stable for the same file).
    name : the face's own name in the file, or None.
    part : the name of the solid/shell or product the face belongs to, or None.
    surface : the kind of its surface: 'plane', 'cylinder', 'cone', 'sphere', 'torus',
        'bspline', 'bezier', 'revolution', 'extrusion', 'offset' or 'other'.
    reversed : True when the face's orientation is TopAbs_REVERSED (its outward normal is minus
        its surface's normal).
    geometry : the exact surface for planes (``point``, outward unit ``normal``), cylinders
        (``point`` on the axis, unit ``axis``, ``radius``, ``hole``: True when the outward normal
        points to the axis) and spheres (``centre``, ``radius``, ``hole``); millimetres, the
        nominal frame. Empty for other surfaces.
    """

    id: int
    name: str | None
    part: str | None
    surface: str
    reversed: bool
    geometry: dict = field(default_factory=dict)


class StepNominal:
    """A STEP model read by :func:`read_step`: faces, a tessellation, exact deviations.

    path : the file. schema : its FILE_SCHEMA (e.g. 'AUTOMOTIVE_DESIGN { 1 0 10303 214 1 1 1 1 }').
    unit : the file's length unit as it names it; mm_per_unit : its size in mm (None when the
        name is not a known unit; OpenCascade converted it all the same).
    faces : tuple of :class:`StepFace`, ``faces[i].id == i + 1``.
    point_set : the tessellation (points (n, 3) mm, outward unit normals (n, 3), triangles
        (m, 3) with outward winding), for registration.
    face_ids : (n,) int64, the face id of every tessellation point.
    deflection : the tessellation's chordal deflection, mm.
    bounds : (2, 3) the B-rep's bounding box (min, max), mm.
    tolerance : the model's largest tolerance (of a face, edge or vertex), mm: how far its
        edges may stray from its faces' surfaces (the CTC-05 test part: 0.034 mm).
    warnings : what was ignored in reading: entities the shape does not use (PMI,
        presentation, properties) that failed OpenCascade's checks.
    """

    def __init__(self, path: str, schema: str, unit: str, mm_per_unit: float | None,
                 faces: tuple, point_set: PointSet, face_ids: np.ndarray, deflection: float,
                 bounds: np.ndarray, brep: "_Brep", warnings: tuple[str, ...] = ()):
        self.path = path
        self.warnings = warnings
        self.schema = schema
        self.unit = unit
        self.mm_per_unit = mm_per_unit
        self.faces = faces
        self.point_set = point_set
        self.face_ids = face_ids
        self.deflection = deflection
        self.bounds = bounds
        self._brep = brep
        self.tolerance = brep.tolerance
        self._tree = surface_tree(point_set.points)

    @property
    def n_faces(self) -> int:
        return len(self.faces)

    def deviations(self, points) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Exact signed distances from ``points`` to the B-rep.

        points : (n, 3) float, mm, nominal frame.

        Returns ``signed`` (n,) mm, ``foot`` (n, 3) the nearest point of the B-rep, ``normal``
        (n, 3) the outward unit normal there, ``face`` (n,) the id of the face the foot lies on.
        ``signed`` is positive along the outward normal (excess material) and negative inside.

        For each point the candidate faces are those of its ``K_NEAREST`` nearest tessellation
        points, then every other face whose bounding box is nearer than the best distance found
        (or than the nearest tessellation point, which lies on the B-rep within the model's
        tolerance): no face that could be nearer is left out. A candidate's surface is projected
        on exactly: planes, cylinders, cones, spheres and tori in closed form (vectorised; the
        unbounded surface's nearest point, whose distance also bounds the face's from below),
        other surfaces with OpenCascade's extrema over the face's (u, v) box (one reused
        projector per face). The foot is kept when it lies on the face's trimmed domain
        (``IntTools_FClass2d``, IN or ON), nearest candidates first; when it lies outside, the
        nearest point of the trimmed face (on an edge, at a vertex, or another interior
        minimum) comes from ``BRepExtrema_DistShapeShape``, asked only while the face's lower
        bound is below the best so far. The nearest wins. On a face the sign comes from the
        face's outward normal at the foot; at a foot on an edge or a vertex from the sum of the
        outward normals of the faces that meet there (right on either side of a sharp convex or
        concave edge).

        Exact to OpenCascade's precision (tested to 0.1 µm against analytic truth and against
        the distance to all faces at once); an extrema search over a general (B-spline) face's
        (u, v) box is OpenCascade's, a grid search refined by Newton steps.
        """
        p = np.ascontiguousarray(points, dtype=np.float64)
        if p.ndim != 2 or p.shape[1] != 3:
            raise ValueError(f"points of shape {p.shape}; expected (n, 3)")
        if not np.isfinite(p).all():
            raise ValueError("points hold NaN or infinity")
        n = p.shape[0]
        if n == 0:
            return np.zeros(0), np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0, np.int64)
        k = min(K_NEAREST, self._tree.n)
        dist, idx = self._tree.query(p, k=k, workers=query_workers(n))
        dist, idx = np.asarray(dist).reshape(n, k), np.asarray(idx).reshape(n, k)
        best = _Best(n)
        best.upper = dist[:, 0] + max(UPPER_MARGIN_MM, self.tolerance)
        pairs = _unique_pairs(np.repeat(np.arange(n), k), self.face_ids[idx].ravel())
        bound, inside = self._brep.project(p, pairs, best)
        more = self._brep.nearer_boxes(p, np.minimum(best.dist, best.upper), pairs)
        if more.shape[0]:
            more_bound, more_inside = self._brep.project(p, more, best)
            pairs = np.concatenate([pairs, more])
            bound = np.concatenate([bound, more_bound])
            inside = np.concatenate([inside, more_inside])
        self._brep.settle(p, pairs, bound, inside, best)
        return self._brep.finish(p, best)


@dataclass
class _Best:
    """The nearest foot found so far, per point: distance, face id, and either the foot's (u, v)
    on the face's surface (``on_face``) or the foot found on the trimmed face with its support
    (an edge, a vertex or the face) for the boundary case."""

    n: int

    def __post_init__(self):
        self.dist = np.full(self.n, np.inf)
        self.face = np.zeros(self.n, np.int64)
        self.uv = np.zeros((self.n, 2))
        self.on_face = np.zeros(self.n, bool)
        self.foot = np.zeros((self.n, 3))
        self.upper = np.full(self.n, np.inf)
        self.support: dict[int, object] = {}


def _unique_pairs(points: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """(m, 2) int64 unique (point index, face id) pairs, sorted by point then face."""
    key = np.unique(points.astype(np.int64) * (1 << 32) + faces.astype(np.int64))
    return np.stack([key >> 32, key & ((1 << 32) - 1)], axis=1)


# ---------------------------------------------------------------------------------------- reading

def read_step(path: str | os.PathLike) -> StepNominal:
    """Read a STEP file (AP203/AP214/AP242) into a :class:`StepNominal` in millimetres.

    InputError (InputNotFoundError for a missing file) naming the file and the problem for an
    empty, oversized, damaged or non-STEP file, and for one that holds no face."""
    path = os.fspath(path)
    schema = check_step_file(path)
    _quiet_opencascade()
    reader, doc, warnings = _transfer(path)
    unit = _file_unit(reader)
    placed = _placed_faces(doc)
    if not placed:
        raise InputError("the STEP file holds no faces (no solid, shell or surface)", path)
    brep = _Brep(placed)
    bounds = brep.bounds()
    if not np.isfinite(bounds).all() or np.abs(bounds).max() > COORD_LIMIT_MM:
        raise InputError("the model lies beyond ±1e9 mm (1000 km); it is not a part", path)
    deflection = deflection_for(float(np.linalg.norm(bounds[1] - bounds[0])))
    points, normals, triangles, face_ids = brep.tessellate(deflection)
    if points.shape[0] < 3 or triangles.shape[0] == 0:
        raise InputError("OpenCascade could not tessellate the model's faces", path)
    ps = PointSet(points, normals=normals, triangles=triangles, path=path)
    faces = tuple(brep.face_record(i) for i in range(1, brep.n + 1))
    return StepNominal(path, schema, unit, _mm_per_unit(unit), faces, ps, face_ids, deflection,
                       bounds, brep, tuple(warnings))


def deflection_for(diagonal_mm: float) -> float:
    """The tessellation's chordal deflection (mm) for a model of this bounding-box diagonal:
    2.5e-5 of it, between ``MIN_DEFLECTION_MM`` (1 µm) and ``MAX_DEFLECTION_MM`` (10 µm) — well
    below any profile zone; registration needs no finer, and the deviations do not use it."""
    return float(min(MAX_DEFLECTION_MM, max(MIN_DEFLECTION_MM, 2.5e-5 * diagonal_mm)))


def check_step_file(path: str) -> str:
    """Check a file's ISO 10303-21 structure before OpenCascade reads it; return its schema.

    InputError naming the file: missing, a folder, empty, over ``MAX_BYTES``, binary, not
    beginning with ``ISO-10303-21;``, without a HEADER or DATA section, or not ending with
    ``END-ISO-10303-21;`` (truncated)."""
    if not os.path.exists(path):
        raise InputNotFoundError("no such file", path)
    if not os.path.isfile(path):
        raise InputError("is a folder, not a file", path)
    size = os.path.getsize(path)
    if size == 0:
        raise InputError("the STEP file is empty", path)
    if size > MAX_BYTES:
        raise InputError(f"the STEP file is {size / 2**20:.0f} MiB; the largest read is "
                         f"{MAX_BYTES >> 20} MiB", path)
    try:
        with open(path, "rb") as f:
            head = f.read(_HEAD_BYTES)
            f.seek(max(0, size - 4096))
            tail = f.read()
    except OSError as e:
        raise InputError(f"cannot be read ({e.strerror})", path) from e
    if b"\x00" in head or b"\x00" in tail:
        raise InputError("is binary, not a STEP file (ISO 10303-21 text)", path)
    text = head.decode("latin-1").lstrip("\ufeff\xef\xbb\xbf \t\r\n")
    if not text.upper().startswith("ISO-10303-21;"):
        raise InputError("is not a STEP file: it does not begin with 'ISO-10303-21;'", path)
    upper = text.upper()
    h, d = upper.find("HEADER;"), upper.find("DATA;")
    if h < 0 or upper.find("ENDSEC;", h) < 0:
        raise InputError("is not a STEP file: it has no HEADER; ... ENDSEC; section", path)
    if d < 0 and size <= _HEAD_BYTES:
        raise InputError("the STEP file has no DATA; section (a header only)", path)
    if d >= 0 and upper[d + 5:].lstrip().startswith("ENDSEC;"):
        raise InputError("the STEP file's DATA section is empty (a header only)", path)
    if not tail.decode("latin-1").rstrip().upper().endswith(_END):
        raise InputError(f"the STEP file is truncated or damaged: it does not end with '{_END}'",
                         path)
    m = _SCHEMA_RE.search(text)
    return m.group(1).strip() if m else ""


def _quiet_opencascade() -> None:
    """OpenCascade's messages (transfer statistics, parse errors) go to stdout, which may be
    the JSON a user pipes on: remove its console printers (once; the errors are read from the
    model's checks instead)."""
    from OCP.Message import Message, Message_PrinterOStream
    Message.DefaultMessenger_s().RemovePrinters(Message_PrinterOStream.get_type_descriptor_s())


def _transfer(path: str):
    """Read and translate the file into an XDE document; (reader, document, warnings about
    damaged entities the shape does not use). InputError when OpenCascade cannot read it, finds
    an entity the shape uses damaged, or translates no shape."""
    from OCP.IFSelect import IFSelect_RetDone
    from OCP.Interface import Interface_Static
    from OCP.STEPCAFControl import STEPCAFControl_Reader
    from OCP.TCollection import TCollection_ExtendedString
    from OCP.TDocStd import TDocStd_Document
    from OCP.XCAFDoc import XCAFDoc_ShapeTool

    reader = STEPCAFControl_Reader()
    # The reader's construction registers these settings (with defaults): set them after it.
    Interface_Static.SetIVal_s("read.stepcaf.subshapes.name", 1)
    Interface_Static.SetCVal_s("xstep.cascade.unit", "MM")
    reader.SetNameMode(True)
    for mode in (reader.SetColorMode, reader.SetLayerMode, reader.SetGDTMode, reader.SetMatMode,
                 reader.SetPropsMode, reader.SetViewMode):
        mode(False)
    # Before OpenCascade parses it: its parser follows some references (an oriented edge's
    # vertices) and dies on a cycle of them.
    instances, directions = _instances(path)
    reached = _check_references(instances, path)
    _check_directions(directions, reached, path)
    try:
        status = reader.ReadFile(path)
    except Exception as e:  # OpenCascade's Standard_Failure
        raise InputError(f"OpenCascade could not read the STEP file ({e})", path) from e
    if status != IFSelect_RetDone:
        raise InputError(f"OpenCascade could not read the STEP file ({status.name})", path)
    warnings = _check_model(reader.Reader(), path, instances, reached)
    doc = TDocStd_Document(TCollection_ExtendedString("XmlXCAF"))
    XCAFDoc_ShapeTool.SetAutoNaming_s(False)  # else unnamed solids are called 'SOLID'
    try:
        ok = reader.Transfer(doc)
    except Exception as e:
        raise InputError(f"OpenCascade could not translate the STEP file ({e})", path) from e
    if not ok:
        raise InputError("the STEP file holds no shape OpenCascade can translate", path)
    return reader, doc, warnings


def _check_model(step_reader, path: str, instances: list, reached: set[int]) -> list[str]:
    """Refuse a model whose parse reported errors (syntax, unresolved references) or whose
    entities that the B-rep uses (:func:`_used_entity_numbers` of the file's ``instances``
    and the #ids ``reached`` from its roots) failed their checks, naming the first and the
    count; return warnings for the damaged entities it does not use (PMI, presentation,
    properties: OpenCascade reads the shape without them)."""
    model = step_reader.StepModel()
    glob = model.GlobalCheck(True)
    if glob.NbFails():
        raise InputError(f"the STEP file is damaged: {glob.NbFails()} error(s), the first: "
                         f"{glob.CFail(1, True)}", path)
    checks = step_reader.WS().ModelCheckList(False)
    bad, unused = [], []
    used = None
    checks.Start()
    while checks.More():
        c, num = checks.Value(), checks.Number()
        if c.NbFails() and num > 0:
            if used is None:
                used = _used_entity_numbers(instances, reached, model.NbEntities())
            entity = model.Value(num)
            keyword = _keyword(entity)
            what = f"entity {num} of the DATA section, a {keyword}: {c.CFail(1, True)}"
            if used is not False and num not in used and _same_kind(used, num, keyword):
                unused.append(what)
            elif used is False and \
                    type(entity).__module__.rsplit(".", 1)[-1] not in _SHAPE_PACKAGES:
                unused.append(what)
            else:
                bad.append(what)
        checks.Next()
    if bad:
        raise InputError(f"the STEP file is damaged: {len(bad)} shape entit"
                         f"{'y is' if len(bad) == 1 else 'ies are'} wrong, the first: {bad[0]}",
                         path)
    if not unused:
        return []
    return [f"{len(unused)} entit{'y' if len(unused) == 1 else 'ies'} the shape does not use "
            f"(PMI, presentation or properties) failed OpenCascade's checks and were ignored; "
            f"the first: {unused[0]}"]


def _keyword(entity) -> str:
    """The STEP keyword of an OpenCascade entity class (StepRepr_IntegerRepresentationItem ->
    INTEGER_REPRESENTATION_ITEM)."""
    return re.sub(r"(?<!^)(?=[A-Z])", "_", type(entity).__name__.split("_", 1)[-1]).upper()


_STRING_RE = re.compile(r"'(?:[^']|'')*'")
_INSTANCE_RE = re.compile(r"\s*#(\d+)\s*=\s*(.*)", re.S)
_REF_RE = re.compile(r"#(\d+)")
_KEYWORD_RE = re.compile(r"([A-Z_][A-Z0-9_]*)\s*\(")
_DIRECTION_RE = re.compile(r"\s*DIRECTION\s*\(\s*''\s*,\s*\(([^()]*)\)\s*\)\s*$", re.I)
BREP_ROOTS = frozenset({
    # the product structure OpenCascade's translation walks …
    "SHAPE_DEFINITION_REPRESENTATION", "SHAPE_REPRESENTATION_RELATIONSHIP",
    "CONTEXT_DEPENDENT_SHAPE_REPRESENTATION", "NEXT_ASSEMBLY_USAGE_OCCURRENCE",
    # … and the shape representations and topological items it translates
    "ADVANCED_BREP_SHAPE_REPRESENTATION", "MANIFOLD_SURFACE_SHAPE_REPRESENTATION",
    "FACETED_BREP_SHAPE_REPRESENTATION", "MANIFOLD_SOLID_BREP", "BREP_WITH_VOIDS",
    "SHELL_BASED_SURFACE_MODEL", "FACETED_BREP", "CLOSED_SHELL", "OPEN_SHELL", "ADVANCED_FACE"})
"""Entities whose references, followed to the end, are everything the B-rep is made of: its
topology, geometry, placements, representation contexts and units, and the assembly's
products, occurrences and transformations. PMI, presentation and property entities refer to
the B-rep, never the other way round, so they are not reached."""


def _instances(path: str) -> tuple[list[tuple[int, list[int], set[str]]], dict[int, str]]:
    """The DATA section's entity instances in file order: (#id, the #ids it refers to, its
    keywords; a complex instance has several); and the direction ratios of every DIRECTION
    (#id -> its list as written, e.g. '0.,0.,1.'). Strings are blanked first (they may hold
    '#', ';' or parentheses)."""
    with open(path, "rb") as f:
        text = f.read().decode("latin-1")
    data = text.upper().find("DATA;")
    body = _STRING_RE.sub("''", text[data + 5:] if data >= 0 else "")
    out, directions = [], {}
    for statement in body.split(";"):
        m = _INSTANCE_RE.match(statement)
        if m:
            rest = m.group(2)
            out.append((int(m.group(1)), [int(r) for r in _REF_RE.findall(rest)],
                        set(_KEYWORD_RE.findall(rest.upper()))))
            d = _DIRECTION_RE.match(rest)
            if d:
                directions[out[-1][0]] = re.sub(r"\s+", "", d.group(1))
    return out, directions


def _check_directions(directions: dict[int, str], reached: set[int], path: str) -> None:
    """InputError naming the first DIRECTION the B-rep uses (``reached``) whose direction ratios
    are all zero: it points nowhere, and OpenCascade's translation of it gives no error but a
    shape without extent (its bounding box not a number, which read as "the model lies beyond
    ±1e9 mm"). Ratios that are not numbers are left to OpenCascade's own check."""
    zero = []
    for eid in sorted(directions.keys() & reached):
        try:
            ratios = [float(v) for v in directions[eid].split(",")]
        except ValueError:
            continue
        if not any(ratios):
            zero.append(eid)
    if zero:
        also = ", ".join(f"#{e}" for e in zero[1:CYCLE_SHOWN + 1])
        also += ", …" if len(zero) > CYCLE_SHOWN + 1 else ""
        also = f", and so {'does' if len(zero) == 2 else 'do'} {also}" if also else ""
        raise InputError(f"the STEP file is damaged: entity #{zero[0]}, a DIRECTION, has length "
                         f"0 (direction ratios ({directions[zero[0]]})){also}: a direction must "
                         "point somewhere", path)


NOT_OF_ITS_OWN_KIND = frozenset({"ORIENTED_EDGE", "ORIENTED_FACE", "ORIENTED_CLOSED_SHELL",
                                 "ORIENTED_OPEN_SHELL", "ORIENTED_PATH"})
"""Entities whose one referenced entity (the edge, face, shell or path they orient) must not be
of their own kind (the topology schema's WHERE rules): OpenCascade checks that a reference is of
the declared type (an edge), and an oriented edge is one, but not these rules."""
CYCLE_SHOWN = 8
"""Entities of a reference cycle named in its refusal at most."""


def _check_references(instances: list[tuple[int, list[int], set[str]]], path: str) -> set[int]:
    """The #ids of the entities the B-rep uses (reached from ``BREP_ROOTS``, :func:`_reach`).

    InputError naming the entities when they refer to each other in a cycle (an oriented edge
    of itself, two of each other, a curve trimmed from itself …: OpenCascade's translation
    follows the references until its stack overflows and the process dies), or when an entity
    of ``NOT_OF_ITS_OWN_KIND`` refers to another of its kind."""
    refs = {eid: r for eid, r, _ in instances}
    kinds = {eid: kw for eid, _, kw in instances}
    reached, cycle = _reach(refs, [eid for eid, _, kw in instances if kw & BREP_ROOTS])
    if cycle is not None:
        first = cycle[0]
        if len(cycle) == 2:
            how = "refers to itself"
        else:
            loop = [f"#{e} {_kind(kinds[e])}" for e in cycle[:-1]]
            if len(loop) > CYCLE_SHOWN:
                loop = loop[:CYCLE_SHOWN] + [f"… ({len(loop) - CYCLE_SHOWN} more)"]
            how = f"refers back to itself through {' -> '.join(loop)} -> #{first}"
        raise InputError(f"the STEP file is damaged: entity #{first}, {_a(kinds[first])}, {how} "
                         "(the entities of a shape must not refer to each other in a cycle)",
                         path)
    for eid in sorted(reached):
        own = kinds[eid] & NOT_OF_ITS_OWN_KIND
        for r in refs[eid]:
            if own & kinds.get(r, set()):
                kind = _kind(own)
                raise InputError(f"the STEP file is damaged: entity #{eid}, {_a(own)}, refers "
                                 f"to #{r}, another {kind}, as the element it orients (an "
                                 f"{kind} must orient one that is not oriented)", path)
    return reached


def _reach(refs: dict[int, list[int]], roots: list[int]) -> tuple[set[int], list[int] | None]:
    """The #ids reached from ``roots`` by following ``refs`` (#id -> the #ids it refers to;
    references to ids not in it are left to the model's own check), and the first reference
    cycle met ([#a, #b, …, #a]; None when there is none). Depth first, iterative: no recursion
    limit to hit however deep the file's references go."""
    state: dict[int, bool] = {}  # True while on the path being walked, False once done
    for root in roots:
        if root in state or root not in refs:
            continue
        state[root] = True
        path, todo = [root], [iter(refs[root])]
        while todo:
            nxt = next(todo[-1], None)
            if nxt is None:
                state[path.pop()] = False
                todo.pop()
            elif nxt in refs and nxt not in state:
                state[nxt] = True
                path.append(nxt)
                todo.append(iter(refs[nxt]))
            elif state.get(nxt):
                return set(state), path[path.index(nxt):] + [nxt]
    return set(state), None


def _kind(keywords: set[str]) -> str:
    """An instance's keyword(s) in words (a complex instance's joined by '+')."""
    return "+".join(sorted(keywords)) or "entity"


def _a(keywords: set[str]) -> str:
    kind = _kind(keywords)
    return ("an " if kind[0] in "AEIOU" else "a ") + kind


def _used_entity_numbers(instances: list[tuple[int, list[int], set[str]]], reached: set[int],
                         n_entities: int):
    """The model numbers (1..N, file order, as OpenCascade numbers them) of the entities the
    B-rep uses (the #ids ``reached`` from ``BREP_ROOTS``), as a :class:`_Used` that also knows
    each number's keywords; False when the file's ``instances`` cannot be matched one to one
    with OpenCascade's."""
    if len(instances) != n_entities:
        return False
    number = {eid: k + 1 for k, (eid, _, _) in enumerate(instances)}
    used = {number[e] for e in reached}
    return _Used(used, {k + 1: kw for k, (_, _, kw) in enumerate(instances)})


class _Used(set):
    """A set of model numbers, with each number's keywords (``keywords[num]``)."""

    def __init__(self, numbers, keywords: dict):
        super().__init__(numbers)
        self.keywords = keywords


def _same_kind(used: "_Used", num: int, keyword: str) -> bool:
    """Whether the file's instance at model number ``num`` is of OpenCascade's entity's kind:
    the check that the two numberings agree before an entity is let pass as unused."""
    return keyword in used.keywords.get(num, ())


def _file_unit(reader) -> str:
    """The file's length unit(s) as it names them ('millimetre', 'INCH' …), '' when none."""
    from OCP.collections import Sequence_TCollection_AsciiString as Names
    lengths, angles, solid_angles = Names(), Names(), Names()
    reader.Reader().FileUnits(lengths, angles, solid_angles)
    names = []
    for i in range(1, lengths.Length() + 1):
        name = lengths.Value(i).ToCString()
        if name not in names:
            names.append(name)
    return ", ".join(names)


def _mm_per_unit(unit: str) -> float | None:
    """Millimetres per the file's unit, from its name (SI prefix + metre, or inch, foot …)."""
    name = unit.strip().lower()
    if name in _CONVERSION_UNITS:
        return _CONVERSION_UNITS[name]
    for spelling in ("metre", "meter"):
        if name.endswith(spelling) and name[: -len(spelling)] in _SI_PREFIX:
            return _SI_PREFIX[name[: -len(spelling)]]
    return None


# ------------------------------------------------------------------------------------ assemblies

def _placed_faces(doc) -> list[tuple]:
    """Every face of every placed instance in the document, in reading order:
    (face moved to its place, its name or None, its part's name or None)."""
    from OCP.collections import Sequence_TDF_Label
    from OCP.TopLoc import TopLoc_Location
    from OCP.XCAFDoc import XCAFDoc_DocumentTool

    tool = XCAFDoc_DocumentTool.ShapeTool_s(doc.Main())
    labels = Sequence_TDF_Label()
    tool.GetFreeShapes(labels)
    out: list[tuple] = []
    for i in range(1, labels.Length() + 1):
        _walk(tool, labels.Value(i), TopLoc_Location(), None, out, 0)
    return out


def _walk(tool, label, loc, named: str | None, out: list, depth: int) -> None:
    """Collect the faces under an XDE label: a reference (an instance) adds its placement to
    ``loc``, an assembly recurses into its components, a part adds its faces. ``named`` is the
    nearest name above (the instance's, else its assembly's): a part without a name of its own
    takes it."""
    from OCP.collections import Sequence_TDF_Label
    from OCP.TDF import TDF_Label

    if depth > 64:
        return  # an assembly nested this deep is a cycle, not a product structure
    if tool.IsReference_s(label):
        ref = TDF_Label()
        tool.GetReferredShape_s(label, ref)
        _walk(tool, ref, loc.Multiplied(tool.GetLocation_s(label)),
              _label_name(label) or named, out, depth + 1)
    elif tool.IsAssembly_s(label):
        components = Sequence_TDF_Label()
        tool.GetComponents_s(label, components, False)
        for i in range(1, components.Length() + 1):
            _walk(tool, components.Value(i), loc, _label_name(label) or named, out, depth + 1)
    else:
        _part_faces(tool, label, loc, _label_name(label) or named, out)


def _label_name(label) -> str | None:
    from OCP.TDataStd import TDataStd_Name
    attr = TDataStd_Name()
    # FindAttribute on a label without the attribute can crash the process: ask IsAttribute.
    if not label.IsAttribute(TDataStd_Name.GetID_s()) or \
            not label.FindAttribute(TDataStd_Name.GetID_s(), attr):
        return None
    name = attr.Get().ToExtString().strip()
    return None if name.upper() in _NO_NAMES else name


def _part_faces(tool, label, loc, part: str | None, out: list) -> None:
    """Append a part's faces (deduplicated, in exploration order) moved by ``loc``, each with its
    own name and the name of the named solid/shell holding it (else the part's)."""
    from OCP.collections import IndexedMap_TopoDS_Shape_TopTools_ShapeMapHasher as ShapeMap
    from OCP.collections import Sequence_TDF_Label
    from OCP.TopAbs import TopAbs_FACE, TopAbs_SHELL, TopAbs_SOLID
    from OCP.TopExp import TopExp
    from OCP.TopoDS import TopoDS

    face_names, face_named = ShapeMap(), []
    body_names, body_named = ShapeMap(), []
    subs = Sequence_TDF_Label()
    tool.GetSubShapes_s(label, subs)
    for i in range(1, subs.Length() + 1):
        name = _label_name(subs.Value(i))
        sub = tool.GetShape_s(subs.Value(i))
        if name is None or sub.IsNull():
            continue
        if sub.ShapeType() == TopAbs_FACE and face_names.Add(sub) > len(face_named):
            face_named.append(name)
        elif sub.ShapeType() in (TopAbs_SOLID, TopAbs_SHELL):
            inner = ShapeMap()
            TopExp.MapShapes_s(sub, TopAbs_FACE, inner)
            for j in range(1, inner.Size() + 1):
                if body_names.Add(inner.FindKey(j)) > len(body_named):
                    body_named.append(name)
    faces = ShapeMap()
    TopExp.MapShapes_s(tool.GetShape_s(label), TopAbs_FACE, faces)
    for i in range(1, faces.Size() + 1):
        f = faces.FindKey(i)
        k, b = face_names.FindIndex(f), body_names.FindIndex(f)
        out.append((TopoDS.Face(f.Moved(loc)), face_named[k - 1] if k else None,
                    body_named[b - 1] if b else part))


# ------------------------------------------------------------------------------------ the B-rep

_SURFACE_KINDS = {"Plane": "plane", "Cylinder": "cylinder", "Cone": "cone", "Sphere": "sphere",
                  "Torus": "torus", "BSplineSurface": "bspline", "BezierSurface": "bezier",
                  "SurfaceOfRevolution": "revolution", "SurfaceOfExtrusion": "extrusion",
                  "OffsetSurface": "offset"}


class _Elementary:
    """Nearest points on an elementary surface — plane, cylinder, cone, sphere or torus —
    unbounded, in closed form and vectorised, in OpenCascade's parametrisation (so that the
    face's trim, drawn in that (u, v), classifies them). The nearest point of the unbounded
    surface is its global minimum of distance: on the face it is the face's nearest point, off
    the face its distance bounds the face's from below."""

    KINDS = ("Plane", "Cylinder", "Cone", "Sphere", "Torus")
    PARAMETERS = ("o", "x", "y", "z", "R", "r", "alpha")

    def __init__(self, kind: str, adaptor):
        surface = getattr(adaptor, kind)()
        ax3 = surface.Position()
        self.kind = kind
        self.o = np.array(ax3.Location().Coord())
        self.x, self.y, self.z = (np.array(d.Coord()) for d in
                                  (ax3.XDirection(), ax3.YDirection(), ax3.Direction()))
        self.R = {"Plane": 0.0, "Cylinder": getattr(surface, "Radius", lambda: 0.0)(),
                  "Cone": getattr(surface, "RefRadius", lambda: 0.0)(),
                  "Sphere": getattr(surface, "Radius", lambda: 0.0)(),
                  "Torus": getattr(surface, "MajorRadius", lambda: 0.0)()}[kind]
        self.r = surface.MinorRadius() if kind == "Torus" else 0.0
        self.alpha = surface.SemiAngle() if kind == "Cone" else 0.0

    @classmethod
    def of(cls, adaptor) -> "_Elementary | None":
        kind = adaptor.GetType().name.removeprefix("GeomAbs_")
        if kind not in cls.KINDS:
            return None
        e = cls(kind, adaptor)
        return None if kind == "Torus" and e.r >= e.R else e  # a spindle torus: the general way

    @classmethod
    def stack(cls, surfaces: list["_Elementary"]) -> "_Elementary":
        """Surfaces of one kind as rows: each parameter an array over them (see :meth:`take`)."""
        s = object.__new__(cls)
        s.kind = surfaces[0].kind
        for name in cls.PARAMETERS:
            setattr(s, name, np.array([getattr(e, name) for e in surfaces], float))
        return s

    def take(self, rows: np.ndarray) -> "_Elementary":
        """Of stacked surfaces (:meth:`stack`), one per point: ``rows`` (m,) indices into them;
        :meth:`nearest` then projects the i-th point on the i-th surface."""
        s = object.__new__(type(self))
        s.kind = self.kind
        for name in self.PARAMETERS:
            setattr(s, name, getattr(self, name)[rows])
        return s

    def nearest(self, p: np.ndarray):
        """For points p (m, 3): distance (m,), u (m,), v (m,), foot (m, 3) and the surface's
        unit normal there (m, 3; the parametrisation's, before the face's orientation). The
        surface is one, or one per point (:meth:`take`)."""
        w = p - self.o
        lx, ly, lz = _rows_dot(w, self.x), _rows_dot(w, self.y), _rows_dot(w, self.z)
        if self.kind == "Plane":
            n = np.broadcast_to(np.cross(self.x, self.y), p.shape)
            h = _rows_dot(w, n)
            return np.abs(h), lx, ly, p - h[:, None] * n, n.copy()
        u = np.arctan2(ly, lx)
        rho = np.hypot(lx, ly)
        if self.kind == "Cylinder":
            v, radius, height = lz, np.broadcast_to(self.R, lz.shape), lz
            d = np.abs(rho - self.R)
        elif self.kind == "Sphere":
            v = np.arctan2(lz, rho)
            radius, height = self.R * np.cos(v), self.R * np.sin(v)
            d = np.abs(np.hypot(rho, lz) - self.R)
        elif self.kind == "Torus":
            v = np.arctan2(lz, rho - self.R)
            radius, height = self.R + self.r * np.cos(v), self.r * np.sin(v)
            d = np.abs(np.hypot(rho - self.R, lz) - self.r)
        else:
            u, v, d, radius, height = self._cone(u, rho, lz)
        e = np.cos(u)[:, None] * self.x + np.sin(u)[:, None] * self.y
        foot = self.o + radius[:, None] * e + height[:, None] * self.z
        return d, u, v, foot, self._normal(u, v, e, radius)

    def _cone(self, u, rho, lz):
        """The double cone's nearest generatrix in the meridian plane of each point: the one on
        the point's side (u) or the opposite one (u + pi), whichever is nearer."""
        sa, ca = np.sin(self.alpha), np.cos(self.alpha)
        d_near = np.abs((rho - self.R) * ca - lz * sa)
        d_far = np.abs((rho + self.R) * ca + lz * sa)
        near = d_near <= d_far
        v = np.where(near, (rho - self.R) * sa + lz * ca, lz * ca - (rho + self.R) * sa)
        u = np.where(near, u, u + np.pi)
        return u, v, np.minimum(d_near, d_far), self.R + v * sa, v * ca

    def _normal(self, u, v, e, radius):
        """D1U x D1V, normalised (its positive factors left out, so it is defined at poles)."""
        tangent_u = -np.sin(u)[:, None] * self.x + np.cos(u)[:, None] * self.y
        if self.kind == "Cylinder":
            dv = np.broadcast_to(self.z, tangent_u.shape)
        elif self.kind == "Cone":
            sa, ca = np.sin(self.alpha)[..., None], np.cos(self.alpha)[..., None]
            dv = sa * e + ca * self.z
            tangent_u = tangent_u * np.where(radius < 0, -1.0, 1.0)[:, None]
        else:  # sphere, torus: d/dv of (cos v e + sin v z), up to the radius
            dv = -np.sin(v)[:, None] * e + np.cos(v)[:, None] * self.z
        n = np.cross(tangent_u, dv)
        return n / np.linalg.norm(n, axis=1, keepdims=True)


class _FaceTools:
    """What the exact distance needs of one face, made once and reused for every point: its
    (located) surface, the closed form of an elementary surface or else a projector over the
    face's (u, v) box, the classifier of its trimmed domain, its surface properties and a
    shape-to-shape distance with it loaded."""

    def __init__(self, face):
        from OCP.BRep import BRep_Tool
        from OCP.BRepTools import BRepTools
        from OCP.GeomAdaptor import GeomAdaptor_Surface
        from OCP.GeomAPI import GeomAPI_ProjectPointOnSurf
        from OCP.GeomLProp import GeomLProp_SLProps
        from OCP.IntTools import IntTools_FClass2d
        from OCP.TopAbs import TopAbs_REVERSED

        self.face = face
        self.reversed = face.Orientation() == TopAbs_REVERSED
        self.surface = BRep_Tool.Surface_s(face)
        self.uv_box = BRepTools.UVBounds_s(face)
        self.elementary = _Elementary.of(GeomAdaptor_Surface(self.surface))
        self.periods = (self.surface.UPeriod() if self.surface.IsUPeriodic() else 0.0,
                        self.surface.VPeriod() if self.surface.IsVPeriodic() else 0.0)
        self.projector = GeomAPI_ProjectPointOnSurf()
        self.projector.Init(self.surface, *self.uv_box)
        self.classifier = IntTools_FClass2d(face, max(BRep_Tool.Tolerance_s(face), 1e-7))
        self.props = GeomLProp_SLProps(self.surface, 1, 1e-12)
        self._distance = None

    def normal(self, u: float, v: float) -> np.ndarray | None:
        """The outward unit normal at (u, v), or None where the surface has none (a pole)."""
        self.props.SetParameters(u, v)
        if not self.props.IsNormalDefined():
            return None
        n = np.array(self.props.Normal().Coord())
        return -n if self.reversed else n

    def point(self, u: float, v: float) -> np.ndarray:
        return np.array(self.surface.Value(u, v).Coord())

    def project(self, pts: np.ndarray):
        """The nearest points of the face's surface to pts (m, 3), for the face's trim to judge:
        (distance, (u, v), found, bound). ``found``: the foot lies in the face's (u, v) box,
        at ``distance``; ``bound``: a lower bound of the distance to the trimmed face (an
        elementary surface's unbounded distance; NaN when there is none but the face's
        bounding box)."""
        if self.elementary is None:
            return self._project_general(pts)
        d, u, v, _, _ = self.elementary.nearest(pts)
        uv, found = _in_box(u, v, np.asarray(self.uv_box, float), np.asarray(self.periods))
        return d, uv, found, d

    def _project_general(self, pts: np.ndarray):
        """OpenCascade's extrema over the face's (u, v) box, one point at a time: the nearest
        point of the surface over the box (its search takes the box's edges in), so on the
        face it is the face's nearest point."""
        from OCP.gp import gp_Pnt

        m = pts.shape[0]
        d, uv, found = np.full(m, np.nan), np.zeros((m, 2)), np.zeros(m, bool)
        proj = self.projector
        for j, (x, y, z) in enumerate(pts.tolist()):
            try:
                proj.Perform(gp_Pnt(x, y, z))
                if proj.IsDone() and proj.NbPoints():
                    d[j], uv[j] = proj.LowerDistance(), proj.LowerDistanceParameters()
                    found[j] = True
            except Exception:  # OpenCascade's StdFail: leave the point to the exact path
                found[j] = False
        return d, uv, found, np.full(m, np.nan)

    def at(self, pts: np.ndarray, uv: np.ndarray):
        """The feet at (u, v) of points pts (m, 3) whose nearest point lies inside the face:
        (feet (m, 3), outward unit normals (m, 3); NaN where the surface has none)."""
        if self.elementary is not None:
            _, _, _, foot, n = self.elementary.nearest(pts)
            return foot, -n if self.reversed else n
        foot, normal = np.zeros((len(pts), 3)), np.full((len(pts), 3), np.nan)
        for j, (u, v) in enumerate(uv.tolist()):
            foot[j] = self.point(u, v)
            n = self.normal(u, v)
            if n is not None:
                normal[j] = n
        return foot, normal

    @functools.cached_property
    def trim(self) -> tuple[np.ndarray, float] | None:
        """The face's trim polylines and band (:meth:`_trim_polylines`), drawn on first use."""
        return self._trim_polylines()

    def _trim_polylines(self) -> tuple[np.ndarray, float] | None:
        """The face's boundary in its (u, v) domain: (segments (E, 4) u0 v0 u1 v1 of the
        polylines of every edge's curve on the surface, within TRIM_DEFLECTION of it; the band
        within which the polylines do not decide), or None when a curve is missing, the
        polylines do not close, or they classify a check point unlike OpenCascade."""
        from OCP.BRepAdaptor import BRepAdaptor_Curve2d
        from OCP.GCPnts import GCPnts_UniformDeflection
        from OCP.TopAbs import TopAbs_EDGE
        from OCP.TopExp import TopExp_Explorer
        from OCP.TopoDS import TopoDS

        from engine.kernels import in_polygon

        u0, u1, v0, v1 = self.uv_box
        deflection = TRIM_DEFLECTION * float(np.hypot(u1 - u0, v1 - v0))
        if not deflection > 0:
            return None
        lines = []
        try:
            explorer = TopExp_Explorer(self.face, TopAbs_EDGE)
            while explorer.More():
                curve = BRepAdaptor_Curve2d(TopoDS.Edge(explorer.Current()), self.face)
                cut = GCPnts_UniformDeflection(curve, deflection, curve.FirstParameter(),
                                               curve.LastParameter())
                if not cut.IsDone() or cut.NbPoints() < 2:
                    return None
                lines.append(np.array([curve.Value(cut.Parameter(i)).Coord()
                                       for i in range(1, cut.NbPoints() + 1)]))
                explorer.Next()
        except Exception:  # a missing curve on the surface, OpenCascade's Standard_Failure
            return None
        band = TRIM_BAND * deflection
        lines = _joined(lines, band) if lines else None
        if lines is None:
            return None
        segments = np.concatenate([np.hstack([p[:-1], p[1:]]) for p in lines])
        rng = np.random.default_rng(3)
        check = np.column_stack([rng.uniform(u0, u1, TRIM_CHECKS),
                                 rng.uniform(v0, v1, TRIM_CHECKS)])
        inside, near = in_polygon(check, segments, band)
        if (inside != self._classify(check))[~near].any():
            return None
        return segments, band

    def _classify(self, uv: np.ndarray) -> np.ndarray:
        """OpenCascade's classification of (u, v) points (m, 2): IN or ON the trimmed face."""
        from OCP.gp import gp_Pnt2d
        from OCP.TopAbs import TopAbs_IN, TopAbs_ON

        cls = self.classifier
        out = np.zeros(uv.shape[0], bool)
        for j, (u, v) in enumerate(uv.tolist()):
            try:
                out[j] = cls.Perform(gp_Pnt2d(u, v), True) in (TopAbs_IN, TopAbs_ON)
            except Exception:
                out[j] = False
        return out

    def nearest_on_face(self, xyz) -> tuple[float, np.ndarray, object] | None:
        """The nearest point of the trimmed face to xyz (BRepExtrema_DistShapeShape): distance,
        foot and its support (the face, an edge or a vertex); None when OpenCascade finds
        none."""
        from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeVertex
        from OCP.BRepExtrema import BRepExtrema_DistShapeShape
        from OCP.gp import gp_Pnt

        if self._distance is None:
            self._distance = BRepExtrema_DistShapeShape()
            self._distance.LoadS2(self.face)
        dss = self._distance
        try:
            dss.LoadS1(BRepBuilderAPI_MakeVertex(gp_Pnt(*xyz)).Vertex())
            if not dss.Perform() or not dss.IsDone() or dss.NbSolution() == 0:
                return None
            return dss.Value(), np.array(dss.PointOnShape2(1).Coord()), dss.SupportOnShape2(1)
        except Exception:
            return None


class _Surfaces:
    """Every face's surface by face id, for projecting many points on many faces with one
    vectorised call per kind of elementary surface (a NIST part has up to 338 faces, and a
    call per face cost more than its arithmetic).

    kind (F + 1,) : index into ``_Elementary.KINDS``, -1 for a general surface (and id 0);
    row (F + 1,) : the face's row in ``stacks[kind]`` (:meth:`_Elementary.stack`);
    uv_box (F + 1, 4), periods (F + 1, 2), reversed (F + 1,) : as ``_FaceTools``'."""

    def __init__(self, tools: list[_FaceTools]):
        m = len(tools) + 1
        self.kind = np.full(m, -1, np.int64)
        self.row = np.zeros(m, np.int64)
        self.uv_box = np.zeros((m, 4))
        self.periods = np.zeros((m, 2))
        self.reversed = np.zeros(m, bool)
        groups: dict[int, list] = {}
        for fid, t in enumerate(tools, 1):
            self.uv_box[fid], self.periods[fid], self.reversed[fid] = t.uv_box, t.periods, \
                t.reversed
            if t.elementary is not None:
                k = _Elementary.KINDS.index(t.elementary.kind)
                group = groups.setdefault(k, [])
                self.kind[fid], self.row[fid] = k, len(group)
                group.append(t.elementary)
        self.stacks = {k: _Elementary.stack(g) for k, g in groups.items()}


class _Trims:
    """The faces' trim polylines (``_FaceTools.trim``) drawn so far, in one segment array:
    face id f's are ``segments[start[f]:stop[f]]`` within ``band[f]``; stop[f] -1: not drawn
    yet, -2: none (OpenCascade's classifier decides)."""

    def __init__(self, n_faces: int):
        self.start = np.zeros(n_faces + 1, np.int64)
        self.stop = np.full(n_faces + 1, -1, np.int64)
        self.band = np.zeros(n_faces + 1)
        self.segments = np.zeros((0, 4))

    def add(self, fids: np.ndarray, tools) -> None:
        """Draw the trims of the faces ``fids`` not drawn yet; tools(fid) -> _FaceTools."""
        new = [int(f) for f in fids if self.stop[f] == -1]
        if not new:
            return
        blocks, at = [self.segments], self.segments.shape[0]
        for f in new:
            trim = tools(f).trim
            if trim is None:
                self.stop[f] = -2
                continue
            segments, self.band[f] = trim
            self.start[f], self.stop[f] = at, at + segments.shape[0]
            at += segments.shape[0]
            blocks.append(segments)
        self.segments = np.ascontiguousarray(np.concatenate(blocks))


class _Brep:
    """The placed faces (id i is ``faces[i - 1]``), their names, tools, boxes and adjacency."""

    def __init__(self, placed: list[tuple]):
        from OCP.BRep import BRep_Builder
        from OCP.collections import IndexedMap_TopoDS_Shape_TopTools_ShapeMapHasher as ShapeMap
        from OCP.ShapeAnalysis import ShapeAnalysis_ShapeTolerance
        from OCP.TopoDS import TopoDS_Compound

        self.index = ShapeMap()
        self.faces, self.names, self.parts = [], [], []
        for face, name, part in placed:
            if self.index.Add(face) > len(self.faces):  # an instance placed twice on itself once
                self.faces.append(face)
                self.names.append(name)
                self.parts.append(part)
        self.n = len(self.faces)
        compound, builder = TopoDS_Compound(), BRep_Builder()
        builder.MakeCompound(compound)
        for face in self.faces:
            builder.Add(compound, face)
        self.compound = compound
        self.tolerance = ShapeAnalysis_ShapeTolerance().Tolerance(compound, 1)
        self._tools: dict[int, _FaceTools] = {}
        self._boxes: np.ndarray | None = None
        self._ancestors = None
        self.mesh: tuple = (np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0, np.int64))

    def tools(self, fid: int) -> _FaceTools:
        t = self._tools.get(fid)
        if t is None:
            t = self._tools[fid] = _FaceTools(self.faces[fid - 1])
        return t

    @functools.cached_property
    def surfaces(self) -> "_Surfaces":
        """The faces' elementary surfaces stacked by kind, for projections in bulk."""
        return _Surfaces([self.tools(fid) for fid in range(1, self.n + 1)])

    def boxes(self) -> np.ndarray:
        """(F, 2, 3) each face's bounding box from its exact geometry (BRepBndLib.AddOptimal),
        widened by 1e-6 mm so that it bounds the face for sure."""
        if self._boxes is None:
            from OCP.Bnd import Bnd_Box
            from OCP.BRepBndLib import BRepBndLib
            boxes = np.zeros((self.n, 2, 3))
            for i, face in enumerate(self.faces):
                box = Bnd_Box()
                BRepBndLib.AddOptimal_s(face, box, False, False)
                boxes[i] = box.CornerMin().Coord(), box.CornerMax().Coord()
            self._boxes = boxes + np.array([-1e-6, 1e-6])[None, :, None]
        return self._boxes

    def bounds(self) -> np.ndarray:
        b = self.boxes()
        return np.array([b[:, 0].min(axis=0), b[:, 1].max(axis=0)])

    def face_record(self, fid: int) -> StepFace:
        from OCP.BRepAdaptor import BRepAdaptor_Surface
        kind = BRepAdaptor_Surface(self.faces[fid - 1]).GetType().name.removeprefix("GeomAbs_")
        t = self.tools(fid)
        return StepFace(fid, self.names[fid - 1], self.parts[fid - 1],
                        _SURFACE_KINDS.get(kind, "other"), t.reversed, _geometry(t, kind))

    # ---------------------------------------------------------------- tessellation
    def tessellate(self, deflection: float):
        """Mesh every face; (points (n, 3), outward normals (n, 3), triangles (m, 3) with
        outward winding, face id (n,)), faces in id order."""
        from OCP.BRepMesh import BRepMesh_IncrementalMesh

        BRepMesh_IncrementalMesh(self.compound, deflection, False, ANGULAR_DEFLECTION, True)
        parts, offset = [], 0
        for fid in range(1, self.n + 1):
            mesh = self._face_mesh(fid)
            if mesh is None:
                continue
            pts, nrm, tri = mesh
            parts.append((pts, nrm, tri + offset, np.full(len(pts), fid, np.int64)))
            offset += len(pts)
        if not parts:
            parts = [(np.zeros((0, 3)), np.zeros((0, 3)), np.zeros((0, 3), np.int64),
                      np.zeros(0, np.int64))]
        points, normals, triangles, ids = (np.concatenate(a) for a in zip(*parts))
        self.mesh = points, normals, ids
        return points, normals, triangles, ids

    def _face_mesh(self, fid: int):
        """One face's mesh: nodes (deduplicated), outward normals from the surface at the
        nodes' (u, v), triangles wound outward; None for a face BRepMesh left empty."""
        from OCP.BRep import BRep_Tool
        from OCP.TopLoc import TopLoc_Location

        loc = TopLoc_Location()
        tri = BRep_Tool.Triangulation_s(self.faces[fid - 1], loc)
        if tri is None or tri.NbNodes() < 3 or tri.NbTriangles() == 0:
            return None
        trsf = loc.Transformation()
        nodes = range(1, tri.NbNodes() + 1)
        pts = np.array([tri.Node(i).Transformed(trsf).Coord() for i in nodes])
        uv = np.array([tri.UVNode(i).Coord() for i in nodes]) if tri.HasUVNodes() else None
        tris = np.array([tri.Triangle(i).Get() for i in range(1, tri.NbTriangles() + 1)],
                        np.int64) - 1
        t = self.tools(fid)
        if t.reversed:
            tris = tris[:, [0, 2, 1]]
        pts, first, inverse = np.unique(pts, axis=0, return_index=True, return_inverse=True)
        tris = inverse.reshape(-1)[tris]
        tris = tris[(tris[:, 0] != tris[:, 1]) & (tris[:, 1] != tris[:, 2])
                    & (tris[:, 0] != tris[:, 2])]
        normals = np.full((len(pts), 3), np.nan)
        if uv is not None:
            for i, (u, v) in enumerate(uv[first]):
                n = t.normal(u, v)
                if n is not None:
                    normals[i] = n
        _fill_normals_from_triangles(pts, tris, normals)
        return pts, normals, tris

    # ---------------------------------------------------------------- exact distance
    def project(self, p: np.ndarray, pairs: np.ndarray, best: _Best) -> tuple:
        """Project the points of the (point index, face id) ``pairs`` on their faces' surfaces
        and keep in ``best`` each point's nearest foot that lies on its trimmed face. Returns
        (bound, inside) per pair: ``bound`` is the distance to the untrimmed surface, exact
        where ``inside``, else a lower bound (the larger of it and the distance to the face's
        bounding box).

        Elementary surfaces are projected first, in bulk (``surfaces``); a general face (one
        projection at a time by OpenCascade's extrema, its projector reused) only where its
        bounding box is nearer than the best foot so far and the point's upper bound: elsewhere
        its box bounds it, for ``settle``. Feet are classified nearest first, per point, and
        only while nearer than the best: the costly classification of the others is skipped.
        (An elementary surface's distance bounds its face's from below; a general face whose
        foot falls outside it is bounded by its bounding box.)"""
        d, uv = np.full(len(pairs), np.inf), np.zeros((len(pairs), 2))
        found = np.zeros(len(pairs), bool)
        bound = _box_distance(self.boxes()[pairs[:, 1] - 1], p[pairs[:, 0]])
        table = self.surfaces
        kind = table.kind[pairs[:, 1]]
        for k in np.unique(kind[kind >= 0]):
            j = np.flatnonzero(kind == k)
            fid = pairs[j, 1]
            d[j], u, v, _, _ = table.stacks[k].take(table.row[fid]).nearest(p[pairs[j, 0]])
            uv[j], found[j] = _in_box(u, v, table.uv_box[fid], table.periods[fid])
        bound[kind >= 0] = np.fmax(bound[kind >= 0], d[kind >= 0])
        inside = np.zeros(len(pairs), bool)
        self._keep_nearest_inside(pairs, d, uv, found.copy(), inside, best)
        limit = np.minimum(best.dist, best.upper)
        general = np.flatnonzero((kind < 0) & (bound < limit[pairs[:, 0]] - TIE_MM))
        for fid, block in _by_face(pairs[general]):
            j = general[block]
            d[j], uv[j], found[j], _ = self.tools(fid).project(p[pairs[j, 0]])
        if general.size:
            pending = np.zeros(len(pairs), bool)
            pending[general] = found[general]
            self._keep_nearest_inside(pairs, d, uv, pending, inside, best)
        return np.where(inside, d, bound), inside

    def _keep_nearest_inside(self, pairs: np.ndarray, d: np.ndarray, uv: np.ndarray,
                             pending: np.ndarray, inside: np.ndarray, best: _Best) -> None:
        """Classify the ``pending`` pairs' feet (at distance ``d``, parameters ``uv``) nearest
        first per point, while nearer than the point's best; mark ``inside`` those on their
        trimmed face and keep the nearest in ``best``."""
        while pending.any():
            cand = np.flatnonzero(pending)
            cand = cand[np.lexsort((d[cand], pairs[cand, 0]))]
            cand = cand[np.unique(pairs[cand, 0], return_index=True)[1]]  # each point's nearest
            cand = cand[d[cand] < best.dist[pairs[cand, 0]] - TIE_MM]
            if cand.size == 0:
                break
            pending[cand] = False
            inside[cand] = self.contains(pairs[cand, 1], uv[cand])
            won = cand[inside[cand]]
            i = pairs[won, 0]
            best.dist[i], best.face[i], best.uv[i], best.on_face[i] = (d[won], pairs[won, 1],
                                                                       uv[won], True)

    def contains(self, fids: np.ndarray, uv: np.ndarray) -> np.ndarray:
        """Whether each (u, v) point (m, 2) lies on its trimmed face ``fids`` (m,) (IN or ON
        its boundary): by the face's trim polylines (``_FaceTools.trim``, every face's in one
        call) away from them, by OpenCascade's classifier near them (or for a face whose
        polylines could not be drawn). A periodic parameter is first moved into the face's
        domain, as OpenCascade's classifier takes it."""
        from engine.kernels import in_polygons

        out = np.zeros(len(fids), bool)
        if len(fids) == 0:
            return out
        trims = self.trims
        trims.add(np.unique(fids), self.tools)
        drawn = np.flatnonzero(trims.stop[fids] >= 0)
        f = fids[drawn]
        table = self.surfaces
        wrapped = np.column_stack([_in_period(uv[drawn, 0], table.periods[f, 0],
                                              table.uv_box[f, 0]),
                                   _in_period(uv[drawn, 1], table.periods[f, 1],
                                              table.uv_box[f, 2])])
        out[drawn], near = in_polygons(wrapped, trims.segments, trims.start[f], trims.stop[f],
                                       trims.band[f])
        ask = np.union1d(drawn[near], np.flatnonzero(trims.stop[fids] < 0))
        for fid, block in _by_face(np.column_stack([ask, fids[ask]])):
            out[ask[block]] = self.tools(fid)._classify(uv[ask[block]])
        return out

    @functools.cached_property
    def trims(self) -> "_Trims":
        return _Trims(self.n)

    def settle(self, p: np.ndarray, pairs: np.ndarray, bound: np.ndarray, inside: np.ndarray,
               best: _Best) -> None:
        """For the pairs whose foot fell outside the face and whose lower ``bound`` is below the
        point's best (and its upper bound), measure the trimmed face (nearest_on_face), each
        point's candidates in increasing order of their bound, while the bound stays below."""
        limit = np.minimum(best.dist, best.upper)
        out = np.flatnonzero(~inside & (bound < limit[pairs[:, 0]] - TIE_MM))
        for j in out[np.lexsort((bound[out], pairs[out, 0]))]:
            i, fid = int(pairs[j, 0]), int(pairs[j, 1])
            if bound[j] >= min(best.dist[i], best.upper[i]) - TIE_MM:
                continue
            found = self.tools(fid).nearest_on_face(p[i])
            if found is not None and found[0] < best.dist[i]:
                best.dist[i], best.face[i], best.foot[i], best.support[i] = found[0], fid, \
                    found[1], found[2]
                best.on_face[i] = False

    def nearer_boxes(self, p: np.ndarray, dist: np.ndarray, done: np.ndarray) -> np.ndarray:
        """(point index, face id) pairs not in ``done`` whose face's bounding box is nearer to
        the point than ``dist``: the faces that could still hold a nearer foot."""
        from engine.kernels import boxes_nearer

        done = done[np.argsort(done[:, 0], kind="stable")]
        start = np.searchsorted(done[:, 0], np.arange(p.shape[0] + 1))
        return boxes_nearer(p, self.boxes(), np.ascontiguousarray(dist, np.float64), start,
                            np.ascontiguousarray(done[:, 1]))

    def finish(self, p: np.ndarray, best: _Best):
        """(signed, foot, normal, face) from each point's nearest foot (see deviations)."""
        if (best.face == 0).any():
            raise NoDistanceError(np.flatnonzero(best.face == 0), p[best.face == 0],
                                  "OpenCascade found no distance to any face")
        foot, normal = np.array(best.foot), np.zeros_like(p)
        on = np.flatnonzero(best.on_face)
        table = self.surfaces
        kind = table.kind[best.face[on]]
        for k in np.unique(kind[kind >= 0]):
            i = on[kind == k]
            fid = best.face[i]
            _, _, _, foot[i], n = table.stacks[k].take(table.row[fid]).nearest(p[i])
            normal[i] = np.where(table.reversed[fid][:, None], -n, n)
        general = on[kind < 0]
        for fid, block in _by_face(np.column_stack([general, best.face[general]])):
            i = general[block]
            foot[i], normal[i] = self.tools(fid).at(p[i], best.uv[i])
        for i in np.flatnonzero(~best.on_face):
            normal[i] = self._boundary_normal(best.support.get(i), foot[i], int(best.face[i]))
        for i in np.flatnonzero(~np.isfinite(normal).all(axis=1)):  # a pole, an apex
            normal[i] = self._normal_near(int(best.face[i]), foot[i])
        delta = p - foot
        size = np.linalg.norm(delta, axis=1)
        side = np.einsum("ij,ij->i", delta, normal)
        return np.where(side < 0, -size, size), foot, normal, best.face.copy()

    def _boundary_normal(self, support, foot: np.ndarray, fid: int) -> np.ndarray:
        """The normal at a foot found on the trimmed face: inside the face its outward normal;
        on an edge or a vertex the sum of the outward normals there of the faces meeting at it
        (each face's normal at the foot's projection on its surface)."""
        total = np.zeros(3)
        for g in self.faces_at(support) or [fid]:
            t = self.tools(g)
            d, uv, found, _ = t.project(foot[None])
            nrm = t.normal(*uv[0]) if found[0] and d[0] < 1e-3 else None
            total += nrm if nrm is not None else 0.0
        size = np.linalg.norm(total)
        if size < 1e-9:
            return self._normal_near(fid, foot)
        return total / size

    def _normal_near(self, fid: int, foot: np.ndarray) -> np.ndarray:
        """Where the surface has no normal (a pole, an apex) or the faces' normals cancel: the
        face's outward normal at the nearest tessellation point of that face."""
        pts, normals, ids = self.mesh
        own = np.flatnonzero(ids == fid)
        j = own[np.argmin(np.linalg.norm(pts[own] - foot, axis=1))]
        return normals[j]

    def faces_at(self, support) -> list[int]:
        """The ids of the faces that hold an edge or a vertex (empty for anything else)."""
        from OCP.TopAbs import TopAbs_EDGE, TopAbs_VERTEX
        if support is None or support.ShapeType() not in (TopAbs_EDGE, TopAbs_VERTEX):
            return []
        if self._ancestors is None:
            self._ancestors = self._adjacency()
        ancestors = self._ancestors[support.ShapeType() == TopAbs_VERTEX]
        k = ancestors.FindIndex(support)
        if k == 0:
            return []
        return sorted({self.index.FindIndex(f) for f in ancestors.FindFromIndex(k)} - {0})

    def _adjacency(self):
        """(edge -> faces, vertex -> faces) maps over all placed faces."""
        from OCP.collections import \
            IndexedDataMap_TopoDS_Shape_List_TopoDS_Shape_TopTools_ShapeMapHasher as Ancestors
        from OCP.TopAbs import TopAbs_EDGE, TopAbs_FACE, TopAbs_VERTEX
        from OCP.TopExp import TopExp

        edges, vertices = Ancestors(), Ancestors()
        TopExp.MapShapesAndAncestors_s(self.compound, TopAbs_EDGE, TopAbs_FACE, edges)
        TopExp.MapShapesAndAncestors_s(self.compound, TopAbs_VERTEX, TopAbs_FACE, vertices)
        return edges, vertices


def _by_face(pairs: np.ndarray):
    """(face id, indices into pairs) for each face among the (point index, face id) pairs."""
    if len(pairs) == 0:
        return
    order = np.argsort(pairs[:, 1], kind="stable")
    starts = np.flatnonzero(np.diff(pairs[order, 1], prepend=-1))
    for block in np.split(order, starts[1:]):
        yield int(pairs[block[0], 1]), block


def _joined(lines: list[np.ndarray], tol: float) -> list[np.ndarray] | None:
    """The polylines (each (k, 2)) with the ends that meet made identical, or None when they do
    not join end to end into closed loops (an end meeting an even number of other ends within
    ``tol``). Ends computed from different curves differ in their last digits: left apart, a
    ray through the vertex would slip between them and miss or double a crossing."""
    ends = np.concatenate([p[[0, -1]] for p in lines])
    meets = np.linalg.norm(ends[:, None] - ends[None], axis=2) <= tol
    if not np.all((np.count_nonzero(meets, axis=1) - 1) % 2 == 1):
        return None
    shared = ends[np.argmax(meets, axis=1)]  # each end's first meeting end (itself at least)
    out = [p.copy() for p in lines]
    for k, p in enumerate(out):
        p[0], p[-1] = shared[2 * k], shared[2 * k + 1]
    return out


def _rows_dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise dot products of a (m, 3) with b (3,) or (m, 3)."""
    return np.einsum("ij,ij->i", a, np.broadcast_to(b, a.shape))


def _in_period(t: np.ndarray, period, start) -> np.ndarray:
    """A periodic parameter t moved by whole periods into [start, start + period) (less 1e-9);
    unchanged where the period is 0 (not periodic). period, start: scalars or per t."""
    period = np.asarray(period, float)
    if not period.any():
        return t
    start = np.asarray(start, float) - 1e-9
    return np.where(period > 0, start + np.mod(t - start, np.where(period > 0, period, 1.0)), t)


def _in_box(u: np.ndarray, v: np.ndarray, uv_box: np.ndarray, periods: np.ndarray):
    """Feet's (u, v) (m,) each into its face's (u, v) box u0 u1 v0 v1 ((4,) or (m, 4)) by whole
    periods ((2,) or (m, 2)): ((m, 2) wrapped (u, v), (m,) whether it lies in the box)."""
    u0, u1, v0, v1 = uv_box.T
    u, v = _in_period(u, periods.T[0], u0), _in_period(v, periods.T[1], v0)
    tol = 1e-9 * (1.0 + np.abs(uv_box).max(axis=-1))
    found = (u >= u0 - tol) & (u <= u1 + tol) & (v >= v0 - tol) & (v <= v1 + tol)
    return np.column_stack([u, v]), found


def _box_distance(boxes: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Distances from points p (m, 3) to boxes (m or 1, 2, 3) (0 inside): a lower bound of the
    distance to anything in the box."""
    gap = np.maximum(np.maximum(boxes[:, 0] - p, p - boxes[:, 1]), 0.0)
    return np.sqrt(np.einsum("ij,ij->i", gap, gap))


def _fill_normals_from_triangles(pts: np.ndarray, tris: np.ndarray, normals: np.ndarray) -> None:
    """Give nodes without a surface normal (poles, apexes) the mean normal of their triangles."""
    missing = ~np.isfinite(normals).all(axis=1)
    if not missing.any():
        return
    fn = np.cross(pts[tris[:, 1]] - pts[tris[:, 0]], pts[tris[:, 2]] - pts[tris[:, 0]])
    acc = np.zeros_like(pts)
    for c in range(3):
        np.add.at(acc, tris[:, c], fn)
    size = np.linalg.norm(acc, axis=1, keepdims=True)
    ok = missing & (size[:, 0] > 0)
    normals[ok] = acc[ok] / size[ok]
    normals[missing & ~ok] = (0.0, 0.0, 1.0)  # a node of no triangle: unused by anything


def _geometry(t: _FaceTools, kind: str) -> dict:
    """The exact surface of a plane, cylinder or sphere face (see StepFace.geometry)."""
    from OCP.BRepAdaptor import BRepAdaptor_Surface
    s = BRepAdaptor_Surface(t.face)
    u0, u1, v0, v1 = t.uv_box
    mid = t.point(0.5 * (u0 + u1), 0.5 * (v0 + v1))
    out = t.normal(0.5 * (u0 + u1), 0.5 * (v0 + v1))
    if kind == "Plane":
        pln = s.Plane()
        return {"point": pln.Location().Coord(), "normal": tuple(out.tolist())}
    if kind == "Cylinder":
        cyl = s.Cylinder()
        axis = cyl.Axis()
        a, o = np.array(axis.Direction().Coord()), np.array(axis.Location().Coord())
        radial = (mid - o) - np.dot(mid - o, a) * a
        return {"point": tuple(o.tolist()), "axis": tuple(a.tolist()), "radius": cyl.Radius(),
                "hole": bool(np.dot(out, radial) < 0)}
    if kind == "Sphere":
        sph = s.Sphere()
        c = np.array(sph.Location().Coord())
        return {"centre": tuple(c.tolist()), "radius": sph.Radius(),
                "hole": bool(np.dot(out, mid - c) < 0)}
    return {}
