"""Malformed, truncated, oddly encoded or absurd input files: refused with a message naming the
file and the problem (exit 65 from the CLI), never read in part, never a native crash, never a
numpy warning or VTK's own output on the terminal.

Files that once crashed the process (exit 134/139) are read in a subprocess running the CLI, so a
regression shows as a failed assertion rather than a dead test run.
"""

import os
import struct
import subprocess
import sys

import ezdxf
import numpy as np
import pytest

from engine.errors import InputError
from engine.io.points import read_points
from engine.io import load_point_set
from engine.io.templates import read_airfoil_template, read_dxf_template

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

# A closed cube (8 vertices, 6 quads), outward winding; total area 6 for side 1.
CUBE_V = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0],
                   [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]], dtype=float)
CUBE_F = [[0, 3, 2, 1], [4, 5, 6, 7], [0, 1, 5, 4], [1, 2, 6, 5], [2, 3, 7, 6], [3, 0, 4, 7]]


def _cloud(n=60, seed=0):
    return np.random.default_rng(seed).normal(size=(n, 3)) * 10.0


def ply_ascii(vertices, faces, declared_vertices=None, extra_header=()):
    nv = len(vertices) if declared_vertices is None else declared_vertices
    head = ["ply", "format ascii 1.0", *extra_header, f"element vertex {nv}", "property float x",
            "property float y", "property float z", f"element face {len(faces)}",
            "property list uchar int vertex_indices", "end_header"]
    rows = [f"{p[0]:.6f} {p[1]:.6f} {p[2]:.6f}" for p in vertices]
    rows += [" ".join(str(v) for v in [len(f), *f]) for f in faces]
    return "\n".join(head + rows) + "\n"


def ply_binary(vertices, faces, order="<", declared_vertices=None):
    nv = len(vertices) if declared_vertices is None else declared_vertices
    fmt = {"<": "binary_little_endian", ">": "binary_big_endian"}[order]
    head = (f"ply\nformat {fmt} 1.0\nelement vertex {nv}\nproperty float x\nproperty float y\n"
            f"property float z\nelement face {len(faces)}\nproperty list uchar int vertex_indices\n"
            "end_header\n").encode()
    body = np.asarray(vertices, dtype=order + "f4").tobytes()
    for f in faces:
        body += struct.pack(f"{order}B{len(f)}i", len(f), *f)
    return head + body


def _triangle_area(ps):
    t = ps.points[ps.triangles]
    return 0.5 * np.linalg.norm(np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]), axis=1).sum()


def _cli(tmp_path, nominal, measured=None):
    """Run ``qa-inspect inspect`` on the files in a fresh process of this worktree's code."""
    if measured is None:
        measured = tmp_path / "measured.xyz"
        np.savetxt(measured, _cloud(), fmt="%.6f")
    env = dict(os.environ, PYTHONPATH=ROOT + os.pathsep + os.environ.get("PYTHONPATH", ""))
    return subprocess.run([sys.executable, "-m", "qa_app.cli", "inspect", str(nominal),
                           str(measured), "--tol", "0.1"], capture_output=True, text=True,
                          cwd=ROOT, env=env, timeout=120)


# ------------------------------------------------------------------ crashes, in a subprocess

def _obj_missing_vertex(tmp_path):
    f = tmp_path / "bad.obj"
    f.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\nf 1 2 9\n")
    return f, r"bad\.obj:6: face refers to vertex 9; the file holds 4 vertices"


def _ply_binary_fewer_declared(tmp_path):
    f = tmp_path / "fewer.ply"
    v = _cloud(40)
    f.write_bytes(ply_binary(v, [[i, i + 1, i + 2] for i in range(0, 36, 3)],
                             declared_vertices=25))
    return f, r"fewer\.ply: inconsistent: the header declares 25 vertices, the file holds 40"


def _ply_ascii_fewer_declared(tmp_path):
    f = tmp_path / "fewer.ply"
    v = _cloud(40)
    f.write_text(ply_ascii(v, [[i, i + 1, i + 2] for i in range(0, 36, 3)], declared_vertices=25))
    return f, r"fewer\.ply: inconsistent: the header declares 25 vertices, the file holds 40"


def _ply_ascii_more_declared(tmp_path):
    # The 90,000 declared for 60,000 held, scaled down: face rows must not become points.
    f = tmp_path / "more.ply"
    v = _cloud(600)
    f.write_text(ply_ascii(v, [[i, i + 1, i + 2] for i in range(0, 597, 3)],
                           declared_vertices=900))
    return f, r"more\.ply:\d+: truncated: the header declares 900 vertices, the file holds 600"


def _vtk_legacy_bad_index(tmp_path):
    import pyvista as pv

    s = pv.Sphere(theta_resolution=8, phi_resolution=6)
    src = tmp_path / "s.vtk"
    s.save(src, binary=False)
    lines = src.read_text().splitlines()
    k = next(i for i, ln in enumerate(lines) if ln.startswith("CONNECTIVITY"))
    lines[k + 1] = "9999 " + lines[k + 1].split(" ", 1)[1]
    f = tmp_path / "bad.vtk"
    f.write_text("\n".join(lines) + "\n")
    return f, r"bad\.vtk: damaged: cell 0 refers to point 9999; the file holds 34 points"


def _vtk_legacy_truncated(tmp_path):
    import pyvista as pv

    src = tmp_path / "s.vtk"
    pv.Sphere(theta_resolution=8, phi_resolution=6).save(src, binary=True)
    raw = src.read_bytes()
    f = tmp_path / "half.vtk"
    f.write_bytes(raw[:len(raw) // 2])
    return f, r"half\.vtk: damaged or truncated VTK legacy file"


def _vtk_legacy_wrong_version(tmp_path):
    # The 5.1 layout (OFFSETS/CONNECTIVITY) under a 4.2 version line: VTK's reader itself
    # crashes on it, so it runs in a child process.
    import pyvista as pv

    src = tmp_path / "s.vtk"
    pv.Sphere(theta_resolution=10, phi_resolution=8).save(src, binary=True)
    f = tmp_path / "v42.vtk"
    f.write_bytes(src.read_bytes().replace(b"Version 5.1", b"Version 4.2", 1))
    return f, r"v42\.vtk: damaged: VTK's reader crashed reading it \(signal \d+\)"


def _npy_huge_header(tmp_path):
    f = tmp_path / "claims.npy"
    np.save(f, _cloud(50))
    raw = f.read_bytes()
    hlen = 10 + int.from_bytes(raw[8:10], "little")
    header = raw[:hlen].decode("latin-1").replace("(50, 3)", "(100000000000, 3)")
    header = header.rstrip("\n").rstrip(" ")
    header = header + " " * (hlen - len(header) - 1) + "\n"
    f.write_bytes(header.encode("latin-1") + raw[hlen:])
    return f, r"claims\.npy: truncated: the header declares 100000000000 rows, the file holds 50"


def _xyz_1e100(tmp_path):
    f = tmp_path / "huge.xyz"
    np.savetxt(f, np.vstack([_cloud(20), [[1e100, 0, 0]]]), fmt="%.6g")
    return f, r"huge\.xyz:21: coordinate 1e\+100 lies beyond ±1e9 mm"


def _dxf_huge_circle(tmp_path):
    doc = ezdxf.new("R2010")
    doc.header["$INSUNITS"] = 4
    doc.modelspace().add_circle((0, 0), 1e300)
    f = tmp_path / "huge.dxf"
    doc.saveas(f)
    return f, r"huge\.dxf: CIRCLE \(handle \w+\) has a coordinate or radius of 1e\+300"


def _dxf_zero_lines(tmp_path):
    doc = ezdxf.new("R2010")
    doc.header["$INSUNITS"] = 4
    doc.modelspace().add_line((1, 1), (1, 1))
    doc.modelspace().add_line((5, 2), (5, 2))
    f = tmp_path / "zero.dxf"
    doc.saveas(f)
    return f, r"zero\.dxf: the drawing holds no contour geometry .*2 entities of zero length"


def _obj_relative_index_before_its_vertices(tmp_path):
    f = tmp_path / "rel.obj"
    v = [f"v {p[0]} {p[1]} {p[2]}" for p in CUBE_V]
    # -5 with only four vertices defined so far: nothing, although the file holds eight.
    f.write_text("\n".join(v[:4] + ["f -1 -2 -5"] + v[4:] + ["f 5 6 7"]) + "\n")
    return f, r"rel\.obj:5: face refers to vertex -5; the file holds 8 vertices \(4 before"


def _obj_index_zero(tmp_path):
    f = tmp_path / "zero.obj"
    f.write_text("\n".join(f"v {p[0]} {p[1]} {p[2]}" for p in CUBE_V) + "\nf 1 2 3\nf 0 1 2\n")
    return f, r"zero\.obj:10: face refers to vertex 0; OBJ numbers vertices from 1"


def _ply_face_out_of_range(tmp_path):
    f = tmp_path / "bad.ply"
    f.write_text(ply_ascii(CUBE_V, CUBE_F[:5] + [[3, 0, 4, 8]]))
    return f, r"bad\.ply:23: face 5 refers to vertex 8; the file holds 8 vertices"


def _ply_binary_two_corner_face(tmp_path):
    f = tmp_path / "short.ply"
    f.write_bytes(ply_binary(CUBE_V, CUBE_F[:5] + [[3, 0]]))
    return f, r"short\.ply: face 5 has 2 corner\(s\); a face needs at least 3"


CLI_CASES = [_obj_missing_vertex, _obj_relative_index_before_its_vertices, _obj_index_zero,
             _ply_face_out_of_range, _ply_binary_two_corner_face, _ply_binary_fewer_declared,
             _ply_ascii_fewer_declared,
             _ply_ascii_more_declared, _vtk_legacy_bad_index, _vtk_legacy_truncated,
             _vtk_legacy_wrong_version,
             _npy_huge_header, _xyz_1e100, _dxf_huge_circle, _dxf_zero_lines]


@pytest.mark.parametrize("make", CLI_CASES, ids=lambda m: m.__name__.strip("_"))
def test_cli_refuses_with_exit_65_and_one_line(tmp_path, make):
    import re

    nominal, message = make(tmp_path)
    r = _cli(tmp_path, nominal)
    assert r.returncode == 65, (r.returncode, r.stderr[-2000:])
    # One line: no traceback, no numpy warning, nothing of VTK's own output.
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("qa-inspect: error: "), r.stderr
    assert re.search(message, lines[0]), lines[0]


_FUZZ_CHILD = """
import sys
from engine.errors import InputError
from engine.io import load_point_set
for path in sys.argv[1:]:
    try:
        load_point_set(path)
        print("read", path, flush=True)
    except InputError:
        print("refused", path, flush=True)
    except Exception as e:  # anything else is a bug: the reader must explain bad input
        print("BUG", path, type(e).__name__, e, flush=True)
"""


def test_cut_and_corrupted_meshes_never_crash_and_cuts_are_refused(tmp_path):
    """Meshes of every format cut short or with random bytes overwritten, read in one child
    process: it must survive them all, every cut PLY, STL or VTK file must be refused (an OBJ
    declares no counts: cut between lines it is a smaller mesh), and nothing but InputError may
    come out."""
    import pyvista as pv

    s = pv.Sphere(radius=10, theta_resolution=10, phi_resolution=8)
    rng = np.random.default_rng(7)
    sources = {}
    for name, kw in (("a.ply", {"binary": False}), ("b.ply", {"binary": True}),
                     ("a.stl", {"binary": False}), ("b.stl", {"binary": True}),
                     ("a.vtk", {"binary": False}), ("b.vtk", {"binary": True}), ("c.vtp", {}),
                     ("a.obj", None)):
        f = tmp_path / name
        s.save(f, **kw) if kw is not None else s.save(f)
        sources[name] = f.read_bytes()
    cuts, files = [], []
    for name, raw in sources.items():
        # VTK formats are read in a child process each (slower): fewer variants.
        for k in range(8 if name.endswith((".ply", ".stl", ".obj")) else 3):
            cut = tmp_path / f"cut{k}_{name}"
            # Cut somewhere in the first 90%: a declared count or the length always shows it.
            cut.write_bytes(raw[:int(rng.uniform(0.05, 0.9) * len(raw))])
            files.append(cut)
            if name.endswith((".ply", ".stl", ".vtk", ".vtp")):
                cuts.append(str(cut))
            bad = tmp_path / f"bad{k}_{name}"
            b = bytearray(raw)
            for i in rng.integers(0, len(b), size=8):
                b[i] = int(rng.integers(0, 256))
            bad.write_bytes(bytes(b))
            files.append(bad)
    env = dict(os.environ, PYTHONPATH=ROOT + os.pathsep + os.environ.get("PYTHONPATH", ""))
    r = subprocess.run([sys.executable, "-c", _FUZZ_CHILD, *map(str, files)], capture_output=True,
                       text=True, cwd=ROOT, env=env, timeout=300)
    assert r.returncode == 0, (r.returncode, r.stdout[-1500:], r.stderr[-1500:])
    outcome = dict(line.split(" ", 2)[1::-1] for line in r.stdout.splitlines())
    assert len(outcome) == len(files) and "BUG" not in r.stdout, r.stdout
    assert all(outcome[c] == "refused" for c in cuts), [c for c in cuts if outcome[c] != "refused"]
    assert r.stderr == "", r.stderr[-2000:]


# ------------------------------------------------------------------ meshes read right

def test_ascii_ply_cut_in_half_is_truncated_not_inspected(tmp_path):
    import pyvista as pv

    s = pv.Sphere(radius=10, theta_resolution=24, phi_resolution=16)
    f = tmp_path / "s.ply"
    s.save(f, binary=False)
    raw = f.read_bytes()
    half = tmp_path / "half.ply"
    half.write_bytes(raw[:len(raw) // 2])
    with pytest.raises(InputError, match=r"half\.ply(:\d+)?: truncated: the header declares \d+ "
                                         r"vertices, the file holds \d+"):
        load_point_set(half)
    s.save(f, binary=True)
    raw = f.read_bytes()
    half.write_bytes(raw[:len(raw) - 7])  # the last face cut
    with pytest.raises(InputError, match=r"truncated: the header declares \d+ faces, the file "
                                         r"holds \d+"):
        load_point_set(half)


@pytest.mark.parametrize("order", ["<", ">"])
def test_binary_ply_both_byte_orders_and_mixed_polygons(tmp_path, order):
    # Quads and triangles mixed (rows of different lengths): the cube split into 2 quads and
    # 8 triangles keeps its area 6 and its 8 vertices.
    faces = CUBE_F[:2] + [t for q in CUBE_F[2:] for t in ([q[0], q[1], q[2]], [q[0], q[2], q[3]])]
    f = tmp_path / "cube.ply"
    f.write_bytes(ply_binary(CUBE_V, faces, order))
    ps = load_point_set(f)
    assert np.allclose(ps.points, CUBE_V) and ps.triangles.shape == (12, 3)
    assert _triangle_area(ps) == pytest.approx(6.0)


def test_obj_negative_relative_indices_and_corner_forms(tmp_path):
    # The bottom face is written after the bottom four vertices only, with relative indices
    # (-1 = the latest vertex so far), the rest after all eight; corners as v/vt/vn. The mesh
    # must equal the one written with absolute indices.
    v = [f"v {p[0]} {p[1]} {p[2]}" for p in CUBE_V]
    absolute = v + ["f " + " ".join(str(i + 1) for i in q) for q in CUBE_F]
    relative = (["o cube"] + v[:4] + ["vt 0 0", "vn 0 0 1"]
                + ["f " + " ".join(f"{i - 4}/1/1" for i in CUBE_F[0])] + v[4:]
                + ["f " + " ".join(f"{i - 8}//1" for i in q) for q in CUBE_F[1:]])
    meshes = []
    for name, lines in (("abs.obj", absolute), ("rel.obj", relative)):
        f = tmp_path / name
        f.write_text("\n".join(lines) + "\n")
        ps = load_point_set(f)
        assert np.allclose(ps.points, CUBE_V) and _triangle_area(ps) == pytest.approx(6.0)
        meshes.append(sorted(map(tuple, np.sort(ps.triangles, axis=1))))
    assert meshes[0] == meshes[1]


def test_stl_truncated_binary_and_ascii(tmp_path):
    import pyvista as pv

    s = pv.Sphere(radius=10, theta_resolution=12, phi_resolution=8)
    f = tmp_path / "s.stl"
    s.save(f, binary=True)
    n = s.n_cells
    raw = f.read_bytes()
    cut = tmp_path / "cut.stl"
    cut.write_bytes(raw[:84 + 50 * 10 + 17])
    with pytest.raises(InputError, match=rf"cut\.stl: truncated: the header declares {n} "
                                         r"triangles .* the file holds 10 "):
        load_point_set(cut)
    s.save(f, binary=False)
    text = f.read_text()
    cut.write_text(text[:text.rfind("endfacet")])
    with pytest.raises(InputError, match=r"truncated: solid 1 has no 'endsolid' line"):
        load_point_set(cut)
    # Whole files: the corners merge into the sphere's vertices (the poles are shared).
    assert load_point_set(f).n == s.n_points


def test_mesh_vertex_beyond_limit_refused_before_vtk(tmp_path):
    v = CUBE_V.copy()
    v[6] = [1e100, 0, 0]
    f = tmp_path / "far.ply"
    f.write_text(ply_ascii(v, CUBE_F))
    with pytest.raises(InputError, match=r"far\.ply: point 6: coordinate 1e\+100 lies beyond"):
        load_point_set(f)


# ------------------------------------------------------------------ text files

def _rows(p):
    return "\n".join(f"{a:.6f},{b:.6f},{c:.6f}" for a, b, c in p)


def test_units_comment_after_the_header_row_is_honoured(tmp_path):
    p = _cloud(10)
    f = tmp_path / "inch.csv"
    f.write_text("x,y,z\n# units: inch\n" + _rows(p / 25.4) + "\n")
    assert np.allclose(read_points(f).points, p, atol=1e-4)
    f.write_text("# exported\nx,y,z\n\n# grid: 5 x 2\n# units: cm\n" + _rows(p / 10) + "\n")
    ps = read_points(f)
    assert ps.grid_shape == (5, 2) and np.allclose(ps.points, p, atol=1e-4)


def test_units_comment_after_the_first_data_row_is_refused(tmp_path):
    p = _cloud(10)
    f = tmp_path / "late.csv"
    f.write_text("x,y,z\n" + _rows(p[:3]) + "\n# units: inch\n" + _rows(p[3:]) + "\n")
    with pytest.raises(InputError, match=r"late\.csv:5: '# units: inch' stands after the first "
                                         r"data row \(line 2\)"):
        read_points(f)


def test_cp1252_text_with_byte_0x85_is_one_line(tmp_path):
    # cp1252 0x85 is an ellipsis; latin-1 would make it a line break and split the comment.
    p = _cloud(6)
    body = "# Messung \u2026 Bauteil \xe9\nid,x,y,z\n" + "\n".join(
        f"P\xe9{i},{a:.6f},{b:.6f},{c:.6f}" for i, (a, b, c) in enumerate(p)) + "\n"
    f = tmp_path / "win.csv"
    f.write_bytes(body.encode("cp1252"))
    ps = read_points(f)
    assert np.allclose(ps.points, p, atol=1e-6) and ps.labels[0] == "P\xe90"


@pytest.mark.parametrize("encoding", ["utf-16", "utf-16-le", "utf-16-be", "utf-8-sig"])
def test_utf16_and_utf8_bom_text(tmp_path, encoding):
    p = _cloud(6)
    f = tmp_path / "u.csv"
    f.write_bytes(("x,y,z\n" + _rows(p) + "\n").encode(encoding))
    assert np.allclose(read_points(f).points, p, atol=1e-6)


def test_binary_bytes_in_a_text_file_still_refused(tmp_path):
    f = tmp_path / "junk.xyz"
    f.write_bytes(b"1 2 3\n\x00\x07\x00\x00\x01binary\n")
    with pytest.raises(InputError, match="binary file"):
        read_points(f)


def test_airfoil_file_in_cp1252(tmp_path):
    f = tmp_path / "a.dat"
    f.write_bytes("NACA 0012 \u2026 profil\n1 0\n0.5 0.06\n0 0\n0.5 -0.06\n1 0\n".encode("cp1252"))
    t = read_airfoil_template(f, 100.0).template
    assert t.closed.tolist() == [True] and np.isclose(np.abs(t.start).max(), 100.0)


# ------------------------------------------------------------------ absurd values

def test_npy_complex_structured_and_length_mismatch(tmp_path):
    np.save(tmp_path / "c.npy", _cloud(5).astype(complex))
    with pytest.raises(InputError, match=r"dtype complex128; expected real numbers"):
        read_points(tmp_path / "c.npy")
    np.save(tmp_path / "s.npy", np.zeros(5, dtype=[("x", "f8"), ("y", "f8"), ("z", "f8")]))
    with pytest.raises(InputError, match=r"expected real numbers"):
        read_points(tmp_path / "s.npy")
    np.save(tmp_path / "t.npy", _cloud(50))
    raw = (tmp_path / "t.npy").read_bytes()
    (tmp_path / "t.npy").write_bytes(raw + raw[-24 * 5:])  # five rows more than declared
    with pytest.raises(InputError, match=r"inconsistent: the header declares 50 rows, the file "
                                         r"holds 55"):
        read_points(tmp_path / "t.npy")


def test_huge_finite_values_refused_in_every_point_format(tmp_path):
    np.save(tmp_path / "h.npy", np.vstack([_cloud(5), [[0, -3e12, 0]]]))
    with pytest.raises(InputError, match=r"h\.npy: point 5: coordinate -3e\+12 lies beyond"):
        read_points(tmp_path / "h.npy")
    # 1e8 inch is 2.54e9 mm: beyond, after conversion.
    f = tmp_path / "inch.xyz"
    f.write_text("# units: in\n0 0 0\n1 0 0\n0 1 0\n1e8 1 1\n")
    with pytest.raises(InputError, match=r"inch\.xyz:5: coordinate 1e\+08 \(x 25\.4 mm\)"):
        read_points(f)
    # Huge normals are only directions: scaled, not overflowing.
    f.write_text("0 0 0 1e300 0 0\n1 0 0 0 1e300 1e300\n0 1 0 0 0 1\n")
    assert np.allclose(read_points(f).normals[1], [0, 2 ** -0.5, 2 ** -0.5])


def test_dxf_zero_length_line_among_real_geometry_is_ignored_and_counted(tmp_path):
    doc = ezdxf.new("R2010")
    doc.header["$INSUNITS"] = 4
    msp = doc.modelspace()
    for a, b in [((0, 0), (30, 0)), ((30, 0), (30, 20)), ((30, 20), (0, 20)), ((0, 20), (0, 0))]:
        msp.add_line(a, b)
    msp.add_line((30, 20), (30, 20))  # at a corner: would otherwise split the chain
    f = tmp_path / "rect.dxf"
    doc.saveas(f)
    d = read_dxf_template(f)
    assert d.template.closed.tolist() == [True] and d.template.n_primitives == 4
    assert d.ignored == {"LINE (zero length)": 1}


def test_dxf_far_spline_refused_before_flattening(tmp_path):
    doc = ezdxf.new("R2010")
    doc.header["$INSUNITS"] = 6  # metres: 2e6 m is 2e9 mm
    doc.modelspace().add_spline(fit_points=[(0, 0), (1e6, 2e6), (2e6, 0), (3e6, 1e6)])
    f = tmp_path / "far.dxf"
    doc.saveas(f)
    with pytest.raises(InputError, match=r"far\.dxf: SPLINE \(handle \w+\) has a coordinate or "
                                         r"radius of 2e\+06 drawing units, beyond ±1e9 mm"):
        read_dxf_template(f)


@pytest.mark.parametrize("binary", [False, True])
def test_ply_with_empty_and_extra_elements(tmp_path, binary):
    # An empty element and an edge element (list + scalars) around the faces: skipped, checked
    # for length; the cube is read whole.
    head = ["ply", f"format {'binary_little_endian' if binary else 'ascii'} 1.0",
            "element material 0", "property float shininess", "element vertex 8",
            "property double x", "property double y", "property double z",
            "element face 6", "property list uchar int vertex_indices",
            "element edge 2", "property int vertex1", "property list uchar ushort extra",
            "property uchar red", "end_header"]
    if binary:
        body = CUBE_V.astype("<f8").tobytes()
        body += b"".join(struct.pack("<B4i", 4, *q) for q in CUBE_F)
        body += struct.pack("<iB2HB", 0, 2, 7, 8, 255) + struct.pack("<iBB", 1, 0, 9)
        raw = ("\n".join(head) + "\n").encode() + body
    else:
        rows = [" ".join(f"{c:g}" for c in p) for p in CUBE_V]
        rows += ["4 " + " ".join(map(str, q)) for q in CUBE_F] + ["0 2 7 8 255", "1 0 9"]
        raw = ("\n".join(head + rows) + "\n").encode()
    f = tmp_path / "cube.ply"
    f.write_bytes(raw)
    ps = load_point_set(f)
    assert np.allclose(ps.points, CUBE_V) and _triangle_area(ps) == pytest.approx(6.0)
    f.write_bytes(raw[:-2])  # the last edge row cut
    with pytest.raises(InputError, match=r"truncated: the header declares 2 'edge' rows, the "
                                         r"file holds 1|edge row 1"):
        load_point_set(f)
