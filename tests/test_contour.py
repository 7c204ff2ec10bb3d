"""2D contours: exact distances to segments and arcs, the sign convention, the nearest search."""

import numpy as np
import pytest
from scipy.optimize import minimize_scalar

from engine.contour import (ARC, ContourIndex, arc, build_template, contains, contour_centroid,
                            deviations_2d, diagonal, segment, signed_area)


def naive_arc_distance(p, c, r, a0, sweep):
    """Bounded 1D minimisation over the arc's angle, ends checked too."""
    f = lambda th: np.hypot(p[0] - c[0] - r * np.cos(th), p[1] - c[1] - r * np.sin(th))
    lo, hi = sorted((a0, a0 + sweep))
    best = min(f(lo), f(hi))
    grid = np.linspace(lo, hi, 721)
    g = grid[np.argmin([f(x) for x in grid])]
    step = (hi - lo) / 720
    res = minimize_scalar(f, bounds=(max(lo, g - step), min(hi, g + step)), method="bounded",
                          options={"xatol": 1e-13})
    return min(best, res.fun)


def naive_segment_distance(p, a, b):
    best = min(np.hypot(*(p - a)), np.hypot(*(p - b)))
    ab = b - a
    t = np.dot(p - a, ab) / np.dot(ab, ab)
    if 0 <= t <= 1:
        # The paper's equation (4): |(X2 - X1) x (X1 - X0)| / |X2 - X1|.
        best = min(best, abs(ab[0] * (a - p)[1] - ab[1] * (a - p)[0]) / np.hypot(*ab))
    return best


def square(x0, y0, s, ccw=True):
    pts = [(x0, y0), (x0 + s, y0), (x0 + s, y0 + s), (x0, y0 + s)]
    if not ccw:
        pts = pts[::-1]
    return [segment(pts[i], pts[(i + 1) % 4]) for i in range(4)]


def slotted_plate():
    """A 40 x 20 plate with rounded right end (a CCW half circle) and a round hole (drawn CW)."""
    outer = [segment((0, 0), (30, 0)), arc((30, 10), 10, -np.pi / 2, np.pi),
             segment((30, 20), (0, 20)), segment((0, 20), (0, 0))]
    hole = [arc((12, 10), 4, 0.0, -2 * np.pi)]
    return build_template([(outer, True), (hole, True)])


def test_signed_area_with_arcs():
    t = slotted_plate()
    assert signed_area(t, 0) == pytest.approx(30 * 20 + np.pi * 100 / 2)
    assert signed_area(t, 1) == pytest.approx(-np.pi * 16)


def test_sign_convention_outer_profile_and_hole():
    t = slotted_plate()
    idx = ContourIndex(t)
    pts = np.array([[15, -0.3],     # below the bottom edge: outside the plate, excess side
                    [15, 0.3],      # just inside the plate
                    [41.5, 10],     # beyond the rounded end
                    [39.0, 10],     # inside the rounded end
                    [12, 10 + 3.5],  # inside the hole: excess material would be here
                    [12, 10 + 4.5]])  # in the material around the hole
    d = deviations_2d(idx, pts).signed
    assert np.allclose(d, [0.3, -0.3, 1.5, -1.0, 0.5, -0.5], atol=1e-12)


def test_winding_does_not_change_the_sign():
    for ccw in (True, False):
        t = build_template([(square(0, 0, 10, ccw), True)])
        d = deviations_2d(ContourIndex(t), np.array([[5, -1.0], [5, 1.0], [11, 5], [9.5, 5]]))
        assert np.allclose(d.signed, [1.0, -1.0, 1.0, -0.5])


def test_open_contour_positive_to_the_left():
    t = build_template([([segment((0, 0), (10, 0)), arc((10, 5), 5, -np.pi / 2, np.pi / 2)],
                         False)])
    d = deviations_2d(ContourIndex(t), np.array([[5, 1.0], [5, -1.0], [14, 5], [16, 5]]))
    # Along +x the left is +y; along the CCW arc the left is toward its centre.
    assert np.allclose(d.signed, [1.0, -1.0, 1.0, -1.0])


def test_corners_convex_and_concave_sign_like_point_in_polygon():
    # An L-shaped outer profile: convex corners and one concave corner at (10, 10).
    pts = [(0, 0), (20, 0), (20, 10), (10, 10), (10, 20), (0, 20)]
    t = build_template([([segment(pts[i], pts[(i + 1) % 6]) for i in range(6)], True)])
    rng = np.random.default_rng(3)
    corners = np.array(pts, float)
    q = (corners[rng.integers(0, 6, 2000)] + rng.normal(0, 0.5, (2000, 2)))
    d = deviations_2d(ContourIndex(t), q).signed
    inside = contains(t, 0, q)
    far = np.abs(d) > 1e-9
    assert np.all((d[far] < 0) == inside[far])


def test_random_templates_match_naive_distances():
    rng = np.random.default_rng(4)
    for trial in range(5):
        # A closed contour of random segments and bulged arcs around a circle.
        k = 12
        ang = np.sort(rng.uniform(0, 2 * np.pi, k))
        rad = rng.uniform(20, 30, k)
        v = np.column_stack([rad * np.cos(ang), rad * np.sin(ang)])
        prims = []
        for i in range(k):
            a, b = v[i], v[(i + 1) % k]
            if i % 3 == 0:
                # Arc through a and b with a random bulge (both signs).
                bulge = rng.choice([-1, 1]) * rng.uniform(0.1, 0.6)
                theta = 4 * np.arctan(bulge)
                chord = b - a
                L = np.hypot(*chord)
                r = L / (2 * np.sin(abs(theta) / 2))
                mid = (a + b) / 2
                nrm = np.array([-chord[1], chord[0]]) / L
                h = r * np.cos(theta / 2)
                c = mid + np.sign(theta) * h * nrm
                a0 = np.arctan2(a[1] - c[1], a[0] - c[0])
                prims.append(arc(c, r, a0, theta))
                assert np.allclose(prims[-1]["end"], b, atol=1e-9)
            else:
                prims.append(segment(a, b))
        t = build_template([(prims, True)])
        q = rng.uniform(-40, 40, (300, 2))
        dev = deviations_2d(ContourIndex(t), q)
        ref = []
        for p in q:
            ds = []
            for i in range(t.n_primitives):
                if t.kind[i] == ARC:
                    ds.append(naive_arc_distance(p, t.centre[i], t.radius[i], t.angle0[i],
                                                 t.sweep[i]))
                else:
                    ds.append(naive_segment_distance(p, t.start[i], t.end[i]))
            ref.append(min(ds))
        assert np.max(np.abs(np.abs(dev.signed) - np.array(ref))) < 1e-9, trial
        inside = contains(t, 0, q)
        far = np.abs(dev.signed) > 1e-6
        assert np.all((dev.signed[far] < 0) == inside[far]), trial


def test_centroid_of_the_contours_weighs_length_not_primitives():
    # A half circle (r 1, centroid (2/pi, 0)) closed by its diameter (centroid the origin), and
    # far away a square of side 2 at (100, 0) cut into 400 tiny segments: every unit of length
    # weighs alike, however many primitives carry it.
    half = [arc((0.0, 0.0), 1.0, -np.pi / 2, np.pi), segment((0.0, 1.0), (0.0, -1.0))]
    corners = np.array([(99, -1), (101, -1), (101, 1), (99, 1), (99, -1)], float)
    fine = [segment(a + (b - a) * k / 100, a + (b - a) * (k + 1) / 100)
            for a, b in zip(corners[:-1], corners[1:]) for k in range(100)]
    t = build_template([(half, True), (fine, True)])
    L_half, L_sq = np.pi + 2.0, 8.0
    expect = (np.array([np.pi * 2 / np.pi, 0.0]) + np.array([100.0, 0.0]) * L_sq) / (L_half + L_sq)
    assert np.allclose(contour_centroid(t), expect, atol=1e-12)
    assert np.allclose(ContourIndex(t).centroid, expect, atol=1e-12)


def test_diagonal_bounds_the_contours_and_takes_each_arcs_circle():
    """The part's size a 2D zone is checked against (engine.pipeline.part_size): a 3-4-5
    segment's box is 50 across; a quarter arc adds its whole circle's box (an upper bound)."""
    assert diagonal(build_template([([segment((0, 0), (30, 40))], False)])) == pytest.approx(50)
    t = build_template([([segment((0, 0), (30, 40)), arc((30, 50), 10, -np.pi / 2, np.pi / 2)],
                         False)])
    assert diagonal(t) == pytest.approx(np.hypot(40, 60))
