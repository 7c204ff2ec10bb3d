"""Whether a fitted pose can be trusted, and the fit that answers the tolerance question.

* :func:`conditioning`: how well the measured points constrain each rigid degree of freedom,
  from the point-to-surface normal equations at the final pose; directions they do not constrain
  (a cylinder along and about its axis, a plane within itself) are named, and the pose
  uncertainty the fit's residuals imply at the points is given.
* :func:`minimax_pose`: the rigid pose that minimises the largest normalised excursion from the
  tolerance zone's centre (Chebyshev / L-infinity), as a sequence of linear programs on the
  linearised pose (scipy's HiGHS) with a trust region, each step checked on the exact deviations.
* :func:`sampling_margin`: per point, how far facets through sampled nominal points can lie from
  the true surface: curvature x spacing^2 / 8.

Shapes: points and normals are (n, 3) in 3D, (n, 2) for a 2D template (3 degrees of freedom:
the rotation about z and the two translations). Units mm; directions in the nominal frame.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

CONDITIONING_POINTS = 16384
"""Fitted points the normal matrix is formed from at most (a seeded subset beyond)."""
DEGENERATE_STRENGTH = 1e-8
"""Below this normalised eigenvalue a direction is unconstrained by the shape itself (a plane,
cylinder or sphere: 1e-11, rounding)."""
WEAK_STRENGTH = 1e-4
"""Below this one a direction is nearly unconstrained by the shape (seen: two faces of a bracket
at right angles, along their common edge, 3e-5; a 180 x 90 mm patch of a gently curved panel
5.6e-5; a 500 x 250 mm paraboloid panel 3e-4; the belly-fairing sample 2e-3) and counts as
unconstrained when the measurement leaves it uncertain: when the residuals imply a 1-sigma
motion along it of more than ``resolution_mm`` (a quarter of the zone width, see
engine.inspection), the pose along it is a guess at the scale that decides the verdict."""


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


@dataclass(frozen=True)
class Conditioning:
    """Conditioning of the point-to-surface fit at the final pose.

    strengths : eigenvalues of the normal matrix (rotations scaled by ``length``, so that both
        kinds are in mm units) over the largest, ascending; one per degree of freedom.
    weak : the directions with strength below WEAK_STRENGTH.
    length : RMS distance of the fitted points from their centroid, mm (the rotation scale).
    pose_sigma_mm : the largest 1-sigma displacement, at any fitted point, that the residuals
        (rms) imply for the pose; None when a direction is unconstrained (the pose is
        undetermined along it) or there are too few points.
    """

    strengths: tuple[float, ...]
    weak: tuple[WeakDirection, ...] = field(default_factory=tuple)
    length: float = 0.0
    pose_sigma_mm: float | None = None


def _jacobian(X: np.ndarray, normals: np.ndarray, c: np.ndarray) -> np.ndarray:
    """d(deviation)/d[rotation, translation] of the update x' = c + R(w)(x - c) + t."""
    r = X - c
    if X.shape[1] == 3:
        return np.concatenate([np.cross(r, normals), normals], axis=1)
    rot = r[:, 0] * normals[:, 1] - r[:, 1] * normals[:, 0]
    return np.column_stack([rot, normals])


def conditioning(X: np.ndarray, normals: np.ndarray, residual_rms: float,
                 resolution_mm: float | None = None) -> Conditioning:
    """Conditioning of fitting points ``X`` (registered, nominal frame) with surface ``normals``.

    A direction is unconstrained when its normalised strength is below DEGENERATE_STRENGTH, or
    below WEAK_STRENGTH while the residuals (rms, mm) imply a 1-sigma motion along it above
    ``resolution_mm`` (None: any weak direction counts)."""
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
        sub = np.random.default_rng(5).choice(n, CONDITIONING_POINTS, replace=False)
        X, normals = X[sub], normals[sub]
    c = X.mean(axis=0)
    length = float(np.sqrt(np.mean(np.sum((X - c) ** 2, axis=1)))) or 1.0
    J = _jacobian(X, normals, c)
    J[:, :nrot] /= length
    A = J.T @ J / X.shape[0]
    lam, V = np.linalg.eigh(A)
    lam = np.maximum(lam, 0.0)
    top = float(lam[-1]) or 1.0
    strengths = lam / top
    weak = []
    for k in np.flatnonzero(strengths < WEAK_STRENGTH):
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
                                  else float(sig)))
    sigma = None
    if not weak and n > dof and np.isfinite(residual_rms) and lam[0] > 0:
        # Pose covariance s^2 (J^T J)^-1; a point moves by G dp, with G its own Jacobian of
        # position (not of distance) with respect to the pose.
        cov = residual_rms ** 2 * np.linalg.inv(A * n)
        r = X - c
        m = X.shape[0]
        if dim == 3:
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
        sigma = float(np.sqrt(var.max()))
    return Conditioning(tuple(float(s) for s in strengths), tuple(weak), length, sigma)


_LEVI = np.zeros((3, 3, 3))
for _i, _j, _k in ((0, 1, 2), (1, 2, 0), (2, 0, 1)):
    _LEVI[_i, _j, _k], _LEVI[_i, _k, _j] = 1.0, -1.0


# ---------------------------------------------------------------------------- minimax fit
@dataclass(frozen=True)
class MinimaxResult:
    T: np.ndarray
    """The pose (4x4 in 3D, 3x3 homogeneous 2D) that minimises the largest excursion."""
    excursion: float
    """max |d - centre| / half-width over the points used: <= 1 means they all fit the zone."""
    start_excursion: float
    """The same at the starting (least-squares) pose."""
    iterations: int
    linear_programs: int


def minimax_pose(evaluate: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray, np.ndarray]],
                 T0: np.ndarray, lower: float, upper: float, use: np.ndarray | None = None,
                 max_iterations: int = 40, tol_mm: float = 1e-7) -> MinimaxResult:
    """Minimise max over points of |d - (lower + upper)/2| / ((upper - lower)/2) over rigid poses.

    evaluate(T) -> (X, d, normals): registered points, their signed deviations (mm) and surface
    normals at pose T, exactly. ``use`` masks the points that take part (the fit's inliers: a
    gross outlier must not drag the pose; it is still judged). Each iteration solves the linear
    program of the linearised problem within a trust region on the points near the current
    maximum (an active set, grown with the points a rejected step showed rising), accepts the
    step only if the exact maximum went down (growing the region when the step was held back by
    it), and otherwise shrinks the region; it stops at an interior optimum of the linear model
    that the exact deviations confirm. The result is never worse than the start.
    """
    from scipy.optimize import linprog

    centre, half = 0.5 * (lower + upper), 0.5 * (upper - lower)
    T = np.array(T0, float)
    X, d, nrm = evaluate(T)
    use = np.ones(d.size, bool) if use is None else np.asarray(use, bool)
    idx_all = np.flatnonzero(use)
    if idx_all.size == 0:
        e0 = float(np.max(np.abs(d - centre)) / half) if d.size else 0.0
        return MinimaxResult(T, e0, e0, 0, 0)
    dim = X.shape[1]
    nrot = 3 if dim == 3 else 1
    dof = nrot + dim

    def excursion(dd):
        return float(np.max(np.abs(dd[idx_all] - centre)))

    e = excursion(d)
    start = e
    radius = max(e, half)  # trust region, mm of motion at the points' scale
    forced = np.zeros(0, dtype=np.int64)  # points a rejected step showed to matter
    lps = 0
    it = 0
    for it in range(1, max_iterations + 1):
        ex = np.abs(d[idx_all] - centre)
        k = min(idx_all.size, max(64, 4 * dof))
        active = np.unique(np.concatenate([
            idx_all[np.argpartition(-ex, k - 1)[:k]], idx_all[ex >= 0.5 * e], forced]))
        c = X[active].mean(axis=0)
        length = float(np.sqrt(np.mean(np.sum((X[idx_all] - c) ** 2, axis=1)))) or 1.0
        J = _jacobian(X[active], nrm[active], c)
        J[:, :nrot] /= length
        r = d[active] - centre
        m = active.size
        # Variables [p (dof), s]; minimise s subject to |r + J p| <= s.
        A = np.block([[J, -np.ones((m, 1))], [-J, -np.ones((m, 1))]])
        b = np.concatenate([-r, r])
        cost = np.zeros(dof + 1)
        cost[-1] = 1.0
        bounds = [(-radius, radius)] * dof + [(0, None)]
        sol = linprog(cost, A_ub=A, b_ub=b, bounds=bounds, method="highs")
        lps += 1
        if sol.status != 0:
            break
        p = sol.x[:dof].copy()
        interior = bool(np.max(np.abs(p)) < 0.999 * radius)
        p[:nrot] /= length
        T_new = _apply_update(T, p, c)
        X_new, d_new, nrm_new = evaluate(T_new)
        e_new = excursion(d_new)
        if e_new < e - tol_mm:
            T, X, d, nrm, e = T_new, X_new, d_new, nrm_new, e_new
            if interior and sol.x[-1] >= e_new - tol_mm:
                break  # the linear model's optimum, and exact here: done
            if not interior:
                radius *= 2.0  # the region held the step back: let it grow again
        else:
            # The linearisation missed points that rose above the model's bound: take them
            # into the next program, and look closer.
            rose = idx_all[np.abs(d_new[idx_all] - centre) > sol.x[-1] + tol_mm]
            forced = np.unique(np.concatenate([forced, rose]))
            radius *= 0.25
            if radius < tol_mm:
                break
    return MinimaxResult(T, e / half, start / half, it, lps)


def _apply_update(T: np.ndarray, p: np.ndarray, c: np.ndarray) -> np.ndarray:
    """x' = c + R(w)(x - c) + t applied after the pose T (3D 4x4 or 2D 3x3)."""
    if T.shape[0] == 4:
        from .geometry import make_transform, rotation_from_rotvec

        R = rotation_from_rotvec(p[None, :3])[0]
        U = make_transform(R, c - R @ c + p[3:])
        return U @ T
    th = p[0]
    R = np.array([[np.cos(th), -np.sin(th)], [np.sin(th), np.cos(th)]])
    U = np.eye(3)
    U[:2, :2] = R
    U[:2, 2] = c - R @ c + p[1:]
    return U @ T


# ---------------------------------------------------------------------------- sampling margin
def sampling_margin(curvature: np.ndarray, spacing: np.ndarray) -> np.ndarray:
    """curvature (1/mm) x spacing (mm)^2 / 8: how far a chord through sampled points can lie
    from the curved surface (the paper's Fig. 4), per point, mm."""
    return np.abs(curvature) * spacing * spacing / 8.0
