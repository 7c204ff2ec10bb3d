"""Reading a STEP file: its checks, the checks of its entities' references, OpenCascade's
reading and translation, and the walk through its assembly to every placed face
(:func:`read_step`; see ``engine.io.step``).

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
"""

from __future__ import annotations

import os
import re

import numpy as np

from engine.errors import InputError
from .. import formats
from engine.pointset import PointSet

from ..points import COORD_LIMIT_MM
from .brep import Brep, StepNominal, deflection_for

MAX_BYTES = 1 << 30
"""The largest STEP file read (1 GiB): OpenCascade holds the whole model in memory, several
times the file's size."""

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
    brep = Brep(placed)
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


def check_step_file(path: str) -> str:
    """Check a file's ISO 10303-21 structure before OpenCascade reads it; return its schema.

    InputError naming the file: missing, a folder, empty, over ``MAX_BYTES``, binary, not
    beginning with ``ISO-10303-21;``, without a HEADER or DATA section, or not ending with
    ``END-ISO-10303-21;`` (truncated)."""
    formats.check_file(path)
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

    face_names, body_names = ShapeMap(), ShapeMap()
    face_named: list[str] = []
    body_named: list[str] = []
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
