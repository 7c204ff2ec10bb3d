"""Pose recovery from arbitrary poses: full and partial coverage, two faces, outliers."""

import numpy as np
import pytest

from engine.geometry import apply_transform, make_transform
from engine.nominal import Nominal
from engine.registration import register
from surfaces import height, height_grid, height_normal, point_set, random_rotation

import samples.generate as gen


@pytest.fixture(scope="module")
def fairing():
    pts, nrm, grid = height_grid(300, 200)
    return Nominal.from_point_set(point_set(pts, nrm, grid))


def _patch(rng, m, xr, yr, noise=0.004):
    x, y = rng.uniform(*xr, m), rng.uniform(*yr, m)
    q = np.column_stack([x, y, height(x, y)])
    return q + rng.normal(0, noise, m)[:, None] * height_normal(x, y)


def _pose(rng):
    return make_transform(random_rotation(rng), rng.uniform(-3000, 3000, 3))


def _max_error(res, measured, truth_nominal_frame):
    return float(np.max(np.linalg.norm(apply_transform(res.T_nominal_measured, measured)
                                       - truth_nominal_frame, axis=1)))


COVERAGE = {  # name: (points, x range, y range)
    "full": (1100, (-245, 245), (-120, 120)),
    "quarter": (400, (0, 245), (0, 120)),
    "tenth": (400, (-200, -50), (-120, -40)),
}


@pytest.mark.parametrize("coverage", list(COVERAGE))
@pytest.mark.parametrize("seed", [1, 2, 3])
def test_pose_recovered_from_random_pose(fairing, coverage, seed):
    rng = np.random.default_rng(100 * seed + len(coverage))
    m, xr, yr = COVERAGE[coverage]
    q = _patch(rng, m, xr, yr)
    T = _pose(rng)
    measured = apply_transform(T, q)
    res = register(fairing, measured)
    assert res.converged
    # Noise 4 um; a small patch of a smooth surface can slide a little along its weak directions.
    limit = {"full": 0.01, "quarter": 0.03, "tenth": 0.3}[coverage]
    assert _max_error(res, measured, q) < limit
    assert res.rms < 0.006
    assert res.hypotheses > 50


def test_gross_outliers_do_not_move_the_pose(fairing):
    rng = np.random.default_rng(9)
    q = _patch(rng, 1100, (-245, 245), (-120, 120))
    T = _pose(rng)
    clean = register(fairing, apply_transform(T, q))
    bad = q.copy()
    idx = rng.choice(len(q), 12, replace=False)
    x, y = bad[idx, 0], bad[idx, 1]
    bad[idx] += rng.choice([-10.0, 10.0], 12)[:, None] * height_normal(x, y)  # mis-probed 10 mm
    dirty = register(fairing, apply_transform(T, bad))
    assert dirty.converged and dirty.n_inliers == len(q) - 12
    assert not dirty.inlier[idx].any()
    moved = apply_transform(dirty.T_nominal_measured, apply_transform(T, q)) \
        - apply_transform(clean.T_nominal_measured, apply_transform(T, q))
    assert np.max(np.linalg.norm(moved, axis=1)) < 1e-3


def test_two_faces_of_a_bracket_cover_a_small_part():
    rng = np.random.default_rng(21)
    nominal = gen.bracket_points(60_000, rng)
    nom = Nominal.from_point_set(point_set(nominal[:, :3], nominal[:, 3:]))
    xa, ya = rng.uniform(25, 105, 50), rng.uniform(8, 52, 50)
    yb, zb = rng.uniform(8, 52, 50), rng.uniform(25, 80, 50)
    q = np.vstack([np.column_stack([xa, ya, gen.face_a_height(xa, ya)]),
                   np.column_stack([gen.face_b_offset(yb, zb), yb, zb])])
    for trial in range(3):
        T = _pose(rng)
        res = register(nom, apply_transform(T, q))
        assert res.converged
        assert _max_error(res, apply_transform(T, q), q) < 0.02, trial


def test_deterministic(fairing):
    rng = np.random.default_rng(5)
    q = _patch(rng, 400, (0, 245), (0, 120))
    measured = apply_transform(_pose(rng), q)
    a, b = register(fairing, measured), register(fairing, measured)
    assert np.array_equal(a.T_nominal_measured, b.T_nominal_measured)
    assert a.rms == b.rms and a.iterations == b.iterations and a.score == b.score


def test_without_a_zone_a_dent_stays_and_mis_probed_points_go(fairing):
    """The registration on its own (no tolerance zone): the gross threshold's floor is 0.1% of
    the nominal's diagonal; a 0.6 mm dent stays in the least-squares fit, 10 mm mis-probes go."""
    rng = np.random.default_rng(31)
    q = _patch(rng, 1100, (-245, 245), (-120, 120))
    x, y = q[:, 0], q[:, 1]
    dent = -0.6 * np.exp(-((x - 80) ** 2 + (y - 20) ** 2) / (2 * 18.0**2))
    q = q + dent[:, None] * height_normal(x, y)
    idx = np.sort(rng.choice(len(q), 11, replace=False))
    q[idx] += rng.choice([-10.0, 10.0], idx.size)[:, None] * height_normal(x[idx], y[idx])
    res = register(fairing, apply_transform(_pose(rng), q))
    rule = res.gross_rule
    assert rule.zone_width_mm is None
    assert rule.floor_mm == pytest.approx(1e-3 * fairing.diagonal)
    assert res.outlier_cut == rule.threshold_mm
    assert np.array_equal(np.flatnonzero(~res.inlier), idx)
