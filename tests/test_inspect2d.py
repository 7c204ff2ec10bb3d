"""2D template inspection: pose from any start, partial coverage, symmetry, planar 3D input,
and the command line with DXF and airfoil templates."""

import json
import math
import os

import ezdxf
import numpy as np
import pytest

from engine.contour import ContourIndex, deviations_2d, points_on
from engine.errors import InputError
from engine.inspection import Tolerance, inspect_2d
from engine.io.templates import read_airfoil_template, read_dxf_template, read_template
from engine.pose import apply_transform, pose_2d
from engine.registration2d import register_2d
from engine.verdict import ACCEPT, REJECT
from qa_app.cli import main
from surfaces import random_rotation
from test_contour import slotted_plate

DATA = os.path.join(os.path.dirname(__file__), "data", "dxf")


@pytest.mark.parametrize("seed", [1, 2, 3, 4])
def test_pose_from_any_angle_and_offset(seed):
    rng = np.random.default_rng(seed)
    t = slotted_plate()
    q = points_on(t, 300, rng) + rng.normal(0, 0.002, (300, 2))
    meas = apply_transform(pose_2d(rng.uniform(0, 2 * np.pi), rng.uniform(-800, 800, 2)), q)
    r = register_2d(ContourIndex(t), meas)
    assert r.converged and not r.symmetric
    assert np.max(np.linalg.norm(apply_transform(r.T_nominal_measured, meas) - q, axis=1)) < 0.003


def test_points_along_part_of_the_contour():
    rng = np.random.default_rng(5)
    t = slotted_plate()
    # Only the rounded end and the bottom edge were measured.
    w = np.array([1.0, 1.0, 0.0, 0.0, 0.0])
    q = points_on(t, 150, rng, w) + rng.normal(0, 0.002, (150, 2))
    meas = apply_transform(pose_2d(2.0, [300.0, -40.0]), q)
    r = register_2d(ContourIndex(t), meas)
    assert np.max(np.linalg.norm(apply_transform(r.T_nominal_measured, meas) - q, axis=1)) < 0.005


def test_symmetric_gear_any_equivalent_pose_is_right():
    rng = np.random.default_rng(6)
    g = read_dxf_template(f"{DATA}/gear_z20.dxf", units="mm").template
    idx = ContourIndex(g)
    q = points_on(g, 400, rng, (g.contour == 0).astype(float))
    meas = apply_transform(pose_2d(1.234, [55.0, -20.0]), q)
    r = register_2d(idx, meas)
    assert r.converged and r.symmetric
    d = deviations_2d(idx, apply_transform(r.T_nominal_measured, meas)).signed
    assert np.max(np.abs(d)) < 1e-6


def test_symmetric_gear_measured_in_3d_one_registration_result():
    """The 2D fit lifted into 3D is the same result type as a 3D registration, whole: the
    chosen and the runner-up pose are both 4x4 in the nominal frame, and a gear's runner-up (a
    symmetry) puts the measured points onto the drawing as well as the chosen pose does."""
    rng = np.random.default_rng(16)
    g = read_dxf_template(f"{DATA}/gear_z20.dxf", units="mm").template
    q = points_on(g, 400, rng, (g.contour == 0).astype(float))
    R = random_rotation(rng)
    meas = np.column_stack([q, np.zeros(len(q))]) @ R.T + rng.uniform(-300, 300, 3)
    res = inspect_2d(g, meas, 3, Tolerance.symmetric(0.05))
    reg = res.registration
    assert type(reg) is type(register_2d(ContourIndex(g), q[:50]))
    assert reg.symmetric and res.extra["template"]["symmetric"]
    idx = ContourIndex(g)
    for T in (reg.T_nominal_measured, reg.runner_up_T):
        assert T.shape == (4, 4)
        X = meas @ T[:3, :3].T + T[:3, 3]
        assert np.max(np.abs(X[:, 2])) < 1e-6
        # The runner-up is the short fit's pose: within a few microns, not to 1e-6.
        assert np.max(np.abs(deviations_2d(idx, X[:, :2]).signed)) < 0.005


def test_planar_template_measured_in_3d_either_face_up():
    rng = np.random.default_rng(7)
    t = slotted_plate()
    q = points_on(t, 250, rng)
    dev = rng.normal(0, 0.003, 250)
    dev[17] = 0.2  # one point out of a ±0.05 zone
    # Move each point along the contour's positive normal by its planted deviation.
    nrm = deviations_2d(ContourIndex(t), q).normal
    q2 = q + dev[:, None] * nrm
    for flip in (1.0, -1.0):
        z = rng.normal(0, 0.001, 250)
        P3 = np.column_stack([q2[:, 0], flip * q2[:, 1], z])
        R = random_rotation(rng)
        meas = P3 @ R.T + rng.uniform(-500, 500, 3)
        res = inspect_2d(t, meas, 3, Tolerance.symmetric(0.05))
        assert res.verdict == REJECT and res.statistics.n_out == 1
        assert res.statistics.worst[0] == 17
        assert np.max(np.abs(res.deviations.signed - dev)) < 0.004
        assert res.extra["flatness"]["peak_to_valley"] == pytest.approx(np.ptp(z), rel=0.2)
        # The 4x4 is a proper rigid transform and puts the points back into the template plane.
        T = res.registration.T_nominal_measured
        assert np.linalg.det(T[:3, :3]) == pytest.approx(1.0)
        assert np.max(np.abs(res.registered[:, 2])) < 0.01


def test_cli_with_dxf_and_2d_points(tmp_path, capsys):
    doc = ezdxf.new("R2010")
    doc.header["$INSUNITS"] = 4
    msp = doc.modelspace()
    msp.add_lwpolyline([(0, 0, 0), (30, 0, math.tan(math.pi / 4)), (30, 20, 0), (0, 20, 0)],
                       format="xyb", close=True)
    msp.add_circle((12, 10), 4)
    msp.add_text("TEMPLATE 7")
    dxf = tmp_path / "frame.dxf"
    doc.saveas(dxf)
    t = read_dxf_template(dxf).template
    rng = np.random.default_rng(8)
    q = points_on(t, 200, rng)
    meas = apply_transform(pose_2d(0.7, [10.0, 20.0]), q)
    f = tmp_path / "m.txt"
    np.savetxt(f, meas, fmt="%.6f")
    code = main(["inspect", str(dxf), str(f), "--tol", "0.01", "--json", str(tmp_path / "r.json")])
    assert code == 0
    doc_ = json.loads((tmp_path / "r.json").read_text())
    assert doc_["verdict"] == ACCEPT and doc_["template"]["closed"] == 2
    assert doc_["template"]["ignored_entities"] == {"TEXT": 1}
    assert doc_["deviations"]["max_abs"] < 1e-5
    assert "template: 2 contour(s)" in capsys.readouterr().out


def test_airfoil_ordinates_template(tmp_path, capsys):
    # NACA 0012, chord 1, Selig order (TE -> upper -> LE -> lower -> TE).
    x = (1 - np.cos(np.linspace(0, np.pi, 60))) / 2
    yt = 0.6 * (0.2969 * np.sqrt(x) - 0.1260 * x - 0.3516 * x**2 + 0.2843 * x**3
                - 0.1036 * x**4)
    upper = np.column_stack([x[::-1], yt[::-1]])
    lower = np.column_stack([x[1:], -yt[1:]])
    dat = tmp_path / "naca0012.dat"
    dat.write_text("NACA 0012\n" + "\n".join(f"{a:.6f} {b:.6f}" for a, b in np.vstack([upper, lower])))
    tpl = read_airfoil_template(dat, 250.0)
    with pytest.raises(InputError, match="needs its chord length"):
        read_template(dat)  # no scale: was a TypeError comparing None with 0
    t = tpl.template
    assert t.closed.tolist() == [True]
    assert np.ptp(np.vstack([t.start, t.end])[:, 0]) == pytest.approx(250.0, abs=1e-3)
    rng = np.random.default_rng(9)
    q = points_on(t, 300, rng)
    f = tmp_path / "m.csv"
    np.savetxt(f, apply_transform(pose_2d(-1.1, [40.0, 5.0]), q), fmt="%.6f", delimiter=",")
    assert main(["inspect", str(dat), str(f), "--tol", "0.3", "--scale", "250"]) == 0
    assert main(["inspect", str(dat), str(f), "--tol", "0.3"]) == 64
    assert "needs --scale" in capsys.readouterr().err
    bad = tmp_path / "bad.dat"
    bad.write_text("NAME\n0 0\n0.5 x\n1 0\n")
    assert main(["inspect", str(bad), str(f), "--tol", "0.3", "--scale", "1"]) == 65
    assert "bad.dat:3: '0.5 x' is not a pair of numbers" in capsys.readouterr().err


def test_points_that_match_no_contour_are_inconclusive():
    rng = np.random.default_rng(10)
    blob = np.column_stack([rng.normal(size=(200, 2)) * 80.0, np.zeros(200)])
    res = inspect_2d(slotted_plate(), blob, 2, Tolerance.symmetric(0.1))
    assert res.verdict == "INCONCLUSIVE"


def test_template_options_on_the_wrong_nominal_are_usage_errors(tmp_path, capsys):
    pts = tmp_path / "n.xyz"
    np.savetxt(pts, np.random.default_rng(0).normal(size=(50, 3)))
    assert main(["inspect", str(pts), str(pts), "--tol", "1", "--layer", "A"]) == 64
    assert "apply to 2D templates" in capsys.readouterr().err
    doc = ezdxf.new("R2010")
    doc.modelspace().add_circle((0, 0), 5)
    dxf = tmp_path / "c.dxf"
    doc.saveas(dxf)
    assert main(["inspect", str(dxf), str(pts), "--tol", "1", "--scale", "2"]) == 64


def plate_with_dent(rng, n, depth, noise=0.002, width=6.0):
    """The slotted plate measured at n points with probing noise, and a dent of ``depth`` mm
    (into the material: negative deviations) in a cosine bell ``width`` mm long centred on the
    bottom edge at x = 15. Returns (nominal points, planted deviations) (n, 2), (n,)."""
    t = slotted_plate()
    q = points_on(t, n, rng)
    dev = rng.normal(0.0, noise, n)
    u = np.abs(q[:, 0] - 15.0) / (width / 2)
    dent = (np.abs(q[:, 1]) < 1e-9) & (u < 1.0)
    dev[dent] -= depth * 0.5 * (1.0 + np.cos(np.pi * u[dent]))
    return t, q, dev, dent


def measured_from(t, q, dev, rng):
    nrm = deviations_2d(ContourIndex(t), q).normal
    meas = apply_transform(pose_2d(rng.uniform(0, 2 * np.pi), rng.uniform(-300, 300, 2)), q + dev[:, None] * nrm)
    return np.column_stack([meas, np.zeros(len(meas))])


def independent_lsq(idx, meas2, T0, kept):
    """scipy's least squares over (theta, tx, ty) about the points' centroid, from T0,
    residuals the exact signed deviations of the kept points."""
    from scipy.optimize import least_squares

    c = meas2[kept].mean(axis=0)

    def pose(x):
        return T0 @ pose_2d(x[0], c - apply_transform(pose_2d(x[0], [0.0, 0.0]), c[None])[0] + x[1:])

    def resid(x):
        return deviations_2d(idx, apply_transform(pose(x), meas2[kept])).signed

    sol = least_squares(resid, np.zeros(3), x_scale="jac", xtol=1e-15,
                        ftol=1e-15, gtol=1e-15)
    return float(np.sum(sol.fun ** 2))


@pytest.mark.parametrize("n", [600, 6000])
def test_least_squares_pose_is_the_least_squares_optimum_with_a_dent_in_tolerance(n):
    # (6,000 points: the fit converges on a subset first, then over every point.)
    rng = np.random.default_rng(21)
    t, q, dev, dent = plate_with_dent(rng, n, depth=0.035)
    meas = measured_from(t, q, dev, rng)
    idx = ContourIndex(t)
    res = inspect_2d(t, meas, 2, Tolerance.symmetric(0.05), index=idx)
    assert dent.sum() >= 20
    assert res.registration.inlier.all()  # the dent is not a gross outlier
    d = res.deviations.signed
    ours = float(np.sum(d ** 2))
    # The reported deviations are the exact ones at the reported pose.
    assert np.allclose(d, deviations_2d(idx, res.registered[:, :2]).signed, atol=1e-9)
    # An independent optimiser started from the true pose (and from ours) finds no lower sum.
    best = min(independent_lsq(idx, meas[:, :2], np.linalg.inv(
        true_pose(meas[:, :2], q)), np.ones(len(q), bool)),
        independent_lsq(idx, meas[:, :2], _planar_pose(res), np.ones(len(q), bool)))
    assert ours <= best * 1.0002


def _planar_pose(res):
    T = np.eye(3)
    T[:2, :2] = res.registration.T_nominal_measured[:2, :2]
    T[:2, 2] = res.registration.T_nominal_measured[:2, 3]
    return T


def true_pose(meas2, q):
    """The true 2D pose (3, 3, nominal -> measured) by Procrustes on the known pairs."""
    a, b = q - q.mean(0), meas2 - meas2.mean(0)
    u, _, vt = np.linalg.svd(b.T @ a)
    R = u @ vt
    T = np.eye(3)
    T[:2, :2] = R
    T[:2, 2] = meas2.mean(0) - R @ q.mean(0)
    return T


def test_only_isolated_points_far_off_are_left_out():
    # A machined plate (193 x 109 mm) measured at 600 points with an in-tolerance dent, and 2%
    # of the points moved 10 mm out, each on its own (25 mm or more apart, so that its nearest
    # measured points lie on the part): exactly those are left out of the fit, and judged.
    rng = np.random.default_rng(22)
    t = read_dxf_template(f"{DATA}/plate_HFP1JZ.dxf").template
    idx = ContourIndex(t)
    q = points_on(t, 600, rng)
    dev = rng.normal(0.0, 0.002, 600)
    owner = t.contour[deviations_2d(idx, q).primitive]
    lengths = np.bincount(t.contour, np.where(t.kind == 0, np.linalg.norm(t.end - t.start, axis=1),
                                              np.abs(t.sweep) * t.radius))
    outer = np.flatnonzero(owner == np.argmax(lengths))
    r = np.hypot(*(q - q[outer[0]]).T)
    dent = (owner == owner[outer[0]]) & (r < 12.0)
    dev[dent] -= 0.03 * 0.5 * (1.0 + np.cos(np.pi * r[dent] / 12.0))
    gross = []
    for i in rng.permutation(outer[~dent[outer]]):
        if all(np.hypot(*(q[i] - q[j])) >= 25.0 for j in gross):
            gross.append(i)
    gross = np.sort(gross[:12])
    assert gross.size == 12 and dent.sum() >= 10
    dev[gross] += 10.0
    res = inspect_2d(t, measured_from(t, q, dev, rng), 2, Tolerance.symmetric(0.05), index=idx)
    assert np.flatnonzero(~res.registration.inlier).tolist() == gross.tolist()
    assert res.verdict == REJECT and res.statistics.n_out == 12
    # The rest were fitted as they are: their deviations are the planted ones.
    kept = res.registration.inlier
    assert np.max(np.abs(res.deviations.signed[kept] - dev[kept])) < 0.005


def test_dense_mis_probes_anywhere_are_left_out():
    # 3,000 points on the plate and 2% of them, drawn at random, moved 10 mm out: mis-probed
    # points are judged isolated by their neighbours along the contour (their feet), not in the
    # plane, where the nearest points of one 10 mm off are often others 10 mm off.
    rng = np.random.default_rng(31)
    t = read_dxf_template(f"{DATA}/plate_HFP1JZ.dxf").template
    idx = ContourIndex(t)
    q = points_on(t, 3000, rng)
    dev = rng.normal(0.0, 0.002, 3000)
    gross = np.sort(rng.choice(3000, 60, replace=False))
    dev[gross] += 10.0
    res = inspect_2d(t, measured_from(t, q, dev, rng), 2, Tolerance.symmetric(0.05), index=idx)
    assert np.flatnonzero(~res.registration.inlier).tolist() == gross.tolist()
    assert res.verdict == REJECT and res.statistics.n_out == 60


@pytest.mark.parametrize("depth, verdict", [(0.035, ACCEPT), (1.5, REJECT)])
def test_a_dent_is_never_left_out(depth, verdict):
    # In tolerance (±0.05) or far out of it (1.5 mm: three times the gross threshold of five
    # zone widths), the dent's points agree with their neighbours: none is left out.
    rng = np.random.default_rng(23)
    t, q, dev, dent = plate_with_dent(rng, 600, depth=depth)
    res = inspect_2d(t, measured_from(t, q, dev, rng), 2, Tolerance.symmetric(0.05))
    assert res.registration.inlier.all()
    assert res.verdict == verdict
    # The pose is the least-squares one over every point: the dent pulls it a little, and the
    # deviations follow the planted ones up to that pull.
    assert np.max(np.abs(res.deviations.signed - dev)) < 0.1 * depth + 0.01


def d_profile():
    """A D profile: a circle R30 about the origin with a flat 40 degrees wide (centred on +x),
    and 300 points measured on the round part only, from 4 degrees clear of the flat on, with
    0.002 mm noise. Returns (template, points in its frame (300, 2))."""
    from engine.contour import arc, build_template, segment

    R0, half, gap = 30.0, np.radians(20.0), np.radians(4.0)
    p0, p1 = (R0 * np.cos(half), R0 * np.sin(half)), (R0 * np.cos(half), -R0 * np.sin(half))
    t = build_template([([arc((0.0, 0.0), R0, half, 2 * np.pi - 2 * half),
                          segment(p1, p0)], True)])
    rng = np.random.default_rng(1)
    a = rng.uniform(half + gap, 2 * np.pi - half - gap, 300)
    q = (R0 + rng.normal(0.0, 0.002, 300))[:, None] * np.column_stack([np.cos(a), np.sin(a)])
    return t, q


@pytest.fixture(scope="module")
def d_profile_as_drawn():
    """The D profile, its points, and the inspection of the points as drawn (identity pose)."""
    t, q = d_profile()
    idx = ContourIndex(t)
    return t, q, idx, inspect_2d(t, np.column_stack([q, np.zeros(len(q))]), 2,
                                 Tolerance.symmetric(0.03), index=idx)


@pytest.mark.parametrize("seed", range(8))
def test_good_points_a_wrong_start_puts_over_the_flat_are_never_left_out(seed,
                                                                         d_profile_as_drawn):
    # The circle leaves the turn free: a start pose turned a few degrees puts a couple of good
    # points over the flat, several zone widths off and on their own. A point is left out only
    # if it stays gross at the fit with it included, which turns them back onto the arc: in
    # every pose nothing is left out, the pose is the least-squares one over every point, and
    # the verdict is the one of the points as drawn.
    t, q, idx, drawn = d_profile_as_drawn
    rng = np.random.default_rng(100 + seed)
    meas2 = apply_transform(pose_2d(rng.uniform(0, 6.28), rng.uniform(-300, 300, 2)), q)
    res = inspect_2d(t, np.column_stack([meas2, np.zeros(len(q))]), 2,
                     Tolerance.symmetric(0.03), index=idx)
    assert res.registration.converged
    assert res.registration.inlier.all() and drawn.registration.inlier.all()
    d = res.deviations.signed
    best = independent_lsq(idx, meas2, np.linalg.inv(true_pose(meas2, q)),
                           np.ones(len(q), bool))
    assert float(np.sum(d ** 2)) <= best * 1.0002
    assert res.verdict == drawn.verdict


def test_the_pipeline_changes_no_dict_of_a_result_after_inspect_2d_built_it(monkeypatch):
    """A result is frozen once built: the pipeline passes the template file's facts (units,
    flattened curves) into inspect_2d instead of writing them into the finished result's
    ``extra``; the facts still reach the result."""
    import copy

    import engine.pipeline as pipeline
    from engine.settings import InspectionSettings

    built = []

    def spy(*args, **kwargs):
        result = inspect_2d(*args, **kwargs)
        built.append((result, copy.deepcopy(result.extra), dict(result.timings_s)))
        return result

    monkeypatch.setattr(pipeline, "inspect_2d", spy)
    sample = os.path.join(os.path.dirname(__file__), "..", "samples", "fuselage_frame")
    run = pipeline.run_files(os.path.join(sample, "template.dxf"),
                             os.path.join(sample, "measured.csv"),
                             InspectionSettings(tol_lower=-0.2, tol_upper=0.2))
    (result, extra, timings), = built
    assert result.extra == extra and result.timings_s == timings
    facts = run.result.extra["template"]
    assert facts["units"] == run.template.units and facts["unitless"] == run.template.unitless
    assert facts["flattened_curves"] == run.template.flattened
    assert facts["ignored_entities"] == run.template.ignored
    assert facts["primitives"] == run.template.template.n_primitives
