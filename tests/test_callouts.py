"""Which points a map calls out (reports.callouts.callout_points, the certificate's and the app's):
the worst point of each separate cluster."""

import numpy as np

from reports.callouts import PASSING_SHARE, callout_points


def grid_with_defects():
    """A 60 × 40 grid of points 2 mm apart, noise of 2 µm, with a dent of −0.4 mm (Gaussian,
    σ 5 mm) at (30, 30), a bump of +0.35 mm (σ 4 mm) at (90, 50) and a single spike of
    +0.3 mm at point (100, 10)."""
    rng = np.random.default_rng(7)
    x, y = np.meshgrid(np.arange(60) * 2.0, np.arange(40) * 2.0)
    pts = np.column_stack([x.ravel(), y.ravel(), np.zeros(x.size)])
    d = rng.normal(0, 0.002, x.size)
    d += -0.4 * np.exp(-((pts[:, 0] - 30) ** 2 + (pts[:, 1] - 30) ** 2) / (2 * 5 ** 2))
    d += 0.35 * np.exp(-((pts[:, 0] - 90) ** 2 + (pts[:, 1] - 50) ** 2) / (2 * 4 ** 2))
    spike = int(np.flatnonzero((pts[:, 0] == 100) & (pts[:, 1] == 10))[0])
    d[spike] = 0.3
    return pts, d, spike


def test_one_callout_per_defect_at_its_worst_point_worst_first():
    pts, d, spike = grid_with_defects()
    flags = callout_points(pts, d, -0.1, 0.1)
    dent = int(np.argmin(d))
    bump = int(np.argmax(np.where(np.hypot(pts[:, 0] - 90, pts[:, 1] - 50) < 20, d, -1)))
    assert flags == [dent, bump, spike]
    assert np.hypot(*(pts[dent, :2] - (30, 30))) < 2.1  # the planted dent's deepest point
    # The five worst points all lie in the dent: a "five worst" rule would flag it five times.
    assert np.all(np.hypot(pts[np.argsort(d)[:5], 0] - 30, pts[np.argsort(d)[:5], 1] - 30) < 5)
    assert callout_points(pts, d, -0.1, 0.1, max_callouts=2) == [dent, bump]


def test_a_dent_beside_a_bump_gets_two_callouts():
    """Adjacent points of opposite sign are separate clusters (a dent and its raised rim)."""
    pts = np.column_stack([np.arange(8.0), np.zeros(8)])
    d = np.array([0, -0.3, -0.6, -0.3, 0.3, 0.5, 0, 0])
    assert callout_points(pts, d, -0.2, 0.2) == [2, 5]


def test_an_accepted_part_calls_out_its_largest_departures():
    """No point outside the zone: the points deviating by at least PASSING_SHARE of the largest
    |deviation| are the candidates, so the dent of an accepted part still gets its flag."""
    pts, d, spike = grid_with_defects()
    inside = d * 0.2  # dent −0.08, bump +0.07, spike +0.06: all inside ±0.1
    assert 0.06 >= PASSING_SHARE * 0.08
    flags = callout_points(pts, inside, -0.1, 0.1)
    assert flags == [int(np.argmin(inside)), int(np.argmax(np.where(
        np.hypot(pts[:, 0] - 90, pts[:, 1] - 50) < 20, inside, -1))), spike]


def test_nothing_to_call_out():
    pts = np.zeros((3, 3)) + np.arange(3.0)[:, None]
    assert callout_points(pts, np.zeros(3), -0.1, 0.1) == []
    assert callout_points(np.zeros((0, 3)), np.zeros(0), -0.1, 0.1) == []
