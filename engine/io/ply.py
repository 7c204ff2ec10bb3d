"""PLY meshes read with numpy, every declared count checked before any native code sees them
(see ``engine.io.meshes``).

PLY: ``ascii``, ``binary_little_endian`` and ``binary_big_endian``, any elements and properties
(scalar and list); the ``vertex`` element's x y z (and nx ny nz) and the ``face`` element's
``vertex_indices`` (or ``vertex_index``) list are used, other elements (a scanner's
``range_grid``, ``edge``, ``material``) are checked for length and skipped. Groups: a scalar
face property named ``group``, ``part``, ``region``, ``face_id`` or ``label`` (the first of
these the face declares) numbers each face's group, its whole-number values naming the groups
("1", "2", … as written, ``-3`` included; PLY holds no strings); without one, the same
property on the vertices groups them (a labelled point cloud). A value that is no whole number
is refused.
"""

from __future__ import annotations

import re
import struct
from dataclasses import dataclass, field

import numpy as np

from engine.errors import InputError

from .mesh_data import MeshData, cells, split_by, vertex_groups
from .points import read_bytes, split_lines


GROUP_PROPERTIES = ("group", "part", "region", "face_id", "label")
"""Names of the PLY scalar property that numbers a face's (else a vertex's) group, first wins."""


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
    order = _PLY_FORMATS[fmt]  # the binary byte order; None: ASCII
    try:
        if order is None:
            values = _ply_ascii(raw, m.end(), header_lines, elements, path)
        else:
            values = _ply_binary(raw, m.end(), order, elements, path)
        return _ply_mesh(values, path)
    except InputError:
        held = None if order is None else _vertices_that_fit(raw, m.end(), order, elements)
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
        polygons = cells(values["face"], n, path,
                          lambda i: (f"face {i}", None if lines is None else int(lines[i])))
    prop = next((p for p in GROUP_PROPERTIES if p in vert), None)
    if polygons is not None and values.get("face_group") is not None:
        numbers, name = values["face_group"]
        names, ids = _group_numbers(numbers, name, "face", path, lines)
        groups = vertex_groups(values["face"], np.arange(ids.size), ids, names, n)
    elif prop is not None:
        names, ids = _group_numbers(vert[prop], prop, "vertex", path)
        groups = dict(zip(names, split_by(ids, len(names))))
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
    counts: list[int | None] = []  # each property's list length (None: not a list)
    pos = off
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
    for j, (p, count) in enumerate(zip(el.props, counts)):
        if p.count_code and count is not None:
            fields += [(f"n{j}", order + p.count_code),
                       (f"l{j}", order + p.code, (max(count, 0),))]
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
