"""E57 scanner files (ASTM E2807) -> a PointSet: the points of every scan, each moved by its
scan's pose into the file's frame, in millimetres (E57 coordinates are metres), with the
intensity and the surface normals (the ``nor:`` extension) when every scan has them.

E57 is read with pye57, which wraps libE57Format (native code). A damaged file must never take
the program down with it, so, as VTK's formats are (engine.io.vtk.read_vtk), the file is
read in a child process (``python -m engine.io.e57`` is that child) after its header has been
checked here: the signature, the version, the declared length against the file's (a truncated
file), the page size and where the XML section lies. libE57Format then checks each page's
CRC-32C as it reads. Anything the child reports, or its crash, is an InputError naming the file.
"""

from __future__ import annotations

import os
import struct

import numpy as np

from engine.errors import InputError, InputNotFoundError
from . import formats
from engine.pointset import PointSet

from .child import CHILD_INPUT_ERROR, arrays_from_child
from .points import finish_point_set

SIGNATURE = b"ASTM-E57"
HEADER = struct.Struct("<8sIIQQQQ")
"""The file header: signature, major and minor version, physical file length, XML section's
physical offset and logical length, page size (ASTM E2807 §9.2)."""
PAGE_SIZE = 1024
"""E57 pages: 1020 bytes of data and a CRC-32C each."""
MM_PER_M = 1000.0
"""E57 coordinates (and pose translations) are metres; the product's unit is the mm."""
E57_READ_TIMEOUT_S = 300.0
"""Longest the E57 reader may take (in its own process) before the file is called
unreadable."""
NORMALS = ("nor:normalX", "nor:normalY", "nor:normalZ")
"""The point fields of the E57 surface-normals extension."""


def check_header(head: bytes, size: int, path: str) -> None:
    """Refuse (InputError) a file whose first bytes ``head`` are no E57 header fit for a file of
    ``size`` bytes: before any native code sees it."""
    if len(head) < HEADER.size or not head.startswith(SIGNATURE):
        raise InputError("not an E57 file (it does not start with the E57 signature "
                         "'ASTM-E57')", path)
    _, major, minor, length, xml_offset, xml_length, page = HEADER.unpack(head[:HEADER.size])
    if major != 1:
        raise InputError(f"E57 version {major}.{minor} is not supported (only 1.x)", path)
    if length != size:
        what = "truncated" if size < length else "damaged"
        raise InputError(f"{what}: the header declares {length:,} bytes, the file holds "
                         f"{size:,}", path)
    if page != PAGE_SIZE or size % PAGE_SIZE:
        raise InputError(f"damaged: page size {page} and length {size:,} (E57 pages are "
                         f"{PAGE_SIZE} bytes)", path)
    # The XML section's logical length grows by 4 bytes of CRC a page when laid out physically.
    if not (HEADER.size <= xml_offset < size
            and xml_offset + xml_length * PAGE_SIZE // (PAGE_SIZE - 4) <= size + PAGE_SIZE):
        raise InputError(f"damaged: the XML section ({xml_length:,} bytes at {xml_offset:,}) "
                         "lies outside the file", path)


def read_e57(path: str) -> PointSet:
    """Every scan of the E57 file ``path`` as one PointSet in mm (see the module's docstring).
    Raises InputError for a file that is no E57 file, is truncated or damaged, or holds no
    points; never crashes."""
    size = os.path.getsize(path)
    if size == 0:
        raise InputError("the file is empty", path)
    check_header(_head(path), size, path)
    arrays = arrays_from_child("engine.io.e57", path, [], "the E57 reader", "damaged E57 file",
                               E57_READ_TIMEOUT_S)
    return _point_set(arrays, path)


def _head(path: str) -> bytes:
    formats.check_file(path)
    try:
        with open(path, "rb") as f:
            return f.read(HEADER.size)
    except FileNotFoundError:
        raise InputNotFoundError("no such file", path) from None
    except OSError as e:
        raise InputError(f"cannot be read ({e.strerror})", path) from e


def _point_set(arrays: dict, path: str) -> PointSet:
    """The child's arrays (metres) as a checked PointSet in mm."""
    from .mesh_data import unit_normals_or_none

    pts = arrays["points"] * MM_PER_M
    if pts.shape[0] == 0:
        raise InputError("the file holds no valid points", path)
    if not np.isfinite(pts).all():
        row = int(np.flatnonzero(~np.isfinite(pts).all(axis=1))[0])
        raise InputError(f"point {row} holds NaN or infinity", path)
    normals = unit_normals_or_none(arrays.get("normals"), pts)
    intensity = arrays.get("intensity")
    if intensity is not None and not np.isfinite(intensity).all():
        intensity = None
    return finish_point_set(PointSet(pts, normals, None, None, None, 3, path,
                                     intensity=intensity))


# ---------------------------------------------------------------------- the child process
def _quaternion_matrix(q: np.ndarray, scan: int) -> np.ndarray:
    """The rotation of the unit quaternion q = (w, x, y, z)."""
    norm = float(np.linalg.norm(q))
    if not (np.isfinite(q).all() and norm > 1e-9):
        raise InputError(f"scan {scan}'s pose rotation {q.tolist()} is no rotation")
    w, x, y, z = q / norm
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def _read_fields(e57, header, fields: list[str]) -> dict:
    """The scan's point fields ``fields`` as float64 arrays (libE57Format's conversion and
    scaling applied)."""
    from pye57 import libe57

    n = header.point_count
    data, buffers = {}, libe57.VectorSourceDestBuffer()
    for name in fields:
        data[name] = np.empty(n, np.float64)
        buffers.append(libe57.SourceDestBuffer(e57.image_file, name, data[name], n, True, True))
    reader = header.points.reader(buffers)
    try:
        got = reader.read()
    finally:
        reader.close()
    if got != n:
        raise InputError(f"damaged: a scan declares {n:,} points, {got:,} could be read")
    return data


def _scan(e57, i: int, size: int) -> dict:
    """Scan ``i``: points (n, 3) in the file's frame (metres), and intensity (n,) and normals
    (n, 3) where it has them; points its invalid-state field marks invalid left out."""
    from pye57.utils import convert_spherical_to_cartesian

    header = e57.get_header(i)
    have = set(header.point_fields)
    n = header.point_count
    if n > 8 * size:  # fewer than one bit a point: a count no file of this size can hold
        raise InputError(f"damaged: scan {i} declares {n:,} points, more than {size:,} bytes "
                         "can hold")
    cart = ["cartesianX", "cartesianY", "cartesianZ"]
    sph = ["sphericalRange", "sphericalAzimuth", "sphericalElevation"]
    coords = cart if set(cart) <= have else sph if set(sph) <= have else None
    if coords is None:
        raise InputError(f"scan {i} has neither cartesian nor spherical coordinates")
    state = ("cartesianInvalidState" if coords is cart else "sphericalInvalidState")
    fields = coords + [f for f in ("intensity", state) if f in have]
    fields += NORMALS if set(NORMALS) <= have else []
    d = _read_fields(e57, header, fields)
    xyz = np.column_stack([d[f] for f in coords])
    if coords is sph:
        xyz = convert_spherical_to_cartesian(xyz)
    valid = d[state] == 0 if state in d else np.ones(n, bool)
    out = {"points": xyz[valid]}
    if "intensity" in d:
        out["intensity"] = d["intensity"][valid]
    if NORMALS[0] in d:
        out["normals"] = np.column_stack([d[f] for f in NORMALS])[valid]
    if header.has_pose():
        R = _quaternion_matrix(np.asarray(header.rotation, float), i)
        out["points"] = out["points"] @ R.T + np.asarray(header.translation, float)
        if "normals" in out:
            out["normals"] = out["normals"] @ R.T
    return out


def _e57_arrays(path: str) -> dict:
    """Plain arrays of an E57 file (run in the child process): ``points`` (n, 3) metres in the
    file's frame; ``intensity`` (n,) and ``normals`` (n, 3) when every scan has them."""
    import pye57

    size = os.path.getsize(path)
    e57 = pye57.E57(path)
    try:
        scans = [_scan(e57, i, size) for i in range(e57.scan_count)]
    finally:
        e57.close()
    if not scans:
        raise InputError("the file holds no scan")
    arrays = {"points": np.concatenate([s["points"] for s in scans])}
    for key in ("intensity", "normals"):
        if all(key in s for s in scans):
            arrays[key] = np.concatenate([s[key] for s in scans])
    return arrays


def _e57_child(argv: list[str]) -> int:
    path, out = argv
    try:
        arrays = _e57_arrays(path)
    except InputError as e:
        print(e.message)
        return CHILD_INPUT_ERROR
    except Exception as e:  # libE57Format's E57Exception and what pye57 raises on a bad file
        # libE57Format's message is its first line; debug context follows.
        text = (str(e).strip().splitlines() or [type(e).__name__])[0][:300]
        print(f"damaged or unreadable E57 file: {text}")
        return CHILD_INPUT_ERROR
    np.savez(out, **arrays)
    return 0


if __name__ == "__main__":  # the child process of read_e57
    import sys

    sys.exit(_e57_child(sys.argv[1:]))
