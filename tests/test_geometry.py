import numpy as np
import pytest

from engine.geometry import (closest_point_on_triangles, rotation_angle_deg,
                             rotation_from_quaternion, rotation_from_rotvec,
                             uniform_rotations)
from naive import closest_point_on_triangle
from surfaces import random_rotation


def _random_triangles(rng, n):
    a = rng.normal(size=(n, 3))
    b = a + rng.normal(size=(n, 3))
    c = a + rng.normal(size=(n, 3))
    # Some degenerate ones: collinear, coincident vertices, zero-size.
    k = n // 10
    c[:k] = a[:k] + 0.37 * (b[:k] - a[:k])
    b[k:2 * k] = a[k:2 * k]
    b[2 * k:3 * k] = c[2 * k:3 * k] = a[2 * k:3 * k]
    return a, b, c


def test_closest_point_on_triangles_matches_naive_twin():
    rng = np.random.default_rng(1)
    n = 3000
    a, b, c = _random_triangles(rng, n)
    p = rng.normal(size=(n, 3)) * 2.0
    q, bary = closest_point_on_triangles(p, a, b, c)
    for i in range(n):
        ref = closest_point_on_triangle(p[i], a[i], b[i], c[i])
        assert np.linalg.norm(p[i] - q[i]) == pytest.approx(np.linalg.norm(p[i] - ref), abs=1e-9)
    assert np.all(bary >= -1e-12) and np.allclose(bary.sum(1), 1.0)
    assert np.allclose(bary[:, :1] * a + bary[:, 1:2] * b + bary[:, 2:] * c, q, atol=1e-9)


def test_closest_point_regions_face_edge_vertex():
    a, b, c = np.array([[0.0, 0, 0]]), np.array([[1.0, 0, 0]]), np.array([[0.0, 1, 0]])
    p = np.array([[0.2, 0.2, 3.0], [0.5, -1.0, 0.5], [-1.0, -1.0, 0.0], [2.0, 2.0, 0.0]])
    q, _ = closest_point_on_triangles(p, *(np.repeat(v, 4, 0) for v in (a, b, c)))
    assert np.allclose(q, [[0.2, 0.2, 0], [0.5, 0, 0], [0, 0, 0], [0.5, 0.5, 0]])


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
