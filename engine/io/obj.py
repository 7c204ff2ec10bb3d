"""OBJ meshes read with numpy, every face index checked before any native code sees it (see
``engine.io.meshes``).

OBJ: ``v`` (x y z, optional w or colour ignored), ``vn``, ``f`` with ``v``, ``v/vt``, ``v//vn``
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
"""

from __future__ import annotations

import re

import numpy as np

from engine.errors import InputError

from .mesh_data import MeshData, cells, split_by, vertex_groups
from .points import read_bytes, text_lines


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
        uniform = _obj_faces_uniform(f_rows, np.asarray(f_before), nv)
        faces = uniform if uniform is not None else [
            _obj_face(row, ln, before, nv, path)
            for row, ln, before in zip(f_rows, f_lines, f_before)]
        polygons = cells(faces, nv, path, lambda i: ("face", f_lines[i]))
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
        """{group: ascending indices of the vertices of its faces} (faces checked by cells;
        face_set (m,) each face's id), the groups in the order the file names them; None for a
        file without g or o. A name no face is under names no group."""
        if not self.named:
            return None
        sets = sorted(self.sets, key=self.sets.__getitem__)
        used = np.zeros(len(sets), dtype=bool)
        used[face_set] = True
        names = list(dict.fromkeys(n for k, u in zip(sets, used) if u for n in k))
        index = {n: i for i, n in enumerate(names)}
        members = [np.array([index[n] for n in k] if u else [], dtype=np.int64)
                   for k, u in zip(sets, used)]
        by_set = split_by(face_set, len(sets))
        face_of = np.concatenate([np.repeat(f, m.size) for f, m in zip(by_set, members)])
        group_of = np.concatenate([np.tile(m, f.size) for f, m in zip(by_set, members)])
        return vertex_groups(faces, face_of, group_of, names, n_vertices)


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
