"""VTK's own formats (``.vtk``, ``.vtp``, ``.vts``) read by VTK's readers in a child process
(:func:`read_vtk`; ``python -m engine.io.vtk`` is that child), and VTK's filters that triangulate
the faces of every mesh once checked (:func:`surface`, also for ``engine.io.meshes``). VTK's own
messages never reach the terminal: they are routed into a string (see ``vtk_log``).

An ASCII legacy file's section lengths are checked first (VTK reads one cut short without
complaint), and cell indices before any VTK filter runs; any error or warning VTK reports while
reading means a damaged or truncated file. STL solids and VTK's formats carry no groups here.
"""

from __future__ import annotations

import os
import threading

import numpy as np

from engine.errors import InputError
from engine.pointset import PointSet

from .child import CHILD_INPUT_ERROR, arrays_from_child
from .mesh_data import check_vertices, unit_normals_or_none
from .points import finish_point_set, read_bytes


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


def surface(data, normals, path: str, groups=None) -> PointSet:
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


def vtk_log():
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
    arrays = arrays_from_child("engine.io.vtk", path, [suffix], "VTK's reader",
                               "damaged file", VTK_READ_TIMEOUT_S)
    pts = arrays["points"]
    check_vertices(pts, path)
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
        return surface(pv.PolyData(pts, **kw), normals, path)
    return finish_point_set(PointSet(pts, normals, None, None, None, 3, path))


def _vtk_arrays(path: str, suffix: str) -> dict:
    """Plain arrays of a VTK file, cells checked (run in the child process): ``points``
    (n, 3); ``polys``/``strips`` VTK cell arrays; ``normals`` (n, 3); ``grid`` (nu, nv)."""
    import pyvista as pv

    if suffix == ".vtk":
        check_legacy_ascii_vtk(read_bytes(path), path)
    window = vtk_log()
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
