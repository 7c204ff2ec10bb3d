"""Geometry kernels over numpy arrays: closest points on triangles, rigid transforms.

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


def skew(v: np.ndarray) -> np.ndarray:
    """(…, 3) vectors → (…, 3, 3) cross-product matrices, skew(a) @ b == cross(a, b)."""
    z = np.zeros(v.shape[:-1])
    return np.stack([
        np.stack([z, -v[..., 2], v[..., 1]], -1),
        np.stack([v[..., 2], z, -v[..., 0]], -1),
        np.stack([-v[..., 1], v[..., 0], z], -1),
    ], -2)


def rotation_from_rotvec(w: np.ndarray) -> np.ndarray:
    """Rodrigues: (…, 3) rotation vectors (radians × unit axis) → (…, 3, 3) rotation matrices."""
    w = np.asarray(w, dtype=np.float64)
    theta = np.linalg.norm(w, axis=-1)[..., None, None]
    K = skew(w)
    small = theta < 1e-8
    th = np.where(small, 1.0, theta)
    s = np.where(small, 1.0 - theta**2 / 6.0, np.sin(th) / th)
    c = np.where(small, 0.5 - theta**2 / 24.0, (1.0 - np.cos(th)) / th**2)
    eye = np.broadcast_to(np.eye(3), K.shape)
    return eye + s * K + c * (K @ K)


def rotation_from_quaternion(q: np.ndarray) -> np.ndarray:
    """Unit quaternion(s) [q0, q1, q2, q3] (scalar first) → rotation matrix, the paper's eq. (1)."""
    q = np.asarray(q, dtype=np.float64)
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    q0, q1, q2, q3 = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    return np.stack([
        np.stack([q0*q0 + q1*q1 - q2*q2 - q3*q3, 2*(q1*q2 - q0*q3), 2*(q1*q3 + q0*q2)], -1),
        np.stack([2*(q1*q2 + q0*q3), q0*q0 - q1*q1 + q2*q2 - q3*q3, 2*(q2*q3 - q0*q1)], -1),
        np.stack([2*(q1*q3 - q0*q2), 2*(q2*q3 + q0*q1), q0*q0 - q1*q1 - q2*q2 + q3*q3], -1),
    ], -2)


def make_transform(R: np.ndarray, t: np.ndarray) -> np.ndarray:
    """(…, 3, 3) rotations and (…, 3) translations → (…, 4, 4) homogeneous transforms."""
    R = np.asarray(R, dtype=np.float64)
    T = np.zeros(R.shape[:-2] + (4, 4))
    T[..., :3, :3] = R
    T[..., :3, 3] = t
    T[..., 3, 3] = 1.0
    return T


def apply_transform(T: np.ndarray, pts: np.ndarray) -> np.ndarray:
    """Map (n, 3) points by a 4x4 transform: T[:3, :3] @ p + T[:3, 3]."""
    return pts @ T[:3, :3].T + T[:3, 3]


def rotation_angle_deg(R: np.ndarray) -> float:
    """Angle of a rotation matrix in degrees."""
    c = (np.trace(R) - 1.0) / 2.0
    return float(np.degrees(np.arccos(np.clip(c, -1.0, 1.0))))


def uniform_rotations(n: int) -> np.ndarray:
    """(n, 3, 3) rotations spread evenly over SO(3): the super-Fibonacci spiral (Alexa, CVPR 2022).

    Deterministic: the same n always gives the same rotations.
    """
    phi = np.sqrt(2.0)
    psi = 1.533751168755204288118041
    i = np.arange(n, dtype=np.float64) + 0.5
    s = i / n
    r = np.sqrt(s)
    R_ = np.sqrt(1.0 - s)
    alpha = 2.0 * np.pi * i / phi
    beta = 2.0 * np.pi * i / psi
    q = np.stack([r * np.sin(alpha), r * np.cos(alpha), R_ * np.sin(beta), R_ * np.cos(beta)], -1)
    return rotation_from_quaternion(q)
