"""What the mesh readers share: :class:`MeshData` (a mesh as its reader returns it), its faces
checked into a VTK cell array, its groups' vertices, and the checks of its vertices and normals.

The PLY, OBJ and STL readers (``engine.io.ply``, ``obj``, ``stl``) build a :class:`MeshData`;
:func:`engine.io.meshes.read_mesh` and :func:`engine.io.vtk.read_vtk` check its vertices and
normals before any VTK filter computes with them (see ``engine.io.meshes``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from engine.errors import InputError

from .points import check_coordinate_range


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


def cells(faces, n_vertices: int, path: str, where) -> np.ndarray:
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


def split_by(ids: np.ndarray, count: int) -> list[np.ndarray]:
    """For ids (m,) in [0, count): the ascending positions holding each id, id by id."""
    order = np.argsort(ids, kind="stable")
    bounds = np.searchsorted(ids[order], np.arange(count + 1))
    return [order[bounds[i]:bounds[i + 1]] for i in range(count)]


def vertex_groups(faces, face_of: np.ndarray, group_of: np.ndarray, names: list[str],
                   n_vertices: int) -> dict[str, np.ndarray]:
    """{name: ascending indices of the vertices of its faces}, each pair (face_of[i],
    group_of[i]) putting a face (checked by :func:`cells`) into group names[group_of[i]]."""
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
            for name, i in zip(names, split_by(key // n_vertices, len(names)))}


def check_vertices(pts: np.ndarray, path: str) -> None:
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
