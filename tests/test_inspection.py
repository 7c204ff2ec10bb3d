"""Verdict rules and statistics, on analytic parts with planted deviations."""

import numpy as np
import pytest

from engine.errors import SettingsError
from engine.geometry import apply_transform, make_transform
from engine.inspection import Tolerance, inspect
from engine.nominal import Nominal
from engine.registration import RegistrationSettings, register
from engine.verdict import ACCEPT, INCONCLUSIVE, REJECT, Statistics, judge
from surfaces import height, height_grid, height_normal, point_set, random_rotation


@pytest.fixture(scope="module")
def fairing():
    pts, nrm, grid = height_grid(300, 200)
    return Nominal.from_point_set(point_set(pts, nrm, grid))


def _part(rng, dev):
    m = len(dev)
    x, y = rng.uniform(-245, 245, m), rng.uniform(-120, 120, m)
    q = np.column_stack([x, y, height(x, y)]) + np.asarray(dev)[:, None] * height_normal(x, y)
    T = make_transform(random_rotation(rng), rng.uniform(-1000, 1000, 3))
    return q, apply_transform(T, q)


def test_small_local_error_rejects_although_rms_is_tiny(fairing):
    """The paper's point: a tiny RMS can hide one point far out of tolerance."""
    rng = np.random.default_rng(1)
    dev = rng.normal(0, 0.003, 1100)
    dev[517] = 0.18
    _, measured = _part(rng, dev)
    res = inspect(fairing, measured, Tolerance.symmetric(0.05))
    assert res.verdict == REJECT
    assert res.statistics.n_out == 1 and res.statistics.worst[0] == 517
    assert res.deviations.signed[517] == pytest.approx(0.18, abs=2e-3)
    assert res.statistics.rms < 0.01  # the RMS alone would have passed the part


def test_accept_with_asymmetric_zone_and_signs(fairing):
    rng = np.random.default_rng(2)
    dev = rng.normal(0, 0.003, 800)
    dev[:40] = np.linspace(-0.09, 0.25, 40)  # a cluster inside [-0.1, +0.3]... spread over the part
    _, measured = _part(rng, dev)
    res = inspect(fairing, measured, Tolerance(-0.1, 0.3))
    assert res.verdict == ACCEPT and res.statistics.n_out == 0
    assert np.max(np.abs(res.deviations.signed - dev)) < 0.01
    flipped = inspect(fairing, measured, Tolerance(-0.3, 0.1))
    assert flipped.verdict == REJECT  # +0.25 is excess material beyond +0.1


def test_statistics_match_numpy():
    d = np.array([-0.2, 0.05, 0.1, 0.31, -0.01])
    st = Statistics.of(d, Tolerance(-0.1, 0.3))
    assert (st.count, st.n_out) == (5, 2)
    assert st.min == -0.2 and st.max == 0.31 and st.max_abs == 0.31
    assert st.mean == pytest.approx(d.mean()) and st.std == pytest.approx(d.std())
    assert st.rms == pytest.approx(np.sqrt(np.mean(d**2)))
    assert st.fraction_in == pytest.approx(0.6)
    assert st.worst[:2] == (0, 3)  # 0.1 beyond the lower limit, then 0.01 beyond the upper


def test_unconverged_or_untrustworthy_pose_is_inconclusive(fairing):
    rng = np.random.default_rng(3)
    _, measured = _part(rng, rng.normal(0, 0.003, 300))
    reg = register(fairing, measured, RegistrationSettings(max_final_iterations=1))
    assert not reg.converged
    verdict, reasons, _ = judge(np.zeros(300), Tolerance.symmetric(1.0), reg)
    assert verdict == INCONCLUSIVE and "did not converge" in reasons[0]


def test_points_that_match_nothing_are_inconclusive_not_rejected(fairing):
    rng = np.random.default_rng(4)
    blob = rng.normal(size=(300, 3)) * 40.0  # a scan of some other object
    res = inspect(fairing, blob, Tolerance.symmetric(0.1))
    assert res.verdict == INCONCLUSIVE


def test_tolerance_validation():
    with pytest.raises(SettingsError):
        Tolerance(0.1, -0.1)
    with pytest.raises(SettingsError):
        Tolerance.symmetric(0.0)
    with pytest.raises(SettingsError):
        Tolerance(float("nan"), 1.0)


def test_unconverged_fit_on_a_subset_still_measures_every_point(fairing):
    """A measurement larger than the fit's subset whose fit does not settle: the deviations and
    the verdict still cover every point."""
    rng = np.random.default_rng(8)
    _, measured = _part(rng, rng.normal(0, 0.003, 900))
    settings = RegistrationSettings(max_final_iterations=1, fit_measured=200)
    res = inspect(fairing, measured, Tolerance.symmetric(1.0), settings)
    assert res.deviations.signed.shape == (900,) and res.in_tolerance.shape == (900,)
    assert res.registration.inlier.shape == (900,)
    assert res.verdict == INCONCLUSIVE
