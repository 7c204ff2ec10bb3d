"""Reading any supported input file into an :class:`engine.pointio.PointSet`.

Text and ``.npy`` point files are read by the engine itself; meshes are read and checked by
``reports.meshfiles`` (numpy) before VTK filters see them, VTK formats through VTK's own readers,
which the engine must not import:

* ``.ply`` (ASCII or binary; scanner PLYs with extra elements such as ``range_grid`` are fine),
  ``.stl``, ``.obj``: points, and triangles when the file has faces (polygons are triangulated);
  PLY ``nx ny nz`` normals when present. Declared counts, face indices and file length are
  checked first: a damaged file is refused ("truncated: the header declares …"), never read in
  part and never handed to native code that could crash the process on it;
* ``.vtk``, ``.vtp``: the same, read by VTK; any error or warning VTK reports while reading means
  a damaged or truncated file, an ASCII legacy file's section lengths are checked first (VTK
  reads one cut short without complaint), and cell indices before any VTK filter runs;
* ``.vts`` (structured grid): a u-v grid (x fastest), its cells are the facets.

VTK's own messages never reach the terminal: they are routed into a string (see ``_vtk_log``).
"""

from __future__ import annotations

import hashlib
import os
import threading

import numpy as np

from engine.errors import InputError, InputNotFoundError
from engine.pointio import (TEXT_SUFFIXES, PointSet, check_coordinate_range,
                            finish_point_set, read_points)

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
    if suffix in (".ply", ".obj", ".stl"):
        return _read_mesh(path, suffix)
    if suffix in MESH_SUFFIXES:
        return _read_vtk(path, suffix)
    if suffix in TEXT_SUFFIXES or suffix == ".npy":
        return read_points(path)
    raise InputError(f"unsupported file type '{suffix or '(none)'}'; supported: "
                     f"{' '.join(ALL_SUFFIXES)}", path)


def _check_vertices(pts: np.ndarray, path: str) -> None:
    """Finite and within ``COORD_LIMIT_MM`` before any VTK filter computes with them."""
    if pts.shape[0] == 0:
        raise InputError("the file holds no points", path)
    if not np.isfinite(pts).all():
        row = int(np.flatnonzero(~np.isfinite(pts).all(axis=1))[0])
        raise InputError(f"vertex {row} holds NaN or infinity", path)
    check_coordinate_range(pts, path)


def _unit_normals_or_none(n: np.ndarray | None, pts: np.ndarray) -> np.ndarray | None:
    """The file's vertex normals made unit, or None when any is missing, zero or not finite."""
    if n is None or n.shape != pts.shape or not np.isfinite(n).all():
        return None
    if np.abs(n).max() > 1e100:  # only directions matter; scale before squaring overflows
        n = n / np.abs(n).max(axis=1)[:, None]
    ln = np.linalg.norm(n, axis=1)
    return n / ln[:, None] if np.all(ln > 1e-12) else None


def _read_mesh(path: str, suffix: str) -> PointSet:
    from .meshfiles import read_obj, read_ply, read_stl

    if os.path.getsize(path) == 0:
        raise InputError("the file is empty", path)
    mesh = {".ply": read_ply, ".obj": read_obj, ".stl": read_stl}[suffix](path)
    pts = mesh.points
    _check_vertices(pts, path)
    normals = _unit_normals_or_none(mesh.normals, pts)
    if mesh.polygons is None:
        return finish_point_set(PointSet(pts, normals, None, None, None, 3, path))
    import pyvista as pv

    _vtk_log()
    return _surface(pv.PolyData(pts, mesh.polygons), normals, path)


def _surface(data, normals, path: str) -> PointSet:
    """PointSet of a checked PolyData with faces: triangulated, windings made consistent."""
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
    return finish_point_set(PointSet(pts, normals, None, None, triangles, 3, path))


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


def _read_vtk(path: str, suffix: str) -> PointSet:
    """A VTK file read in a child process: VTK's readers trust offsets and sizes inside the file
    and can crash on a damaged one (a flipped byte in a binary legacy file's offsets does), which
    here becomes an InputError instead of the end of the program. The child checks the cells
    before handing back plain arrays; the filters then run here on checked data."""
    import subprocess
    import sys
    import tempfile

    import pyvista as pv

    if os.path.getsize(path) == 0:
        raise InputError("the file is empty", path)
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    env = dict(os.environ, PYTHONPATH=root + os.pathsep + os.environ.get("PYTHONPATH", ""))
    with tempfile.TemporaryDirectory(prefix="qa-vtk-") as tmp:
        out = os.path.join(tmp, "arrays.npz")
        try:
            r = subprocess.run([sys.executable, "-m", "reports.loading", path, suffix, out],
                               capture_output=True, text=True, env=env,
                               timeout=VTK_READ_TIMEOUT_S)
        except subprocess.TimeoutExpired:
            raise InputError(f"VTK's reader did not finish within {VTK_READ_TIMEOUT_S:g} s "
                             "(damaged file?)", path) from None
        if r.returncode == _CHILD_INPUT_ERROR:
            raise InputError(r.stdout.strip() or "damaged file", path)
        if r.returncode != 0:
            how = f"signal {-r.returncode}" if r.returncode < 0 else f"exit {r.returncode}"
            raise InputError(f"damaged: VTK's reader crashed reading it ({how})", path)
        with np.load(out, allow_pickle=False) as z:
            arrays = {k: z[k] for k in z.files}
    pts = arrays["points"]
    _check_vertices(pts, path)
    normals = _unit_normals_or_none(arrays.get("normals"), pts)
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


_CHILD_INPUT_ERROR = 3


def _vtk_arrays(path: str, suffix: str) -> dict:
    """Plain arrays of a VTK file, cells checked (run in the child process): ``points``
    (n, 3); ``polys``/``strips`` VTK cell arrays; ``normals`` (n, 3); ``grid`` (nu, nv)."""
    import pyvista as pv

    if suffix == ".vtk":
        from .meshfiles import check_legacy_ascii_vtk

        with open(path, "rb") as f:
            check_legacy_ascii_vtk(f.read(), path)
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
        return _CHILD_INPUT_ERROR
    np.savez(out, **arrays)
    return 0


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


if __name__ == "__main__":  # the child process of _read_vtk
    import sys

    sys.exit(_vtk_child(sys.argv[1:]))
