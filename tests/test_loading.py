"""Mesh and VTK formats through engine.io, and their bad-input classes."""

import numpy as np
import pytest
import pyvista as pv

from engine.errors import InputError, InputNotFoundError
from engine.nominal import Nominal
from engine.io import load_point_set


def _sphere():
    return pv.Sphere(radius=10.0, theta_resolution=24, phi_resolution=16)


@pytest.mark.parametrize("suffix, binary", [(".ply", True), (".ply", False), (".stl", True),
                                            (".stl", False), (".vtk", True), (".vtp", True),
                                            (".obj", None)])
def test_mesh_formats_give_triangles_and_outward_nominal(tmp_path, suffix, binary):
    s = _sphere()
    f = tmp_path / f"s{suffix}"
    if binary is None:
        s.save(f)
    else:
        s.save(f, binary=binary)
    ps = load_point_set(f)
    assert ps.triangles is not None and ps.triangles.shape[1] == 3
    nom = Nominal.from_point_set(ps)
    # Outward: every vertex normal points away from the centre.
    assert np.all(np.einsum("ij,ij->i", nom.normals(np.arange(nom.n)), nom.points) > 0)


def test_ply_point_cloud_with_extra_scanner_elements(tmp_path):
    rng = np.random.default_rng(0)
    pts = rng.normal(size=(30, 3))
    lines = ["ply", "format ascii 1.0", "obj_info num_cols 5", "element vertex 30",
             "property float x", "property float y", "property float z",
             "element range_grid 6", "property list uchar int vertex_indices", "end_header"]
    lines += [f"{p[0]:.6f} {p[1]:.6f} {p[2]:.6f}" for p in pts]
    lines += ["5 0 1 2 3 4", "5 5 6 7 8 9", "0", "0", "5 10 11 12 13 14", "0"]
    f = tmp_path / "scan.ply"
    f.write_text("\n".join(lines) + "\n")
    ps = load_point_set(f)
    assert ps.triangles is None and np.allclose(ps.points, pts, atol=1e-6)


def test_ply_normals_are_kept(tmp_path):
    s = _sphere().compute_normals()
    f = tmp_path / "n.ply"
    s.save(f)
    ps = load_point_set(f)
    assert ps.normals is not None and np.allclose(np.linalg.norm(ps.normals, axis=1), 1.0)


def test_vts_structured_grid_is_a_uv_grid(tmp_path):
    x, y = np.meshgrid(np.linspace(0, 10, 11), np.linspace(0, 5, 6), indexing="xy")
    z = 0.1 * x * y
    g = pv.StructuredGrid(x[..., None], y[..., None], z[..., None])
    f = tmp_path / "g.vts"
    g.save(f)
    ps = load_point_set(f)
    assert sorted(ps.grid_shape) == [6, 11] and ps.grid_shape[0] * ps.grid_shape[1] == ps.n
    nom = Nominal.from_point_set(ps)
    assert nom.kind == "grid" and nom.triangles.shape[0] == 2 * 10 * 5


def test_bad_mesh_files(tmp_path):
    empty = tmp_path / "e.stl"
    empty.write_bytes(b"")
    with pytest.raises(InputError, match="e.stl: the file is empty"):
        load_point_set(empty)
    junk = tmp_path / "j.ply"
    junk.write_text("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nend_header\n1\n")
    with pytest.raises(InputError, match="j.ply"):
        load_point_set(junk)
    with pytest.raises(InputNotFoundError, match="no such file"):
        load_point_set(tmp_path / "missing.stl")
    with pytest.raises(InputNotFoundError, match="is a folder, not a file"):
        load_point_set(tmp_path)
    other = tmp_path / "x.step"
    other.write_text("ISO-10303-21;")
    with pytest.raises(InputError, match="unsupported file type '.step'"):
        load_point_set(other)
