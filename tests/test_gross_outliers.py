"""The least-squares fit is least squares: only gross outliers are excluded from the alignment.

Truth is independent of the engine: planted mis-probed points (10 mm off along the exact normal),
planted dents of known depth, and the least-squares optimum found by scipy's
``least_squares`` over a 6-parameter pose (residuals: the signed point-to-surface deviations),
started from the known true pose.
"""

import json
import os

import numpy as np
import pytest
from scipy.optimize import least_squares

import samples.generate as gen
from engine.deviation import point_to_surface
from engine.geometry import apply_transform, make_transform, rotation_from_rotvec
from engine.inspection import Tolerance, inspect
from engine.nominal import Nominal
from engine.outliers import gross_outliers, gross_rule
from engine.registration import RegistrationSettings, register
from reports.loading import load_point_set
from surfaces import height, height_grid, height_normal, point_set, random_rotation

ZONE = Tolerance.symmetric(0.25)


@pytest.fixture(scope="module")
def fairing():
    pts, nrm, grid = height_grid(300, 200)
    return Nominal.from_point_set(point_set(pts, nrm, grid))


def _dent(x, y, depth, centre, sigma=18.0):
    return -depth * np.exp(-((x - centre[0]) ** 2 + (y - centre[1]) ** 2) / (2 * sigma**2))


def _part(rng, m=1100, depth=0.0, centre=(120.0, -40.0), noise=0.004):
    """(points in the nominal frame, planted deviations, measured points, T_measured_nominal)."""
    x, y = rng.uniform(-245, 245, m), rng.uniform(-120, 120, m)
    d = rng.normal(0.0, noise, m) + _dent(x, y, depth, centre)
    q = np.column_stack([x, y, height(x, y)]) + d[:, None] * height_normal(x, y)
    T = make_transform(random_rotation(rng), rng.uniform(-2000, 2000, 3))
    return q, d, apply_transform(T, q), T


def _mis_probe(rng, q, fraction=0.02, offset=10.0):
    """q with ``fraction`` of its points moved ``offset`` mm along the normal (either way)."""
    idx = np.sort(rng.choice(len(q), int(round(fraction * len(q))), replace=False))
    bad = q.copy()
    bad[idx] += rng.choice([-offset, offset], idx.size)[:, None] * height_normal(q[idx, 0],
                                                                                 q[idx, 1])
    return bad, idx


def _optimum(nominal, measured, T0, keep):
    """Independent least-squares optimum of sum(d^2) over ``measured[keep]`` (scipy, 6 pose
    parameters: a rotation vector about the kept points' centroid and a translation, after T0)."""
    X0 = apply_transform(T0, measured[keep])
    c = X0.mean(axis=0)

    def residuals(p):
        R = rotation_from_rotvec(p[None, :3])[0]
        return point_to_surface(nominal, (X0 - c) @ R.T + c + p[3:]).signed

    r = least_squares(residuals, np.zeros(6), x_scale=np.r_[np.full(3, 1e-3), np.ones(3)],
                      xtol=1e-15, ftol=1e-15, gtol=1e-15, method="lm")
    return float(np.sum(r.fun**2))


def _sum_sq(res, keep):
    d = res.deviations.signed[keep]
    return float(np.sum(d * d))


def test_two_percent_mis_probed_points_are_exactly_the_excluded_ones(fairing):
    """1,100 points with an in-tolerance dent, 22 of them mis-probed 10 mm off: exactly those 22
    are excluded from the alignment, and the pose is the least-squares pose of the others."""
    rng = np.random.default_rng(41)
    q, _, _, T = _part(rng, depth=0.15)
    bad, idx = _mis_probe(rng, q)
    good = np.setdiff1d(np.arange(len(q)), idx)
    clean = inspect(fairing, apply_transform(T, q[good]), ZONE)
    dirty = inspect(fairing, apply_transform(T, bad), ZONE)
    assert idx.size == 22
    assert np.array_equal(np.flatnonzero(dirty.outlier), idx)
    assert not clean.outlier.any()
    # The good points end where the least-squares pose of the good points alone puts them.
    moved = apply_transform(dirty.registration.T_nominal_measured, apply_transform(T, q)) \
        - apply_transform(clean.registration.T_nominal_measured, apply_transform(T, q))
    assert np.max(np.linalg.norm(moved, axis=1)) < 1e-4
    rule = dirty.registration.gross_rule
    assert dirty.registration.outlier_cut == rule.threshold_mm == pytest.approx(2.5)
    assert "gross outlier" in rule.describe() and "2.5 mm" in rule.describe()
    # The excluded points are judged all the same: 10 mm off is out of tolerance.
    assert not dirty.in_tolerance[idx].any()


@pytest.mark.parametrize("depth", [0.15, 0.4, 3.0])
def test_a_dent_is_never_excluded(fairing, depth):
    """An in-tolerance dent (0.15 mm on +-0.25), an out-of-tolerance one (0.4 mm) and one deeper
    than the gross threshold (3 mm > 5 zone widths): all its points stay in the fit."""
    rng = np.random.default_rng(int(depth * 100))
    q, d, measured, _ = _part(rng, depth=depth)
    res = inspect(fairing, measured, ZONE)
    assert res.registration.converged
    assert not res.outlier.any() and res.registration.n_inliers == len(q)
    deepest = int(np.argmin(d))
    assert res.deviations.signed[deepest] < -0.6 * depth  # the dent is there, and judged
    if depth > 0.25:
        assert not res.in_tolerance[deepest]


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_pose_is_the_least_squares_optimum(fairing, seed):
    """Held-out parts with a dent somewhere (in tolerance or not): sum(d^2) over every point is
    within 0.02% of an independent optimiser's."""
    rng = np.random.default_rng(500 + seed)
    depth = [0.12, 0.2, 0.4][seed - 1]
    centre = (rng.uniform(-200, 200), rng.uniform(-90, 90))
    q, _, measured, T = _part(rng, depth=depth, centre=centre)
    res = inspect(fairing, measured, ZONE)
    keep = np.ones(len(q), bool)
    assert not res.outlier.any()
    best = _optimum(fairing, measured, np.linalg.inv(T), keep)
    assert _sum_sq(res, keep) <= best * (1 + 2e-4)


def test_subset_then_all_points_ends_at_the_all_point_optimum(fairing):
    """With the subset-then-all-points strategy (a 400-point subset here) the pose is still the
    least-squares optimum over every kept point, gross outliers excluded."""
    rng = np.random.default_rng(77)
    q, _, _, T = _part(rng, depth=0.3, centre=(-60.0, 30.0))
    bad, idx = _mis_probe(rng, q)
    measured = apply_transform(T, bad)
    res = register(fairing, measured, RegistrationSettings(fit_measured=400), zone_width=0.5)
    keep = np.ones(len(q), bool)
    keep[idx] = False
    assert res.converged and np.array_equal(res.inlier, keep)
    best = _optimum(fairing, measured, np.linalg.inv(T), keep)
    d = res.deviations.signed[keep]
    assert float(np.sum(d * d)) <= best * (1 + 2e-4)


def test_dense_points_mis_probed_side_by_side_are_still_excluded(fairing):
    """20,000 points (0.8 mm apart), 2% of them 10 mm off: each has other mis-probed points
    within a few millimetres, nearer in space than the surface points below it; measured along
    the surface they are still isolated, and exactly they are excluded."""
    rng = np.random.default_rng(78)
    q, _, _, T = _part(rng, m=20_000, depth=0.3, centre=(-60.0, 30.0))
    bad, idx = _mis_probe(rng, q)
    res = inspect(fairing, apply_transform(T, bad), ZONE)
    assert res.registration.converged
    assert np.array_equal(np.flatnonzero(res.outlier), idx)


def test_belly_fairing_sample_excludes_no_good_point():
    """The bundled sample (a 0.15 mm dent and a 0.06 mm rise on +-0.25 mm, no mis-probed point):
    nothing excluded, and the pose is the least-squares pose over all 1,100 points."""
    folder = os.path.join(os.path.dirname(os.path.abspath(gen.__file__)), "belly_fairing")
    with open(os.path.join(folder, "truth.json")) as f:
        truth = json.load(f)
    nom = Nominal.from_point_set(load_point_set(os.path.join(folder, "nominal.csv")))
    measured = load_point_set(os.path.join(folder, "measured.csv")).points
    res = inspect(nom, measured, Tolerance.symmetric(truth["tolerance_mm"]))
    assert not res.outlier.any()
    keep = np.ones(len(measured), bool)
    best = _optimum(nom, measured, np.array(truth["T_nominal_measured"]), keep)
    assert _sum_sq(res, keep) <= best * (1 + 2e-4)


def test_rule_keeps_a_sharp_rimmed_dent_and_flags_mis_probes_even_side_by_side():
    """The rule itself, on a flat 40 x 40 grid (1 mm pitch): a flat-bottomed pit 3 mm deep with
    a sharp rim (beyond the 2.5 mm threshold) is a region and stays; isolated 10 mm spikes are
    gross, and so are three spikes that happen to lie side by side among good points (each has
    at most 2 alike among its 8 nearest, none has 3)."""
    x, y = np.meshgrid(np.arange(40.0), np.arange(40.0))
    x, y = x.ravel(), y.ravel()
    pts = np.column_stack([x, y, np.zeros(x.size)])
    d = np.random.default_rng(0).normal(0, 0.003, x.size)
    pit = (x - 10) ** 2 + (y - 10) ** 2 <= 9
    d[pit] -= 3.0
    at = {(xi, yi): i for i, (xi, yi) in enumerate(zip(x.astype(int), y.astype(int)))}
    spikes = np.array([at[30, 5], at[5, 30], at[20, 20], at[21, 21], at[22, 20]])
    d[spikes] += 10.0
    rule = gross_rule(d, 0.5, 0.05)
    assert rule.threshold_mm == pytest.approx(2.5)
    assert np.array_equal(np.flatnonzero(gross_outliers(d, pts, rule)), np.sort(spikes))


def test_outputs_state_the_rule_and_mark_only_the_excluded_points(fairing):
    """JSON: the rule in words with its threshold and the excluded points; CSV: an
    excluded_from_alignment column true exactly on them; QIF: the same per-point flag."""
    import csv
    import io

    from lxml import etree

    from reports.qif import qif_results_document
    from reports.results import points_csv, result_document, result_json

    rng = np.random.default_rng(43)
    q, _, _, T = _part(rng, m=600, depth=0.4)
    bad, idx = _mis_probe(rng, q)
    measured = apply_transform(T, bad)
    res = inspect(fairing, measured, ZONE)
    doc = json.loads(result_json(result_document(res, [], {})))
    gross = doc["registration"]["gross_outliers"]
    assert gross["n_excluded"] == idx.size == 12
    assert [e["index"] for e in gross["excluded"]] == idx.tolist()
    assert gross["threshold_mm"] == pytest.approx(2.5) and gross["zone_width_mm"] == 0.5
    assert gross["rule"].startswith("a point is excluded from the alignment only as a gross "
                                    "outlier") and "2.5 mm" in gross["rule"]
    rows = list(csv.DictReader(io.StringIO(points_csv(res, measured, None))))
    assert "outlier" not in rows[0]
    flagged = [i for i, r in enumerate(rows) if r["excluded_from_alignment"] == "true"]
    assert flagged == idx.tolist()
    # The 0.4 mm dent is out of tolerance, fitted, and not flagged.
    assert sum(r["in_tolerance"] == "false" for r in rows) > idx.size
    root = etree.fromstring(qif_results_document(doc, res.registered, res.deviations.signed,
                                                 res.in_tolerance, outlier=res.outlier))
    ns = {"q": root.nsmap[None]}
    value, = root.xpath("//q:AttributeStr[@name='qa-inspect:excluded-from-alignment']/@value",
                        namespaces=ns)
    assert [i for i, c in enumerate(value) if c == "1"] == idx.tolist()
    assert not root.xpath("//q:AttributeStr[@name='qa-inspect:outlier']", namespaces=ns)
