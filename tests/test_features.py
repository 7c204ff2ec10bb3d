"""engine.gdt.features against independent truth: the minimum zone against an exhaustive search over
every candidate normal and a multi-start Nelder-Mead over the normal's angles; the least-squares
circle, sphere and cylinder against analytic shapes in random poses (exact without noise; within
a few standard errors of the truth with noise, the standard errors from the test's own model of
the residuals, and a stationary point of that model's sum of squares); position values against
hand-computed ones; every degenerate input refused with a message."""

import numpy as np
import pytest
from scipy.optimize import minimize

from engine.errors import QAError
from engine.gdt.features import (FeatureError, fit_circle_lsq, fit_cylinder_lsq, fit_line_lsq,
                             fit_plane_lsq, fit_sphere_lsq, flatness, position_value)
from surfaces import random_rotation


# ---- independent twins -------------------------------------------------------------------------

def brute_force_min_zone(p):
    """The minimum zone width of (n, 3) or (n, 2) points by exhaustive search: the optimal pair
    of planes touches the points face-to-vertex or edge-to-edge, so its normal is the cross
    product of two point differences (3D) or normal to one (2D); every candidate's max - min
    is a valid zone, the smallest is the minimum. O(n^4): small n only."""
    i, j = np.triu_indices(len(p), 1)
    D = p[j] - p[i]
    if p.shape[1] == 2:
        N = np.column_stack([-D[:, 1], D[:, 0]])
    else:
        a, b = np.triu_indices(len(D), 1)
        N = np.cross(D[a], D[b])
    nn = np.linalg.norm(N, axis=1)
    N = N[nn > 1e-12 * nn.max()] / nn[nn > 1e-12 * nn.max(), None]
    best = np.inf
    for s in range(0, len(N), 100_000):
        proj = p @ N[s:s + 100_000].T
        best = min(best, float(np.min(proj.max(axis=0) - proj.min(axis=0))))
    return best


def nelder_mead_min_zone(p, normal, starts, rng):
    """The smallest width max - min of p . n(theta, phi) that Nelder-Mead finds from ``starts``
    random normals within ~20 degrees of ``normal``."""
    def width(x):
        n = np.array([np.sin(x[0]) * np.cos(x[1]), np.sin(x[0]) * np.sin(x[1]), np.cos(x[0])])
        s = p @ n
        return s.max() - s.min()

    best = np.inf
    for _ in range(starts):
        n0 = normal + 0.35 * rng.normal(size=3) / np.sqrt(3)
        n0 /= np.linalg.norm(n0)
        x0 = [np.arccos(n0[2]), np.arctan2(n0[1], n0[0])]
        r = minimize(width, x0, method="Nelder-Mead",
                     options={"xatol": 1e-13, "fatol": 1e-15, "maxiter": 4000, "maxfev": 8000})
        best = min(best, r.fun)
    return best


def standard_errors(residual, x_true, sigma):
    """sqrt(diag(sigma^2 (J^T J)^-1)) of a least-squares model with residuals ``residual(x)``
    at the truth (central-difference Jacobian): the spread of a fit under noise sigma."""
    x_true = np.asarray(x_true, float)
    J = np.empty((residual(x_true).size, x_true.size))
    for k in range(x_true.size):
        h = np.zeros_like(x_true)
        h[k] = 1e-6
        J[:, k] = (residual(x_true + h) - residual(x_true - h)) / 2e-6
    return sigma * np.sqrt(np.diag(np.linalg.inv(J.T @ J)))


def assert_stationary(residual, x, scale):
    """x minimises sum(residual**2) locally: the residual vector is orthogonal to every column
    of the Jacobian (central differences, steps 1e-5 x scale; cosine below 1e-6, the
    first-order condition) and no such step in any parameter lowers the sum."""
    x = np.asarray(x, float)
    r0 = residual(x)
    f0 = np.sum(r0 ** 2)
    for k in range(x.size):
        h = np.zeros_like(x)
        h[k] = 1e-5 * scale
        rp, rm = residual(x + h), residual(x - h)
        column = (rp - rm) / (2 * h[k])
        assert abs(column @ r0) <= 1e-6 * np.linalg.norm(column) * np.linalg.norm(r0)
        assert np.sum(rp ** 2) >= f0 and np.sum(rm ** 2) >= f0


def _posed_plate(rng, n, height):
    """n points over a 100 x 60 mm plate with z = height(x, y), in a random pose; returns
    (points, the plate's unit normal in the pose)."""
    x, y = rng.uniform(-50, 50, n), rng.uniform(-30, 30, n)
    R = random_rotation(rng)
    t = rng.uniform(-200, 200, 3)
    return np.column_stack([x, y, height(x, y)]) @ R.T + t, R[:, 2]


# ---- flatness -----------------------------------------------------------------------------------

@pytest.mark.parametrize("surface", ["noise", "bump", "saddle"])
def test_flatness_is_the_exhaustive_minimum_zone(surface):
    rng = np.random.default_rng({"noise": 1, "bump": 2, "saddle": 3}[surface])
    for _ in range(4):
        e = rng.normal(0, 0.01, 36)

        def height(x, y):
            if surface == "bump":
                return 0.003 * e + 0.05 * np.exp(-((x - 10) ** 2 + y ** 2) / 200.0)
            if surface == "saddle":
                return 0.003 * e + 2e-5 * x * y
            return e

        p, normal = _posed_plate(rng, 36, height)
        hint = normal + 0.2 * rng.normal(size=3)
        z = flatness(p, hint)
        truth = brute_force_min_zone(p)
        assert z.width == pytest.approx(truth, abs=1e-12)
        assert z.normal @ hint > 0 and np.linalg.norm(z.normal) == pytest.approx(1.0, abs=1e-15)
        s = p @ z.normal
        assert s.min() == pytest.approx(z.low, abs=1e-12) and s.max() == pytest.approx(z.high,
                                                                                     abs=1e-12)
        assert z.width == pytest.approx(z.high - z.low, abs=1e-15)
        assert z.width <= fit_plane_lsq(p).form_error + 1e-12


@pytest.mark.parametrize("surface", ["noise", "bump", "saddle"])
def test_flatness_of_many_points_matches_nelder_mead(surface):
    rng = np.random.default_rng(10 + ["noise", "bump", "saddle"].index(surface))
    shapes = {"noise": lambda x, y: rng.normal(0, 0.005, x.size),
              "bump": lambda x, y: 0.04 * np.exp(-((x + 5) ** 2 + (y - 8) ** 2) / 150.0),
              "saddle": lambda x, y: 1e-5 * x * y + rng.normal(0, 0.001, x.size)}
    p, normal = _posed_plate(rng, 2000, shapes[surface])
    z = flatness(p)  # default hint: the least-squares normal
    nm = nelder_mead_min_zone(p, normal, 12, rng)
    assert z.width <= nm + 1e-12  # never worse than the optimiser
    assert nm - z.width < 1e-6 * z.width  # which comes close to it from some start
    assert abs(z.normal @ normal) > np.cos(0.01)


def test_flatness_of_exactly_planar_points_is_zero():
    rng = np.random.default_rng(4)
    for _ in range(5):
        p, normal = _posed_plate(rng, 50, lambda x, y: np.zeros_like(x))
        z = flatness(p, normal)
        assert z.width < 1e-9
        assert np.linalg.norm(z.normal - normal) < 1e-9
    grid = np.stack(np.meshgrid(np.arange(5.0), np.arange(4.0)), -1).reshape(-1, 2)
    assert flatness(np.column_stack([grid, np.full(20, 3.0)])).width == 0.0


def test_flatness_does_not_depend_on_the_hint():
    rng = np.random.default_rng(5)
    p, normal = _posed_plate(rng, 400, lambda x, y: rng.normal(0, 0.01, x.size))
    truth = flatness(p, normal)
    for tilt in (0.3, 0.8, 1.2):  # radians off the plate's normal
        side = np.cross(normal, rng.normal(size=3))
        hint = np.cos(tilt) * normal + np.sin(tilt) * side / np.linalg.norm(side)
        z = flatness(p, -hint)
        assert z.width == pytest.approx(truth.width, abs=1e-12)
        assert z.normal == pytest.approx(-truth.normal, abs=1e-12)


def test_straightness_of_2d_points_is_the_exhaustive_minimum_zone():
    rng = np.random.default_rng(6)
    for _ in range(5):
        x = rng.uniform(0, 80, 40)
        y = 0.01 * rng.normal(size=40) + 1e-4 * (x - 40) ** 2
        a = rng.uniform(0, 2 * np.pi)
        R = np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])
        p = np.column_stack([x, y]) @ R.T + rng.uniform(-50, 50, 2)
        z = flatness(p, R[:, 1])
        assert z.width == pytest.approx(brute_force_min_zone(p), abs=1e-12)
        assert z.normal @ R[:, 1] > 0


# ---- least-squares plane and line ----------------------------------------------------------------

def test_lsq_plane_exact_and_noisy():
    rng = np.random.default_rng(7)
    p, normal = _posed_plate(rng, 300, lambda x, y: np.zeros_like(x))
    f = fit_plane_lsq(p, normal)
    assert np.linalg.norm(f.normal - normal) < 1e-12 and f.rms < 1e-12 and f.form_error < 1e-12
    sigma = 0.01
    p, normal = _posed_plate(rng, 3000, lambda x, y: rng.normal(0, sigma, x.size))
    f = fit_plane_lsq(p, -normal)
    assert f.normal @ normal < 0
    # the normal of least spread: the covariance's smallest eigenvector, found independently
    w, v = np.linalg.eigh(np.cov(p.T))
    assert abs(f.normal @ v[:, 0]) == pytest.approx(1.0, abs=1e-12)
    assert f.rms == pytest.approx(sigma, rel=0.05)
    assert f.residuals == pytest.approx((p - f.centroid) @ f.normal, abs=1e-12)
    assert f.form_error == pytest.approx(np.ptp(f.residuals))
    # the tilt is known to about sigma / (sqrt(n) * plate size): 6e-6 rad here
    assert np.linalg.norm(np.cross(f.normal, normal)) < 5 * sigma / np.sqrt(3000) / 25


def test_lsq_line_in_2d():
    rng = np.random.default_rng(8)
    t = rng.uniform(-40, 40, 100)
    d = np.array([0.6, 0.8])
    p = np.array([3.0, -2.0]) + t[:, None] * d
    f = fit_line_lsq(p, [0.8, -0.6])
    assert f.normal == pytest.approx([0.8, -0.6], abs=1e-12) and f.form_error < 1e-12


# ---- circle and sphere ---------------------------------------------------------------------------

def _circle_residual(p):
    return lambda x: np.linalg.norm(p - x[:-1], axis=1) - x[-1]


@pytest.mark.parametrize("arc_deg", [360, 90])
def test_lsq_circle_recovers_random_circles(arc_deg):
    rng = np.random.default_rng(arc_deg)
    for _ in range(5):
        c, r = rng.uniform(-100, 100, 2), rng.uniform(2, 50)
        a0 = rng.uniform(0, 2 * np.pi)
        th = a0 + np.radians(arc_deg) * rng.uniform(0, 1, 60)
        exact = c + r * np.column_stack([np.cos(th), np.sin(th)])
        f = fit_circle_lsq(exact)
        assert f.converged and np.linalg.norm(f.centre - c) < 1e-9 and abs(f.radius - r) < 1e-9
        assert f.form_error < 1e-9
        sigma = 0.01
        noisy = exact + rng.normal(0, sigma, exact.shape)
        f = fit_circle_lsq(noisy)
        model = _circle_residual(noisy)
        se = standard_errors(model, np.append(c, r), sigma)
        assert np.all(np.abs(np.append(f.centre, f.radius) - np.append(c, r)) < 5 * se)
        assert_stationary(model, np.append(f.centre, f.radius), r)
        assert f.residuals == pytest.approx(model(np.append(f.centre, f.radius)), abs=1e-12)
        assert f.rms == pytest.approx(np.sqrt(np.mean(f.residuals ** 2)))


@pytest.mark.parametrize("cap", ["full", "hemisphere"])
def test_lsq_sphere_recovers_random_spheres(cap):
    rng = np.random.default_rng(20 if cap == "full" else 21)
    for _ in range(5):
        c, r = rng.uniform(-100, 100, 3), rng.uniform(2, 50)
        u = rng.normal(size=(200, 3))
        if cap == "hemisphere":
            u[:, 2] = np.abs(u[:, 2])
        u = (u / np.linalg.norm(u, axis=1)[:, None]) @ random_rotation(rng).T
        exact = c + r * u
        f = fit_sphere_lsq(exact)
        assert f.converged and np.linalg.norm(f.centre - c) < 1e-9 and abs(f.radius - r) < 1e-9
        sigma = 0.005
        noisy = exact + rng.normal(0, sigma, exact.shape)
        f = fit_sphere_lsq(noisy)
        model = _circle_residual(noisy)
        se = standard_errors(model, np.append(c, r), sigma)
        assert np.all(np.abs(np.append(f.centre, f.radius) - np.append(c, r)) < 5 * se)
        assert_stationary(model, np.append(f.centre, f.radius), r)
        assert f.form_error == pytest.approx(np.ptp(f.residuals))


# ---- cylinder ------------------------------------------------------------------------------------

def _cylinder(rng, n, arc_deg, length=20.0):
    """n points on a random cylinder (pose, radius) over ``arc_deg`` of its circumference;
    returns (points, axis point at the points' mean height, unit axis, radius, frame rows)."""
    R = random_rotation(rng)
    e1, e2, ax = R[:, 0], R[:, 1], R[:, 2]
    c, r = rng.uniform(-100, 100, 3), rng.uniform(3, 30)
    phi = np.radians(arc_deg) * rng.uniform(0, 1, n)
    t = rng.uniform(-length / 2, length / 2, n)
    t -= t.mean()  # c is then the axis point closest to the centroid
    p = c + r * (np.cos(phi)[:, None] * e1 + np.sin(phi)[:, None] * e2) + t[:, None] * ax
    return p, c, ax, r, (e1, e2, ax)


def _cylinder_model(p, c, frame):
    """Residuals of the cylinder with axis through c + x0 e1 + y0 e2 along unit(ax + a e1 + b
    e2) and radius R, x = [x0, y0, a, b, R]."""
    e1, e2, ax = frame

    def residual(x):
        d = ax + x[2] * e1 + x[3] * e2
        d = d / np.linalg.norm(d)
        w = p - (c + x[0] * e1 + x[1] * e2)
        return np.linalg.norm(w - (w @ d)[:, None] * d, axis=1) - x[4]
    return residual


def _cylinder_params(f, c, frame):
    """A fitted cylinder as the model's x (the axis' crossing of the plane through c normal to
    the true axis, the tilt, the radius)."""
    e1, e2, ax = frame
    d = f.direction / (f.direction @ ax)
    cross = f.point + ((c - f.point) @ ax) / (f.direction @ ax) * f.direction
    return np.array([(cross - c) @ e1, (cross - c) @ e2, d @ e1, d @ e2, f.radius])


@pytest.mark.parametrize("arc_deg", [360, 180])
def test_lsq_cylinder_recovers_random_cylinders(arc_deg):
    rng = np.random.default_rng(30 + arc_deg)
    for _ in range(4):
        p, c, ax, r, frame = _cylinder(rng, 300, arc_deg)
        hint = ax + 0.15 * rng.normal(size=3)
        f = fit_cylinder_lsq(p, hint)
        assert f.converged and f.direction @ hint > 0
        assert np.linalg.norm(np.cross(f.direction, ax)) < 1e-9
        assert np.linalg.norm(f.point - c) < 1e-9 and abs(f.radius - r) < 1e-9
        t = (p - c) @ ax
        assert f.ends == pytest.approx(c + np.array([t.min(), t.max()])[:, None] * ax, abs=1e-9)
        sigma = 0.005
        noisy = p + rng.normal(0, sigma, p.shape)
        f = fit_cylinder_lsq(noisy, hint)
        model = _cylinder_model(noisy, c, frame)
        truth = np.array([0, 0, 0, 0, r])
        se = standard_errors(model, truth, sigma)
        assert np.all(np.abs(_cylinder_params(f, c, frame) - truth) < 5 * se)
        assert_stationary(model, _cylinder_params(f, c, frame), r)
        assert f.rms == pytest.approx(sigma, rel=0.15)
        assert f.form_error == pytest.approx(np.ptp(f.residuals))


# ---- position ------------------------------------------------------------------------------------

def test_position_of_a_centre_is_twice_its_distance():
    assert position_value([10.03, 19.96], [10.0, 20.0]).value == pytest.approx(0.1, abs=1e-12)
    s = position_value([1.0, 2.0, 3.02], [1.0, 2.0, 3.0])  # a sphere: a spherical zone
    assert s.value == pytest.approx(0.04, abs=1e-12) and s.distances.shape == (1,)


def test_position_of_an_axis_moved_and_tilted():
    # the nominal axis: along z through (5, 5, 0), hole 12 mm deep; the fitted axis is moved by
    # (0.03, -0.04) at its bottom and tilted by 0.1 degree about y
    L, tilt = 12.0, np.radians(0.1)
    ends = np.array([[5.03, 4.96, 0.0], [5.03 + L * np.tan(tilt), 4.96, L]])
    pos = position_value(ends, [5.0, 5.0, -3.0], [0.0, 0.0, 2.0])
    top = np.hypot(0.03 + L * np.tan(tilt), 0.04)
    assert pos.distances == pytest.approx([0.05, top], abs=1e-12)
    assert pos.value == pytest.approx(2 * top, abs=1e-12)


def test_position_of_a_fitted_hole_moved_by_a_known_vector():
    rng = np.random.default_rng(40)
    nominal_point, nominal_axis = np.array([20.0, 30.0, 0.0]), np.array([0.0, 0.0, 1.0])
    R = random_rotation(rng)  # datum frame in a random pose: the value must not care
    move, tilt = np.array([0.02, 0.05, 0.0]), np.radians(0.2)
    ax = np.array([np.sin(tilt), 0.0, np.cos(tilt)])
    e1 = np.cross([0.0, 1.0, 0.0], ax)
    e2 = np.cross(ax, e1)
    phi, depth = rng.uniform(0, 2 * np.pi, 400), rng.uniform(0, 10, 400)
    base = nominal_point + move  # the actual axis at the hole's bottom, z = 0
    p = base + 4.0 * (np.cos(phi)[:, None] * e1 + np.sin(phi)[:, None] * e2) + depth[:, None] * ax
    f = fit_cylinder_lsq(p @ R.T, R @ nominal_axis)
    pos = position_value(f.ends, R @ nominal_point, R @ nominal_axis)
    lo, hi = depth.min(), depth.max()  # the ends' distances from the nominal axis, by hand
    expect = [np.hypot(move[0] + d * np.sin(tilt), move[1]) for d in (lo, hi)]
    assert pos.distances == pytest.approx(expect, abs=1e-9)
    assert pos.value == pytest.approx(2 * max(expect), abs=1e-9)


# ---- degenerate input ----------------------------------------------------------------------------

@pytest.mark.parametrize("call, message", [
    (lambda: flatness(np.zeros((2, 3)) + [[0, 0, 0], [1, 0, 0]]), "at least 3 points"),
    (lambda: flatness(np.outer(np.arange(5.0), [1, 2, 3])), "lie on a line"),
    (lambda: fit_plane_lsq(np.outer(np.arange(5.0), [1, 2, 3])), "determine a plane"),
    (lambda: fit_plane_lsq(np.ones((4, 3))), "coincide"),
    (lambda: fit_line_lsq(np.ones((4, 3))), "(n, 2)"),
    (lambda: fit_circle_lsq([[0, 0], [1, 1]]), "a circle needs at least 3 points, got 2"),
    (lambda: fit_circle_lsq(np.outer(np.arange(6.0), [1, -1])), "lie on a line: they do not "
                                                               "determine a circle"),
    (lambda: fit_circle_lsq(np.zeros((5, 3))), "(n, 2), got an array of shape (5, 3)"),
    (lambda: fit_sphere_lsq(np.eye(3)), "at least 4 points"),
    (lambda: fit_sphere_lsq(np.column_stack([np.cos(np.arange(8.0)), np.sin(np.arange(8.0)),
                                             np.zeros(8)])), "lie in a plane"),
    (lambda: fit_sphere_lsq([[0, 0, 0], [1, 0, 0], [0, 1, 0], [np.nan, 0, 1]]), "NaN"),
    (lambda: fit_cylinder_lsq(np.eye(3), [0, 0, 1]), "at least 5 points"),
    (lambda: fit_cylinder_lsq(np.column_stack([np.cos(np.arange(8.0)), np.sin(np.arange(8.0)),
                                               np.zeros(8)]), [0, 0, 1]), "one plane"),
    (lambda: fit_cylinder_lsq(np.random.default_rng(0).normal(size=(9, 3)), [0, 0, 0]),
     "axis_hint must be a finite non-zero vector"),
    (lambda: flatness(np.random.default_rng(0).normal(size=(9, 3)), [1, 0]), "normal_hint"),
    (lambda: position_value([[0, 0], [1, 1]], [0, 0, 0]), "same dimension"),
    (lambda: position_value([[0, 0], [1, 1]], [0, 0], [0, 0, 1]), "needs 3D points"),
])
def test_degenerate_input_is_refused_with_a_message(call, message):
    with pytest.raises(FeatureError) as e:
        call()
    assert message in str(e.value)
    assert isinstance(e.value, QAError) and isinstance(e.value, ValueError)
