"""Whether a fitted pose can be trusted (the fits themselves are engine.fits; whether the
verdict survives the pose's uncertainty is engine.pose_sensitivity).

* :func:`conditioning`: how well the measured points constrain each rigid degree of freedom,
  from the point-to-surface normal equations at the final pose; directions they do not constrain
  (a cylinder along and about its axis, a plane within itself) are named, and the pose
  uncertainty the fit's residuals imply at the points is given.
* :func:`sampling_margin`: per point, how far facets through sampled nominal points can lie from
  the true surface: curvature x spacing^2 / 8.
* :func:`deviation_jacobian`, :func:`pose_covariance`, :func:`deviation_sigma`: the pose's
  covariance from the fit's residuals, propagated to each point's deviation;
  :func:`uncertainty_poses`: the poses at the edge of that uncertainty for the points nearest
  a limit.

Shapes: points and normals are (n, 3) in 3D, (n, 2) for a 2D template (3 degrees of freedom:
the rotation about z and the two translations). Units mm; directions in the nominal frame.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .pose import pose_jacobian, screw_motion
from .seeds import DEFAULT_SEED, rng

CONDITIONING_POINTS = 16384
"""Fitted points the normal matrix is formed from at most (a seeded subset beyond)."""
CONDITIONING_SEED = 5
"""The random stream of that subset (engine.seeds)."""
DEGENERATE_STRENGTH = 1e-8
"""Below this normalised eigenvalue a direction is unconstrained by the shape itself (a plane,
cylinder or sphere: 1e-11, rounding)."""
WEAK_STRENGTH = 1e-4
"""Below this one a direction is nearly unconstrained by the shape (seen: two faces of a bracket
at right angles, along their common edge, 3e-5; a 180 x 90 mm patch of a gently curved panel
5.6e-5; a 500 x 250 mm paraboloid panel 3e-4; the belly-fairing sample 2e-3) and counts as
unconstrained when the measurement leaves it uncertain: when the residuals imply a 1-sigma
motion along it of more than ``resolution_mm`` (a quarter of the zone width, see
engine.verdict), the pose along it is a guess at the scale that decides the verdict."""


@dataclass(frozen=True)
class WeakDirection:
    type: str
    """"translation" or "rotation"."""
    axis: tuple[float, ...]
    """Unit vector in the nominal frame: the translation's direction or the rotation's axis."""
    strength: float
    """The direction's eigenvalue over the largest one (0: not constrained at all)."""
    sigma_mm: float | None = None
    """1-sigma motion along it that the fit's residuals imply (None: infinite)."""
    twist: tuple[float, ...] = ()
    """The direction as a unit motion (the normal matrix's eigenvector): rotation (rad x
    ``Conditioning.length``) then translation (mm), about ``Conditioning.centre``; 6 numbers
    in 3D, 3 for a 2D template. A rotation of a part measured off its axis carries the
    translation that keeps it about the true axis."""


@dataclass(frozen=True)
class Conditioning:
    """Conditioning of the point-to-surface fit at the final pose.

    strengths : eigenvalues of the normal matrix (rotations scaled by ``length``, so that both
        kinds are in mm units) over the largest, ascending; one per degree of freedom.
    weak : the directions with strength below WEAK_STRENGTH (``weak_below`` of conditioning).
    length : RMS distance of the fitted points from their centroid, mm (the rotation scale).
    pose_sigma_mm : the largest 1-sigma displacement, at any fitted point, that the residuals
        (rms) imply for the pose; None when a direction is unconstrained (the pose is
        undetermined along it) or there are too few points.
    """

    strengths: tuple[float, ...]
    weak: tuple[WeakDirection, ...] = field(default_factory=tuple)
    length: float = 0.0
    pose_sigma_mm: float | None = None
    centre: tuple[float, ...] = ()
    """Centroid of the fitted points (nominal frame, mm): the rotations' origin in ``twist``."""


def conditioning(X: np.ndarray, normals: np.ndarray, residual_rms: float,
                 resolution_mm: float | None = None, seed: int = DEFAULT_SEED,
                 weak_below: float = WEAK_STRENGTH) -> Conditioning:
    """Conditioning of fitting points ``X`` (registered, nominal frame) with surface ``normals``.

    A direction is unconstrained when its normalised strength is below DEGENERATE_STRENGTH, or
    below ``weak_below`` (WEAK_STRENGTH) while the residuals (rms, mm) imply a 1-sigma motion
    along it above ``resolution_mm`` (None: any weak direction counts). seed : the inspection's
    (engine.seeds), of the subset beyond ``CONDITIONING_POINTS``."""
    X = np.asarray(X, float)
    normals = np.asarray(normals, float)
    n, dim = X.shape
    nrot = 3 if dim == 3 else 1
    dof = nrot + dim
    if n < dof:
        return Conditioning(tuple([0.0] * dof), (), 0.0, None)
    if n > CONDITIONING_POINTS:
        # The normal matrix per point converges long before 200,000 points; the covariance
        # still divides by all n.
        sub = rng(seed, CONDITIONING_SEED).choice(n, CONDITIONING_POINTS, replace=False)
        X, normals = X[sub], normals[sub]
    c = X.mean(axis=0)
    length = float(np.sqrt(np.mean(np.sum((X - c) ** 2, axis=1)))) or 1.0
    J = pose_jacobian(X, normals, c)
    J[:, :nrot] /= length
    A = J.T @ J / X.shape[0]
    lam, V = np.linalg.eigh(A)
    lam = np.maximum(lam, 0.0)
    top = float(lam[-1]) or 1.0
    strengths = lam / top
    weak = []
    for k in np.flatnonzero(strengths < weak_below):
        # Normalised units are mm: the covariance along the eigenvector is s^2 / (n lambda).
        sig = (float(residual_rms) / np.sqrt(n * lam[k])
               if lam[k] > 0 and np.isfinite(residual_rms) else None)
        if strengths[k] >= DEGENERATE_STRENGTH and resolution_mm is not None and \
                sig is not None and sig <= resolution_mm:
            continue  # weak, but the measurement pins it down finely enough
        v = V[:, k]
        rot, tr = v[:nrot], v[nrot:]
        if np.linalg.norm(rot) >= np.linalg.norm(tr):
            axis = (rot / np.linalg.norm(rot)) if dim == 3 else np.array([0.0, 0.0, np.sign(
                rot[0]) or 1.0])
            kind = "rotation"
        else:
            axis = tr / np.linalg.norm(tr)
            kind = "translation"
        if dim == 2 and kind == "translation":
            axis = np.append(axis, 0.0)
        # Sign: the largest component positive, so the same direction reads the same way.
        axis = axis * (1.0 if axis[np.argmax(np.abs(axis))] >= 0 else -1.0)
        weak.append(WeakDirection(kind, tuple(float(a) for a in axis), float(strengths[k]),
                                  None if sig is None or strengths[k] < DEGENERATE_STRENGTH
                                  else float(sig), tuple(float(a) for a in v)))
    sigma = None
    if not weak and n > dof and np.isfinite(residual_rms) and lam[0] > 0:
        sigma = _pose_sigma(X, c, length, A, n, residual_rms)
    return Conditioning(tuple(float(s) for s in strengths), tuple(weak), length, sigma,
                        tuple(float(a) for a in c))


def _pose_sigma(X: np.ndarray, c: np.ndarray, length: float, A: np.ndarray, n: int,
                residual_rms: float) -> float:
    """The largest 1-sigma displacement (mm) at any of the points ``X`` ((m, 3) or (m, 2),
    nominal frame) that the residuals (rms, mm, of all ``n`` fitted points) imply for the pose:
    ``A`` the normal matrix per point (rotations scaled by ``length`` about the centroid ``c``,
    as in :func:`conditioning`), invertible."""
    # Pose covariance s^2 (J^T J)^-1; a point moves by G dp, with G its own Jacobian of
    # position (not of distance) with respect to the pose.
    cov = residual_rms ** 2 * np.linalg.inv(A * n)
    r = X - c
    m = X.shape[0]
    if X.shape[1] == 3:
        G = np.zeros((m, 3, 6))
        # A rotation w moves r by w x r = (eps_ijk r_k) w_j.
        G[:, :, :3] = np.einsum("ijk,nk->nij", _LEVI, r) / length
        G[:, :, 3:] = np.eye(3)
    else:
        G = np.zeros((m, 2, 3))
        G[:, 0, 0] = -r[:, 1] / length
        G[:, 1, 0] = r[:, 0] / length
        G[:, :, 1:] = np.eye(2)
    var = np.einsum("nij,jk,nik->n", G, cov, G)
    return float(np.sqrt(var.max()))


_LEVI = np.zeros((3, 3, 3))
for _i, _j, _k in ((0, 1, 2), (1, 2, 0), (2, 0, 1)):
    _LEVI[_i, _j, _k], _LEVI[_i, _k, _j] = 1.0, -1.0


# ---------------------------------------------------------------------------- sampling margin
def sampling_margin(curvature: np.ndarray, spacing: np.ndarray) -> np.ndarray:
    """curvature (1/mm) x spacing (mm)^2 / 8: how far a chord through sampled points can lie
    from the curved surface (the paper's Fig. 4), per point, mm."""
    return np.abs(curvature) * spacing * spacing / 8.0


def deviation_jacobian(X: np.ndarray, normals: np.ndarray, cond: Conditioning) -> np.ndarray:
    """(n, 6) in 3D, (n, 3) in 2D: how each point's deviation changes with the pose twist
    (rotations x ``cond.length``, then translations, mm; about ``cond.centre``) at points X
    (nominal frame) with the nominal's ``normals`` there."""
    X = np.asarray(X, float)
    J = pose_jacobian(X, np.asarray(normals, float), np.asarray(cond.centre, float))
    J[:, :(3 if X.shape[1] == 3 else 1)] /= cond.length  # the twists' units (mm)
    return J


def pose_covariance(J: np.ndarray, residual_rms: float, cond: Conditioning) -> np.ndarray:
    """Covariance (dof, dof) of the pose twist fitted by least squares to the points whose
    :func:`deviation_jacobian` is ``J`` (n, dof): s^2 (J^T J)^+ with s^2 = n / (n - dof) x
    rms^2 (the residuals' variance; dof the directions fitted), over the directions that are
    not free (a free one has no finite variance: :func:`pose_sensitivity` scans it instead;
    its variance here is 0)."""
    n = J.shape[0]
    dof = J.shape[1]
    A = J.T @ J
    free = [np.asarray(w.twist, float) for w in cond.weak if w.sigma_mm is None and w.twist]
    if free:
        F = np.linalg.qr(np.array(free).T)[0]
        Pc = np.eye(dof) - F @ F.T
        A = Pc @ A @ Pc
    lam, V = np.linalg.eigh(A)
    keep = lam > DEGENERATE_STRENGTH * max(float(lam[-1]), 1e-300)
    fitted = int(keep.sum())
    if n <= fitted:
        return np.zeros((dof, dof))
    return (residual_rms ** 2 * n / (n - fitted)) * (V[:, keep] / lam[keep]) @ V[:, keep].T


def deviation_sigma(J: np.ndarray, cov: np.ndarray) -> np.ndarray:
    """(n,) the standard deviation (mm) of each point's deviation from the pose alone:
    sqrt(J_i cov J_i^T), J (n, dof) the points' :func:`deviation_jacobian`."""
    return np.sqrt(np.maximum(np.einsum("ij,jk,ik->i", J, cov, J), 0.0))


UNCERTAINTY_SIGMAS = 3.0
"""The pose's uncertainty region from the fit's residuals, all directions together: the
ellipsoid of this many sigma of the full pose covariance (weak and strong directions and their
combinations; the free ones are scanned on their own)."""
UNCERTAINTY_POINTS = 32
"""Points whose margin is within UNCERTAINTY_SIGMAS of their deviation's sigma get a pose of
their own at most (the nearest to a limit in sigmas first)."""


def uncertainty_poses(X: np.ndarray, normals: np.ndarray, residual_rms: float, T: np.ndarray,
                      d: np.ndarray, lower: float, upper: float, cond: Conditioning,
                      margin: np.ndarray | None = None) -> list[np.ndarray]:
    """Poses on the edge of the pose's uncertainty region that move a point across a limit.

    X, normals : (n, 3) or (n, 2) fitted points at pose T (nominal frame) and their nominal
        normals; d : (n,) their deviations (mm); residual_rms : the fit's RMS residual (mm).
    The pose covariance is s^2 (J^T J)^-1 over the directions that are not free (s^2 the
    residuals' variance, n / (n - dof) x rms^2; J the points' deviation Jacobian); a point's
    deviation then has sigma_i = sqrt(J_i Sigma J_i^T) from the pose alone. For each point whose
    distance to the nearest value where its pointwise verdict changes (a limit, or a guarded
    margin's) is below UNCERTAINTY_SIGMAS x sigma_i (at most UNCERTAINTY_POINTS of them), the
    pose UNCERTAINTY_SIGMAS sigma away along the direction that moves its deviation most
    towards that value (Sigma J_i^T / sigma_i), as the exact rigid motion before T: 4x4 (3x3
    in 2D). [] when no point is that close or the fit has too few points."""
    X = np.asarray(X, float)
    normals = np.asarray(normals, float)
    d = np.asarray(d, float)
    n, dim = X.shape
    nrot = 3 if dim == 3 else 1
    dof = nrot + dim
    if n <= dof or not np.isfinite(residual_rms) or not cond.length or not cond.centre:
        return []
    c = np.asarray(cond.centre, float)
    J = deviation_jacobian(X, normals, cond)
    cov = pose_covariance(J, residual_rms, cond)
    JS = J @ cov
    sd = np.sqrt(np.maximum(np.einsum("ij,ij->i", JS, J), 0.0))
    m = np.zeros(n) if margin is None else np.asarray(margin, float)
    cuts = np.stack([lower - m, lower + m, upper - m, upper + m])
    gap = cuts - d
    k = np.argmin(np.abs(gap), axis=0)
    toward = gap[k, np.arange(n)]
    ratio = np.abs(toward) / np.maximum(sd, 1e-300)
    risk = np.flatnonzero((ratio < UNCERTAINTY_SIGMAS) & (sd > 0))
    risk = risk[np.argsort(ratio[risk])][:UNCERTAINTY_POINTS]
    poses = []
    for i in risk:
        p = UNCERTAINTY_SIGMAS * (np.sign(toward[i]) or 1.0) * JS[i] / sd[i]
        poses.append(screw_motion(p, 1.0, c, cond.length) @ np.asarray(T, float))
    return poses
