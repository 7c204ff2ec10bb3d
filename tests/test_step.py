"""STEP nominals (engine.io.step): reading, the tessellation, and exact deviations to the B-rep,
against truth computed independently (tests/step_models.py: primitives of known size and pose,
a B-spline evaluated with scipy from its control points, the STEP text itself)."""

from __future__ import annotations

import os
import re
import subprocess
import sys

import numpy as np
import pytest

import step_models as sm
from engine.errors import InputError, InputNotFoundError
from engine.io import formats
from engine.io.step import read_step

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
NIST = os.path.join(ROOT, "tests", "data", "step", "nist_ftc_06_asme1_rd.stp")
FTC08 = os.path.join(ROOT, "tests", "data", "step", "nist_ftc_08_asme1_ap242-e1.stp")
PRECISION = 1e-7  # mm: 0.1 µm


def _text(path) -> str:
    with open(path, encoding="latin-1") as f:
        return f.read()


@pytest.fixture(scope="module")
def posed_box(tmp_path_factory):
    """The box with a hole in a random pose, written in millimetres: (nominal, R, t, path)."""
    R, t = sm.random_pose(7)
    path = sm.write_step(sm.placed(sm.box_with_hole(), R, t),
                         tmp_path_factory.mktemp("step") / "box.step")
    return read_step(path), R, t, path


# ---------------------------------------------------------------------------------- exact distances

def test_box_with_hole_deviations_are_exact_with_outward_sign(posed_box):
    nominal, R, t, _ = posed_box
    rng = np.random.default_rng(1)
    feet, normals, which = sm.box_face_samples(rng, 40)
    offset = rng.uniform(-0.5, 0.5, len(feet))
    q = feet + offset[:, None] * normals
    q, feet_w, normals_w = q @ R.T + t, feet @ R.T + t, normals @ R.T
    signed, foot, normal, face = nominal.deviations(q)
    assert np.abs(signed - offset).max() < PRECISION
    assert np.abs(foot - feet_w).max() < PRECISION
    assert np.abs(normal - normals_w).max() < 1e-9
    kinds = np.array([nominal.faces[f - 1].surface for f in face])
    assert (kinds[which == "hole"] == "cylinder").all()
    assert (kinds[which != "hole"] == "plane").all()
    # one face per side of the box: the points of one side all name the same face, sides differ
    ids = {w: set(face[which == w]) for w in set(which)}
    assert all(len(v) == 1 for w, v in ids.items() if w != "hole")
    assert len({next(iter(v)) for w, v in ids.items() if w != "hole"}) == 6


def test_beyond_a_face_the_distance_is_to_its_edge_not_its_untrimmed_surface(posed_box):
    """Points past a face's boundary: above the hole (the top plane's untrimmed surface is 0.5
    away, the rim 1.118), in the hole below the rim (the hole's wall), past an edge and past a
    corner of the box (the edge line, the vertex)."""
    nominal, R, t, _ = posed_box
    c, r, top = sm.HOLE_CENTRE, sm.HOLE_RADIUS, sm.BOX[2]
    q = np.array([[c[0] + 4, c[1], top + 0.5],    # over the hole: rim at (25, 15, 20)
                  [c[0] + 4, c[1], top - 0.5],    # in the hole: wall at (25, 15, 19.5)
                  [40 + 0.3, 12.0, 20 + 0.4],     # past the edge x = 40, z = 20
                  [40 + 0.2, 30 + 0.3, 20 + 0.6],  # past the corner (40, 30, 20)
                  [40 - 0.2, 12.0, 20 - 0.1]])    # inside, nearer the top than the side
    feet = np.array([[c[0] + r, c[1], top], [c[0] + r, c[1], top - 0.5], [40, 12, 20],
                     [40, 30, 20], [40 - 0.2, 12.0, 20]])
    truth = np.linalg.norm(q - feet, axis=1) * np.array([1, 1, 1, 1, -1])
    signed, foot, normal, _ = nominal.deviations(q @ R.T + t)
    assert np.abs(signed - truth).max() < PRECISION
    assert np.abs(foot - (feet @ R.T + t)).max() < PRECISION
    assert abs(truth[0] - 1.118033988749895) < 1e-12  # not the untrimmed plane's 0.5


def test_sphere_patch_exact_and_trimmed_at_its_rim(tmp_path):
    """A hemisphere: points off the spherical face by known amounts, and points below the
    equator outside it, whose nearest point is the rim circle (the untrimmed sphere would say
    1 mm), or the base disk."""
    R, t = sm.random_pose(3)
    nominal = read_step(sm.write_step(sm.placed(sm.hemisphere(), R, t), tmp_path / "hemi.step"))
    rng = np.random.default_rng(2)
    dirs = sm.sphere_directions(rng, 200, 0.15, 1.5)  # inside: nearer the sphere than the disk
    offset = rng.uniform(-1.0, 1.0, len(dirs))
    q = dirs * (sm.SPHERE_RADIUS + offset[:, None])
    signed, foot, normal, face = nominal.deviations(q @ R.T + t)
    assert np.abs(signed - offset).max() < PRECISION
    assert np.abs(normal - dirs @ R.T).max() < 1e-9
    below = sm.sphere_directions(rng, 50, -0.35, -0.1) * (sm.SPHERE_RADIUS + 1.0)  # beyond the disk
    rim = np.column_stack([below[:, :2] / np.linalg.norm(below[:, :2], axis=1, keepdims=True)
                           * sm.SPHERE_RADIUS, np.zeros(len(below))])
    signed, foot, _, _ = nominal.deviations(below @ R.T + t)
    assert np.abs(signed - np.linalg.norm(below - rim, axis=1)).max() < PRECISION
    assert np.abs(foot - (rim @ R.T + t)).max() < PRECISION
    under = np.column_stack([rng.uniform(-6, 6, (30, 2)), rng.uniform(-0.8, -0.1, 30)])
    signed, _, normal, _ = nominal.deviations(under @ R.T + t)
    assert np.abs(signed + under[:, 2]).max() < PRECISION  # below the disk: outside, positive
    assert np.abs(normal - np.array([0, 0, -1.0]) @ R.T).max() < 1e-9


def test_past_a_sharp_edge_the_sign_is_outward(tmp_path):
    """A 30-degree wedge: points in the region beyond its sharp edge are nearest to the edge
    itself, and outside; one face's normal alone would call those near either face's plane
    inside (the sign comes from both faces' normals)."""
    nominal = read_step(sm.write_step(sm.wedge(30.0), tmp_path / "wedge.step"))
    phi = np.radians(np.linspace(122, 268, 60))  # the edge's normal cone: 120 to 270 degrees
    r = np.linspace(0.05, 2.0, 60)
    q = np.column_stack([r * np.cos(phi), r * np.sin(phi), np.linspace(1, 9, 60)])
    signed, foot, normal, _ = nominal.deviations(q)
    assert np.abs(signed - r).max() < PRECISION
    assert np.abs(foot[:, :2]).max() < PRECISION
    assert (np.einsum("ij,ij->i", q - foot, normal) > 0).all()


@pytest.mark.parametrize("path", [NIST, FTC08], ids=os.path.basename)
def test_deviations_agree_with_brute_force_over_all_faces(path):
    """Points anywhere near and around NIST FTC-06 and FTC-08 (inside, outside, far): the
    distance equals OpenCascade's distance to all its faces at once (no candidate faces, no
    bounds), so the candidate search leaves no nearer face out; and the sign is OpenCascade's
    solid classifier's (rays against the faces, no normals): positive outside, negative
    inside. (FTC-08's plates have holes: feet off their planar faces are measured on their
    edges in closed form, engine.io.step.boundary.)"""
    nominal = read_step(path)
    rng = np.random.default_rng(12)
    lo, hi = nominal.bounds
    q = np.concatenate([rng.uniform(lo - 20, hi + 20, (150, 3)),
                        nominal.point_set.points[rng.choice(nominal.point_set.n, 100)]
                        + rng.normal(0, 1.0, (100, 3))])
    brute = sm.distance_to_shape(sm.read_faces(path), q)
    signed = nominal.deviations(q)[0]
    assert np.abs(np.abs(signed) - brute).max() < PRECISION
    outside = sm.outside_solid(path, q)
    clear = (np.abs(signed) > 1e-6) & ~np.isnan(outside)  # NaN: on the boundary
    assert clear.sum() > 240 and ((signed > 0) == (outside == 1.0))[clear].all()


def test_box_search_kernel_matches_its_naive_twin():
    """The compiled search for faces whose bounding box is nearer than a point's best distance
    (engine.kernels.boxes_nearer) finds the same pairs as the obvious loop, leaving out the
    pairs already measured; points inside, on and far from boxes, zero and infinite limits."""
    from engine.kernels import boxes_nearer
    from naive import boxes_nearer as naive

    rng = np.random.default_rng(5)
    lo = rng.uniform(-10, 10, (25, 3))
    boxes = np.stack([lo, lo + rng.uniform(0, 8, (25, 3))], axis=1)
    p = np.concatenate([rng.uniform(-15, 15, (300, 3)), boxes[:5, 0], boxes[5:10].mean(axis=1)])
    limit = rng.uniform(0, 12, len(p))
    limit[:10], limit[10:20] = 0.0, np.inf
    done = np.unique(np.column_stack([rng.integers(0, len(p), 400),
                                      rng.integers(1, 26, 400)]), axis=0)
    start = np.searchsorted(done[:, 0], np.arange(len(p) + 1))
    got = boxes_nearer(p, boxes, limit, start, np.ascontiguousarray(done[:, 1]))
    pairs = {tuple(r) for r in got.tolist()}
    assert len(pairs) == len(got) and pairs == naive(p, boxes, limit, done.tolist())
    assert len(pairs) > 1000 and (np.diff(got[:, 0]) >= 0).all()


def test_trim_polylines_classify_as_opencascade_does_right_up_to_their_band():
    """Feet are classified on a face by its trim's polylines in the (u, v) domain away from
    them: on every face of NIST FTC-06, random (u, v) points over the face's box and points just
    outside the band on both sides of every polyline segment classify exactly as OpenCascade's
    classifier (IntTools_FClass2d) does, and the polylines are drawn for every face."""
    from engine.io.step.faces import TRIM_BAND  # noqa: F401  (the band is the polylines' own)

    nominal = read_step(NIST)
    rng = np.random.default_rng(8)
    checked = 0
    for fid in range(1, nominal.n_faces + 1):
        tools = nominal._brep.tools(fid)
        u0, u1, v0, v1 = tools.uv_box
        box = np.column_stack([rng.uniform(u0, u1, 300), rng.uniform(v0, v1, 300)])
        trim = tools._trim_polylines()
        assert trim is not None, f"face {fid}: no trim polylines"
        segments, band = trim
        a, b = segments[:, :2], segments[:, 2:]
        long = np.linalg.norm(b - a, axis=1) > 0
        mid, d = 0.5 * (a + b)[long], (b - a)[long]
        normal = np.column_stack([-d[:, 1], d[:, 0]]) / np.linalg.norm(d, axis=1)[:, None]
        near = np.concatenate([mid + 1.5 * band * normal, mid - 1.5 * band * normal])
        uv = np.concatenate([box, near])
        got = nominal._brep.contains(np.full(uv.shape[0], fid), uv)
        truth = tools.classify(uv)
        assert np.array_equal(got, truth), f"face {fid}: {np.count_nonzero(got != truth)} differ"
        checked += uv.shape[0]
    assert checked > 50_000


def test_a_far_side_extremum_is_not_the_nearest_point_of_a_partial_face(tmp_path):
    """An open half cylinder (radius 10, y >= 0): from inside, on the missing half's side, the
    surface's extremum on the face is its far side (13 away), the nearest point is the face's
    edge (sqrt(10^2 + 3^2) away). And a B-spline trough z = x^2/4, |x| <= 5, from (0, y, 10)
    on its axis: the surface's only extremum there is its bottom (10 away), a maximum across;
    the nearest points are its rims (x = +-5, z = 6.25: 6.25 away)."""
    half = read_step(sm.write_step(sm.half_cylinder_sheet(), tmp_path / "half.step"))
    z = np.linspace(2, 18, 9)
    signed, foot, _, _ = half.deviations(np.column_stack([np.zeros(9), np.full(9, -3.0), z]))
    assert np.abs(np.abs(signed) - np.hypot(10, 3)).max() < PRECISION
    assert np.abs(np.abs(foot[:, 0]) - 10).max() < PRECISION and np.abs(foot[:, 1]).max() < 1e-9
    trough = read_step(sm.write_step(sm.trough_sheet(), tmp_path / "trough.step"))
    assert [f.surface for f in trough.faces] == ["bspline"]
    signed, foot, _, _ = trough.deviations(np.column_stack([np.zeros(9), z, np.full(9, 10.0)]))
    assert np.abs(np.abs(signed) - 6.25).max() < PRECISION
    assert np.abs(np.abs(foot[:, 0]) - 5).max() < PRECISION


def test_closed_forms_agree_with_opencascade_extrema(tmp_path):
    """The closed-form nearest points of planes, cylinders, cones, spheres and tori (the fast
    kernel) against OpenCascade's extrema on the same unbounded surface and its normal there
    (the slow twin), on every such face of NIST FTC-06 and a cone and a torus. (OpenCascade's
    extrema miss a double cone's far nappe: beyond the apex the closed form is nearer, and its
    foot lies on the surface with the point on its normal.)"""
    from OCP.GeomAPI import GeomAPI_ProjectPointOnSurf
    from OCP.GeomLProp import GeomLProp_SLProps
    from OCP.gp import gp_Pnt

    from engine.io.step.faces import FaceTools
    faces = sm.faces_of(sm.read_faces(NIST)) + sm.faces_of(sm.cone_and_torus())
    rng = np.random.default_rng(13)
    seen, compared = set(), 0
    for face in faces:
        tools = FaceTools(face)
        if tools.elementary is None:
            continue
        seen.add(tools.elementary.kind)
        q = sm.face_centre(face) + rng.normal(0, 3.0, (20, 3))
        d, u, v, foot, normal = tools.elementary.nearest(q)
        twin = GeomAPI_ProjectPointOnSurf()
        twin.Init(tools.surface, *tools.surface.Bounds())
        props = GeomLProp_SLProps(tools.surface, 1, 1e-12)
        for j, p in enumerate(q):
            props.SetParameters(u[j], v[j])
            assert np.abs(foot[j] - props.Value().Coord()).max() < 1e-8
            assert np.abs(normal[j] - props.Normal().Coord()).max() < 1e-9
            assert np.linalg.norm(np.cross(p - foot[j], normal[j])) < 1e-8
            twin.Perform(gp_Pnt(*p))
            if not twin.IsDone() or twin.NbPoints() == 0:
                continue  # OpenCascade found none (a point near a cylinder's axis)
            compared += 1
            if tools.elementary.kind == "Cone" and d[j] < twin.LowerDistance() - 1e-9:
                continue
            assert abs(d[j] - twin.LowerDistance()) < 1e-9
            assert np.abs(foot[j] - twin.NearestPoint().Coord()).max() < 1e-8
    assert seen == {"Plane", "Cylinder", "Cone", "Sphere", "Torus"} and compared > 2500
    cone = FaceTools(next(f for f in sm.faces_of(sm.cone_and_torus())
                          if FaceTools(f).elementary.kind == "Cone")).elementary
    q = rng.uniform([-15, -15, -10], [15, 15, 50], (200, 3))  # around both nappes (apex z=25)
    U, V = np.meshgrid(np.linspace(0, 2 * np.pi, 721), np.linspace(-80, 80, 1601))
    sa, ca = np.sin(cone.alpha), np.cos(cone.alpha)
    radius = cone.R + V.ravel() * sa
    dense = np.column_stack([radius * np.cos(U.ravel()), radius * np.sin(U.ravel()),
                             V.ravel() * ca]) @ np.array([cone.x, cone.y, cone.z]) + cone.o
    from scipy.spatial import cKDTree
    sampled = cKDTree(dense).query(q)[0]
    d, _, _, foot, _ = cone.nearest(q)
    assert np.abs(d - sampled).max() < 0.05  # the sampling's resolution
    assert np.abs(np.linalg.norm(q - foot, axis=1) - d).max() < 1e-9


@pytest.mark.parametrize("reversed_", [False, True])
def test_bspline_face_exact_against_an_independent_evaluation(tmp_path, reversed_):
    """A bicubic B-spline sheet (a single open face): points offset along the normal that
    scipy's B-spline bases give from the control points. The sign follows the face's
    orientation in the file (reversed face: the other side is outward)."""
    ctrl = sm.bspline_control_points()
    nominal = read_step(sm.write_step(sm.bspline_face(ctrl, reversed_), tmp_path / "sheet.step"))
    assert [f.surface for f in nominal.faces] == ["bspline"]
    rng = np.random.default_rng(5)
    u, v = rng.uniform(0.15, 0.85, (2, 300))
    feet, normals = sm.bspline_eval(ctrl, u, v)
    if reversed_:
        normals = -normals
    offset = rng.uniform(-0.3, 0.3, len(u))
    signed, foot, normal, _ = nominal.deviations(feet + offset[:, None] * normals)
    assert np.abs(signed - offset).max() < PRECISION
    assert np.abs(foot - feet).max() < 1e-6
    assert np.abs(normal - normals).max() < 1e-6


def test_a_face_written_the_wrong_way_round_still_measures_outward(tmp_path):
    """A box whose top face sits in its shell reversed (its normal points into the solid, as
    built and as written): the nominal's normals and signs there are outward all the same."""
    solid, top = sm.box_one_face_reversed()
    assert sm.oriented_normal_at_centre(top)[2] < -0.99  # inward, as built
    bad = sm.write_step(solid, tmp_path / "wrong.step")
    good = sm.write_step(sm.box(), tmp_path / "good.step")
    assert _face_senses(bad) != _face_senses(good)  # the file says it: one face's sense differs
    nominal = read_step(bad)
    rng = np.random.default_rng(4)
    xy = rng.uniform(2, 28, (50, 2))
    offset = rng.uniform(-0.5, 0.5, 50)
    signed, _, normal, face = nominal.deviations(np.column_stack([xy, 20 + offset]))
    assert np.abs(signed - offset).max() < PRECISION
    assert np.allclose(normal, [0, 0, 1])
    on_top = nominal.face_ids == face[0]
    assert np.allclose(nominal.point_set.normals[on_top], [0, 0, 1])


def _face_senses(path) -> list[str]:
    """The same_sense flags of a STEP file's ADVANCED_FACEs, sorted."""
    text = _text(path)
    return sorted(re.findall(r"ADVANCED_FACE\(.*?,\.([TF])\.\)", text, flags=re.S))


# ---------------------------------------------------------------------------------- reading

@pytest.mark.parametrize("unit, name, mm", [("INCH", "INCH", 25.4), ("M", "metre", 1000.0)])
def test_units_are_converted_to_millimetres(posed_box, tmp_path, unit, name, mm):
    nominal, R, t, _ = posed_box
    other = read_step(sm.write_step(sm.placed(sm.box_with_hole(), R, t), tmp_path / "u.step",
                                    unit))
    assert nominal.unit == "millimetre" and nominal.mm_per_unit == 1.0
    assert other.unit == name and other.mm_per_unit == mm
    text = _text(other.path)
    assert ("CONVERSION_BASED_UNIT('INCH'" in text) == (unit == "INCH")
    assert np.allclose(other.bounds, nominal.bounds, rtol=0, atol=1e-8)
    rng = np.random.default_rng(8)
    feet, normals, _ = sm.box_face_samples(rng, 10)
    q = (feet + rng.uniform(-0.5, 0.5, (len(feet), 1)) * normals) @ R.T + t
    assert np.abs(other.deviations(q)[0] - nominal.deviations(q)[0]).max() < 1e-8


def test_assembly_places_every_instance_with_names(tmp_path):
    """Two instances of a part placed by two rigid transforms: all faces of both, at their
    places, named from the file (the part's product name and a named face)."""
    part = sm.box_with_hole()
    top = next(k for k, f in enumerate(sm.faces_of(part), 1)
               if abs(sm.face_centre(f)[2] - sm.BOX[2]) < 1e-9)
    poses = [sm.random_pose(21), sm.random_pose(22)]
    path = sm.write_assembly(part, "BRACKET", {top: "MOUNTING_FACE"}, poses, tmp_path / "a.step")
    nominal = read_step(path)
    assert nominal.n_faces == 14
    assert {f.part for f in nominal.faces} == {"BRACKET"}
    named = [f.id for f in nominal.faces if f.name == "MOUNTING_FACE"]
    assert len(named) == 2 and named[1] - named[0] == 7
    rng = np.random.default_rng(9)
    feet, normals, which = sm.box_face_samples(rng, 10)
    offset = rng.uniform(-0.5, 0.5, len(feet))
    for instance, (R, t) in enumerate(poses):
        q = (feet + offset[:, None] * normals) @ R.T + t
        signed, foot, _, face = nominal.deviations(q)
        assert np.abs(signed - offset).max() < PRECISION
        assert ((face - 1) // 7 == instance).all()  # the faces of this instance
        up = (which == "z+")
        assert {nominal.faces[f - 1].name for f in face[up]} == {"MOUNTING_FACE"}
    corners = np.array([[x, y, z] for x in (0, 40) for y in (0, 30) for z in (0, 20)], float)
    placed = np.concatenate([corners @ R.T + t for R, t in poses])
    assert np.allclose(nominal.bounds, [placed.min(0), placed.max(0)], atol=1e-5)


def test_faces_have_stable_ids_in_reading_order(posed_box):
    nominal, _, _, path = posed_box
    again = read_step(path)
    assert [f.id for f in nominal.faces] == list(range(1, nominal.n_faces + 1)) == \
        [f.id for f in again.faces]
    assert np.array_equal(nominal.face_ids, again.face_ids)
    assert np.array_equal(nominal.point_set.points, again.point_set.points)
    assert nominal.n_faces == 7 and sorted(f.surface for f in nominal.faces) == \
        ["cylinder"] + ["plane"] * 6
    hole = next(f for f in nominal.faces if f.surface == "cylinder")
    assert hole.geometry["hole"] and abs(hole.geometry["radius"] - sm.HOLE_RADIUS) < 1e-12


# ---------------------------------------------------------------------------------- tessellation

def test_tessellation_normals_outward_winding_and_deflection(posed_box):
    """Every point's normal is its face's exact outward normal; triangles wind outward; the
    hole's chords stay within the stated deflection of the exact cylinder."""
    nominal, R, t = posed_box[:3]
    ps = nominal.point_set
    local = (ps.points - t) @ R
    for fid in range(1, nominal.n_faces + 1):
        own = nominal.face_ids == fid
        exact = sm.box_hole_normal(local[own], local[own]) @ R.T
        assert np.abs(ps.normals[own] - exact).max() < 1e-9
    tri = ps.triangles
    cross = np.cross(ps.points[tri[:, 1]] - ps.points[tri[:, 0]],
                     ps.points[tri[:, 2]] - ps.points[tri[:, 0]])
    assert (np.einsum("ij,ij->i", cross, ps.normals[tri].sum(axis=1)) > 0).all()
    assert (nominal.face_ids[tri] == nominal.face_ids[tri[:, :1]]).all()
    cylinder = next(f.id for f in nominal.faces if f.surface == "cylinder")
    hole = nominal.face_ids[tri[:, 0]] == cylinder
    centroids = ((ps.points[tri[hole]].mean(axis=1)) - t) @ R
    sag = sm.HOLE_RADIUS - np.hypot(*(centroids[:, :2] - sm.HOLE_CENTRE).T)
    assert 0 < sag.max() <= nominal.deflection * 1.001
    assert 1e-3 <= nominal.deflection <= 0.01


# ---------------------------------------------------------------------------------- damaged files

def _damaged(tmp_path):
    good = sm.write_step(sm.box_with_hole(), tmp_path / "good.step")
    text = _text(good)
    header = text[: text.index("DATA;")]
    lines = text.splitlines(True)
    bound = re.search(r"#(\d+) = FACE_BOUND\('',#(\d+),", text)
    point = re.search(r"#(\d+) = CARTESIAN_POINT", text).group(1)
    return {
        "empty": ("", "empty"),
        "truncated": (text[: len(text) // 2], "truncated"),
        "garbage": (bytes(np.random.default_rng(0).integers(0, 256, 4000, dtype=np.uint8)),
                    "binary"),
        "not STEP": ("x y z\n1 2 3\n", "not a STEP file"),
        "header only": (header + "DATA;\nENDSEC;\nEND-ISO-10303-21;\n", "DATA section is empty"),
        "no DATA": (header + "END-ISO-10303-21;\n", "no DATA"),
        "syntax": ("".join(lines[:40] + ["#9999 = FOO((;;'\n"] + lines[40:]), "damaged"),
        "missing entities": ("".join(lines[:60] + lines[90:]), "damaged"),
        "wrong entity type": (text.replace(bound.group(0), bound.group(0).replace(
            f"#{bound.group(2)},", f"#{point},")), "a FACE_BOUND"),
        "no shape": (header + "DATA;\n#1 = PRODUCT('x','x','',());\nENDSEC;\nEND-ISO-10303-21;\n",
                     "no shape"),
    }


def _write_damaged(tmp_path) -> list[tuple[str, str]]:
    """Write the damaged files; [(path, words their refusal says)]."""
    out = []
    for name, (content, words) in _damaged(tmp_path).items():
        path = tmp_path / f"{name}.step"
        path.write_bytes(content if isinstance(content, bytes) else content.encode("latin-1"))
        out.append((str(path), words))
    return out


def test_damaged_step_files_are_refused_with_a_clear_error(tmp_path):
    for path, words in _write_damaged(tmp_path):
        with pytest.raises(InputError) as e:
            read_step(path)
        assert str(e.value).startswith(path + ": ")
        assert words in e.value.message, (path, str(e.value))
    with pytest.raises(InputNotFoundError):
        read_step(tmp_path / "absent.step")


_READ_ALL = """
import sys
from engine.errors import InputError
from engine.io.step import read_step
for p in sys.argv[1:]:
    try:
        read_step(p)
        print("READ", p)
    except InputError:
        print("REFUSED", p)
"""


def test_damaged_files_never_crash_the_process(tmp_path):
    """The same files read in a child process: it exits normally, with each refusal."""
    paths = [path for path, _ in _write_damaged(tmp_path)]
    r = subprocess.run([sys.executable, "-c", _READ_ALL, *paths], capture_output=True, text=True,
                       cwd=ROOT, env={**os.environ, "PYTHONPATH": ROOT})
    assert r.returncode == 0, r.stderr
    assert r.stdout.split().count("REFUSED") == len(paths), r.stdout + r.stderr


REDTEAM = os.path.join(ROOT, "tests", "data", "step", "redteam")


def _cycles(tmp_path) -> list[tuple[str, str]]:
    """The red team's reference cycles, and an oriented edge of an oriented edge (no cycle,
    but a reference the schema forbids): [(path, words the refusal must say)]."""
    looped = os.path.join(REDTEAM, "edgeloop_cycle.stp")
    chain = tmp_path / "oe_chain.stp"
    chain.write_text(_text(looped).replace("#20 = ORIENTED_EDGE('',*,*,#20,.F.);",
                                           "#20 = ORIENTED_EDGE('',*,*,#55,.F.);"),
                     encoding="latin-1")
    return [(looped, "entity #20, an ORIENTED_EDGE, refers to itself"),
            (os.path.join(REDTEAM, "oe_cycle2.stp"),
             "#20 ORIENTED_EDGE -> #55 ORIENTED_EDGE -> #20"),
            (str(chain), "entity #20, an ORIENTED_EDGE, refers to #55, another ORIENTED_EDGE")]


@pytest.mark.parametrize("command", ["inspect", "batch"])
def test_reference_cycles_are_refused_by_the_command_line(tmp_path, command):
    """Entities of the B-rep that refer to each other in a cycle killed OpenCascade's parser
    (exit 139, nothing said). Run as the user runs it, in a child process: exit 65, one line
    naming the file and the entity, no traceback, no output."""
    measured = tmp_path / "part" / "m.csv"
    measured.parent.mkdir()
    measured.write_text("".join(f"{i},{i % 3},{i % 5}\n" for i in range(20)))
    for path, words in _cycles(tmp_path):
        out = tmp_path / "out"
        args = (["inspect", path, str(measured), "--tol", "0.1", "--json", str(out / "r.json")]
                if command == "inspect" else
                ["batch", path, str(measured.parent / "*.csv"), "--tol", "0.1", "--out",
                 str(out), "--workers", "1"])
        if command == "inspect":
            out.mkdir()
        r = subprocess.run([sys.executable, "-m", "qa_app.cli", *args], capture_output=True,
                           text=True, cwd=tmp_path, env={**os.environ, "PYTHONPATH": ROOT},
                           timeout=300)
        assert r.returncode == 65, (path, r.returncode, r.stderr)
        assert r.stderr.startswith(f"qa-inspect: error: {path}: the STEP file is damaged: ")
        assert words in r.stderr and len(r.stderr.splitlines()) == 1, r.stderr
        assert "Traceback" not in r.stderr and r.stdout == ""
        assert not out.exists() or not any(out.rglob("*")), list(out.rglob("*"))
        if out.exists():
            out.rmdir()


def test_a_direction_of_length_zero_is_named_as_damage(tmp_path, capsys):
    """Issue 22 item 10: zero_dir.stp (DIRECTIONs #13 and #30 of length 0) was refused as "the
    model lies beyond ±1e9 mm". It is a damaged file (65) naming the direction; a zero
    direction the shape does not use is none of its business."""
    from qa_app.cli import main

    path = os.path.join(REDTEAM, "zero_dir.stp")
    with pytest.raises(InputError) as e:
        read_step(path)
    assert str(e.value) == (f"{path}: the STEP file is damaged: entity #13, a DIRECTION, has "
                            "length 0 (direction ratios (0.,0.,0.)), and so does #30: a "
                            "direction must point somewhere")
    measured = tmp_path / "m.csv"
    measured.write_text("".join(f"{i},{i % 3},{i % 5}\n" for i in range(20)))
    assert main(["inspect", path, str(measured), "--tol", "0.1"]) == 65
    err = capsys.readouterr().err
    assert "entity #13, a DIRECTION, has length 0" in err and len(err.splitlines()) == 1
    good = sm.write_step(sm.box(), tmp_path / "good.step")
    text = _text(good)
    unused = tmp_path / "unused.step"
    unused.write_text(text.replace("ENDSEC;\nEND-ISO", "#99999 = DIRECTION('',(0.,0.,0.));\n"
                                   "ENDSEC;\nEND-ISO"), encoding="latin-1")
    assert "#99999" in _text(unused)
    assert read_step(str(unused)).n_faces == read_step(good).n_faces == 6


def test_a_reference_cycle_of_any_length_is_found_without_recursion():
    """The walk over the entities is iterative: a chain 200,000 entities deep is walked, a
    cycle through all of them is found and named in short."""
    from engine.io.step.reader import _check_references

    n = 200_000
    chain = [(1, [2], {"CLOSED_SHELL"})] + [(i, [i + 1], {"TRIMMED_CURVE"})
                                             for i in range(2, n)] + [(n, [], {"EDGE_CURVE"})]
    assert len(_check_references(chain, "deep.step")) == n
    looped = chain[:-1] + [(n, [2], {"EDGE_CURVE"})]
    with pytest.raises(InputError) as e:
        _check_references(looped, "deep.step")
    assert "entity #2, a TRIMMED_CURVE, refers back to itself through #2 TRIMMED_CURVE -> " \
           "#3 TRIMMED_CURVE" in str(e.value)
    assert f"({n - 1 - 8} more) -> #2" in str(e.value)


# ---------------------------------------------------------------------------------- real files

AP242 = [os.path.join(ROOT, "tests", "data", "step", f)
         for f in ("nist_ctc_01_asme1_ap242-e1.stp", "nist_ctc_03_asme1_ap242-e2.stp")]


@pytest.mark.parametrize("path", AP242, ids=os.path.basename)
def test_real_ap242_files_are_read_with_every_face(path):
    """NIST AP242 files with semantic PMI: hundreds of their PMI and presentation entities fail
    OpenCascade's checks (values rounded, descriptions that are no string), none of which the
    B-rep uses. They are read, every ADVANCED_FACE a face, and the ignored entities said."""
    nominal = read_step(path)
    assert nominal.n_faces == len(re.findall(r"=\s*ADVANCED_FACE\s*\(", _text(path)))
    assert len(nominal.warnings) == 1 and "the shape does not use" in nominal.warnings[0]
    assert "ignored" in nominal.warnings[0]


def test_a_damaged_entity_the_shape_does_not_use_is_a_warning(tmp_path):
    """A damaged property entity (an integer item holding 1.5) in a good file: read, with a
    warning naming it; the same damage on an entity of the B-rep still refuses the file."""
    text = _text(sm.write_step(sm.box_with_hole(), tmp_path / "good.step"))
    extra = "#99990 = INTEGER_REPRESENTATION_ITEM('count',1.5);\n"
    path = tmp_path / "pmi.step"
    path.write_text(text.replace("ENDSEC;\nEND-ISO", extra + "ENDSEC;\nEND-ISO"),
                    encoding="latin-1")
    nominal = read_step(path)
    assert nominal.n_faces == 7
    assert "INTEGER_REPRESENTATION_ITEM" in nominal.warnings[0]
    assert "1 entity the shape does not use" in nominal.warnings[0]
    # The same kind of damage on a B-rep entity (a face bound's orientation that is no boolean).
    bound = re.search(r"(#\d+ = FACE_BOUND\('',#\d+,)\.T\.\)", text)
    bad = tmp_path / "brep.step"
    bad.write_text(text.replace(bound.group(0), bound.group(1) + "1.5)"), encoding="latin-1")
    with pytest.raises(InputError, match="damaged"):
        read_step(bad)


def test_nist_ftc06_faces_and_bounds_match_the_file_text():
    """NIST FTC-06 (inch): OpenCascade's faces are the file's ADVANCED_FACEs, the box is that of
    the file's vertices (read from the text, in inches, x 25.4), and every tessellation point
    lies on the B-rep."""
    text = _text(NIST)
    nominal = read_step(NIST)
    assert nominal.n_faces == len(re.findall(r"=\s*ADVANCED_FACE\s*\(", text)) == 144
    assert nominal.unit == "INCH" and nominal.mm_per_unit == 25.4
    points = dict(re.findall(r"#(\d+)\s*=\s*CARTESIAN_POINT\s*\(\s*'[^']*'\s*,\s*\(([^)]*)\)",
                             text))
    vertices = [points[i] for i in re.findall(r"=\s*VERTEX_POINT\s*\(\s*'[^']*'\s*,\s*#(\d+)",
                                              text)]
    xyz = 25.4 * np.array([[float(c) for c in v.split(",")] for v in vertices])
    assert np.allclose(nominal.bounds, [xyz.min(0), xyz.max(0)], atol=1e-5)
    ps = nominal.point_set
    sample = np.random.default_rng(0).choice(ps.n, 2000, replace=False)
    assert np.abs(nominal.deviations(ps.points[sample])[0]).max() < 1e-6


# ---------------------------------------------------------------------------------- the wheel

def test_opencascade_leaves_pyvista_vtk_alone():
    """The cadquery-ocp-novtk wheel ships no VTK of its own (cadquery-ocp's overwrites
    pyvista's vtkmodules), and OpenCascade then pyvista import and work in one process."""
    from importlib.metadata import files
    shipped = [str(f) for f in files("cadquery-ocp-novtk")]
    assert any(f.startswith("OCP/") for f in shipped)
    assert not [f for f in shipped if "vtkmodules" in f or f.split("/")[-1].startswith("libvtk")]
    code = ("import OCP.BRepPrimAPI, pyvista\nm = pyvista.Sphere()\n"
            "b = OCP.BRepPrimAPI.BRepPrimAPI_MakeBox(1.0, 2.0, 3.0).Shape()\n"
            "print(m.n_points > 0, not b.IsNull())")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT)
    assert r.returncode == 0 and r.stdout.split() == ["True", "True"], r.stderr


def test_opencascade_loads_only_when_a_step_file_is_read():
    code = ("import sys, engine.io, engine.io.step, engine.pipeline\n"
            "print('OCP' in sys.modules)")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT,
                       env={**os.environ, "PYTHONPATH": ROOT})
    assert r.returncode == 0 and r.stdout.split() == ["False"], r.stderr


def test_step_is_a_file_kind():
    assert formats.kind_of("PART.STEP") == formats.kind_of("part.stp") == formats.STEP
    assert formats.STEP_SUFFIXES == (".stp", ".step")


def test_nist_file_is_bundled_with_its_source():
    assert os.path.getsize(NIST) < 2_000_000
    source = _text(os.path.join(os.path.dirname(NIST), "SOURCE.txt"))
    assert "public domain" in source.lower() and "nist_ftc_06_asme1_rd.stp" in source


def test_a_closed_model_has_no_border_to_lie_past_and_an_open_sheet_has_one(tmp_path):
    """A measured point lies past the nominal's border only where the surface ends. A closed
    model has no such place: on the perfect NIST CTC-01 and FTC-07, 600 points on their exact
    faces lie past none (the tessellation, meshed face by face, had put 151 and 75 of them
    past a border; 327 and 253 with 2 µm noise). The open half-cylinder sheet ends at its
    edges: a point past one, along the surface continued, lies past it; a point off its middle
    does not."""
    from engine.nominal import Nominal
    from engine.step_model import ExactDistances
    from sweep import on_part

    data = os.path.join(os.path.dirname(__file__), "data", "step")
    for name in ("nist_ctc_01_asme1_ap203.stp", "nist_ftc_07_asme1_ap242-e2.stp"):
        part = read_step(os.path.join(data, name))
        P, _, _ = on_part(part, np.random.default_rng(3), 600)
        exact = ExactDistances(part, Nominal.from_point_set(part.point_set))
        assert part.closed and not np.asarray(exact.beyond(P)).any()
    sheet = read_step(sm.write_step(sm.half_cylinder_sheet(), tmp_path / "half.step"))
    assert not sheet.closed
    exact = ExactDistances(sheet, Nominal.from_point_set(sheet.point_set))
    # The sheet: radius 10 about z, y >= 0, 0 <= z <= 20; past its straight edges (x = +-10,
    # y = 0) and its top arc, along the surface continued.
    past = np.array([[10.0, -5.0, 10.0], [-10.5, -4.0, 5.0], [0.0, 10.0, 25.0]])
    over = np.array([[0.0, 11.0, 10.0], [0.0, 9.0, 10.0]])
    assert np.asarray(exact.beyond(past)).all() and not np.asarray(exact.beyond(over)).any()


def test_distances_within_a_bound_are_exact_and_the_farther_ones_are_marked():
    """A search asks only whether its points lie near the part (engine.weak_search): within the
    bound the signed distance is the full query's to the last digit; beyond it, NaN, and never
    for a point within it. Points on NIST FTC-06's faces moved 0-40 mm in random directions,
    against the bound 3 mm."""
    from engine.nominal import Nominal
    from engine.step_model import ExactDistances
    from sweep import on_part

    part = read_step(NIST)
    exact = ExactDistances(part, Nominal.from_point_set(part.point_set))
    rng = np.random.default_rng(5)
    P, _, _ = on_part(part, rng, 400)
    v = rng.normal(size=P.shape)
    X = P + v / np.linalg.norm(v, axis=1, keepdims=True) * rng.uniform(0.0, 40.0, (len(P), 1))
    full = exact.deviations(X).signed
    got = exact.deviations_within(X, 3.0)
    within = got.signed
    near = np.abs(full) <= 3.0
    assert 50 < near.sum() < len(X) - 50  # both kinds asked about
    np.testing.assert_array_equal(within[near], full[near])
    np.testing.assert_array_equal(got.normal[near], exact.deviations(X).normal[near])
    assert np.isnan(within[~near]).all() and np.isnan(got.normal[~near]).all()
