"""Geometry kernels over numpy arrays: closest points on triangles, rigid transforms.

Every fast kernel here has a slow, obvious twin in ``tests/naive.py`` that the tests compare
against on random inputs. Units are whatever the inputs are in (millimetres in this product).
"""

from __future__ import annotations

import numpy as np


def closest_point_on_segments(p: np.ndarray, a: np.ndarray, b: np.ndarray):
    """Closest point to each ``p`` on the segment ``a``–``b``.

    p, a, b : (n, 3) float. Returns (closest (n, 3), t (n,)) with closest = a + t (b - a),
    t in [0, 1]; a zero-length segment gives t = 0.
    """
    ab = b - a
    denom = np.einsum("ij,ij->i", ab, ab)
    t = np.einsum("ij,ij->i", p - a, ab)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(denom > 0.0, t / np.where(denom > 0.0, denom, 1.0), 0.0)
    t = np.clip(t, 0.0, 1.0)
    return a + t[:, None] * ab, t


def closest_point_on_triangles(p: np.ndarray, a: np.ndarray, b: np.ndarray, c: np.ndarray):
    """Exact closest point to each ``p`` on the (solid) triangle ``a b c``.

    p, a, b, c : (n, 3) float. Returns (closest (n, 3), bary (n, 3)) where
    closest = bary[:, 0] a + bary[:, 1] b + bary[:, 2] c, bary >= 0, sum 1. Faces, edges and
    vertices are all handled (Ericson's Voronoi-region tests, vectorised); degenerate
    (zero-area) triangles reduce to the nearest of their edges.
    """
    p = np.asarray(p, dtype=np.float64)
    ab = b - a
    ac = c - a
    ap = p - a
    bp = p - b
    cp = p - c
    d1 = _dot(ab, ap)
    d2 = _dot(ac, ap)
    d3 = _dot(ab, bp)
    d4 = _dot(ac, bp)
    d5 = _dot(ab, cp)
    d6 = _dot(ac, cp)
    va = d3 * d6 - d5 * d4
    vb = d5 * d2 - d1 * d6
    vc = d1 * d4 - d3 * d2
    n = p.shape[0]
    u = np.zeros(n)
    v = np.zeros(n)
    w = np.zeros(n)
    # Face region first; later assignments (edges, then vertices) take precedence, in the
    # reverse of Ericson's early-return order.
    den = va + vb + vc
    inside = den > 0
    sden = np.where(inside, den, 1.0)
    v[:] = vb / sden
    w[:] = vc / sden
    u[:] = 1.0 - v - w

    def _set(mask, uu, vv, ww):
        u[mask], v[mask], w[mask] = uu[mask], vv[mask], ww[mask]

    zero = np.zeros(n)
    one = np.ones(n)
    e_bc = (va <= 0) & (d4 - d3 >= 0) & (d5 - d6 >= 0)
    t = _safe_div(d4 - d3, (d4 - d3) + (d5 - d6))
    _set(e_bc, zero, 1.0 - t, t)
    e_ac = (vb <= 0) & (d2 >= 0) & (d6 <= 0)
    t = _safe_div(d2, d2 - d6)
    _set(e_ac, 1.0 - t, zero, t)
    e_ab = (vc <= 0) & (d1 >= 0) & (d3 <= 0)
    t = _safe_div(d1, d1 - d3)
    _set(e_ab, 1.0 - t, t, zero)
    _set((d6 >= 0) & (d5 <= d6), zero, zero, one)
    _set((d3 >= 0) & (d4 <= d3), zero, one, zero)
    _set((d1 <= 0) & (d2 <= 0), one, zero, zero)

    # Zero-area triangles: the region tests are not meaningful; take the nearest edge.
    ab2, ac2 = _dot(ab, ab), _dot(ac, ac)
    degenerate = np.flatnonzero(ab2 * ac2 - _dot(ab, ac) ** 2
                                <= 1e-12 * np.maximum(ab2 * ac2, 1e-300))
    bary = np.stack([u, v, w], axis=1)
    if degenerate.size:
        bary[degenerate] = _nearest_edge(p[degenerate], a[degenerate], b[degenerate],
                                         c[degenerate])
    closest = a + bary[:, 1:2] * ab + bary[:, 2:3] * ac
    return closest, bary


def _dot(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    return x[:, 0] * y[:, 0] + x[:, 1] * y[:, 1] + x[:, 2] * y[:, 2]


def _safe_div(num: np.ndarray, den: np.ndarray) -> np.ndarray:
    ok = den != 0
    return np.clip(np.where(ok, num / np.where(ok, den, 1.0), 0.0), 0.0, 1.0)


def _nearest_edge(p, a, b, c) -> np.ndarray:
    """Barycentrics of the nearest point on the three edges (for degenerate triangles)."""
    m = p.shape[0]
    best_d = np.full(m, np.inf)
    best_b = np.zeros((m, 3))
    for (s0, s1, i0, i1) in ((a, b, 0, 1), (b, c, 1, 2), (c, a, 2, 0)):
        q, t = closest_point_on_segments(p, s0, s1)
        d = _dot(p - q, p - q)
        better = d < best_d
        best_d = np.where(better, d, best_d)
        bb = np.zeros((m, 3))
        bb[:, i0] = 1.0 - t
        bb[:, i1] = t
        best_b[better] = bb[better]
    return best_b


def barycentric(p: np.ndarray, a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Barycentric coordinates (n, 3) of the projection of each ``p`` onto the plane of ``a b c``,
    not clamped to the triangle (negative outside it); NaN for degenerate triangles."""
    ab = b - a
    ac = c - a
    ap = p - a
    d00 = np.einsum("ij,ij->i", ab, ab)
    d01 = np.einsum("ij,ij->i", ab, ac)
    d11 = np.einsum("ij,ij->i", ac, ac)
    d20 = np.einsum("ij,ij->i", ap, ab)
    d21 = np.einsum("ij,ij->i", ap, ac)
    det = d00 * d11 - d01 * d01
    ok = det > 1e-12 * np.maximum(d00 * d11, 1e-300)
    safe = np.where(ok, det, 1.0)
    v = np.where(ok, (d11 * d20 - d01 * d21) / safe, np.nan)
    w = np.where(ok, (d00 * d21 - d01 * d20) / safe, np.nan)
    return np.stack([1.0 - v - w, v, w], axis=1)


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


def horn_rigid(p: np.ndarray, m: np.ndarray, w: np.ndarray | None = None) -> np.ndarray:
    """Closed-form rigid motion T (4x4) minimising sum w |T p - m|^2 (Horn's quaternion method).

    p, m : (n, 3) corresponding points; w : (n,) non-negative weights or None.
    """
    w = np.ones(p.shape[0]) if w is None else np.asarray(w, dtype=np.float64)
    sw = w.sum()
    cp = (w[:, None] * p).sum(0) / sw
    cm = (w[:, None] * m).sum(0) / sw
    S = ((p - cp) * w[:, None]).T @ (m - cm)
    sxx, sxy, sxz = S[0]
    syx, syy, syz = S[1]
    szx, szy, szz = S[2]
    N = np.array([
        [sxx + syy + szz, syz - szy, szx - sxz, sxy - syx],
        [syz - szy, sxx - syy - szz, sxy + syx, szx + sxz],
        [szx - sxz, sxy + syx, -sxx + syy - szz, syz + szy],
        [sxy - syx, szx + sxz, syz + szy, -sxx - syy + szz],
    ])
    evals, evecs = np.linalg.eigh(N)
    R = rotation_from_quaternion(evecs[:, np.argmax(evals)])
    return make_transform(R, cm - R @ cp)


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
