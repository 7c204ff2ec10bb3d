"""A box region on a STEP model (engine.gdt.regions): the model's tessellation points lie only on
its faces' edges, so a box over the middle of a large plane held none of them and the plan was
refused ("selects no point"); it now takes the faces its box crosses and, of their measured
points, those whose closest point lies in the box. The overlap test of triangles and boxes has
a linear-programming twin."""

import json

import numpy as np
import pytest

from naive import rigid_motion
from test_step_inspection import STEP, measured_on, plane_minimum_zone, write


def _meets_lp(tri, lo, hi):
    """Whether a point of the triangle tri (3, 3) lies in [lo, hi]: a feasibility linear
    program in its barycentric weights."""
    from scipy.optimize import linprog

    A = np.vstack([tri.T, -tri.T])
    lp = linprog(np.zeros(3), A_ub=A, b_ub=np.concatenate([hi, -lo]), A_eq=np.ones((1, 3)),
                 b_eq=[1.0], bounds=[(0, None)] * 3, method="highs")
    return lp.status == 0


def test_triangles_in_box_equals_its_linear_programming_twin():
    from engine.gdt.regions import triangles_in_box

    rng = np.random.default_rng(31)
    V = rng.uniform(-2, 2, (400, 3, 3))
    V[:100] = V[:100, :1] + 0.3 * (V[:100] - V[:100, :1])  # small ones too
    lo, hi = np.array([-0.5, -0.3, -0.8]), np.array([0.6, 0.4, 0.2])
    got = triangles_in_box(V, lo, hi)
    twin = np.array([_meets_lp(t, lo, hi) for t in V])
    assert got.tolist() == twin.tolist() and 0 < got.sum() < len(V)


def _pose_of(M, X):
    """The rigid motion taking the points X (n, 3) onto M (Kabsch)."""
    return rigid_motion(X, M)


@pytest.fixture(scope="module")
def part():
    from engine.io.step import read_step

    return read_step(STEP)


def test_a_box_over_the_middle_of_a_large_step_plane_selects_its_points(tmp_path, part):
    """A box over the middle of the model's largest axis-aligned plane, holding none of its
    tessellation points: the flatness of its region is the minimum zone (a linear program
    here) of the true points whose closest point lies in the box."""
    from engine.gdt.regions import triangles_in_box

    rng = np.random.default_rng(32)
    M, planted, face, true, N = measured_on(part, rng, n=600, true_points=True)
    samples = part.point_set.points
    t = part.point_set.triangles

    def holds(P, lo, hi):
        return np.all((P >= lo) & (P <= hi), axis=1)

    # The largest axis-aligned plane; a box over its middle (about its points, a twentieth of
    # its extent) holding no tessellation point (the defect's case) and crossing no other face.
    planes = [f.id for f in part.faces if f.surface == "plane" and np.any(face == f.id)
              and np.max(np.abs(N[face == f.id][0])) > 1 - 1e-9]
    fid = max(planes, key=lambda i: np.prod(np.sort(np.ptp(true[face == i], axis=0))[1:]))
    on, n = true[face == fid], N[face == fid][0]
    axis = int(np.argmax(np.abs(n)))
    half = np.where(np.arange(3) == axis, 0.5, 0.025 * np.ptp(on, axis=0))
    for mid in on:
        lo, hi = mid - half, mid + half
        crossing = np.asarray(part.face_ids)[t[triangles_in_box(samples[t], lo, hi)]]
        if not holds(samples, lo, hi).any() and set(crossing.ravel()) == {fid}:
            break
    assert not holds(samples, lo, hi).any()
    # 60 points probed in the box on the face, each off it by a planted deviation.
    P = lo + rng.uniform(0, 1, (60, 3)) * (hi - lo)
    P[:, axis] = mid[axis]
    assert np.all(part.deviations(P)[3] == fid)
    dev = rng.normal(0, 0.005, 60)
    extra = P + dev[:, None] * n
    T = _pose_of(M, true)
    M = np.vstack([M, extra @ T[:3, :3].T + T[:3, 3]])
    true = np.vstack([true, extra])
    face, planted, N = np.concatenate([face, np.full(60, fid)]), \
        np.concatenate([planted, dev]), np.vstack([N, np.tile(n, (60, 1))])
    write(tmp_path / "m.csv", M)
    (tmp_path / "plan.toml").write_text(f"""
[[region]]
name = "F"
box = [{lo.tolist()}, {hi.tolist()}]
[[characteristic]]
id = "1"
type = "flatness"
region = "F"
zone = 1.0
""")
    from qa_app.cli import main

    assert main(["inspect", STEP, str(tmp_path / "m.csv"), "--plan",
                 str(tmp_path / "plan.toml"), "--json", str(tmp_path / "r.json")]) == 0
    (c,) = json.loads((tmp_path / "r.json").read_text())["characteristics"]
    foot = true - planted[:, None] * N  # the points' closest points on the model
    inside = (face == fid) & np.all((foot >= lo) & (foot <= hi), axis=1)
    assert c["n_points"] == int(inside.sum()) >= 10
    assert c["value"] == pytest.approx(plane_minimum_zone(true[inside], n), abs=1e-7)
