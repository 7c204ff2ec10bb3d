"""Small E57 files written with pye57's writer for the reader's tests (coordinates in metres,
as E57 has them)."""

from __future__ import annotations

import uuid

import numpy as np

NORMALS_URI = "http://www.libe57.org/E57_EXT_surface_normals.txt"


def write_e57(path, scans) -> None:
    """Write ``scans``, each a dict: ``points`` (n, 3) metres in the scan's own frame;
    optional ``intensity`` (n,), ``normals`` (n, 3) (the ``nor:`` extension), ``invalid`` (n,)
    bool (cartesianInvalidState 2), ``rotation`` (w, x, y, z) and ``translation`` (3,) metres
    (the scan's pose: file frame = R x + t). Scans with normals are written node by node
    (pye57's write_scan_raw knows no normals), the others with write_scan_raw."""
    import pye57

    e57 = pye57.E57(str(path), mode="w")
    try:
        if any("normals" in s for s in scans):
            e57.image_file.extensionsAdd("nor", NORMALS_URI)
        for s in scans:
            if "normals" in s:
                _write_with_normals(e57, s)
                continue
            p = np.asarray(s["points"], float)
            data = {"cartesianX": p[:, 0], "cartesianY": p[:, 1], "cartesianZ": p[:, 2]}
            if "intensity" in s:
                data["intensity"] = np.asarray(s["intensity"], float)
            if "invalid" in s:
                data["cartesianInvalidState"] = np.where(s["invalid"], 2, 0).astype(np.int8)
            e57.write_scan_raw(data, rotation=np.asarray(s.get("rotation", (1, 0, 0, 0)), float),
                               translation=np.asarray(s.get("translation", (0, 0, 0)), float))
    finally:
        e57.close()


def _write_with_normals(e57, s) -> None:
    from pye57 import libe57

    imf = e57.image_file
    p = np.ascontiguousarray(s["points"], float)
    nrm = np.ascontiguousarray(s["normals"], float)
    scan = libe57.StructureNode(imf)
    scan.set("guid", libe57.StringNode(imf, "{%s}" % uuid.uuid4()))
    pose = libe57.StructureNode(imf)
    rot, tr = libe57.StructureNode(imf), libe57.StructureNode(imf)
    for k, v in zip("wxyz", s.get("rotation", (1, 0, 0, 0))):
        rot.set(k, libe57.FloatNode(imf, float(v)))
    for k, v in zip("xyz", s.get("translation", (0, 0, 0))):
        tr.set(k, libe57.FloatNode(imf, float(v)))
    pose.set("rotation", rot)
    pose.set("translation", tr)
    scan.set("pose", pose)
    proto = libe57.StructureNode(imf)
    columns = {}
    for i, name in enumerate(("cartesianX", "cartesianY", "cartesianZ")):
        proto.set(name, libe57.FloatNode(imf, float(p[:, i].min()), libe57.E57_DOUBLE,
                                         float(p[:, i].min()),
                                         float(p[:, i].max())))
        columns[name] = np.ascontiguousarray(p[:, i])
    for i, name in enumerate(("nor:normalX", "nor:normalY", "nor:normalZ")):
        proto.set(name, libe57.FloatNode(imf, 0.0, libe57.E57_SINGLE, -1.0, 1.0))
        columns[name] = np.ascontiguousarray(nrm[:, i])
    points = libe57.CompressedVectorNode(imf, proto, libe57.VectorNode(imf, True))
    scan.set("points", points)
    e57.data3d.append(scan)
    buffers = libe57.VectorSourceDestBuffer()
    for name, col in columns.items():
        buffers.append(libe57.SourceDestBuffer(imf, name, col, col.size, True, True))
    writer = points.writer(buffers)
    writer.write(p.shape[0])
    writer.close()
