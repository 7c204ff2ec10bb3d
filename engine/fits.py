"""The fits of a pose beyond the registration's least squares: the minimax refit, which answers
the tolerance question "can this part be placed inside its zone?".

* :func:`minimax_pose`: the rigid pose that minimises the largest normalised excursion from the
  tolerance zone's centre (Chebyshev / L-infinity), as a sequence of linear programs on the
  linearised pose (scipy's HiGHS) with a trust region, each step checked on the exact deviations.
* :func:`minimax`: that fit as the inspection runs it, from the least-squares pose, with the
  facts the outputs report (:func:`minimax_facts`).

Shapes: points and normals are (n, 3) in 3D, (n, 2) for a 2D template (3 degrees of freedom:
the rotation about z and the two translations). Units mm; directions in the nominal frame.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from .choices import Fit
from .pose import apply_update, pose_jacobian
from .tolerance import Tolerance

FITS = tuple(f.value for f in Fit)


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
        J = pose_jacobian(X[active], nrm[active], c)
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
        T_new = apply_update(T, p, c)
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


def minimax(evaluate, T: np.ndarray, use: np.ndarray, tol: Tolerance,
            extra: dict) -> np.ndarray:
    """The minimax pose from the least-squares one (its facts go into ``extra``), fitted on the
    points ``use`` (n,) bool: the registration's ``inlier``, every point but the gross outliers
    (engine.outliers) it excluded from the alignment. A local defect stays in: it is what the
    minimax fit has to place."""
    from .progress import report

    report("minimax fit (linear programs)", 0.97)
    mm = minimax_pose(evaluate, T, tol.lower, tol.upper, use=use)
    extra[Fit.MINIMAX.value] = minimax_facts(mm)
    return mm.T


def minimax_facts(mm) -> dict:
    return {"excursion": mm.excursion, "least_squares_excursion": mm.start_excursion,
            "iterations": mm.iterations, "linear_programs": mm.linear_programs,
            "excursion_definition": "max over the fitted points (all but those excluded from "
                                    "the alignment as gross outliers) of "
                                    "|d - (lower + upper)/2| / ((upper - lower)/2): <= 1 means "
                                    "they fit the zone"}
