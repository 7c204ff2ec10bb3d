"""PLY, OBJ and STL meshes read with numpy and checked before any native code sees them.

VTK's readers trust a file's declared counts and indices: a face pointing at a missing vertex, or a
PLY header declaring fewer vertices than the file holds, crashes the process in the filters that
follow, and a truncated file is read as a shorter mesh. Here every declared count is checked
against the rows or bytes present, every face index against the vertex count, and any mismatch
raises :class:`~engine.errors.InputError` naming the file, line where known, and the problem
("truncated: the header declares 90000 vertices, the file holds 60000").

* PLY: ``ascii``, ``binary_little_endian`` and ``binary_big_endian``, any elements and properties
  (scalar and list); the ``vertex`` element's x y z (and nx ny nz) and the ``face`` element's
  ``vertex_indices`` (or ``vertex_index``) list are used, other elements (a scanner's
  ``range_grid``, ``edge``, ``material``) are checked for length and skipped. Groups: a scalar
  face property named ``group``, ``part``, ``region``, ``face_id`` or ``label`` (the first of
  these the face declares) numbers each face's group, its whole-number values naming the groups
  ("1", "2", … as written, ``-3`` included; PLY holds no strings); without one, the same
  property on the vertices groups them (a labelled point cloud). A value that is no whole number
  is refused.
* OBJ: ``v`` (x y z, optional w or colour ignored), ``vn``, ``f`` with ``v``, ``v/vt``, ``v//vn``
  or ``v/vt/vn`` corners, 1-based, negative indices relative to the vertices defined so far;
  ``vn`` become vertex normals when there is one per vertex and every corner uses its vertex's
  own. Groups: ``g NAME …`` puts the faces that follow into each NAME (several names: several
  groups; ``g`` alone: the group ``default``), ``o NAME`` into the object NAME as well (the rest
  of the line is its name); an ``o`` starts a new object, whose faces are in no ``g`` group until
  the next ``g``. Group and object names share one namespace. A face under neither (before the
  first ``g`` or ``o``) is in ``default``, as the OBJ specification has it. A file without ``g``
  or ``o`` has no groups, nor does one without faces; a name no face follows (a ``g`` just
  before another) names no group.
  Other statements (``vt``, ``l``, ``s``, ``usemtl``, …) are ignored.
* STL: binary (length exactly 84 + 50 x the declared triangle count) or ASCII (``solid`` …
  ``facet normal`` … ``outer loop`` three ``vertex`` ``endloop endfacet`` … ``endsolid``, any
  number of solids); bit-identical corners are merged into shared vertices, as VTK's reader did.

A group's points are the vertices of its faces: a vertex on the edge between faces of two groups
is in both (:class:`engine.pointset.PointSet` ``groups``). STL solids and VTK's formats carry no
groups here.

Coordinates stay in the file's units (meshes carry none; millimetres by convention).

VTK's own formats (``.vtk``, ``.vtp``, ``.vts``) are read by VTK's readers in a child process
(:func:`read_vtk`; ``python -m engine.io.meshes`` is that child), and the faces of every mesh are
triangulated by VTK's filters once checked. VTK's own messages never reach the terminal: they are
routed into a string (see ``_vtk_log``).

Why a reader of our own rather than a library's (tried 2026-12-01): trimesh (MIT) reads the bad
files these checks exist for without a word — an ASCII PLY declaring 25 vertices of 40 as 25
vertices and no faces, one declaring 60 of 40 with face rows read as points; OBJ negative indices
against the whole file instead of the vertices above the line; ``f 0 1 2`` as ``[0, 0, 1]``; an
ASCII STL cut before ``endsolid`` or a binary one cut mid-triangle as an empty scene. plyfile
reads PLY well but is GPL-3.0-or-later (this project is MIT) and parses ASCII PLY 5-15 times
slower. The checks these formats need parse every row anyway, so a library would add a second
parse and no safety.
"""

from __future__ import annotations

import os
import re
import struct
import threading
from dataclasses import dataclass, field

import numpy as np

from engine.errors import InputError
from engine.pointset import PointSet

from .child import CHILD_INPUT_ERROR, arrays_from_child
from .points import check_coordinate_range, finish_point_set, read_bytes, split_lines, text_lines


@dataclass(frozen=True)
class MeshData:
    """A mesh as read from a file.

    points : (n, 3) float64, the file's coordinates.
    polygons : VTK cell array (int64: k, i0 … ik-1, k, …) of faces with k >= 3 and every index
        in [0, n), or None for a point cloud.
    normals : (n, 3) float64 vertex normals as stored (not normalised), or None.
    """

    points: np.ndarray
    polygons: np.ndarray | None = None
    normals: np.ndarray | None = None
    groups: dict[str, np.ndarray] | None = None
    """{name: ascending vertex indices} (engine.pointset.PointSet ``groups``), or None."""


GROUP_PROPERTIES = ("group", "part", "region", "face_id", "label")
"""Names of the PLY scalar property that numbers a face's (else a vertex's) group, first wins."""


GROUP_FLAGS_MAX = 1 << 26
"""Up to this many (group, vertex) pairs, a face group's vertices are found with a flag per
pair (that many bytes); beyond, by sorting."""


def _lens_flat(faces) -> tuple[np.ndarray, np.ndarray]:
    """(corners per face (m,), every face's vertex indices one after the other) of faces given
    as an (m, k) int array or a list of index sequences."""
    if isinstance(faces, np.ndarray):
        m, k = faces.shape
        return np.full(m, k, dtype=np.int64), faces.astype(np.int64).ravel()
    lens = np.fromiter((len(f) for f in faces), dtype=np.int64, count=len(faces))
    return lens, np.fromiter((v for f in faces for v in f), dtype=np.int64,
                             count=int(lens.sum()))


def _cells(faces, n_vertices: int, path: str, where) -> np.ndarray:
    """VTK cell array of faces given as an (m, k) int array or a list of index sequences, after
    checking every face has >= 3 corners and every index lies in [0, n_vertices).

    where(i) -> (description of face i, 1-based line or None) for messages."""
    lens, flat = _lens_flat(faces)
    m = lens.size
    short = np.flatnonzero(lens < 3)
    if short.size:
        what, line = where(int(short[0]))
        raise InputError(f"{what} has {lens[short[0]]} corner(s); a face needs at least 3",
                         path, line)
    bad = np.flatnonzero((flat < 0) | (flat >= n_vertices))
    if bad.size:
        face = int(np.searchsorted(np.cumsum(lens), bad[0], side="right"))
        what, line = where(face)
        raise InputError(f"{what} refers to vertex {flat[bad[0]]}; the file holds {n_vertices} "
                         f"vertices (numbered from 0)", path, line)
    starts = np.concatenate([[0], np.cumsum(lens + 1)[:-1]])
    cells = np.empty(int(lens.sum()) + m, dtype=np.int64)
    cells[starts] = lens
    mask = np.ones(cells.size, dtype=bool)
    mask[starts] = False
    cells[mask] = flat
    return cells


def _split_by(ids: np.ndarray, count: int) -> list[np.ndarray]:
    """For ids (m,) in [0, count): the ascending positions holding each id, id by id."""
    order = np.argsort(ids, kind="stable")
    bounds = np.searchsorted(ids[order], np.arange(count + 1))
    return [order[bounds[i]:bounds[i + 1]] for i in range(count)]


def _vertex_groups(faces, face_of: np.ndarray, group_of: np.ndarray, names: list[str],
                   n_vertices: int) -> dict[str, np.ndarray]:
    """{name: ascending indices of the vertices of its faces}, each pair (face_of[i],
    group_of[i]) putting a face (checked by :func:`_cells`) into group names[group_of[i]]."""
    lens, flat = _lens_flat(faces)
    starts = np.cumsum(lens) - lens
    k = lens[face_of]
    pair = np.repeat(np.arange(face_of.size), k)
    corner = starts[face_of][pair] + np.arange(pair.size) - np.repeat(np.cumsum(k) - k, k)
    key = group_of[pair].astype(np.int64) * n_vertices + flat[corner]
    size = len(names) * n_vertices
    if size <= GROUP_FLAGS_MAX:  # a flag per (group, vertex): faster than sorting the pairs
        seen = np.zeros(size, dtype=bool)
        seen[key] = True
        key = np.flatnonzero(seen)
    else:
        key = np.unique(key)
    return {name: key[i] % n_vertices
            for name, i in zip(names, _split_by(key // n_vertices, len(names)))}


def _group_numbers(values, prop: str, what: str, path: str, lines=None
                   ) -> tuple[list[str], np.ndarray]:
    """(group names, each row's group index) of a PLY group property's values: whole numbers,
    named as written ("7"). lines : each row's 1-based line (ASCII) or None."""
    v = np.asarray(values, dtype=np.float64)
    bad = np.flatnonzero(~np.isfinite(v) | (v != np.round(v)))
    if bad.size:
        i = int(bad[0])
        raise InputError(f"{what} {i}: its group property '{prop}' is {v[i]:g}; group numbers "
                         "are whole numbers", path, None if lines is None else int(lines[i]))
    numbers, ids = np.unique(v, return_inverse=True)
    return [str(int(x)) for x in numbers], ids.ravel()


# --------------------------------------------------------------------------------------- PLY

_PLY_TYPES = {"char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1", "short": "i2",
              "int16": "i2", "ushort": "u2", "uint16": "u2", "int": "i4", "int32": "i4",
              "uint": "u4", "uint32": "u4", "float": "f4", "float32": "f4", "double": "f8",
              "float64": "f8"}
_STRUCT = {"i1": "b", "u1": "B", "i2": "h", "u2": "H", "i4": "i", "u4": "I", "f4": "f", "f8": "d"}
_PLY_FORMATS = {"ascii": None, "binary_little_endian": "<", "binary_big_endian": ">"}
_FACE_LISTS = ("vertex_indices", "vertex_index")


@dataclass
class _Prop:
    name: str
    code: str  # numpy type code without byte order ("f4")
    count_code: str | None = None  # list properties: the count's type


@dataclass
class _Element:
    name: str
    count: int
    line: int
    props: list = field(default_factory=list)

    @property
    def plural(self) -> str:
        return {"vertex": "vertices", "face": "faces"}.get(self.name, f"'{self.name}' rows")

    @property
    def has_list(self) -> bool:
        return any(p.count_code for p in self.props)


def _ply_header(text: str, path: str) -> tuple[str, list[_Element]]:
    lines = split_lines(text)
    fmt = None
    elements: list[_Element] = []
    for ln, raw in enumerate(lines[1:], start=2):
        tok = raw.split()
        if not tok or tok[0] in ("comment", "obj_info"):
            continue
        if tok[0] == "format":
            if len(tok) != 3 or tok[1] not in _PLY_FORMATS:
                raise InputError(f"unknown PLY format '{' '.join(tok[1:])}'", path, ln)
            fmt = tok[1]
        elif tok[0] == "element":
            if len(tok) != 3 or not tok[2].isdigit():
                raise InputError(f"header line '{raw.strip()}' is not 'element NAME COUNT'",
                                 path, ln)
            elements.append(_Element(tok[1], int(tok[2]), ln))
        elif tok[0] == "property":
            if not elements:
                raise InputError("a property before any element", path, ln)
            if len(tok) == 5 and tok[1] == "list" and tok[2] in _PLY_TYPES \
                    and tok[3] in _PLY_TYPES and _PLY_TYPES[tok[2]][0] in "iu":
                elements[-1].props.append(_Prop(tok[4], _PLY_TYPES[tok[3]], _PLY_TYPES[tok[2]]))
            elif len(tok) == 3 and tok[1] in _PLY_TYPES:
                elements[-1].props.append(_Prop(tok[2], _PLY_TYPES[tok[1]]))
            else:
                raise InputError(f"header line '{raw.strip()}' is not a valid property", path, ln)
            if [p.name for p in elements[-1].props].count(tok[-1]) > 1:
                raise InputError(f"property '{tok[-1]}' is declared twice", path, ln)
        else:
            raise InputError(f"unknown PLY header keyword '{tok[0]}'", path, ln)
    if fmt is None:
        raise InputError("the PLY header has no 'format' line", path)
    vertex = [e for e in elements if e.name == "vertex"]
    names = {p.name for p in vertex[0].props if not p.count_code} if vertex else set()
    if not vertex or not {"x", "y", "z"} <= names:
        raise InputError("the PLY header declares no 'vertex' element with x, y and z", path)
    for e in elements:
        if e.name == "face":
            lists = [p for p in e.props if p.name in _FACE_LISTS and p.count_code]
            if not lists:
                raise InputError("the 'face' element has no 'vertex_indices' list", path, e.line)
            if lists[0].code[0] not in "iu":
                raise InputError("the faces' vertex indices are not integers", path, e.line)
    return fmt, elements


def read_ply(path: str) -> MeshData:
    """A PLY file's vertices, faces and vertex normals (see the module docstring)."""
    raw = read_bytes(path)
    if not raw.startswith(b"ply"):
        raise InputError("not a PLY file (it does not start with 'ply')", path, 1)
    m = re.search(rb"(?m)^end_header[ \t]*(\r\n|\n|\r|\Z)", raw[:1 << 20])
    if m is None:
        raise InputError("truncated or damaged PLY header: no 'end_header' line", path)
    fmt, elements = _ply_header(raw[:m.start()].decode("ascii", "replace"), path)
    header_lines = raw[:m.end()].count(b"\n")
    try:
        if fmt == "ascii":
            values = _ply_ascii(raw, m.end(), header_lines, elements, path)
        else:
            values = _ply_binary(raw, m.end(), _PLY_FORMATS[fmt], elements, path)
        return _ply_mesh(values, path)
    except InputError:
        held = None if fmt == "ascii" else _vertices_that_fit(raw, m.end(), _PLY_FORMATS[fmt],
                                                              elements)
        if held is not None:
            raise _truncated(elements[0], held, path) from None
        raise


def _ply_mesh(values: dict, path: str) -> MeshData:
    vert = values["vertex"]
    points = np.column_stack([vert[c] for c in "xyz"]).astype(np.float64)
    normals = None
    if all(c in vert for c in ("nx", "ny", "nz")):
        normals = np.column_stack([vert[c] for c in ("nx", "ny", "nz")]).astype(np.float64)
    polygons = groups = None
    n = points.shape[0]
    lines = values.get("face_lines")
    if values.get("face") is not None and len(values["face"]):
        polygons = _cells(values["face"], n, path,
                          lambda i: (f"face {i}", None if lines is None else int(lines[i])))
    prop = next((p for p in GROUP_PROPERTIES if p in vert), None)
    if polygons is not None and values.get("face_group") is not None:
        names, ids = _group_numbers(*values["face_group"], "face", path, lines)
        groups = _vertex_groups(values["face"], np.arange(ids.size), ids, names, n)
    elif prop is not None:
        names, ids = _group_numbers(vert[prop], prop, "vertex", path)
        groups = dict(zip(names, _split_by(ids, len(names))))
    return MeshData(points, polygons, normals, groups)


def _named_group(el: _Element, numbers) -> tuple[object, str] | None:
    """(the face group property's values, its name) for _ply_mesh, or None without one."""
    grp = _face_props(el)[1]
    return None if grp is None else (numbers, el.props[grp].name)


def _face_props(el: _Element) -> tuple[int | None, int | None]:
    """(index of the face element's vertex list, of its group property), each or None (for
    other elements both None)."""
    if el.name != "face":
        return None, None
    want = next((j for j, p in enumerate(el.props) if p.name in _FACE_LISTS and p.count_code),
                None)
    scalars = {p.name: j for j, p in enumerate(el.props) if not p.count_code}
    return want, next((scalars[g] for g in GROUP_PROPERTIES if g in scalars), None)


def _truncated(el: _Element, held: int, path: str, line=None):
    word = "truncated" if held < el.count else "inconsistent"
    return InputError(f"{word}: the header declares {el.count} {el.plural}, the file holds "
                      f"{held}", path, line)


def _ply_ascii(raw: bytes, body: int, header_lines: int, elements, path) -> dict:
    try:
        text = raw[body:].decode("ascii")
    except UnicodeDecodeError as e:
        line = header_lines + raw[body:body + e.start].count(b"\n") + 1
        raise InputError("a non-ASCII byte in the data of an ASCII PLY file (damaged?)",
                         path, line) from None
    lines = split_lines(text)
    keep = [i for i, s in enumerate(lines) if s and not s.isspace()]
    rows = [lines[i] for i in keep]
    line_of = np.asarray(keep, dtype=np.int64) + header_lines + 1  # row -> 1-based file line
    values: dict = {}
    pos = 0
    for ei, el in enumerate(elements):
        block = rows[pos:pos + el.count]
        if not el.has_list:
            got = _ascii_fixed(el, block, pos, line_of, path)
        else:
            try:
                got = _ascii_lists(el, block, pos, line_of, path)
            except InputError:
                prev = elements[ei - 1] if ei > 0 else None
                if prev is not None and not prev.has_list:
                    # Rows of the previous element running on: its count is too small.
                    held = prev.count + _rows_like(prev, rows, pos)
                    if held > prev.count:
                        raise _truncated(prev, held, path) from None
                raise
        if el.name == "vertex":
            values["vertex"] = got
        elif el.name == "face":
            values["face"], group, values["face_lines"] = got
            values["face_group"] = _named_group(el, group)
        pos += el.count
    if pos < len(rows):
        last = elements[-1] if elements else None
        if last is not None and not last.has_list:
            held = last.count + _rows_like(last, rows, pos)
            if held > last.count:
                raise _truncated(last, held, path, int(line_of[pos]))
        raise InputError(f"inconsistent: {len(rows) - pos} data rows follow the elements the "
                         "header declares", path, int(line_of[pos]))
    return values


def _rows_like(el: _Element, rows: list[str], start: int) -> int:
    """How many rows from ``start`` on look like rows of the fixed-size element ``el``."""
    n = 0
    for s in rows[start:]:
        tok = s.split()
        if len(tok) != len(el.props):
            break
        try:
            [float(t) for t in tok]
        except ValueError:
            break
        n += 1
    return n


def _ascii_fixed(el: _Element, block: list[str], pos: int, line_of, path) -> dict:
    """Columns of an element of scalar properties, one row per line, as float64."""
    ntok = len(el.props)
    if el.count == 0:
        return {p.name: np.zeros(0) for p in el.props}
    arr = None
    if block:
        try:
            arr = np.loadtxt(block, dtype=np.float64, ndmin=2, comments=None)
        except ValueError:
            arr = None
    if arr is None or arr.shape[1] != ntok or len(block) < el.count:
        for k, s in enumerate(block):
            tok = s.split()
            if len(tok) != ntok:
                if k == 0:
                    raise InputError(f"a {el.name} row holds {len(tok)} values where the header "
                                     f"declares {ntok} properties", path, int(line_of[pos]))
                raise _truncated(el, k, path, int(line_of[pos + k]))
            for t in tok:
                try:
                    float(t)
                except ValueError:
                    raise InputError(f"'{t}' is not a number", path,
                                     int(line_of[pos + k])) from None
        raise _truncated(el, len(block), path)
    return {p.name: arr[:, j] for j, p in enumerate(el.props)}


def _ascii_lists(el: _Element, block: list[str], pos: int, line_of, path):
    """(face index lists (an (m, k) array when uniform), face group numbers (m,) or None,
    row -> line) of a list element; other list elements are only checked."""
    want, grp = _face_props(el)
    lines = line_of[pos:pos + len(block)]
    if len(block) == el.count and block:
        got = _ascii_uniform(el, block, want, grp)
        if got is not None:
            return (*got, lines)
    out, groups = [], []
    for k, s in enumerate(block):
        tok = s.split()
        t = 0
        for j, p in enumerate(el.props):
            if p.count_code:
                try:
                    n = int(tok[t])
                except (IndexError, ValueError):
                    raise InputError(f"{el.name} row {k}: '{tok[t] if t < len(tok) else ''}' is "
                                     "not a list length", path, int(lines[k])) from None
                items = tok[t + 1:t + 1 + n]
                if n < 0 or len(items) < n:
                    raise InputError(f"{el.name} row {k}: a list of {n} holds {len(items)} values",
                                     path, int(lines[k]))
                if j == want:
                    try:
                        out.append([int(v) for v in items])
                    except ValueError:
                        raise InputError(f"{el.name} row {k}: vertex indices must be integers",
                                         path, int(lines[k])) from None
                t += 1 + n
            else:
                if j == grp:
                    groups.append(_ascii_number(tok, t, f"{el.name} row {k}: its '{p.name}'",
                                                path, int(lines[k])))
                t += 1
        if t != len(tok):
            raise InputError(f"{el.name} row {k} holds {len(tok)} values where its properties "
                             f"take {t}", path, int(lines[k]))
    if len(block) < el.count:
        raise _truncated(el, len(block), path)
    return (out if want is not None else None), (groups if grp is not None else None), lines


def _ascii_number(tok: list[str], t: int, what: str, path: str, line: int) -> float:
    """Token ``t`` of a row as a number (``what``: the value it is, for messages)."""
    if t >= len(tok):
        raise InputError(f"{what} is missing: the row ends before it", path, line)
    try:
        return float(tok[t])
    except ValueError:
        raise InputError(f"{what} '{tok[t]}' is not a number", path, line) from None


def _ascii_uniform(el: _Element, block: list[str], want: int | None, grp: int | None):
    """(face index lists (m, k), group numbers (m,) or None) when every row's lists are as long
    as the first row's (triangle or quad meshes) and every index is an integer; None otherwise
    (the row-by-row reader then names the row at fault)."""
    whole = all(p.code[0] in "iu" for p in el.props)
    try:
        arr = np.loadtxt(block, dtype=np.int64 if whole else np.float64, ndmin=2,
                         comments=None)
    except ValueError:
        return None
    col, lists, group = 0, None, None
    for j, p in enumerate(el.props):
        if col >= arr.shape[1]:
            return None
        if p.count_code:
            n = arr[0, col]
            if not (np.isfinite(n) and 0 <= n == int(n)) or np.any(arr[:, col] != n):
                return None
            if j == want:
                lists = arr[:, col + 1:col + 1 + int(n)]
            col += 1 + int(n)
        else:
            if j == grp:
                group = arr[:, col]
            col += 1
    if col != arr.shape[1] or (lists is not None and np.any(lists != np.round(lists))):
        return None
    return (None if lists is None else lists.astype(np.int64)), group


def _vertices_that_fit(raw: bytes, off: int, order: str, elements) -> int | None:
    """For the usual layout (vertices, then faces of one list property), the vertex count that
    would make the file's length and face rows consistent, when it differs from the declared
    one: the header then miscounts the vertices, which is the message to give."""
    if len(elements) != 2 or [e.name for e in elements] != ["vertex", "face"] \
            or elements[0].has_list or len(elements[1].props) != 1:
        return None
    vert, face = elements
    iv = np.dtype([(p.name, order + p.code) for p in vert.props]).itemsize
    prop = face.props[0]
    csize, isize = np.dtype(prop.count_code).itemsize, np.dtype(prop.code).itemsize
    end = len(raw.rstrip(b" \t\r\n\x00")) if raw.endswith((b"\n", b"\r")) else len(raw)
    for k in (3, 4):  # triangles, quads
        row = csize + k * isize
        rest = end - off - face.count * row
        if iv == 0 or rest <= 0 or rest % iv or rest // iv == vert.count:
            continue
        start = off + (rest // iv) * iv
        counts = np.frombuffer(raw, order + prop.count_code, face.count * row // csize, start)
        if np.all(counts[::row // csize] == k) if row % csize == 0 else False:
            return rest // iv
    return None


def _ply_binary(raw: bytes, off: int, order: str, elements, path) -> dict:
    values: dict = {}
    for el in elements:
        avail = len(raw) - off
        if not el.has_list:
            dt = np.dtype([(p.name, order + p.code) for p in el.props])
            if dt.itemsize == 0 or el.count == 0:
                if el.name == "vertex":
                    values["vertex"] = {p.name: np.zeros(0) for p in el.props}
                continue
            if el.count * dt.itemsize > avail:
                raise _truncated(el, avail // dt.itemsize, path)
            arr = np.frombuffer(raw, dt, el.count, off)
            off += el.count * dt.itemsize
            if el.name == "vertex":
                values["vertex"] = {p.name: arr[p.name] for p in el.props}
            continue
        lists, group, off = _binary_lists(raw, off, order, el, path)
        if el.name == "face":
            values["face"], values["face_group"] = lists, _named_group(el, group)
    rest = raw[off:]
    if rest.strip(b" \t\r\n\x00"):
        raise InputError(f"inconsistent: {len(rest)} bytes follow the data the header declares "
                         "(its element counts do not match the file)", path)
    return values


def _binary_lists(raw: bytes, off: int, order: str, el: _Element, path):
    """(face index lists, or None for other elements; face group numbers or None; the offset
    after the element)."""
    want, grp = _face_props(el)
    if el.count == 0:
        return [], None, off
    # Fast path: every row's lists as long as the first row's (triangle or quad meshes).
    counts, pos = [], off
    for p in el.props:
        size = np.dtype(p.count_code or p.code).itemsize
        if pos + size > len(raw):
            raise _truncated(el, 0, path)
        if p.count_code:
            n = int(np.frombuffer(raw, order + p.count_code, 1, pos)[0])
            counts.append(n)
            pos += size + n * np.dtype(p.code).itemsize
        else:
            counts.append(None)
            pos += size
    fields = []
    for j, (p, n) in enumerate(zip(el.props, counts)):
        if p.count_code:
            fields += [(f"n{j}", order + p.count_code), (f"l{j}", order + p.code, (max(n, 0),))]
        else:
            fields.append((f"s{j}", order + p.code))
    dt = np.dtype(fields)
    if el.count * dt.itemsize <= len(raw) - off:
        arr = np.frombuffer(raw, dt, el.count, off)
        if all(np.all(arr[f"n{j}"] == n) for j, n in enumerate(counts) if n is not None):
            return ((arr[f"l{want}"] if want is not None else None),
                    (arr[f"s{grp}"] if grp is not None else None), off + el.count * dt.itemsize)
    return _binary_rows(raw, off, order, el, path, want, grp)


def _binary_rows(raw: bytes, off: int, order: str, el: _Element, path, want, grp):
    """:func:`_binary_lists` for rows of different lengths: walk them."""
    out, groups = [], []
    pos = off
    end = len(raw)
    fmt = [(order + _STRUCT[p.count_code], np.dtype(p.count_code).itemsize,
            _STRUCT[p.code], np.dtype(p.code).itemsize) if p.count_code else
           (None, np.dtype(p.code).itemsize, order + _STRUCT[p.code], 0) for p in el.props]
    for k in range(el.count):
        for j, (cf, csize, item, isize) in enumerate(fmt):
            if pos + csize > end:
                raise _truncated(el, k, path)
            if cf is None:
                if j == grp:
                    groups.append(struct.unpack_from(item, raw, pos)[0])
                pos += csize
                continue
            n = struct.unpack_from(cf, raw, pos)[0]
            pos += csize
            if n < 0 or pos + n * isize > end:
                if n < 0:
                    raise InputError(f"damaged: {el.name} row {k} has a list of length {n}", path)
                raise _truncated(el, k, path)
            if j == want:
                out.append(struct.unpack_from(f"{order}{n}{item}", raw, pos))
            pos += n * isize
    return (out if want is not None else None), (groups if grp is not None else None), pos


# --------------------------------------------------------------------------------------- OBJ

def read_obj(path: str) -> MeshData:
    """An OBJ file's vertices and faces (and ``vn`` normals for a point cloud with one per
    vertex)."""
    lines = text_lines(read_bytes(path), path, "text OBJ file")
    v_rows, v_lines, vn_rows = [], [], []
    f_rows, f_lines, f_before, f_set = [], [], [], []
    groups = _ObjGroups()
    now = groups.current()
    for i, s in enumerate(lines):
        if s.startswith("v "):  # the common cases first, without splitting the line
            v_rows.append(s[2:])
            v_lines.append(i + 1)
            continue
        if s.startswith("f "):
            f_rows.append(s[2:])
            f_lines.append(i + 1)
            f_before.append(len(v_rows))
            f_set.append(now)
            continue
        parts = s.split(None, 1)
        if not parts:
            continue
        key = parts[0]
        if key == "v":
            v_rows.append(parts[1] if len(parts) > 1 else "")
            v_lines.append(i + 1)
        elif key == "vn":
            vn_rows.append(parts[1] if len(parts) > 1 else "")
        elif key in ("f", "fo"):
            f_rows.append(parts[1] if len(parts) > 1 else "")
            f_lines.append(i + 1)
            f_before.append(len(v_rows))
            f_set.append(now)
        elif key in ("g", "o"):
            now = groups.statement(key, parts[1] if len(parts) > 1 else "")
        elif s.rstrip().endswith("\\"):
            raise InputError("line continuations ('\\') are not supported", path, i + 1)
    if not v_rows:
        raise InputError("the file holds no vertices ('v' lines)", path)
    points = _obj_numbers(v_rows, v_lines, path, "v")
    nv = points.shape[0]
    polygons = named = None
    if f_rows:
        faces = _obj_faces_uniform(f_rows, np.asarray(f_before), nv)
        if faces is None:
            faces = [_obj_face(row, ln, before, nv, path)
                     for row, ln, before in zip(f_rows, f_lines, f_before)]
        polygons = _cells(faces, nv, path, lambda i: ("face", f_lines[i]))
        named = groups.of_vertices(faces, np.asarray(f_set, dtype=np.int64), nv)
    normals = None
    if vn_rows and len(vn_rows) == nv and all(_same_vn(row) for row in f_rows):
        # One normal per vertex, each corner using its vertex's own: vertex normals.
        normals = _obj_numbers(vn_rows, None, path, "vn")
    return MeshData(points, polygons, normals, named)


class _ObjGroups:
    """The groups of an OBJ file's faces as its lines are read (the module docstring): each
    distinct set of groups a face can be in gets an id, the faces keep the id."""

    def __init__(self):
        self.named = False  # whether the file has a g or o statement
        self.g: tuple[str, ...] = ()
        self.o: str | None = None
        self.sets: dict[tuple[str, ...], int] = {}

    def current(self) -> int:
        """The id of the groups a face gets now."""
        names = tuple(dict.fromkeys(self.g + ((self.o,) if self.o else ()))) or ("default",)
        return self.sets.setdefault(names, len(self.sets))

    def statement(self, key: str, rest: str) -> int:
        """Take a ``g`` or ``o`` statement (``rest``: the line after its keyword); the id of
        the groups of the faces that follow."""
        rest = rest.split("#")[0]
        self.named = True
        if key == "g":
            self.g = tuple(rest.split()) or ("default",)
        else:  # a new object: its faces are in no g group until the next g
            self.o, self.g = rest.strip() or None, ()
        return self.current()

    def of_vertices(self, faces, face_set: np.ndarray, n_vertices: int
                    ) -> dict[str, np.ndarray] | None:
        """{group: ascending indices of the vertices of its faces} (faces checked by _cells;
        face_set (m,) each face's id), the groups in the order the file names them; None for a
        file without g or o. A name no face is under names no group."""
        if not self.named:
            return None
        sets = sorted(self.sets, key=self.sets.get)
        used = np.zeros(len(sets), dtype=bool)
        used[face_set] = True
        names = list(dict.fromkeys(n for k, u in zip(sets, used) if u for n in k))
        index = {n: i for i, n in enumerate(names)}
        members = [np.array([index[n] for n in k] if u else [], dtype=np.int64)
                   for k, u in zip(sets, used)]
        by_set = _split_by(face_set, len(sets))
        face_of = np.concatenate([np.repeat(f, m.size) for f, m in zip(by_set, members)])
        group_of = np.concatenate([np.tile(m, f.size) for f, m in zip(by_set, members)])
        return _vertex_groups(faces, face_of, group_of, names, n_vertices)


def _same_vn(row: str) -> bool:
    """Every corner of an ``f`` row names the same vertex and normal (``7//7``, ``7/3/7``)."""
    for t in row.split():
        parts = t.split("/")
        if len(parts) != 3 or parts[2] != parts[0]:
            return False
    return True


def _obj_faces_uniform(rows: list[str], before: np.ndarray, nv: int) -> np.ndarray | None:
    """(m, k) 0-based vertex indices when every face has k corners and every index resolves
    within [0, nv); None otherwise (the row-by-row reader then names the line at fault)."""
    text = "\n".join(rows)
    if "/" in text:
        text = re.sub(r"/\S*", "", text)  # v/vt/vn -> v
    try:
        idx = np.loadtxt(text.split("\n"), dtype=np.int64, ndmin=2, comments="#")
    except ValueError:
        return None
    if idx.shape[0] != len(rows) or np.any(idx == 0):
        return None
    idx = np.where(idx > 0, idx - 1, before[:, None] + idx)
    if np.any(idx < 0) or np.any(idx >= nv):
        return None
    return idx


def _obj_face(row: str, ln: int, before: int, nv: int, path: str) -> list[int]:
    """0-based vertex indices of one ``f`` row (``before``: vertices defined above it)."""
    try:
        idx = [int(t.partition("/")[0]) for t in row.split("#")[0].split()]
    except ValueError:
        raise InputError(f"face '{row.strip()}' holds a corner that is not a vertex index",
                         path, ln) from None
    res = []
    for v in idx:
        if v == 0:
            raise InputError("face refers to vertex 0; OBJ numbers vertices from 1", path, ln)
        # Negative: relative to the vertices defined so far (-1 is the latest).
        r = v - 1 if v > 0 else before + v
        if r < 0 or r >= nv:
            raise InputError(f"face refers to vertex {v}; the file holds {nv} vertices"
                             + (f" ({before} before this line)" if v < 0 else ""), path, ln)
        res.append(r)
    return res


def _obj_numbers(rows: list[str], lines, path, key) -> np.ndarray:
    try:
        return np.loadtxt(rows, dtype=np.float64, ndmin=2, usecols=(0, 1, 2), comments="#")
    except ValueError:
        pass
    for k, s in enumerate(rows):
        tok = s.split("#")[0].split()
        try:
            if len(tok) < 3:
                raise ValueError
            [float(t) for t in tok[:3]]
        except ValueError:
            raise InputError(f"'{key} {s.strip()}' is not three numbers", path,
                             None if lines is None else lines[k]) from None
    raise InputError(f"'{key}' lines cannot be read", path)


# --------------------------------------------------------------------------------------- STL

_STL_DTYPE = np.dtype([("n", "<f4", (3,)), ("v", "<f4", (3, 3)), ("attr", "<u2")])
_FACET_WORDS = {0: "facet", 1: "normal", 5: "outer", 6: "loop", 7: "vertex", 11: "vertex",
                15: "vertex", 19: "endloop", 20: "endfacet"}


def read_stl(path: str) -> MeshData:
    """An STL file's triangles, bit-identical corners merged into shared vertices."""
    raw = read_bytes(path)
    declared = int.from_bytes(raw[80:84], "little") if len(raw) >= 84 else None
    binary_fits = declared is not None and len(raw) == 84 + 50 * declared
    head = raw[:1024]
    if not binary_fits and raw.lstrip()[:5].lower() == b"solid" and b"\x00" not in head:
        corners = _stl_ascii(raw, path)
    else:
        if declared is None:
            raise InputError(f"truncated: a binary STL needs at least 84 bytes, the file holds "
                             f"{len(raw)}", path)
        if not binary_fits:
            held = (len(raw) - 84) // 50
            word = "truncated" if held < declared else "inconsistent"
            raise InputError(f"{word}: the header declares {declared} triangles "
                             f"({84 + 50 * declared} bytes), the file holds {held} "
                             f"({len(raw)} bytes)", path)
        corners = np.frombuffer(raw, _STL_DTYPE, declared, 84)["v"].reshape(-1, 3)
    if corners.shape[0] == 0:
        raise InputError("the file holds no triangles", path)
    # + 0.0 turns -0.0 into 0.0, so that the two merge like equal coordinates do.
    corners = corners.astype(np.float64) + 0.0
    if not np.isfinite(corners).all():
        row = int(np.flatnonzero(~np.isfinite(corners).all(axis=1))[0])
        raise InputError(f"triangle {row // 3} holds NaN or infinity", path)
    # Group equal corners (a stable lexicographic sort); number the groups in the order the
    # file first uses them.
    n = corners.shape[0]
    order = np.lexsort(corners.T[::-1])
    sc = corners[order]
    new = np.ones(n, dtype=bool)
    new[1:] = np.any(sc[1:] != sc[:-1], axis=1)
    group = np.empty(n, dtype=np.int64)
    group[order] = np.cumsum(new) - 1
    first = order[new]  # the stable sort puts each group's first use first
    by_use = np.argsort(first)
    rank = np.empty_like(by_use)
    rank[by_use] = np.arange(by_use.size)
    tri = rank[group].reshape(-1, 3)
    return MeshData(sc[new][by_use], _cells(tri, by_use.size, path,
                                            lambda i: (f"triangle {i}", None)))


def _stl_ascii(raw: bytes, path: str) -> np.ndarray:
    """(3m, 3) corners of an ASCII STL's facets, the structure checked token by token."""
    text = "\n".join(text_lines(raw, path, "text STL file"))
    marks = list(re.finditer(r"(?im)^[ \t]*(end)?solid\b.*$", text))
    out = []
    solids = 0
    pos = 0
    for k in range(0, len(marks), 2):
        head = marks[k]
        if head.group(1) or text[pos:head.start()].strip():
            raise InputError("damaged ASCII STL: text outside 'solid' … 'endsolid'", path,
                             text.count("\n", 0, head.start()) + 1)
        tail = marks[k + 1] if k + 1 < len(marks) else None
        tokens = text[head.end():tail.start() if tail else len(text)].split()
        nfacets = len(tokens) // 21
        if tail is None:
            raise InputError(f"truncated: solid {solids + 1} has no 'endsolid' line (the file "
                             f"ends after {nfacets} complete facets)", path)
        if not tail.group(1):
            raise InputError("damaged ASCII STL: 'solid' inside a solid", path,
                             text.count("\n", 0, tail.start()) + 1)
        if len(tokens) % 21:
            raise InputError(f"damaged ASCII STL: solid {solids + 1} holds {len(tokens)} words, "
                             "not a whole number of 21-word facets (facet normal i j k outer "
                             "loop, 3 vertex x y z, endloop endfacet)", path,
                             text.count("\n", 0, head.start()) + 1)
        for col, word in _FACET_WORDS.items():
            words = tokens[col::21]
            if set(words) != {word} and words and {w.lower() for w in words} != {word}:
                k = next(k for k, w in enumerate(words) if w.lower() != word)
                raise InputError(f"damaged ASCII STL: facet {k} of solid {solids + 1} has "
                                 f"'{words[k]}' where '{word}' belongs", path)
        try:
            xyz = np.column_stack([np.fromiter(map(float, tokens[c::21]), np.float64, nfacets)
                                   for c in (8, 9, 10, 12, 13, 14, 16, 17, 18)])
        except ValueError:
            raise InputError(f"damaged ASCII STL: a vertex of solid {solids + 1} is not three "
                             "numbers", path) from None
        out.append(xyz.reshape(-1, 3))
        solids += 1
        pos = tail.end()
    if text[pos:].strip():
        raise InputError("damaged ASCII STL: text outside 'solid' … 'endsolid'", path)
    if not solids:
        raise InputError("the file holds no triangles", path)
    return np.concatenate(out)


# ------------------------------------------------------------------------- VTK legacy ASCII

_LEGACY_CELLS = {"VERTICES", "LINES", "POLYGONS", "TRIANGLE_STRIPS", "CELLS"}


def check_legacy_ascii_vtk(raw: bytes, path: str) -> None:
    """Every section of an ASCII legacy ``.vtk`` file holds the count of values it declares.

    VTK's reader reads such a file cut short without complaint (a cut in the points gives as
    many points as declared, a cut in the normals nothing at all), so the count is checked here
    first. Binary legacy files are left to VTK, which reports a short read; a section this check
    does not know (``METADATA``, …) ends it and VTK reads as before."""
    parts = raw.split(b"\n", 3)
    if len(parts) < 4 or parts[2].strip().upper() != b"ASCII":
        return
    tok = parts[3].decode("ascii", "replace").split()
    n = len(tok)
    i = 0
    m = None  # the tuple count of the current POINT_DATA / CELL_DATA section
    try:
        while i < n:
            k = tok[i].upper()
            nxt = _skip_legacy_dataset_section(tok, i, k, path)
            if nxt is None and k in ("POINT_DATA", "CELL_DATA"):
                m = int(tok[i + 1])
                nxt = i + 2
            elif nxt is None and m is not None:
                nxt = _skip_legacy_attribute_section(tok, i, k, m, path)
            if nxt is None:
                return  # a section this check does not know: VTK reads as before
            i = nxt
    except (IndexError, ValueError):
        raise InputError("truncated or damaged legacy VTK header line", path) from None


def _take_legacy_values(tok: list[str], i: int, count: int, what: str, path: str) -> int:
    """The index in ``tok`` (the file's whitespace-separated tokens after its third line) past
    the ``count`` values of a section that start at ``tok[i]``; a section cut short, or followed
    by more numbers than it declares, is refused."""
    n = len(tok)
    if i + count > n:
        raise InputError(f"truncated: {what} declares {count} values, the file holds "
                         f"{n - i}", path)
    i += count
    if i < n and tok[i][0] in "0123456789+-.":
        raise InputError(f"inconsistent: {what} declares {count} values, more follow", path)
    return i


def _skip_legacy_dataset_section(tok: list[str], i: int, k: str, path: str) -> int | None:
    """The index in ``tok`` past the geometry or topology section whose keyword ``k`` stands at
    ``tok[i]`` (``DATASET``, ``POINTS``, cells, ``CELL_TYPES``, structured-grid extents), its
    value count checked; None when ``k`` names no such section."""
    n = len(tok)
    if k == "DATASET":
        i += 2
    elif k == "POINTS":
        cnt = int(tok[i + 1])
        i += 3
        i = _take_legacy_values(tok, i, 3 * cnt, f"POINTS {cnt}", path)
    elif k in ("DIMENSIONS", "ORIGIN", "SPACING", "ASPECT_RATIO"):
        i += 4
    elif k in _LEGACY_CELLS:
        cnt, size = int(tok[i + 1]), int(tok[i + 2])
        i += 3
        if i < n and tok[i].upper() == "OFFSETS":
            i += 2
            i = _take_legacy_values(tok, i, cnt, f"{k} {cnt} (offsets)", path)
            if i >= n or tok[i].upper() != "CONNECTIVITY":
                raise InputError(f"damaged: {k} has offsets but no connectivity", path)
            i += 2
        i = _take_legacy_values(tok, i, size, f"{k} {cnt} {size}", path)
    elif k == "CELL_TYPES":
        cnt = int(tok[i + 1])
        i += 2
        i = _take_legacy_values(tok, i, cnt, f"CELL_TYPES {cnt}", path)
    else:
        return None
    return i


def _skip_legacy_attribute_section(tok: list[str], i: int, k: str, m: int,
                                   path: str) -> int | None:
    """The index in ``tok`` past the data attribute whose keyword ``k`` stands at ``tok[i]``
    (``SCALARS``, ``VECTORS``, ``FIELD``, …) in a POINT_DATA / CELL_DATA section of ``m``
    tuples, its value count checked; None when ``k`` names no such attribute."""
    n = len(tok)
    if k == "SCALARS":
        i += 3
        ncomp = 1
        if i < n and tok[i].isdigit():
            ncomp = int(tok[i])
            i += 1
        if i < n and tok[i].upper() == "LOOKUP_TABLE":
            i += 2
        i = _take_legacy_values(tok, i, m * ncomp, f"SCALARS {tok[i - 1]}", path)
    elif k in ("VECTORS", "NORMALS"):
        i += 3
        i = _take_legacy_values(tok, i, 3 * m, k, path)
    elif k == "TEXTURE_COORDINATES":
        dim = int(tok[i + 2])
        i += 4
        i = _take_legacy_values(tok, i, m * dim, k, path)
    elif k in ("TENSORS", "TENSORS6"):
        i += 3
        i = _take_legacy_values(tok, i, (9 if k == "TENSORS" else 6) * m, k, path)
    elif k == "FIELD":
        narr = int(tok[i + 2])
        i += 3
        for _ in range(narr):
            ncomp, ntup = int(tok[i + 1]), int(tok[i + 2])
            i += 4
            i = _take_legacy_values(tok, i, ncomp * ntup, f"FIELD array {tok[i - 4]}", path)
    else:
        return None
    return i


def _check_vertices(pts: np.ndarray, path: str) -> None:
    """Finite and within ``COORD_LIMIT_MM`` before any VTK filter computes with them."""
    if pts.shape[0] == 0:
        raise InputError("the file holds no points", path)
    if not np.isfinite(pts).all():
        row = int(np.flatnonzero(~np.isfinite(pts).all(axis=1))[0])
        raise InputError(f"vertex {row} holds NaN or infinity", path)
    check_coordinate_range(pts, path)


def unit_normals_or_none(n: np.ndarray | None, pts: np.ndarray) -> np.ndarray | None:
    """The file's vertex normals made unit, or None when any is missing, zero or not finite."""
    if n is None or n.shape != pts.shape or not np.isfinite(n).all():
        return None
    if np.abs(n).max() > 1e100:  # only directions matter; scale before squaring overflows
        n = n / np.abs(n).max(axis=1)[:, None]
    ln = np.linalg.norm(n, axis=1)
    return n / ln[:, None] if np.all(ln > 1e-12) else None


def read_mesh(path: str, suffix: str) -> PointSet:
    """A PLY, OBJ or STL file (``suffix``) read with numpy; its faces triangulated by VTK."""
    if os.path.getsize(path) == 0:
        raise InputError("the file is empty", path)
    mesh = {".ply": read_ply, ".obj": read_obj, ".stl": read_stl}[suffix](path)
    pts = mesh.points
    _check_vertices(pts, path)
    normals = unit_normals_or_none(mesh.normals, pts)
    if mesh.polygons is None:
        return finish_point_set(PointSet(pts, normals, None, None, None, 3, path, mesh.groups))
    import pyvista as pv

    _vtk_log()
    return _surface(pv.PolyData(pts, mesh.polygons), normals, path, mesh.groups)


def _surface(data, normals, path: str, groups=None) -> PointSet:
    """PointSet of a checked PolyData with faces: triangulated, windings made consistent (the
    points kept as they are, so ``groups``' vertex indices stay theirs)."""
    # Meshes in the wild mix windings; make neighbouring triangles agree (the engine then
    # turns a closed mesh outward by its signed volume).
    tri = data.triangulate().compute_normals(cell_normals=True, point_normals=False,
                                             split_vertices=False, consistent_normals=True,
                                             auto_orient_normals=False)
    faces = np.asarray(tri.faces).reshape(-1, 4) if tri.n_cells else np.zeros((0, 4), int)
    triangles = None
    if faces.size and np.all(faces[:, 0] == 3):
        triangles = faces[:, 1:].astype(np.int64)
    pts = np.asarray(tri.points, dtype=np.float64)
    if normals is not None and normals.shape != pts.shape:
        normals = None
    if groups is not None and pts.shape[0] != data.n_points:
        raise InputError("its mesh's points changed in triangulation; its groups cannot be "
                         "kept", path)
    return finish_point_set(PointSet(pts, normals, None, None, triangles, 3, path, groups))


_VTK_LOCK = threading.Lock()
_VTK_WINDOW = None


def _vtk_log():
    """VTK's message window, set once per process to a string buffer: VTK's errors, warnings
    and debug text never reach the user's terminal; readers inspect them instead."""
    global _VTK_WINDOW
    if _VTK_WINDOW is None:
        from vtkmodules.vtkCommonCore import vtkLogger, vtkOutputWindow, vtkStringOutputWindow

        window = vtkStringOutputWindow()
        vtkOutputWindow.SetInstance(window)
        vtkLogger.SetStderrVerbosity(vtkLogger.VERBOSITY_OFF)
        _VTK_WINDOW = window
    return _VTK_WINDOW


def _vtk_reader(suffix: str):
    if suffix == ".vtp":
        from vtkmodules.vtkIOXML import vtkXMLPolyDataReader
        return vtkXMLPolyDataReader()
    if suffix == ".vts":
        from vtkmodules.vtkIOXML import vtkXMLStructuredGridReader
        return vtkXMLStructuredGridReader()
    from vtkmodules.vtkIOLegacy import vtkDataSetReader
    reader = vtkDataSetReader()
    reader.ReadAllNormalsOn()
    return reader


def _check_cells(data, path: str) -> None:
    """Every cell's point indices within the point count, offsets consistent: VTK's filters
    trust them and crash the process otherwise."""
    from vtkmodules.util.numpy_support import vtk_to_numpy

    n = data.GetNumberOfPoints()
    if data.IsA("vtkPolyData"):
        arrays = [data.GetVerts(), data.GetLines(), data.GetPolys(), data.GetStrips()]
    elif data.IsA("vtkUnstructuredGrid"):
        arrays = [data.GetCells()]
    else:
        arrays = []
    for ca in arrays:
        if ca is None or ca.GetNumberOfCells() == 0:
            continue
        conn = vtk_to_numpy(ca.GetConnectivityArray())
        offsets = vtk_to_numpy(ca.GetOffsetsArray())
        if offsets[0] != 0 or offsets[-1] != conn.size or np.any(np.diff(offsets) < 0):
            raise InputError("damaged: its cell offsets are inconsistent", path)
        bad = np.flatnonzero((conn < 0) | (conn >= n))
        if bad.size:
            cell = int(np.searchsorted(offsets, bad[0], side="right")) - 1
            raise InputError(f"damaged: cell {cell} refers to point {conn[bad[0]]}; the file "
                             f"holds {n} points", path)


VTK_READ_TIMEOUT_S = 300.0
"""Longest a VTK reader may take (in its own process) before the file is called unreadable."""


def read_vtk(path: str, suffix: str) -> PointSet:
    """A VTK file read in a child process: VTK's readers trust offsets and sizes inside the file
    and can crash on a damaged one (a flipped byte in a binary legacy file's offsets does), which
    here becomes an InputError instead of the end of the program. The child checks the cells
    before handing back plain arrays; the filters then run here on checked data."""
    import pyvista as pv

    if os.path.getsize(path) == 0:
        raise InputError("the file is empty", path)
    arrays = arrays_from_child("engine.io.meshes", path, [suffix], "VTK's reader",
                               "damaged file", VTK_READ_TIMEOUT_S)
    pts = arrays["points"]
    _check_vertices(pts, path)
    normals = unit_normals_or_none(arrays.get("normals"), pts)
    if "grid" in arrays:
        nu, nv = (int(v) for v in arrays["grid"])
        return finish_point_set(PointSet(pts, normals, None, (nu, nv), None, 3, path))
    polys, strips = arrays.get("polys"), arrays.get("strips")
    if (polys is not None and polys.size) or (strips is not None and strips.size):
        kw = {}
        if polys is not None and polys.size:
            kw["faces"] = polys
        if strips is not None and strips.size:
            kw["strips"] = strips
        return _surface(pv.PolyData(pts, **kw), normals, path)
    return finish_point_set(PointSet(pts, normals, None, None, None, 3, path))




def _vtk_arrays(path: str, suffix: str) -> dict:
    """Plain arrays of a VTK file, cells checked (run in the child process): ``points``
    (n, 3); ``polys``/``strips`` VTK cell arrays; ``normals`` (n, 3); ``grid`` (nu, nv)."""
    import pyvista as pv

    if suffix == ".vtk":
        check_legacy_ascii_vtk(read_bytes(path), path)
    window = _vtk_log()
    reader = _vtk_reader(suffix)
    reader.SetFileName(path)
    with _VTK_LOCK:
        before = len(window.GetOutput() or "")
        reader.Update()
        reported = (window.GetOutput() or "")[before:]
    what = "VTK legacy" if suffix == ".vtk" else f"VTK XML ({suffix})"
    if reported.strip() or reader.GetErrorCode():
        raise InputError(f"damaged or truncated {what} file (VTK's reader reports an error)",
                         path)
    out = reader.GetOutputDataObject(0)
    if out is None or out.GetNumberOfPoints() == 0:
        raise InputError("the file holds no points", path)
    if out.IsA("vtkMultiBlockDataSet"):
        raise InputError("multi-block files are not supported; export one surface", path)
    _check_cells(out, path)
    data = pv.wrap(out)
    arrays = {"points": np.asarray(data.points, dtype=np.float64)}
    for key in ("Normals", "normals"):
        if key in data.point_data:
            arrays["normals"] = np.asarray(data.point_data[key], dtype=np.float64)
            break
    if isinstance(data, pv.StructuredGrid):
        dims = tuple(int(d) for d in data.dimensions)
        flat = [d for d in dims if d > 1]
        if len(flat) != 2:
            raise InputError(f"structured grid of dimensions {dims}: a surface grid has exactly "
                             "two dimensions above 1", path)
        if flat[0] * flat[1] != data.n_points:
            raise InputError(f"damaged: a {flat[0]} x {flat[1]} grid with {data.n_points} "
                             "points", path)
        arrays["grid"] = np.array(flat)
    elif isinstance(data, pv.PolyData):
        arrays["polys"] = np.asarray(data.faces, dtype=np.int64)
        arrays["strips"] = np.asarray(data.strips, dtype=np.int64)
    else:
        surf = data.extract_surface().triangulate()
        arrays = {"points": np.asarray(surf.points, dtype=np.float64),
                  "polys": np.asarray(surf.faces, dtype=np.int64)}
    return arrays


def _vtk_child(argv: list[str]) -> int:
    path, suffix, out = argv
    try:
        arrays = _vtk_arrays(path, suffix)
    except InputError as e:
        print(e.message)
        return CHILD_INPUT_ERROR
    np.savez(out, **arrays)
    return 0


if __name__ == "__main__":  # the child process of read_vtk
    import sys

    sys.exit(_vtk_child(sys.argv[1:]))
