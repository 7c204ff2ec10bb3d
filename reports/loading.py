"""Reading any supported input file into an :class:`engine.pointio.PointSet`.

Text and ``.npy`` point files are read by the engine itself; meshes and VTK formats go through
pyvista/VTK, which the engine must not import:

* ``.ply`` (ASCII or binary; scanner PLYs with extra elements such as ``range_grid`` are fine),
  ``.stl``, ``.obj``, ``.vtk``, ``.vtp``: points, and triangles when the file has faces
  (polygons are triangulated); ``Normals`` point data when present;
* ``.vts`` (structured grid): a u-v grid (x fastest), its cells are the facets.
"""

from __future__ import annotations

import hashlib
import os

import numpy as np

from engine.errors import InputError, InputNotFoundError
from engine.pointio import TEXT_SUFFIXES, PointSet, finish_point_set, read_points

MESH_SUFFIXES = (".ply", ".stl", ".obj", ".vtk", ".vtp", ".vts")
ALL_SUFFIXES = TEXT_SUFFIXES + (".npy",) + MESH_SUFFIXES
TEMPLATE_SUFFIXES = (".dxf", ".dat")
"""2D contour templates: DXF drawings and airfoil ordinates (see reports.template2d)."""


def is_template(path: str) -> bool:
    return os.path.splitext(path)[1].lower() in TEMPLATE_SUFFIXES


def load_point_set(path: str | os.PathLike) -> PointSet:
    """Read a point, mesh or grid file (units: millimetres unless the file says otherwise)."""
    path = os.fspath(path)
    if not os.path.exists(path):
        raise InputNotFoundError("no such file", path)
    if not os.path.isfile(path):
        raise InputNotFoundError("is not a file", path)
    suffix = os.path.splitext(path)[1].lower()
    if suffix in MESH_SUFFIXES:
        return _read_vtk(path, suffix)
    if suffix in TEXT_SUFFIXES or suffix == ".npy":
        return read_points(path)
    raise InputError(f"unsupported file type '{suffix or '(none)'}'; supported: "
                     f"{' '.join(ALL_SUFFIXES)}", path)


def _read_vtk(path: str, suffix: str) -> PointSet:
    import pyvista as pv

    if os.path.getsize(path) == 0:
        raise InputError("the file is empty", path)
    try:
        data = pv.read(path)
    except Exception as e:  # VTK readers raise assorted types for damaged files
        raise InputError(f"not a readable {suffix[1:].upper()} file ({e})", path) from e
    if data is None or data.n_points == 0:
        raise InputError("the file holds no points", path)
    if isinstance(data, pv.MultiBlock):
        raise InputError("multi-block files are not supported; export one surface", path)
    pts = np.asarray(data.points, dtype=np.float64)
    normals = None
    for key in ("Normals", "normals"):
        if key in data.point_data and np.asarray(data.point_data[key]).shape == pts.shape:
            n = np.asarray(data.point_data[key], dtype=np.float64)
            ln = np.linalg.norm(n, axis=1)
            if np.all(ln > 1e-12) and np.isfinite(n).all():
                normals = n / ln[:, None]
            break
    if isinstance(data, pv.StructuredGrid):
        dims = tuple(int(d) for d in data.dimensions)
        flat = [d for d in dims if d > 1]
        if len(flat) != 2:
            raise InputError(f"structured grid of dimensions {dims}: a surface grid has exactly "
                             "two dimensions above 1", path)
        return finish_point_set(PointSet(pts, normals, None, (flat[0], flat[1]), None, 3, path))
    triangles = None
    if isinstance(data, pv.PolyData) and (data.n_faces > 0 or data.n_strips > 0):
        # Meshes in the wild mix windings; make neighbouring triangles agree (the engine then
        # turns a closed mesh outward by its signed volume).
        tri = data.triangulate().compute_normals(cell_normals=True, point_normals=False,
                                                 split_vertices=False, consistent_normals=True,
                                                 auto_orient_normals=False)
        faces = np.asarray(tri.faces).reshape(-1, 4)
        if faces.size and np.all(faces[:, 0] == 3):
            triangles = faces[:, 1:].astype(np.int64)
        pts = np.asarray(tri.points, dtype=np.float64)
        if normals is not None and normals.shape != pts.shape:
            normals = None
    elif not isinstance(data, pv.PolyData):
        surf = data.extract_surface().triangulate()
        pts = np.asarray(surf.points, dtype=np.float64)
        faces = np.asarray(surf.faces).reshape(-1, 4)
        triangles = faces[:, 1:].astype(np.int64) if faces.size else None
        normals = None
    if not np.isfinite(pts).all():
        row = int(np.flatnonzero(~np.isfinite(pts).all(axis=1))[0])
        raise InputError(f"vertex {row} holds NaN or infinity", path)
    return finish_point_set(PointSet(pts, normals, None, None, triangles, 3, path))


def sha256_of(path: str | os.PathLike) -> str:
    """SHA-256 of a file's bytes, hex. InputError (naming the file) when it cannot be read."""
    h = hashlib.sha256()
    try:
        with open(path, "rb") as f:
            for chunk in iter(lambda: f.read(1 << 20), b""):
                h.update(chunk)
    except FileNotFoundError:
        raise InputNotFoundError("no such file", os.fspath(path)) from None
    except OSError as e:
        raise InputError(f"cannot be read ({e.strerror})", os.fspath(path)) from e
    return h.hexdigest()
