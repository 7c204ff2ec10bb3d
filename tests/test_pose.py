"""engine.pose, the rigid motions, against independent truth: scipy's rotations, the update
written out point by point, finite differences of analytic distances (a sphere, a circle), and the
known motion of a sphere."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from engine.pose import (apply_transform, apply_update, compose_updates, gauss_newton_step,
                         make_transform, pose_jacobian, rotation_2d, rotation_angle_deg,
                         rotation_from_quaternion, rotation_from_rotvec, uniform_rotations)
from surfaces import random_rotation


def test_rotations_agree_and_are_proper():
    rng = np.random.default_rng(2)
    w = rng.normal(size=(50, 3))
    R = rotation_from_rotvec(w)
    assert np.allclose(R @ np.transpose(R, (0, 2, 1)), np.eye(3), atol=1e-12)
    assert np.allclose(np.linalg.det(R), 1.0)
    # Quaternion for the same rotation: [cos(t/2), sin(t/2) axis].
    t = np.linalg.norm(w, axis=1)
    q = np.column_stack([np.cos(t / 2), np.sin(t / 2)[:, None] * w / t[:, None]])
    assert np.allclose(rotation_from_quaternion(q), R, atol=1e-12)
    for Ri, ti in zip(R, t):
        expected = np.degrees(ti % (2 * np.pi))
        expected = min(expected, 360 - expected)
        assert rotation_angle_deg(Ri) == pytest.approx(expected, abs=1e-6)


def test_uniform_rotations_cover_so3():
    U = uniform_rotations(60)
    assert U.shape == (60, 3, 3)
    assert np.allclose(np.linalg.det(U), 1.0)
    rng = np.random.default_rng(3)
    worst = 0.0
    for _ in range(200):
        R = random_rotation(rng)
        worst = max(worst, min(rotation_angle_deg(R @ Ui.T) for Ui in U))
    assert worst < 60.0  # every rotation lies within an ICP basin of one sample


def _random_poses(rng, h, d):
    R = Rotation.random(h, random_state=rng).as_matrix() if d == 3 else \
        rotation_2d(rng.uniform(-np.pi, np.pi, h))
    return make_transform(R, rng.normal(0, 50, (h, d)))


@pytest.mark.parametrize("d", [2, 3])
def test_an_update_moves_every_point_as_written(d):
    """x' = c + R(w) (T x - c) + t, with R from scipy (3D) or the angle (2D), for a stack of
    poses and for one."""
    rng = np.random.default_rng(11)
    T = _random_poses(rng, 5, d)
    k = 3 if d == 3 else 1
    delta = np.column_stack([rng.normal(0, 0.3, (5, k)), rng.normal(0, 5, (5, d))])
    c = rng.normal(0, 20, (5, d))
    x = rng.normal(0, 30, (40, d))
    moved = apply_transform(compose_updates(T, delta, c), x)
    for h in range(5):
        R = Rotation.from_rotvec(delta[h, :3]).as_matrix() if d == 3 else \
            np.array([[np.cos(delta[h, 0]), -np.sin(delta[h, 0])],
                      [np.sin(delta[h, 0]), np.cos(delta[h, 0])]])
        Tx = x @ T[h, :d, :d].T + T[h, :d, d]
        expect = c[h] + (Tx - c[h]) @ R.T + delta[h, k:]
        assert np.allclose(moved[h], expect, atol=1e-10)
        assert np.allclose(apply_transform(apply_update(T[h], delta[h], c[h]), x), expect,
                           atol=1e-10)


@pytest.mark.parametrize("d", [2, 3])
def test_the_jacobian_is_the_derivative_of_the_distance(d):
    """pose_jacobian's columns are the derivatives of each point's signed distance to a sphere
    (a circle in 2D) under the update about c: central differences, step 1e-6."""
    rng = np.random.default_rng(12)
    o, r = rng.normal(0, 5, d), 40.0
    u = rng.normal(size=(30, d))
    x = o + (r + rng.normal(0, 0.5, (30, 1))) * u / np.linalg.norm(u, axis=1, keepdims=True)
    normals = (x - o) / np.linalg.norm(x - o, axis=1, keepdims=True)
    c = rng.normal(0, 10, d)
    J = pose_jacobian(x, normals, c)
    eye = np.eye(d + 1)
    for j in range(J.shape[1]):
        e = np.zeros(J.shape[1])
        e[j] = 1e-6
        dist = [np.linalg.norm(apply_transform(apply_update(eye, s * e, c), x) - o, axis=1)
                for s in (1, -1)]
        assert np.allclose((dist[0] - dist[1]) / 2e-6, J[:, j], atol=1e-5)


def test_a_gauss_newton_step_puts_a_shifted_sphere_back():
    """Points of a sphere (centre 0, radius 50) shifted by t0: one step moves them back onto it
    to second order in |t0|, and carries the shifted centre back to 0; it turns them by no more
    than the sphere leaves free (the minimum-norm solution: a turn about the centroid c, which
    sits near the centre, is nearly a null direction and stays small)."""
    rng = np.random.default_rng(13)
    u = rng.normal(size=(500, 3))
    x = 50.0 * u / np.linalg.norm(u, axis=1, keepdims=True)
    t0 = np.array([0.01, -0.02, 0.005])
    xs = x + t0
    normals = xs / np.linalg.norm(xs, axis=1, keepdims=True)
    step, c = gauss_newton_step(xs, normals, np.linalg.norm(xs, axis=1) - 50.0)
    U = apply_update(np.eye(4), step, c)
    assert np.abs(np.linalg.norm(apply_transform(U, xs), axis=1) - 50.0).max() < 1e-5
    assert np.linalg.norm(apply_transform(U, t0[None])) < 1e-5
    assert np.linalg.norm(step[:3]) < 1e-3
    assert np.allclose(c, xs.mean(axis=0))


def test_lower_along_takes_the_first_shortening_that_lowers_the_cost():
    """The backtracking both fits share (engine.pose.lower_along): a translation step of 8 mm
    towards a target 1 mm away lowers |t - target|^2 first at 8 / 2^3 = 1 mm; with only two
    halvings allowed no step lowers it; evaluate is called once per try, in order."""
    from engine.pose import lower_along

    target = np.array([1.0, 0.0, 0.0])
    step = np.array([0, 0, 0, 8.0, 0, 0])
    tried = []

    def evaluate(T):
        tried.append(T[0, 3])
        return float(np.sum((T[:3, 3] - target) ** 2)), "kept"

    T, kept = lower_along(np.eye(4), step, np.zeros(3), 1.0, evaluate, 2.0, 4)
    assert np.allclose(T[:3, 3], target) and np.allclose(T[:3, :3], np.eye(3))
    assert kept == "kept" and tried == [8.0, 4.0, 2.0, 1.0]
    tried.clear()
    assert lower_along(np.eye(4), step, np.zeros(3), 1.0, evaluate, 2.0, 2) is None
    assert tried == [8.0, 4.0, 2.0]


def test_a_screw_motion_is_the_exponential_of_its_generator():
    """screw_motion in closed form against scipy's matrix exponential of the generator (an
    independent evaluation), 3D and 2D, from 1e-9 to 1000 mm of amplitude; and a half turn
    about an axis through the centre leaves the axis fixed and moves a point across it."""
    from scipy.linalg import expm

    from engine.pose import screw_motion

    rng = np.random.default_rng(4)
    for _ in range(500):
        amp, length = 10 ** rng.uniform(-9, 3), rng.uniform(1.0, 200.0)
        for k in (3, 2):
            tw = rng.normal(size=2 * k if k == 3 else 3)
            tw /= np.linalg.norm(tw)
            c = rng.normal(size=k) * 50.0
            v = tw * amp
            G = np.zeros((k + 1, k + 1))
            if k == 3:
                w = v[:3] / length
                G[:3, :3] = [[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]]
            else:
                G[:2, :2] = [[0.0, -v[0] / length], [v[0] / length, 0.0]]
            G[:k, k] = v[-k:] - G[:k, :k] @ c
            np.testing.assert_allclose(screw_motion(tw, amp, c, length), expm(G), rtol=0,
                                       atol=1e-9)
    c, length = np.array([5.0, -3.0, 2.0]), 10.0
    E = screw_motion([0.0, 0.0, 1.0, 0.0, 0.0, 0.0], np.pi * length, c, length)
    np.testing.assert_allclose(E[:3, :3] @ (c + [0, 0, 7.0]) + E[:3, 3], c + [0, 0, 7.0],
                               atol=1e-12)
    np.testing.assert_allclose(E[:3, :3] @ (c + [1.0, 0, 0]) + E[:3, 3], c - [1.0, 0, 0],
                               atol=1e-12)
