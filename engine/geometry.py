"""Geometry kernels over numpy arrays: closest points on triangles (rigid motions are in
engine.pose).

Every fast kernel here has a slow, obvious twin in ``tests/naive.py`` that the tests compare
against on random inputs. Units are whatever the inputs are in (millimetres in this product).
"""

from __future__ import annotations

import numpy as np

from . import kernels


def closest_point_on_triangles(p: np.ndarray, a: np.ndarray, b: np.ndarray, c: np.ndarray):
    """Exact closest point to each ``p`` on the (solid) triangle ``a b c``.

    p, a, b, c : (n, 3) float. Returns (closest (n, 3), bary (n, 3)) where
    closest = bary[:, 0] a + bary[:, 1] b + bary[:, 2] c, bary >= 0, sum 1. Faces, edges and
    vertices are all handled (Ericson's Voronoi-region tests, compiled in ``engine.kernels``);
    degenerate (zero-area) triangles reduce to the nearest of their edges.
    """
    p, a, b, c = (np.ascontiguousarray(x, dtype=np.float64) for x in (p, a, b, c))
    bary = np.empty((p.shape[0], 3))
    kernels.closest_bary_batch(p, a, b, c, bary)
    closest = bary[:, :1] * a + bary[:, 1:2] * b + bary[:, 2:3] * c
    return closest, bary
