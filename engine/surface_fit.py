"""The point-to-surface finish of a registration: Gauss-Newton least squares of the signed
point-to-surface deviations (engine.deviation) over every measured point but the gross outliers
(engine.outliers), in rounds that re-apply the gross-outlier rule at each new pose, after a few
robust iterations that bring a pose from the ICP stages into the least-squares basin
(engine.registration's step 3)."""

from __future__ import annotations

import dataclasses
import time

import numpy as np

from .deviation import Deviations, point_to_surface
from .neighbours import spread_subset
from .nominal import Nominal
from .outliers import (INCLUDED_FIT_ITERATIONS, fit_without_gross, gross_outliers, gross_rule,
                       robust_centre_sigma)
from .pose import apply_transform, apply_update, gauss_newton_step, lower_along
from .progress import report
from .registration_types import PoseFit, RegistrationSettings, RobustFit


# ---------------------------------------------------------------------------- final stage
MAX_FINISHES = 4
"""Point-to-surface finishes at most, of the best-scoring distinct candidate poses: each costs
a full fit over every measured point, and the global stage alone (a nominal no larger than its
coarsest level) leaves up to 32 candidates."""
ALTERNATIVE_ITERATIONS = 10
"""Gauss-Newton iterations at most of the finish of each candidate after the best-scoring one
(a candidate near the right pose settles in a few; the exact finish of a STEP nominal hands
over after EXACT_HANDOVER_ITERATIONS, 8, anyway)."""
ROBUST_ITERATIONS = 3
"""Gauss-Newton iterations of the point-to-surface fit that still use the robust cut (they bring
the pose from the ICP stages into the least-squares basin); the iterations after them are plain
least squares over every point but the gross outliers."""
MAX_ROUNDS = 4
"""Least-squares fits, each followed by the gross-outlier rule at its pose, until the excluded
set no longer changes."""


def pose_score(d: np.ndarray, scale: float) -> float:
    """How well deviations d (mm) fit, mm: sqrt(exp(mean(log(d^2 + scale^2))) - scale^2).

    Poses rank as by the mean Cauchy loss log(1 + (d / scale)^2) of their points: 0.01 for a
    point at a tenth of ``scale``, 0.7 at ``scale``, 9.2 at 100 x ``scale``. While the
    deviations are small against ``scale`` the score is about their RMS (close fits compare as
    least squares does); beyond it a point counts by the logarithm of its distance. So a few
    gross outliers do not decide between poses; a pose that leaves a quarter of the points
    millimetres off loses to one that keeps every point within hundredths; and a pose with
    every point but one (a mis-probe, a missing hole) at the noise does not lose to one slid
    along a weak direction that spreads that point's error over all of them."""
    s2 = scale * scale
    return float(np.sqrt(max(np.exp(pose_loss(d, scale)) - s2, 0.0)))


def pose_loss(d: np.ndarray, scale: float, weights: np.ndarray | None = None) -> np.ndarray:
    """mean(log(d^2 + scale^2)) over the last axis of deviations d (mm): what
    :func:`pose_score` ranks poses by (lower is better), per row of a (k, m) array of k poses'
    deviations (engine.weak_search scans poses so); ``weights`` (m,): a weighted mean."""
    return np.average(np.log(d * d + scale * scale), axis=-1, weights=weights)


LOST_AFTER = ROBUST_ITERATIONS + 2
"""A watched finish (:class:`Watch`) may be given up from this evaluation of its deviations
on: the first after a least-squares step (the robust iterations evaluate ``ROBUST_ITERATIONS``
poses and the pose they end at)."""


@dataclasses.dataclass
class Watch:
    """The finish of a candidate pose when a better one is known, watched: it is given up at an
    evaluation of its deviations (the ``LOST_AFTER``-th or a later one) whose score
    (:func:`pose_score` at ``scale``) is no lower than its start's and above ``beat`` (the
    registration passes the best finish's score so far x engine.verdict.AMBIGUITY_SCORE_RATIO:
    a finish is not given up while it scores within that ratio of the best). The fit then ends,
    not converged, at the best pose it saw (``best``). Least squares over every point pulls a
    wrong pose towards the points it leaves off the part: the belly fairing's second candidate
    went from 1.3 mm to 637 mm over the 11 evaluations of its budget, 46 of the whole
    inspection's 157 ms (1.15 s of 2.7 s on a million-point nominal).

    Over 2,084 such finishes in ten sweeps of NIST parts (patches, 2 % mis-probes, bumps), the
    rule gives up 728 (2,698 of 18,010 evaluations saved); one would have ended below the best,
    a wrong pose at 0.160 mm against another wrong pose's 0.175 mm (the truth's: 0.002 mm). None
    that would have ended within the ambiguity ratio of the best is reported beyond it."""

    scale: float
    beat: float
    start: float | None = None
    seen: int = 0
    gave_up: bool = False
    best: tuple | None = None
    """(score, pose (4, 4), Deviations, seconds their evaluation took) of the best seen."""

    def sees(self, T: np.ndarray, dev: Deviations, dev_s: float) -> bool:
        """Whether the finish is given up at pose ``T``, the next evaluated, with its deviations
        ``dev`` (which took ``dev_s`` seconds)."""
        score = pose_score(dev.signed, self.scale)
        if self.best is None or score < self.best[0]:
            self.best = (score, T, dev, dev_s)
        self.start = score if self.start is None else self.start
        self.seen += 1
        self.gave_up = self.gave_up or (self.seen >= LOST_AFTER and score >= self.start
                                        and score > self.beat)
        return self.gave_up


def point_to_surface_fit(nominal: Nominal, measured: np.ndarray, T: np.ndarray,
                          settings: RegistrationSettings, zone_width: float | None,
                          watch: Watch | None = None) -> PoseFit:
    """Least squares of the signed point-to-surface deviations over every point but the gross
    outliers of :mod:`engine.outliers`.

    The first ``ROBUST_ITERATIONS`` Gauss-Newton iterations use the robust cut (a pose from the
    ICP stages may still be off by more than the spread of the deviations); then the fit is
    plain least squares over the points the gross-outlier rule keeps at the current pose, run to
    convergence, the rule applied again at the new pose, until the kept set is stable; a point
    is left out only if it is gross at the least-squares pose over every point too (one linear
    step from there when it moves no point by more than ``LINEAR_INCLUDED`` x the threshold,
    else iterated: _confirmed_rounds).
    Measurements larger than ``fit_measured`` points iterate on a seeded subset of that size;
    then the rule is applied to every point and one Gauss-Newton step over every kept point
    moves the pose to the all-point optimum (the subset's optimum is within noise /
    sqrt(subset) of it, so one step of a nearly linear problem suffices; should it move any
    point by more than ``finish_step_mm``, change the kept set, or a point left out not stay
    gross with every point included, iteration over all points continues instead). The
    deviations follow that last step to first order (exact to ~step^2 x curvature, far below
    a nanometre). Returns the fit over all points (its deviation_s: the seconds their last
    evaluation took). ``watch``: the fit is given up where it is when the watch says so.
    """
    floor = settings.outlier_floor * nominal.diagonal
    n = measured.shape[0]
    fsub = spread_subset(measured, settings.fit_measured, settings.seed)
    sub = measured[fsub]
    budget = settings.max_final_iterations
    robust = _gauss_newton(nominal, sub, T, settings, None, floor, min(ROBUST_ITERATIONS, budget),
                           watch=watch)
    total = robust.iterations
    floor = gross_floor(nominal, settings, zone_width)
    # On a subset, the final stage over every point checks the points left out.
    if fsub.size == n:
        fit = _confirmed_rounds(nominal, sub, robust, settings, zone_width, floor, budget - total,
                                watch)
    else:
        fit = _least_squares_rounds(nominal, sub, robust, settings, zone_width, floor,
                                    budget - total, watch=watch)[0]
    total += fit.iterations
    if watch is not None and watch.gave_up:
        return _given_up(nominal, measured, watch, fsub.size < n, zone_width, floor, total)
    if fsub.size < n:
        fit, more = _on_every_point(nominal, measured, fit, settings, zone_width, floor, budget)
        total += more
    converged, message = fit.converged, ""
    if not converged:
        message = (f"the point-to-surface fit did not settle within "
                   f"{settings.max_final_iterations} iterations (or the points it excludes as "
                   f"gross outliers within {MAX_ROUNDS} fits)")
    kept = int(fit.inlier.sum())
    if kept < 6:
        converged = False
        message = (f"only {kept} points are not gross outliers (beyond "
                   f"{fit.rule.threshold_mm:.3g} mm)")
    return dataclasses.replace(fit, converged=converged, iterations=total, message=message)


def _on_every_point(nominal, measured, fit, settings, zone_width, floor,
                    budget) -> tuple[PoseFit, int]:
    """point_to_surface_fit's last stage after a ``fit`` on a subset: (the fit over every
    measured point, the Gauss-Newton iterations it took)."""
    total = 0
    X = apply_transform(fit.T_nominal_measured, measured)
    t0 = time.perf_counter()
    dev = point_to_surface(nominal, X)
    rule = gross_rule(dev.signed, zone_width, floor)
    keep = ~gross_outliers(dev.signed, dev.foot, rule)
    fit = dataclasses.replace(fit, inlier=keep, rule=rule, deviations=dev,
                              deviation_s=time.perf_counter() - t0)
    finished = not settings.finish_on_all_points
    if not finished and fit.converged and keep.sum() >= 6:
        delta, c = gauss_newton_step(X[keep], dev.normal[keep], dev.signed[keep])
        total += 1
        if _largest_motion(delta, X[keep] - c) <= settings.finish_step_mm:
            moved, X_m = _moved(dev, X, delta, c)
            rule_m = gross_rule(moved.signed, zone_width, floor)
            keep_m = ~gross_outliers(moved.signed, moved.foot, rule_m)
            # Points left out must stay gross with them included (engine.outliers); else
            # iterate over all points, which fits with them.
            ok = np.array_equal(keep_m, keep)
            if ok and not keep.all():
                gross = _gross_included(X_m, moved, zone_width, floor)
                ok = gross is not None and bool(np.all(gross[~keep]))
            if ok:
                fit = dataclasses.replace(
                    fit, T_nominal_measured=apply_update(fit.T_nominal_measured, delta, c),
                    deviations=moved, rule=rule_m)
                finished = True
    if not finished:
        fit = _confirmed_rounds(nominal, measured, fit, settings, zone_width, floor, budget)
        total += fit.iterations
    return fit, total


def _given_up(nominal: Nominal, measured: np.ndarray, watch: Watch, subset: bool,
              zone_width: float | None, floor: float, iterations: int) -> PoseFit:
    """The fit the ``watch`` gave up: at the best pose it saw, not converged, its deviations
    evaluated again on every point of ``measured`` when it watched a ``subset`` of them."""
    assert watch.best is not None
    _, T, dev, dev_s = watch.best
    return pose_as_it_is(nominal, measured, T, zone_width, floor, iterations,
                         "given up: it scored no better than where it started, and well behind "
                         "the best pose", None if subset else dev, dev_s)


def pose_as_it_is(nominal: Nominal, measured: np.ndarray, T: np.ndarray,
                  zone_width: float | None, floor: float, iterations: int, message: str,
                  dev: Deviations | None = None, dev_s: float = 0.0) -> PoseFit:
    """The pose T of the points ``measured`` as it is, in the form of point_to_surface_fit's
    result, not converged: its deviations (``dev`` when known, whose evaluation took ``dev_s``
    seconds) and the points the gross-outlier rule (floor ``floor``, mm) keeps."""
    if dev is None:
        t0 = time.perf_counter()
        dev = point_to_surface(nominal, apply_transform(T, measured))
        dev_s = time.perf_counter() - t0
    rule = gross_rule(dev.signed, zone_width, floor)
    return PoseFit(T, False, iterations, ~gross_outliers(dev.signed, dev.foot, rule), rule, dev,
                   dev_s, message)


def gross_floor(nominal: Nominal, settings: RegistrationSettings,
                 zone_width: float | None) -> float:
    """The gross-outlier threshold's floor, mm."""
    fraction = settings.outlier_floor if zone_width is not None else \
        settings.gross_floor_without_zone
    return fraction * nominal.diagonal


def _confirmed_rounds(nominal, pts, start, settings, zone_width, floor, budget,
                      watch=None) -> PoseFit:
    """Least squares over every point of ``pts`` but the gross outliers, a point left out only
    if it is gross with it included too (engine.outliers.fit_without_gross): _least_squares_rounds
    once, and when it leaves points out, the rule at the least-squares pose over every point (the
    probe: one linear step when that suffices, else at most ``INCLUDED_FIT_ITERATIONS``
    iterations), and then _least_squares_rounds again. Same arguments and result as
    _least_squares_rounds' fit (iterations: of every fit run; ``budget`` for all)."""
    used = 0

    def fit(start, included, cap=None):
        nonlocal used
        left = budget - used if cap is None else min(budget - used, cap)
        out, gross = _least_squares_rounds(nominal, pts, start, settings, zone_width, floor,
                                           left, included, watch)
        used += out.iterations
        return out, gross, out

    def probe(start):
        nonlocal used
        # Every point included usually moves the pose so little that the deviations can
        # follow to first order: no new evaluation (mis-probes among many points). Only which
        # points are gross there is used: the final fit is a real one.
        gross = _gross_included(apply_transform(start.T_nominal_measured, pts),
                                start.deviations, zone_width, floor)
        used += 1
        if gross is not None:
            return start, gross
        return fit(start, np.zeros(len(pts), bool), INCLUDED_FIT_ITERATIONS)[:2]

    (_, _, out), _ = fit_without_gross(fit, start, pts.shape[0], probe)
    return dataclasses.replace(out, converged=out.converged and used <= budget, iterations=used)


def _least_squares_rounds(nominal, pts, start, settings, zone_width, floor, budget,
                          included=None, watch=None) -> tuple[PoseFit, np.ndarray]:
    """Least squares over the points of ``pts`` the gross-outlier rule keeps at the pose of
    ``start`` (a fit whose deviations are those of ``pts`` at its pose; ``floor``: the rule's
    floor, mm), the rule applied again
    at each new optimum until the kept set is stable (at most ``MAX_ROUNDS`` fits and ``budget``
    Gauss-Newton iterations in all). included : (m,) bool, only these may be left out (None:
    any; all False: plain least squares over every point). ``watch`` (:class:`Watch`): no more
    fits once it has given the finish up. Returns the fit and (m,) bool, the points gross by the
    rule alone at its pose."""
    T, dev, dev_s = start.T_nominal_measured, start.deviations, start.deviation_s
    total, converged = 0, False
    keep = np.zeros(0, bool)  # none kept yet (the first round never stops: not converged)
    for _ in range(MAX_ROUNDS):
        rule = gross_rule(dev.signed, zone_width, floor)
        gross = _gross(dev, rule, included)
        new = ~gross if included is None else ~(gross & included)
        if converged and np.array_equal(new, keep):
            break
        keep = new
        if total >= budget or (watch is not None and watch.gave_up):
            converged = False
            break
        step = _gauss_newton(nominal, pts, T, settings, keep, floor, budget - total, dev, dev_s,
                             watch)
        T, converged, dev, dev_s = (step.T_nominal_measured, step.converged, step.deviations,
                                    step.deviation_s)
        total += step.iterations
    else:
        # The last fit's set is the one its pose was fitted on; the rule at that pose may
        # differ by a point at the threshold (the fit is reported as not settled then).
        rule = gross_rule(dev.signed, zone_width, floor)
        gross = _gross(dev, rule, included)
        if not np.array_equal(~gross if included is None else ~(gross & included), keep):
            converged = False
    if included is not None and not included.any():
        gross = gross_outliers(dev.signed, dev.foot, rule)
    return PoseFit(T, converged, total, keep, rule, dev, dev_s), gross


def _gross(dev, rule, included):
    """The rule's gross outliers at ``dev`` (none looked for where ``included`` is all False)."""
    if included is not None and not included.any():
        return np.zeros(dev.signed.size, bool)
    return gross_outliers(dev.signed, dev.foot, rule)


def _moved(dev: Deviations, X: np.ndarray, delta: np.ndarray, c: np.ndarray):
    """The deviations ``dev`` of the points ``X`` (n, 3) after the small step ``delta`` about
    ``c`` (from gauss_newton_step), to first order (exact to ~step^2 x curvature), and the moved
    points."""
    motion = np.cross(delta[:3], X - c) + delta[3:]
    along = np.einsum("ij,ij->i", motion, dev.normal)
    return Deviations(dev.signed + along, dev.foot + motion - along[:, None] * dev.normal,
                      dev.normal, dev.curved), X + motion


LINEAR_INCLUDED = 0.1
"""The fit over every point that decides which points stay gross with them included is one
linear step when that step moves no point by more than this fraction of the gross threshold."""


def _gross_included(X: np.ndarray, dev: Deviations, zone_width, floor):
    """(n,) bool: the points of ``X`` (n, 3), deviations ``dev``, gross at the least-squares pose
    over all of them, when one linear step reaches it; None when the step is too long to trust
    (then iterate instead).

    The step moves no point by more than m <= LINEAR_INCLUDED x the gross threshold; a distance
    changes by no more than the point moves, so the deviations followed to first order are
    within 2 m of the true ones whatever the nominal's shape (an edge crossed, a kink): a point
    counts as gross only beyond the threshold + 2 m."""
    delta, c = gauss_newton_step(X, dev.normal, dev.signed)
    moved, _ = _moved(dev, X, delta, c)
    rule = gross_rule(moved.signed, zone_width, floor)
    m = _largest_motion(delta, X - c)
    if m > LINEAR_INCLUDED * rule.threshold_mm:
        return None
    return gross_outliers(moved.signed, moved.foot,
                          dataclasses.replace(rule, threshold_mm=rule.threshold_mm + 2.0 * m))


def _largest_motion(delta: np.ndarray, rel: np.ndarray) -> float:
    """Largest displacement (mm) a small step moves any of the points ``rel`` (about its centre)."""
    reach = float(np.sqrt(np.max(np.einsum("ij,ij->i", rel, rel)))) if rel.size else 0.0
    return float(np.linalg.norm(delta[:3]) * reach + np.linalg.norm(delta[3:]))


def _gauss_newton(nominal, pts, T, settings, use, floor, max_iter, dev=None,
                  dev_s=0.0, watch=None) -> RobustFit:
    """Iterate the linearised point-to-surface least squares on ``pts`` (m, 3) from pose ``T``.

    use : (m,) bool, the fixed set of points fitted (the iteration converges to the
    least-squares optimum over them); None: the robust cut (``outlier_sigmas`` robust standard
    deviations, at least ``floor`` mm) re-estimated at every iteration (the coarse iterations
    only). Converged when a step would move no fitted point by more than ``convergence_mm``;
    that last step is not applied, so the returned deviations belong to the returned pose.
    ``dev`` (and the seconds ``dev_s`` it took): the deviations at ``T`` when known already.
    ``watch`` (:class:`Watch`) sees every pose evaluated (and each one a shortened step
    lands on; not the shortened steps tried); the fit stops, not converged, when it gives the
    finish up. Returns the fit (its inlier: the points fitted).
    """
    mask = use
    for it in range(1, max_iter + 1):
        report(f"point-to-surface fit on {pts.shape[0]:,} points, iteration {it}",
               0.85 + 0.1 * it / max(max_iter, 10))
        X = apply_transform(T, pts)
        seen = dev is None
        if dev is None:
            t0 = time.perf_counter()
            dev = point_to_surface(nominal, X)
            dev_s = time.perf_counter() - t0
        d = dev.signed
        if use is None:
            mask = np.abs(d) <= robust_cut(d, settings.outlier_sigmas, floor)
        if seen and watch is not None and watch.sees(T, dev, dev_s):
            return RobustFit(T, False, it, mask, dev, dev_s)
        if mask.sum() < 6:
            return RobustFit(T, False, it, mask, dev, dev_s)
        delta, c = gauss_newton_step(X[mask], dev.normal[mask], d[mask])
        moved = _largest_motion(delta, X[mask] - c)
        if moved < settings.convergence_mm:
            return RobustFit(T, True, it, mask, dev, dev_s)
        if use is None or settings.noise_mm is None:
            # Full steps: the robust cut moves with the pose (no one sum of squares to lower),
            # and a measurement at a CMM's noise converges by them.
            T, dev = apply_update(T, delta, c), None
            continue
        lower = _lower_along(nominal, pts, T, delta, c, mask, d)
        if lower is None:
            # No fraction of the step lowers the sum of squares: at a measurement's noise of
            # millimetres feet flip between faces at an edge or between a thin wall's two
            # sides, and full steps would cycle (a 3D camera's points, 5 mm of noise about a
            # moulded housing: 1-2 mm steps, back and forth, 50 iterations). The pose is the
            # optimum along the step to within the shortest one tried.
            return RobustFit(T, moved / SHORTEN ** SHORTENINGS
                             <= STALL_OF_NOISE * settings.noise_mm, it, mask, dev, dev_s)
        T, dev, dev_s = lower
        if watch is not None and watch.sees(T, dev, dev_s):
            return RobustFit(T, False, it, mask, dev, dev_s)
    if dev is None:
        t0 = time.perf_counter()
        dev = point_to_surface(nominal, apply_transform(T, pts))
        dev_s = time.perf_counter() - t0
        if watch is not None:
            watch.sees(T, dev, dev_s)
    if use is None:
        mask = np.abs(dev.signed) <= robust_cut(dev.signed, settings.outlier_sigmas, floor)
    return RobustFit(T, False, max_iter, mask, dev, dev_s)


SHORTEN = 4
SHORTENINGS = 4
"""When the measurement's noise is known (RegistrationSettings.noise_mm: a scene's), a
Gauss-Newton step that does not lower the sum of squares is shortened ``SHORTEN``-fold at most
this many times (to 1/256 of it: each try costs an evaluation of every point) …"""
STALL_OF_NOISE = 0.01
"""… and when none of them does, the fit has settled if the shortest step tried moved no point
by more than this fraction of the noise."""


def _lower_along(nominal, pts, T, delta, c, mask, d):
    """The first of the step ``delta`` (about c) and its shortenings (``SHORTENINGS``) from pose T
    whose sum of squared deviations over ``mask`` is below that of ``d`` (the deviations at T):
    (T', Deviations at T', seconds their evaluation took); None when none is."""
    def evaluate(T_new):
        t0 = time.perf_counter()
        dev = point_to_surface(nominal, apply_transform(T_new, pts))
        return float(np.sum(dev.signed[mask] ** 2)), (dev, time.perf_counter() - t0)

    lower = lower_along(T, delta, c, float(np.sum(d[mask] ** 2)), evaluate, SHORTEN,
                        SHORTENINGS)
    return None if lower is None else (lower[0], *lower[1])


def robust_cut(d: np.ndarray, sigmas: float, floor: float) -> float:
    """Outlier cut for deviations d (mm): |median| + ``sigmas`` x 1.4826 x median absolute
    deviation, never below ``floor``. Shared by the 3D and 2D fits."""
    med, sigma = robust_centre_sigma(d)
    return float(max(abs(med) + sigmas * sigma, floor))
