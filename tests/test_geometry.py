import numpy as np
import pytest

from engine.geometry import closest_point_on_triangles
from naive import closest_point_on_triangle


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
