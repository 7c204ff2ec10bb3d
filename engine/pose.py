"""Rigid motions, in one place: 3D poses as 4x4 homogeneous transforms, 2D poses (a contour
template's plane) as 3x3 ones.

* building and reading them: :func:`make_transform`, :func:`pose_2d`, :func:`rotation_from_rotvec`,
  :func:`rotation_from_quaternion`, :func:`rotation_angle_deg`, :func:`uniform_rotations`;
* applying them: :func:`apply_transform` (one pose or a stack of H poses, 2D or 3D);
* the small-motion update every fit takes, x' = c + R(w) (x - c) + t after a pose, about a
  centre c: :func:`compose_updates` (a stack) and :func:`apply_update` (one);
* its linearisation against point-to-surface (or point-to-contour) deviations:
  :func:`pose_jacobian`, and the steps solved from it: :func:`min_norm_solve`,
  :func:`gauss_newton_step`.

Names follow the frames: ``T_nominal_measured`` maps measured coordinates into the nominal's.
An update's parameters are [rotation, translation]: (6,) = [w (rotation vector, radians), t (mm)]
in 3D, (3,) = [angle (radians), tx, ty] in 2D; the compiled ICP kernel
(``icp_kernels._apply_step``) applies the same update inside its loop.
"""

from __future__ import annotations

import numpy as np


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


def rotation_2d(theta: np.ndarray) -> np.ndarray:
    """(…,) angles (radians, counter-clockwise) → (…, 2, 2) rotation matrices."""
    th = np.asarray(theta, dtype=np.float64)
    cs, sn = np.cos(th), np.sin(th)
    return np.stack([np.stack([cs, -sn], -1), np.stack([sn, cs], -1)], -2)


def pose_2d(theta, t) -> np.ndarray:
    """The 2D pose (3, 3) turning by ``theta`` (radians, counter-clockwise) and moving by t (2,),
    mm."""
    return make_transform(rotation_2d(theta), t)


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
    """(…, d, d) rotations and (…, d) translations → (…, d+1, d+1) homogeneous transforms
    (d = 3, or 2 for a contour's plane)."""
    R = np.asarray(R, dtype=np.float64)
    d = R.shape[-1]
    T = np.zeros(R.shape[:-2] + (d + 1, d + 1))
    T[..., :d, :d] = R
    T[..., :d, d] = t
    T[..., d, d] = 1.0
    return T


def apply_transform(T: np.ndarray, pts: np.ndarray) -> np.ndarray:
    """Map points by a homogeneous transform: R p + t.

    T : (d+1, d+1) or a stack (H, d+1, d+1); pts : (n, d). Returns (n, d), or (H, n, d) for a
    stack (every pose applied to the same points)."""
    d = T.shape[-1] - 1
    if T.ndim == 2:
        return pts @ T[:d, :d].T + T[:d, d]
    return pts @ T[:, :d, :d].transpose(0, 2, 1) + T[:, None, :d, d]


def rotation_angle_deg(R: np.ndarray) -> float:
    """Angle of a 3D rotation matrix in degrees."""
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


def compose_updates(T: np.ndarray, delta: np.ndarray, c: np.ndarray) -> np.ndarray:
    """The poses U @ T, U the update x' = c + R(w) (x - c) + t about centre c.

    T : (H, d+1, d+1) poses; delta : (H, 6) [w, t] in 3D, (H, 3) [angle, tx, ty] in 2D;
    c : (H, d) centres (mm, in the frame T maps into)."""
    nrot = 3 if T.shape[-1] == 4 else 1
    R = rotation_from_rotvec(delta[:, :3]) if nrot == 3 else rotation_2d(delta[:, 0])
    Rc = np.einsum("hij,hj->hi", R, c)
    return make_transform(R, c - Rc + delta[:, nrot:]) @ T


def apply_update(T: np.ndarray, p: np.ndarray, c: np.ndarray) -> np.ndarray:
    """One pose T (d+1, d+1) after the update ``p`` about ``c`` (:func:`compose_updates`)."""
    return compose_updates(T[None], np.asarray(p)[None], np.asarray(c)[None])[0]


def lower_along(T: np.ndarray, step: np.ndarray, c: np.ndarray, cost: float, evaluate,
                shorten: float, shortenings: int):
    """Backtracking along a Gauss-Newton ``step`` (about ``c``) from pose T: the first of the
    step and its shortenings (``step / shorten**k``, k = 1 … ``shortenings``) whose cost is
    below ``cost``, as (T', what ``evaluate`` said there); None when none is. ``evaluate(T')``
    returns (cost at T', anything the caller keeps)."""
    for k in range(shortenings + 1):
        T_new = apply_update(T, step / shorten ** k, c)
        value, kept = evaluate(T_new)
        if value < cost:
            return T_new, kept
    return None


def pose_jacobian(X: np.ndarray, normals: np.ndarray, c: np.ndarray) -> np.ndarray:
    """d(deviation)/d[rotation, translation] of the update about the centre c
    (:func:`compose_updates`) at points X with unit surface (or contour) normals ``normals``.

    X, normals : (…, n, 3) → (…, n, 6); or (…, n, 2) → (…, n, 3) in 2D. c : (3,) / (2,), or
    (…, 1, d) per stack. Nominal frame."""
    r = X - c
    if X.shape[-1] == 3:
        return np.concatenate([np.cross(r, normals), normals], axis=-1)
    rot = r[..., 0] * normals[..., 1] - r[..., 1] * normals[..., 0]
    return np.concatenate([rot[..., None], normals], axis=-1)


def min_norm_solve(A: np.ndarray, b: np.ndarray, nrot: int, length) -> np.ndarray:
    """Minimum-norm solution of the pose normal equations A x = b, (..., k, k) and (..., k),
    whose first ``nrot`` unknowns are rotations about points spread ``length`` (mm; scalar or
    (...,)) around the centre.

    In units where rotations move points by millimetres, directions whose eigenvalue is below
    1e-6 of the largest are left alone: along what the points do not constrain (a sphere's
    rotations, a plane's slides, a circle's turn) the step is zero, instead of whatever
    rounding and sampling noise make of a (nearly) singular system.
    """
    k = A.shape[-1]
    s = np.ones(np.shape(length) + (k,))
    s[..., :nrot] = 1.0 / np.maximum(np.asarray(length, float), 1e-12)[..., None]
    As = A * s[..., :, None] * s[..., None, :]
    w, V = np.linalg.eigh(As)
    top = np.maximum(w[..., -1:], 1e-300)
    ok = w > 1e-6 * top
    inv = np.where(ok, 1.0 / np.where(ok, w, 1.0), 0.0)
    coef = np.einsum("...ji,...j->...i", V, b * s) * inv
    return np.einsum("...ij,...j->...i", V, coef) * s


def rms_radius(r: np.ndarray) -> float:
    """sqrt(mean |r|^2) of points r (n, d) about their centre, mm (1 for no points): the lever
    arm that puts a rotation in millimetres."""
    return float(np.sqrt(np.mean(np.sum(r * r, axis=1)))) if r.size else 1.0


def gauss_newton_step(X: np.ndarray, normals: np.ndarray, d: np.ndarray):
    """One linearised least-squares step of the signed deviations ``d`` (n,) of points X (n, 3)
    or (n, 2) with unit normals at their feet, about the points' centroid c, minimum-norm along
    what they leave unconstrained (:func:`min_norm_solve`). Returns (step, c)."""
    c = X.mean(axis=0)
    J = pose_jacobian(X, normals, c)
    step = min_norm_solve(J.T @ J, J.T @ d, 3 if X.shape[1] == 3 else 1, rms_radius(X - c))
    return -step, c


def in_plane(T2: np.ndarray) -> np.ndarray:
    """The 2D homogeneous transform T2 (3, 3) as the 3D one (4, 4) that leaves z alone."""
    E = np.eye(4)
    E[:2, :2] = T2[:2, :2]
    E[:2, 3] = T2[:2, 2]
    return E


def largest_speed(twist, X: np.ndarray, centre, length: float) -> float:
    """The largest speed (mm per unit of amplitude) of points ``X`` (m, 3) or (m, 2) under
    ``twist`` (rotations first, in mm at ``length`` from ``centre``, then translations: the
    fits' small-motion coordinates): a screw motion moves each point at a constant speed."""
    v = np.asarray(twist, float)
    r = X - np.asarray(centre, float)
    if X.shape[1] == 3:
        vel = np.cross(v[:3] / length, r) + v[3:]
    else:
        vel = v[0] / length * np.column_stack([-r[:, 1], r[:, 0]]) + v[1:]
    return float(np.linalg.norm(vel, axis=1).max())


def screw_motion(twist, amplitude: float, centre, length: float) -> np.ndarray:
    """The exact rigid motion (4x4, or 3x3 in 2D) of ``amplitude`` along a unit ``twist``
    (engine.trust.WeakDirection.twist: rotations first, in mm at ``length`` from ``centre``,
    then translations) about ``centre``: the screw motion exp(amplitude x twist), so a rotation
    about a cylinder's axis stays on the cylinder however large it is. In closed form (the
    exponential of a rigid motion's generator: Rodrigues' rotation, and its integral for the
    translation), 0.04 ms a call whatever else runs: scipy.linalg.expm takes 0.013 ms with one
    BLAS thread but 0.8-8 ms with two on a busy machine (0.25 s of the uncertainty region's
    32 poses on NIST FTC-07 so)."""
    v = np.asarray(twist, float) * amplitude
    c = np.asarray(centre, float)
    k = c.size
    if k == 3:
        w, t = v[:3] / length, v[3:]
        W, theta = skew(w), float(np.linalg.norm(w))
    else:
        th, t = v[0] / length, v[1:]
        W, theta = np.array([[0.0, -th], [th, 0.0]]), abs(th)
    a, b, e = _exp_coefficients(theta)
    E = np.eye(k + 1)
    E[:k, :k] = np.eye(k) + a * W + b * (W @ W)
    # The generator's translation, velocity w x (x - c) + t, through the rotation's integral.
    E[:k, k] = (np.eye(k) + b * W + e * (W @ W)) @ (t - W @ c)
    return E


def _exp_coefficients(theta: float) -> tuple[float, float, float]:
    """sin(theta) / theta, (1 - cos(theta)) / theta^2, (theta - sin(theta)) / theta^3: the
    coefficients of W and W^2 in exp(W) and in its integral, for a skew matrix W of angle
    ``theta`` (2D too: there W^2 = -theta^2 I); by their series below 1e-4 rad, where the
    closed forms lose digits."""
    if theta < 1e-4:
        t2 = theta * theta
        return 1.0 - t2 / 6.0, 0.5 - t2 / 24.0, 1.0 / 6.0 - t2 / 120.0
    s, co = np.sin(theta), np.cos(theta)
    return s / theta, (1.0 - co) / theta ** 2, (theta - s) / theta ** 3
