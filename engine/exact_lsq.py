"""The least squares of exact deviations: a pose refined on the exact surface of a posed
measurement (engine.surface.Posed: a STEP model's faces) by Gauss-Newton steps over the points
the gross-outlier rule keeps, each step halved until it lowers the sum of squares
(:func:`exact_fit` for a registration, :func:`kept_fit` for a pose and a few points). The
search among poses that uses it is engine.exact_fit's.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from .pose import apply_update, lower_along, pose_jacobian
from .seeds import rng
from .surface import Posed

EXACT_FIT_POINTS = 8192
"""The exact least squares iterates on at most this many of the points it keeps (a seeded random
choice), then takes one step on every point: each exact evaluation costs tens of microseconds a
point."""
EXACT_FIT_SEED = 11
"""The random stream of that choice (engine.seeds)."""


EXACT_MAX_STEPS = 20
"""All-point Gauss-Newton steps of the exact fit at most (each one exact evaluation of every
point); it ends sooner when a step would move no point by more than 1e-9 of their extent."""


EXACT_HALVINGS = 4
"""A step of the exact fit that does not lower the sum of squares is halved at most this many
times …"""
EXACT_STALL_OF_ZONE = 0.01
"""… and when none of them does, the fit has settled if the step moved no point by more than
this fraction of the zone's width, or if the decrease of the sum of squares the step promised
was less than one residual variance (the step is then inside the least-squares pose's own
1-sigma ellipsoid: NIST CTC-01 with its largest face bowed 1 mm stalled at 1.29 um steps that
promised 0.00027 mm^2, its residual variance 0.071 mm^2)."""


def exact_fit(reg, posed: Posed, zone_width: float, seed: int):
    """The registration finished on the exact surface: least squares of the exact deviations
    from the pose found on the nominal's sample (within its chordal error of the answer), over
    the points the gross-outlier rule (engine.outliers) keeps at the pose reached.

    The points kept at first are those the rule keeps by the sample's deviations at the
    handover pose; Gauss-Newton iterates on a seeded spread of at most ``EXACT_FIT_POINTS`` of
    them (cheap: its optimum is within its sampling of every point's), then steps over every
    point, each step at the exact deviations of every point and the rule applied to them again,
    until a step would move no point by more than 1e-9 of their extent: the pose is then the
    least-squares optimum over the points the rule keeps there, and the deviations returned are
    exact at it. A step that does not lower the sum of squares is halved (``EXACT_HALVINGS``);
    when no fraction of it does, the fit ends there. converged, rms, inliers and rule are this
    fit's. seed : the inspection's (engine.seeds)."""
    from .outliers import gross_outliers, gross_rule

    floor = reg.gross_rule.floor_mm
    rule = gross_rule(reg.deviations.signed, zone_width, floor)
    use = ~gross_outliers(reg.deviations.signed, reg.deviations.foot, rule)
    T = _subset_fit(posed, reg.T_nominal_measured, use, seed)
    X, dev = posed.at(T)
    extent = float(np.linalg.norm(np.ptp(X, axis=0))) or 1.0
    converged = False
    for _ in range(EXACT_MAX_STEPS):
        rule = gross_rule(dev.signed, zone_width, floor)
        use = ~gross_outliers(dev.signed, dev.foot, rule)
        if np.count_nonzero(use) < 6:
            break
        gn = _gn_step_exact(X[use], dev.normal[use], dev.signed[use])
        if gn.moved <= 1e-9 * extent:
            converged = True
            break
        cost = float(np.sum(dev.signed[use] ** 2))
        lower = _lower_along(posed.at, T, gn.step, gn.c, cost, lambda dv: dv.signed[use])
        if lower is None:
            # No fraction of the step lowers the sum of squares: a point's foot flips between
            # two faces at an edge, and full steps would cycle between two poses (NIST FTC-06
            # with its largest face bowed 1 mm: 0.38 um steps, back and forth, for ever). The
            # pose is the optimum to within that step.
            variance = cost / max(int(np.count_nonzero(use)) - 6, 1)
            converged = (gn.moved <= EXACT_STALL_OF_ZONE * zone_width
                         or gn.promised <= variance)
            break
        T, X, dev = lower
    d_in = dev.signed[use]
    message = "" if converged else ("the least-squares fit on the exact surface did not settle")
    return replace(reg, T_nominal_measured=T, deviations=dev, converged=converged,
                   message=message, inlier=use, n_inliers=int(use.sum()),
                   rms=float(np.sqrt(np.mean(d_in * d_in))) if use.any() else float("nan"),
                   outlier_cut=rule.threshold_mm, gross_rule=rule)


def kept_fit(posed: Posed, T: np.ndarray, idx: np.ndarray, floor_mm: float,
             zone_width: float, seed: int, iterations: int) -> np.ndarray:
    """The pose from T fitted by least squares of the exact deviations (:func:`_subset_fit`,
    ``iterations`` at most) of those of the points ``idx`` that the gross-outlier rule (floor
    ``floor_mm``, mm) keeps at T."""
    from .outliers import gross_outliers, gross_rule

    _, dev = posed.at(T, idx)
    rule = gross_rule(dev.signed, zone_width, floor_mm)
    use = np.zeros(posed.points.shape[0], bool)
    use[idx[~gross_outliers(dev.signed, dev.foot, rule)]] = True
    return _subset_fit(posed, T, use, seed, iterations)


@dataclass(frozen=True)
class _Step:
    """A Gauss-Newton step of the exact fit: step (6,), rotation vector then translation, about
    c (3,), the points' centroid; moved, the largest displacement it gives a point (mm);
    promised, the decrease of the sum of squares the linearised model promises (mm^2)."""

    step: np.ndarray
    c: np.ndarray
    moved: float
    promised: float


def _gn_step_exact(X: np.ndarray, normal: np.ndarray, signed: np.ndarray) -> _Step:
    """One Gauss-Newton step of the signed deviations ``signed`` (m,) of points X (m, 3) with
    the surface normals at their feet."""
    c = X.mean(axis=0)
    J = pose_jacobian(X, normal, c)
    step = np.linalg.lstsq(J, -signed, rcond=None)[0]
    moved = float(np.max(np.linalg.norm(np.cross(step[:3], X - c) + step[3:], axis=1)))
    return _Step(step, c, moved, float(np.sum((J @ step) ** 2)))


def _subset_fit(posed: Posed, T: np.ndarray, use: np.ndarray, seed: int,
                max_iterations: int = 50) -> np.ndarray:
    """The pose from T by Gauss-Newton least squares of the exact deviations of a seeded random
    choice of at most EXACT_FIT_POINTS of the points ``use``, until no point moves by more
    than 1e-9 of their extent (or ``max_iterations``), or no fraction of a step
    (``_lower_along``) lowers their sum of squares: the pose is then the optimum to within that
    step. (Full steps cycled there: NIST FTC-07's runner-up pose, its largest face bowed
    0.1 mm, went back and forth by 1.5 um for all of its 20 iterations.)"""
    idx = np.flatnonzero(use)
    if idx.size > EXACT_FIT_POINTS:
        idx = np.sort(rng(seed, EXACT_FIT_SEED).choice(idx, EXACT_FIT_POINTS, replace=False))
    if idx.size < 6:
        return T
    X, dev = posed.at(T, idx)
    extent = float(np.linalg.norm(np.ptp(X, axis=0))) or 1.0
    for _ in range(max_iterations):
        gn = _gn_step_exact(X, dev.normal, dev.signed)
        if gn.moved <= 1e-9 * extent:
            return apply_update(T, gn.step, gn.c)
        lower = _lower_along(lambda Tc: posed.at(Tc, idx), T, gn.step, gn.c,
                             float(np.sum(dev.signed ** 2)), lambda dv: dv.signed)
        if lower is None:
            break
        T, X, dev = lower
    return T


def _lower_along(measure, T: np.ndarray, step: np.ndarray, c: np.ndarray, cost: float,
                 residuals):
    """The first of the Gauss-Newton ``step`` (about c) and its halves (``EXACT_HALVINGS``)
    from pose T whose sum of squared ``residuals(dev)`` is below ``cost``: (T', X', dev') with
    measure(T') = (X', dev'); None when none is."""
    def evaluate(T_new):
        X_new, dev_new = measure(T_new)
        return float(np.sum(residuals(dev_new) ** 2)), (X_new, dev_new)

    lower = lower_along(T, step, c, cost, evaluate, 2.0, EXACT_HALVINGS)
    return None if lower is None else (lower[0], *lower[1])
