"""Planar sections (engine.section, engine.io.step.section, ``qa-inspect inspect --section``,
the certificate's section pages) against independent truth: OpenCascade's own section and the
analytic curves of STEP models, a naive per-triangle cut and the analytic cuts of tessellated
solids, and the inspection's own deviations."""

from __future__ import annotations

import dataclasses
import json
import math
import os
import subprocess

import numpy as np
import pytest

import naive
import step_models as sm
from engine.errors import SettingsError
from engine.inspection import Tolerance, inspect
from engine.nominal import Nominal
from engine.pose import apply_transform, make_transform
from engine.scene import typical_spacing
from engine.section import (axis_plane, chain_order, mesh_cut, mesh_section, nominal_curve,
                            point_plane, section_name, section_of)
from qa_app.cli import main
from surfaces import (height_grid, point_set, points_off_surface, random_rotation,
                      write_grid_nominal, write_labelled_points)

DATA = os.path.join(os.path.dirname(os.path.abspath(__file__)), "data", "step")


# ---------------------------------------------------------------------------- meshes

def uv_sphere(r: float = 30.0, n_lat: int = 24, n_lon: int = 40):
    """A closed triangulated sphere: poles and rings of equal latitude steps; (points,
    triangles wound outward)."""
    th = np.linspace(0, np.pi, n_lat + 1)[1:-1]
    ph = np.linspace(0, 2 * np.pi, n_lon, endpoint=False)
    T, P = np.meshgrid(th, ph, indexing="ij")
    ring = r * np.column_stack([np.sin(T.ravel()) * np.cos(P.ravel()),
                                np.sin(T.ravel()) * np.sin(P.ravel()), np.cos(T.ravel())])
    pts = np.vstack([[0, 0, r], ring, [0, 0, -r]])
    n_r = len(th)
    idx = 1 + np.arange(n_r * n_lon).reshape(n_r, n_lon)
    tris = [[0, idx[0, j], idx[0, (j + 1) % n_lon]] for j in range(n_lon)]
    for i in range(n_r - 1):
        for j in range(n_lon):
            a, b = idx[i, j], idx[i, (j + 1) % n_lon]
            c, d = idx[i + 1, j], idx[i + 1, (j + 1) % n_lon]
            tris += [[a, c, b], [b, c, d]]
    south = len(pts) - 1
    tris += [[south, idx[-1, (j + 1) % n_lon], idx[-1, j]] for j in range(n_lon)]
    return pts, np.array(tris, np.int64)


def cylinder(r: float = 20.0, h: float = 50.0, n: int = 36):
    """A closed triangulated cylinder about z, 0 <= z <= h, with n sides (quads split along a
    diagonal) and fan caps; (points, triangles wound outward)."""
    a = 2 * np.pi * np.arange(n) / n
    ring = np.column_stack([r * np.cos(a), r * np.sin(a)])
    pts = np.vstack([np.column_stack([ring, np.zeros(n)]), np.column_stack([ring, np.full(n, h)]),
                     [[0, 0, 0], [0, 0, h]]])
    tris = []
    for j in range(n):
        k = (j + 1) % n
        tris += [[j, k, n + k], [j, n + k, n + j], [2 * n, k, j], [2 * n + 1, n + j, n + k]]
    return pts, np.array(tris, np.int64)


def _on_crossed_edge(v, points, triangles, plane, tol=1e-9) -> bool:
    """Is v where the plane crosses some edge of the triangles (to ``tol``)?"""
    d = plane.distance(points)
    for k in range(3):
        a, b = triangles[:, k], triangles[:, (k + 1) % 3]
        crossed = (d[a] >= 0) != (d[b] >= 0)
        a, b = a[crossed], b[crossed]
        t = d[a] / (d[a] - d[b])
        x = points[a] + t[:, None] * (points[b] - points[a])
        if np.min(np.linalg.norm(x - v, axis=1)) <= tol:
            return True
    return False


@pytest.mark.parametrize("plane", [axis_plane("z", 7.3), axis_plane("x", -11.0),
                                   point_plane([1.0, 2.0, 3.0], [0.3, -0.5, 0.8])])
def test_the_mesh_cut_is_the_naive_per_triangle_cut(plane):
    pts, tris = uv_sphere()
    curve = mesh_section(pts, tris, plane)
    segs = naive.plane_cut_segments(pts, tris, plane.origin, plane.normal)
    naive_len = sum(math.dist(a, b) for a, b in segs)
    assert len(curve.polylines) == 1 and curve.closed == (True,)
    assert curve.length == pytest.approx(naive_len, abs=1e-9)
    naive_points = np.array([p for s in segs for p in s])
    for v in curve.polylines[0]:
        assert abs(plane.distance(v[None])[0]) <= 1e-9
        assert np.min(np.linalg.norm(naive_points - v, axis=1)) <= 1e-9
        assert _on_crossed_edge(v, pts, tris, plane)
    # Outward: the normals in the plane point away from the sphere's axis through the plane.
    c2 = plane.to_2d(np.zeros((1, 3)))[0]
    p2 = plane.to_2d(curve.polylines[0])
    assert np.all(np.einsum("ij,ij->i", curve.normals[0], p2 - c2) > 0)


def test_the_cylinder_cut_is_its_polygon():
    r, n = 20.0, 36
    pts, tris = cylinder(r, 50.0, n)
    curve = mesh_section(pts, tris, axis_plane("z", 17.0))
    assert curve.closed == (True,) and curve.chord_mm == 0.0
    assert curve.length == pytest.approx(n * 2 * r * math.sin(math.pi / n), abs=1e-9)
    p = curve.polylines[0]
    assert np.all(np.abs(p[:, 2] - 17.0) <= 1e-12)
    # Every vertex on a side edge (radius r) or on a diagonal, between two side edges' crossings.
    on_side = np.abs(np.hypot(p[:, 0], p[:, 1]) - r) <= 1e-9
    assert on_side.sum() == n
    assert all(_on_crossed_edge(v, pts, tris, axis_plane("z", 17.0)) for v in p)


def test_a_cut_through_vertices_and_along_a_face_stays_one_loop():
    """The plane through a ring of the sphere's vertices, and the cylinder's top cap: the cut
    is still one closed loop (vertices on the plane count as above it)."""
    pts, tris = uv_sphere(30.0, 24, 40)
    z_ring = float(pts[1 + 5 * 40, 2])
    curve = mesh_section(pts, tris, axis_plane("z", z_ring))
    ring_r = math.hypot(*pts[1 + 5 * 40, :2])
    assert curve.closed == (True,)
    assert curve.length == pytest.approx(40 * 2 * ring_r * math.sin(math.pi / 40), abs=1e-9)
    cpts, ctris = cylinder(20.0, 50.0, 36)
    top = mesh_section(cpts, ctris, axis_plane("z", 50.0))
    assert top.closed == (True,)
    assert top.length == pytest.approx(36 * 40.0 * math.sin(math.pi / 36), abs=1e-9)


def test_an_unwelded_mesh_is_cut_as_one_curve():
    """A mesh written triangle by triangle (each vertex repeated): the cut joins across."""
    pts, tris = cylinder()
    loose = pts[tris.ravel()]
    curve = mesh_section(loose, np.arange(len(loose)).reshape(-1, 3), axis_plane("z", 17.0))
    assert len(curve.polylines) == 1 and curve.closed == (True,)
    ends, keys, tri = mesh_cut(pts, tris, axis_plane("z", 17.0))
    assert len(tri) == 72 and ends.shape == (72, 2, 3) and keys.shape == (72, 2)


def test_chaining_open_pieces_and_junctions():
    assert chain_order(np.array([[0, 1], [2, 1], [2, 3]])) == [([(0, False), (1, True),
                                                                 (2, False)], False)]
    loops = chain_order(np.array([[0, 1], [1, 2], [2, 0], [5, 5]]))
    assert sorted(closed for _, closed in loops) == [True, True]
    assert section_name(0) == "A-A" and section_name(25) == "Z-Z" and section_name(26) == "AA-AA"


# ---------------------------------------------------------------------------- STEP models

@pytest.fixture(scope="module")
def box_step(tmp_path_factory):
    from engine.io.step import read_step

    path = sm.write_step(sm.box_with_hole(), tmp_path_factory.mktemp("sec") / "box.stp")
    return read_step(path)


def test_the_box_with_a_hole_is_cut_into_its_rectangle_and_circle(box_step):
    curve = nominal_curve(axis_plane("z", 10.0), step=box_step)
    assert curve.source == "step" and curve.closed == (True, True)
    assert 1e-3 <= curve.chord_mm <= 0.01
    lengths = sorted(_closed_length(p) for p in curve.polylines)
    r = sm.HOLE_RADIUS
    kc = next(k for k, p in enumerate(curve.polylines) if np.ptp(p[:, 0]) < 11)
    circle, rect = curve.polylines[kc], curve.polylines[1 - kc]
    assert lengths[1] == pytest.approx(2 * (sm.BOX[0] + sm.BOX[1]), abs=1e-9)
    for p in curve.polylines:
        assert np.all(np.abs(p[:, 2] - 10.0) <= 1e-9)
    # The circle's vertices on the circle; its chords within the stated tolerance of it.
    rho = np.hypot(*(circle[:, :2] - sm.HOLE_CENTRE).T)
    assert np.all(np.abs(rho - r) <= 1e-9)
    mids = 0.5 * (circle + np.roll(circle, -1, axis=0))[:, :2] - sm.HOLE_CENTRE
    sag = r - np.hypot(*mids.T)
    assert np.all(sag >= -1e-12) and sag.max() <= curve.chord_mm + 1e-12
    # A chord of sagitta s falls short of its arc by about 8 s^2 / (3 chord): in all, at most
    # 2 pi s / 3 (s <= the chord tolerance).
    assert 2 * math.pi * r - 2.1 * curve.chord_mm <= _closed_length(circle) <= 2 * math.pi * r
    # The rectangle's vertices on the box's outline.
    x, y = rect[:, 0], rect[:, 1]
    edge = np.minimum.reduce([np.abs(x), np.abs(x - sm.BOX[0]), np.abs(y), np.abs(y - sm.BOX[1])])
    assert np.all(edge <= 1e-9)
    # Outward normals in the plane: away from the box's centre, into the hole.
    c = sm.BOX[:2] / 2
    assert np.all(np.einsum("ij,ij->i", curve.normals[1 - kc], rect[:, :2] - c) > 0)
    assert np.all(np.einsum("ij,ij->i", curve.normals[kc],
                            circle[:, :2] - sm.HOLE_CENTRE) / r < -0.999)


def _closed_length(p):
    return float(np.linalg.norm(np.diff(np.vstack([p, p[:1]]), axis=0), axis=1).sum())


@pytest.fixture(scope="module")
def ctc01():
    from engine.io.step import read_step

    return read_step(os.path.join(DATA, "nist_ctc_01_asme1_ap203.stp"))


@pytest.mark.parametrize("plane", [axis_plane("z", -25.0), axis_plane("x", 101.5),
                                   point_plane([10.0, 5.0, -30.0], [0.2, 0.3, 1.0])])
def test_a_nist_part_is_cut_as_opencascade_cuts_it(ctc01, plane):
    """CTC-01's section equals OpenCascade's BRepAlgoAPI_Section of its faces, built here: every
    vertex lies on it (1e-9 mm), and the lengths agree within the chords' shortfall."""
    from OCP.BRep import BRep_Builder
    from OCP.BRepAlgoAPI import BRepAlgoAPI_Section
    from OCP.BRepGProp import BRepGProp
    from OCP.gp import gp_Dir, gp_Pln, gp_Pnt
    from OCP.GProp import GProp_GProps
    from OCP.TopoDS import TopoDS_Compound

    compound, builder = TopoDS_Compound(), BRep_Builder()
    builder.MakeCompound(compound)
    for fid in range(1, ctc01.n_faces + 1):
        builder.Add(compound, ctc01.face_shape(fid))
    occ = BRepAlgoAPI_Section(compound, gp_Pln(gp_Pnt(*plane.origin), gp_Dir(*plane.normal)))
    props = GProp_GProps()
    BRepGProp.LinearProperties_s(occ.Shape(), props)
    curve = nominal_curve(plane, step=ctc01)
    verts = np.vstack(curve.polylines)
    assert np.all(np.abs(plane.distance(verts)) <= 1e-9)
    sample = verts[:: max(1, len(verts) // 150)]
    assert sm.distance_to_shape(occ.Shape(), sample).max() <= 1e-9
    mids = np.vstack([0.5 * (p + np.roll(p, -1, axis=0)) for p in curve.polylines])
    assert sm.distance_to_shape(occ.Shape(), mids[:: max(1, len(mids) // 150)]).max() <= \
        curve.chord_mm + 1e-9
    assert curve.length <= props.Mass() + 1e-9
    assert curve.length == pytest.approx(props.Mass(), rel=1e-4)
    assert all(curve.closed)  # a solid's section closes


def test_a_plane_that_misses_the_part_is_named(ctc01):
    with pytest.raises(SettingsError, match=r"z = 500 mm misses the part.*z runs from -100"):
        nominal_curve(axis_plane("z", 500.0), step=ctc01)
    # Just below the part: the offset as given, not rounded onto the part's own bound.
    with pytest.raises(SettingsError, match=r"z = -100\.00001 mm misses the part"):
        nominal_curve(axis_plane("z", -100.00001), step=ctc01)
    with pytest.raises(SettingsError, match="bare points"):
        nominal_curve(axis_plane("z", 0.0), nominal=Nominal(np.random.default_rng(0).normal(
            size=(50, 3)), None, "estimated"))


# ---------------------------------------------------------------------------- band, deviations

@pytest.fixture(scope="module")
def inspected():
    pts, nrm, grid = height_grid(120, 60)
    nominal = Nominal.from_point_set(point_set(pts, nrm, grid))
    rng = np.random.default_rng(3)
    q = points_off_surface(rng, 3000, rng.normal(0, 0.01, 3000))
    measured = apply_transform(make_transform(random_rotation(rng), [40.0, -20.0, 300.0]), q)
    return nominal, inspect(nominal, measured, Tolerance.symmetric(0.05))


@pytest.mark.parametrize("band", [None, 2.0])
def test_the_band_holds_the_inspections_points_and_deviations(inspected, band):
    nominal, res = inspected
    s = section_of(res, axis_plane("x", 30.0), "A-A", band, nominal=nominal, seed=0)
    want_band = 0.75 * typical_spacing(res.registered, seed=0) if band is None else band
    assert s.band == want_band
    idx = np.flatnonzero(np.abs(res.registered[:, 0] - 30.0) <= want_band)
    assert len(idx) > 10
    np.testing.assert_array_equal(s.index, idx)
    np.testing.assert_array_equal(s.signed, res.deviations.signed[idx])
    np.testing.assert_array_equal(s.offset, res.registered[idx, 0] - 30.0)
    np.testing.assert_array_equal(s.foot, res.deviations.foot[idx][:, [1, 2]])
    n = res.deviations.normal[idx][:, [1, 2]]
    np.testing.assert_allclose(s.direction, n / np.linalg.norm(n, axis=1, keepdims=True),
                               atol=1e-12)
    doc = s.document()
    assert doc["n_points"] == len(idx) and doc["deviation_max"] == res.deviations.signed[idx].max()
    assert doc["plane"]["axis"] == "x" and doc["plane"]["offset"] == 30.0


def test_a_whisker_along_a_surface_parallel_to_the_plane_takes_the_curves_normal(inspected):
    """A z section of the nearly flat surface: the feet's normals have no direction in the
    plane; the whiskers take the curve's."""
    nominal, res = inspected
    s = section_of(res, axis_plane("z", -20.0), "B-B", 3.0, nominal=nominal)
    assert len(s.index) > 0
    np.testing.assert_allclose(np.linalg.norm(s.direction, axis=1), 1.0, atol=1e-12)


# ---------------------------------------------------------------------------- the command line

@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("seccli")
    write_grid_nominal(d / "nominal.csv", 90, 60)
    rng = np.random.default_rng(1)
    q = points_off_surface(rng, 600, rng.normal(0, 0.01, 600))
    write_labelled_points(d / "measured.csv",
                          apply_transform(make_transform(random_rotation(rng), [1, 2, 3]), q))
    return d


def _cli(*args):
    return main([str(a) for a in args])


@pytest.mark.parametrize("option, text", [
    (["--section", "w=3"], "'w=3' is not a section: give AXIS=MM with AXIS x, y or z"),
    (["--section", "z"], "'z' is not a section"),
    (["--section", "z="], "'' is not a number"),
    (["--section", "z=abc"], "'abc' is not a number"),
    (["--section", "z=inf"], "finite"),
    (["--section-band", "2"], "--section-band applies with --section"),
    (["--section", "z=1", "--section-band", "-1"], "--section-band must be a positive"),
])
def test_section_usage_errors_exit_64_before_any_work(files, capsys, option, text):
    out = files / "bad.json"
    code = _cli("inspect", files / "nominal.csv", files / "measured.csv", "--tol", "0.05",
                "--json", out, *option)
    err = capsys.readouterr().err
    assert code == 64 and text in err and "Traceback" not in err
    assert not out.exists()


def test_a_section_of_a_2d_template_is_a_usage_error(tmp_path, capsys):
    dxf = os.path.join(os.path.dirname(DATA), "dxf")
    template = next(os.path.join(dxf, f) for f in sorted(os.listdir(dxf)) if f.endswith(".dxf"))
    code = _cli("inspect", template, tmp_path / "m.csv", "--tol", "0.1", "--section", "z=0")
    assert code == 64 and "2D template" in capsys.readouterr().err


def test_a_section_that_misses_the_part_writes_nothing(files, capsys):
    outs = [files / "miss.json", files / "miss.csv", files / "miss.pdf"]
    code = _cli("inspect", files / "nominal.csv", files / "measured.csv", "--tol", "0.05",
                "--section", "z=-20", "--section", "z=900", "--json", outs[0], "--csv", outs[1],
                "--report", outs[2])
    err = capsys.readouterr().err
    assert code == 64 and "z = 900 mm misses the part" in err and "Traceback" not in err
    assert not any(p.exists() for p in outs)


@pytest.fixture(scope="module")
def sectioned(files):
    j1, j2, pdf = files / "plain.json", files / "sec.json", files / "sec.pdf"
    assert _cli("inspect", files / "nominal.csv", files / "measured.csv", "--tol", "0.05",
                "--json", j1, "--seed", "5") == 0
    assert _cli("inspect", files / "nominal.csv", files / "measured.csv", "--tol", "0.05",
                "--json", j2, "--seed", "5", "--section", "x=20", "--section", "Y=-30.5",
                "--section-band", "4", "--report", pdf) == 0
    return json.loads(j1.read_text()), json.loads(j2.read_text()), pdf


def test_the_json_gets_sections_and_is_unchanged_without(sectioned):
    plain, with_sections = (dict(d) for d in sectioned[:2])
    sections = with_sections.pop("sections")
    assert "sections" not in plain
    for doc in (plain, with_sections):
        doc.pop("timings_s", None)
    assert plain == with_sections
    assert [s["name"] for s in sections] == ["A-A", "B-B"]
    assert [s["plane"]["name"] for s in sections] == ["x = 20 mm", "y = -30.5 mm"]
    for s in sections:
        assert s["band_mm"] == 4.0 and s["n_points"] > 0 and s["curve"]["source"] == "mesh"
        assert s["curve"]["length_mm"] > 200 and s["n_out_of_tolerance"] == 0
        assert -0.05 < s["deviation_min"] <= s["deviation_max"] < 0.05


def test_the_certificate_has_a_page_per_section(sectioned):
    _, doc, pdf = sectioned
    text = subprocess.run(["pdftotext", "-layout", str(pdf), "-"], capture_output=True,
                          text=True, check=True).stdout
    pages = text.split("\f")
    for s in doc["sections"]:
        title = f"Section {s['name']}, {s['plane']['name']}"
        on = [p for p in pages if title in p]
        assert len(on) == 1, title
        page = " ".join(on[0].split())
        assert f"{s['n_points']} within ±4 mm of the plane" in page
        assert "magnified" in page and "tolerance envelope" in page
    pages_of = [k for k, p in enumerate(pages) if "Section A-A" in p or "Section B-B" in p]
    assert pages_of[1] == pages_of[0] + 1


def test_a_step_nominal_is_cut_exactly_from_the_command_line(tmp_path, capsys):
    """The box with a hole as the STEP nominal: the JSON's section is OpenCascade's (its
    rectangle and circle), with the inspection's points and deviations in the band."""
    step = sm.write_step(sm.box_with_hole(), tmp_path / "box.stp")
    rng = np.random.default_rng(4)
    feet, normals, _ = sm.box_face_samples(rng, 150)
    q = feet + rng.normal(0, 0.005, len(feet))[:, None] * normals
    write_labelled_points(tmp_path / "m.csv",
                          apply_transform(make_transform(random_rotation(rng), [9, 8, 7]), q))
    out = tmp_path / "r.json"
    assert _cli("inspect", step, tmp_path / "m.csv", "--tol", "0.05", "--json", out,
                "--section", "z=10", "--section-band", "1.5") == 0
    assert "section A-A, z = 10 mm: curve" in capsys.readouterr().out
    s = json.loads(out.read_text())["sections"][0]
    assert s["curve"]["source"] == "step" and s["curve"]["polylines"] == 2
    assert s["curve"]["closed"] == 2 and s["curve"]["chord_mm"] > 0
    full = 2 * (sm.BOX[0] + sm.BOX[1]) + 2 * math.pi * sm.HOLE_RADIUS
    assert full - 2.1 * s["curve"]["chord_mm"] <= s["curve"]["length_mm"] <= full
    assert s["n_points"] > 10 and abs(s["deviation_min"]) < 0.05


def test_a_mesh_is_cut_alike_at_its_low_and_high_ends():
    """A plane through the cylinder's bottom cap (its lowest vertices on it) is cut as its top
    cap is: one loop, the polygon's perimeter (it "missed the part", exit 64, at the low end
    while the high end was cut)."""
    cpts, ctris = cylinder(20.0, 50.0, 36)
    want = 36 * 40.0 * math.sin(math.pi / 36)
    for z in (0.0, 50.0):
        curve = mesh_section(cpts, ctris, axis_plane("z", z))
        assert curve.closed == (True,), z
        assert curve.length == pytest.approx(want, abs=1e-9), z


def test_the_default_band_ignores_points_measured_twice(inspected):
    """Every measured point repeated (a program run twice): the default band is the one of the
    distinct points (the typical spacing was 0: a band of 0 mm showed no point)."""
    nominal, res = inspected
    twice = dataclasses.replace(res, registered=np.vstack([res.registered, res.registered]),
                                deviations=dataclasses.replace(
                                    res.deviations,
                                    **{f: np.concatenate([getattr(res.deviations, f)] * 2)
                                       for f in ("signed", "foot", "normal", "curved")}))
    once = section_of(res, axis_plane("x", 30.0), "A-A", None, nominal=nominal, seed=0)
    s = section_of(twice, axis_plane("x", 30.0), "A-A", None, nominal=nominal, seed=0)
    assert s.band == once.band > 0 and len(s.index) == 2 * len(once.index)


def test_a_band_from_one_distinct_point_is_refused(inspected):
    nominal, res = inspected
    one = dataclasses.replace(res, registered=np.repeat(res.registered[:1], 5, axis=0))
    with pytest.raises(SettingsError, match="give --section-band MM"):
        section_of(one, axis_plane("x", 30.0), "A-A", None, nominal=nominal, seed=0)


@pytest.mark.parametrize("seed", range(4))
def test_coincident_points_are_found_as_a_naive_comparison_finds_them(seed):
    """engine.neighbours.coincident_pairs (the nominal's welding of a mesh written face by face
    and the section's, one function) against the naive all-pairs comparison: every copy of a
    point paired with the lowest-numbered point of the same coordinates (the same bits: -0.0 is
    not 0.0), and a mesh's cut welded across its repeated vertices."""
    from engine.neighbours import coincident_pairs
    from engine.section import _welded

    rng = np.random.default_rng(seed)
    base = rng.integers(-2, 3, size=(40, 3)).astype(float)  # small grid: many repeats
    base[rng.random(base.shape) < 0.2] *= -1.0  # some 0.0 become -0.0
    cand = np.sort(rng.choice(40, 30, replace=False))
    want = []
    for j in cand:
        same = [i for i in cand if base[i].tobytes() == base[j].tobytes()]
        if same[0] != j:
            want.append((same[0], j))
    got = coincident_pairs(base, cand)
    assert sorted(map(tuple, got.tolist())) == sorted(want)
    tris = rng.choice(cand, size=(25, 3))
    rep = {c: r for r, c in want}
    assert _welded(base, tris).tolist() == [[rep.get(v, v) for v in t] for t in tris.tolist()]
