"""Soft registration in the template plane: rotation + translation of measured 2D points onto a
contour template, from any start; and the plane of a planar template measured in 3D.

Same structure as the 3D engine: a global search over pose hypotheses (rotations every 10 degrees
about the centroid, the measured centroid on the contours' length-weighted centroid; and a
measured point near the centroid put on anchors along the contours with its local direction
along theirs), ICP on a dense sampling of the contours (point-to-line
against the nearest sample's tangent), then Gauss-Newton on the exact signed point-to-contour
distance. Robust cuts (6 robust sigmas) steer the coarse stages only; the final fit is plain least
squares over every point but the gross outliers of :mod:`engine.outliers` (re-applied at each new
pose until the set is stable; a point left out only if gross at the fit over every point too),
converged on the pose step, working relative to the centroid of
the fitted points, so that the pose comes out exact whatever the size and position of the
coordinates. Left-out points stay in the verdict.

A template with symmetries (a gear) has several equally good poses; any of them gives the same
deviations. The result says so when the runner-up pose maps the template onto itself; every pose
of that symmetry is then refitted briefly, since a drawn gear is rarely exactly symmetric and the
points may fit one tooth's pose better than the others.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np
from scipy.spatial import cKDTree

from .contour import ContourIndex, Deviations2D, deviations_2d
from .neighbours import query
from .outliers import INCLUDED_FIT_ITERATIONS, fit_without_gross, gross_outliers, gross_rule
from .progress import report
from .pose import (apply_transform, apply_update, compose_updates, gauss_newton_step,
                   min_norm_solve, pose_2d, pose_jacobian, rotation_2d)
from .registration_types import CONTOUR_RMS, PoseFit, RegistrationResult, RobustFit
from .seeds import DEFAULT_SEED, rng
from .surface_fit import robust_cut

SPREAD_SEED = 11
"""The random stream of the 2D registration's seeded subsets of the points (engine.seeds)."""
GROSS_FLOOR = 1e-4
"""The gross-outlier rule's floor, as a fraction of the template's diagonal (as in 3D)."""
RULE_ROUNDS = 4
"""The final fit re-applies the gross-outlier rule at each new pose; after this many changes of
the left-out set, the set is kept as it is and only the pose is converged."""
STEP_TOL = 1e-10
"""The final fit has converged when its pose step moves no point by more than this fraction of
the coordinates' size (some 1e6 times the float resolution of the coordinates, 0.03 um at 3e5 mm)
plus 1e-4 of the RMS of the deviations (a step that changes the sum of squares by at most 1e-8
of itself)."""


class _Samples:
    """Dense samples of the contours with their unit tangents (for ICP pairing)."""

    def __init__(self, index: ContourIndex):
        t = index.t
        pts = index.tree.data
        owner = index.owner
        seg = t.kind[owner] == 0
        tan = np.empty_like(pts)
        d = t.end[owner] - t.start[owner]
        tan[seg] = d[seg]
        rad = pts - t.centre[owner]
        tan[~seg] = np.column_stack([-rad[~seg, 1], rad[~seg, 0]]) * np.sign(t.sweep[owner][~seg])[:, None]
        tan /= np.maximum(np.linalg.norm(tan, axis=1, keepdims=True), 1e-300)
        self.pts, self.tan, self.tree = pts, tan, index.tree
        self.normal = np.column_stack([-tan[:, 1], tan[:, 0]])
        self.spacing = index.spacing

    def coarse(self, m: int) -> "_Samples":
        """Every k-th sample (about m of them) with its own kd-tree: the global search's points
        are often far from the contour, where a dense tree makes each query expensive."""
        k = max(1, len(self.pts) // m)
        out = object.__new__(_Samples)
        out.pts, out.tan, out.normal = self.pts[::k], self.tan[::k], self.normal[::k]
        out.tree = cKDTree(out.pts) if k > 1 else self.tree
        out.spacing = self.spacing * k
        return out


def register_2d(index: ContourIndex, measured: np.ndarray, n_angles: int = 36,
                max_anchors: int = 400, outlier_sigmas: float = 6.0,
                max_iterations: int = 50, zone_width: float | None = None,
                seed: int = DEFAULT_SEED) -> RegistrationResult:
    """Find the 2D pose of measured points (n, 2) on the template of ``index``.

    outlier_sigmas : the robust cut of the coarse stages; zone_width : the tolerance zone's
    width (mm), for the gross-outlier rule of the final fit (None: not known); seed : the
    inspection's, of every seeded subset of the points (engine.seeds)."""
    p = np.asarray(measured, float)
    S = _Samples(index)
    extent_t = float(np.linalg.norm(np.ptp(S.pts, axis=0)))
    extent_m = float(np.linalg.norm(np.ptp(p, axis=0)))
    h = S.spacing
    T, n_hyp = _candidates(index, S, p, n_angles, max_anchors, outlier_sigmas, extent_t, extent_m,
                           seed)
    # Exact point-to-contour Gauss-Newton with a robust cut: a few steps for the best three (on
    # a subset of the points), the best of them to convergence; then the final least squares,
    # on the subset first (cheap), then over every point.
    near = 0.01 * extent_t
    fsub = _spread(p, 4096, seed)
    # (A single clear candidate needs no short round.)
    short = [_gauss_newton2(index, p[fsub], Tc, outlier_sigmas, 5 if len(T) > 1 else 0, h)
             for Tc in T[:3]]
    cut0 = min(_cut(f) for f in short)
    scores = [float(np.sqrt(np.mean(np.minimum(f.deviations.signed ** 2, cut0 ** 2))))
              for f in short]
    best = int(np.argmin(scores))
    long = _gauss_newton2(index, p[fsub], short[best].T_nominal_measured, outlier_sigmas,
                          max_iterations, h)
    Tb, it = long.T_nominal_measured, long.iterations
    floor = GROSS_FLOOR * max(extent_t, 1e-12)
    tol = STEP_TOL * max(extent_t, float(np.max(np.abs(index.tree.data))), 1.0)

    def final(Tc, pts):
        return _least_squares(index, pts, Tc, zone_width, floor, tol, max_iterations)

    fit = final(Tb, p[fsub])
    Tb, it = fit.T_nominal_measured, it + fit.iterations
    score = float(np.sqrt(np.mean(np.minimum(fit.deviations.signed ** 2, cut0 ** 2))))
    runner = next((int(j) for j in np.argsort(scores, kind="stable") if j != best
                   and _distinct(short[j].T_nominal_measured, Tb, p[fsub],
                                 0.01 * max(extent_m, 1e-12))), None)
    symmetric = False
    if runner is not None and scores[runner] <= 1.05 * score + 0.1 * h:
        # Does the relative transform map the template onto itself?
        rel = short[runner].T_nominal_measured @ np.linalg.inv(Tb)
        symmetric = _maps_onto_itself(rel, S, h)
        refit = _symmetric_pose(index, S, p[fsub], rel, Tb, outlier_sigmas, cut0, floor, seed) \
            if symmetric else None
        if refit is not None:
            fit = final(refit, p[fsub])
            Tb, it = fit.T_nominal_measured, it + fit.iterations
            score = float(np.sqrt(np.mean(np.minimum(fit.deviations.signed ** 2, cut0 ** 2))))
    if fsub.size < p.shape[0]:
        fit = final(Tb, p)
        it += fit.iterations
    message = "" if fit.converged else (f"the point-to-contour fit did not settle within "
                                        f"{max_iterations} iterations")
    return RegistrationResult.from_fit(
        fit.T_nominal_measured, fit.deviations, fit.inlier, fit.rule, near,
        converged=fit.converged, iterations=5 + 6 + 8 + it, score=score, hypotheses=n_hyp,
        runner_up_score=None if runner is None else scores[runner],
        runner_up_T=None if runner is None else short[runner].T_nominal_measured,
        message=message,
        rms_definition=CONTOUR_RMS, symmetric=symmetric)


def _candidates(index: ContourIndex, S: "_Samples", p: np.ndarray, n_angles: int,
                max_anchors: int, outlier_sigmas: float, extent_t: float, extent_m: float,
                seed: int):
    """(T (k, 3, 3), n_hypotheses): the candidate poses of the measured points p (n, 2) on the
    template, best first, after the global search and ICP on the contour samples."""
    cm = p.mean(axis=0)
    sub = _spread(p, 48, seed)
    hyps = []
    # Rotations about the centroid, centroid on the template's centroid.
    ct = index.centroid
    for th in np.linspace(0, 2 * np.pi, n_angles, endpoint=False):
        hyps.append(pose_2d(th, ct - rotation_2d(th) @ cm))
    # The point nearest the centroid onto anchors along the contours, direction along theirs:
    # an anchor every 5% of the measured extent (so one lands near the right place however
    # little of the contour was measured), at most max_anchors.
    p0, d0 = _reference(p, seed)
    per_anchor = max(0.05 * extent_m / max(S.spacing, 1e-12), 1.0)
    step = max(1, int(per_anchor), len(S.pts) // max_anchors)
    for k in range(0, len(S.pts), step):
        base = np.arctan2(S.tan[k, 1], S.tan[k, 0]) - np.arctan2(d0[1], d0[0])
        for th in (base, base + np.pi):
            hyps.append(pose_2d(th, S.pts[k] - rotation_2d(th) @ p0))
    T = np.array(hyps)
    n_hyp = T.shape[0]
    Sc = S.coarse(1000)
    report(f"global search over {n_hyp} poses", 0.1)
    T, score = _icp2(T, p[sub[_spread(p[sub], 24, seed)]], Sc, iterations=5)
    T = _best_distinct(T, score, p[sub], 24, 0.01 * max(extent_m, 1e-12))
    report(f"global search, best {T.shape[0]} poses", 0.35)
    T, score = _icp2(T, p[sub], Sc, iterations=6)
    T = _best_distinct(T, score, p[sub], 12, 0.01 * max(extent_m, 1e-12))
    report("ICP on the full contour samples", 0.55)
    T, score = _icp2(T, p[_spread(p, 256, seed)], S, iterations=8)
    T_icp = T
    report("point-to-contour fit", 0.75)
    order = np.argsort(score, kind="stable")
    # Candidates clearly worse than the best (4x its score, beyond the sampling noise) are not
    # worth exact fits; close ones are (they may be the same fit elsewhere: a symmetry).
    keep = score[order] <= 4.0 * score[order[0]] + (0.1 * S.spacing) ** 2
    T = T[order][keep]
    if np.sqrt(score[order[0]]) > 0.1 * S.spacing and order.size > 3:
        # No pose fits within the sampling (a few contours measured out of many, far apart):
        # ICP's ranking means little; rank every candidate by a few exact steps instead.
        floor0 = 1e-6 * max(extent_t, 1e-12)
        T, xs = _short_fits(index, p[_spread(p, 256, seed)], T_icp[order], outlier_sigmas,
                            S.spacing, floor0, 3)
        T = T[np.argsort(xs, kind="stable")]
    return T, n_hyp


def _symmetric_pose(index: ContourIndex, S: "_Samples", q: np.ndarray, rel: np.ndarray,
                    Tb: np.ndarray, outlier_sigmas: float, cut: float, floor: float,
                    seed: int):
    """A drawing is rarely exactly symmetric: of all the poses the symmetry ``rel`` (3, 3,
    template frame) gives from ``Tb`` (a gear's every tooth), the points q (m, 2) may fit one
    better. Each is refitted briefly; the pose that halves the fitted one's score, or None."""
    group = _symmetry_group(rel, S, S.spacing)
    if not group:
        return None
    msub = _spread(q, 256, seed)
    alt, alt_scores = _short_fits(index, q[msub], np.array([np.eye(3)] + group) @ Tb,
                                  outlier_sigmas, cut, floor, 3)
    k = int(np.argmin(alt_scores))
    return alt[k] if alt_scores[k] < 0.5 * alt_scores[0] else None


def _maps_onto_itself(U: np.ndarray, S: _Samples, h: float) -> bool:
    """Whether the 2D transform U (3, 3, template frame) maps the contour samples onto the
    contours, within twice their spacing ``h``."""
    dist, _ = S.tree.query(apply_transform(U, S.pts[:: max(1, len(S.pts) // 2000)]))
    return bool(np.max(dist) <= 2 * h)


def _symmetry_group(rel: np.ndarray, S: _Samples, h: float, max_order: int = 360) -> list:
    """The rotations (3, 3, template frame) of the cyclic symmetry that ``rel`` (a rotation
    mapping the template onto itself) belongs to, identity excluded: its smallest step is
    rel's angle divided by the largest m <= 12 for which that rotation still maps the template
    onto itself. Empty for a translation or an order above ``max_order``."""
    phi = float(np.arctan2(rel[1, 0], rel[0, 0]))
    if abs(phi) < 1e-6:
        return []
    c = np.linalg.solve(np.eye(2) - rel[:2, :2], rel[:2, 2])  # the fixed point

    def about_c(a):
        return pose_2d(a, c - rotation_2d(a) @ c)

    m = max([k for k in range(1, 13) if k == 1 or _maps_onto_itself(about_c(phi / k), S, h)])
    n = int(round(2 * np.pi / abs(phi / m)))
    if not 2 <= n <= max_order:
        return []
    return [about_c(2 * np.pi * k / n) for k in range(1, n)]


def _short_fits(index: ContourIndex, p: np.ndarray, T: np.ndarray, sigmas: float,
                cut0: float, floor: float, iterations: int):
    """A few robust Gauss-Newton steps for H poses T (H, 3, 3) at once over the points p (m, 2)
    (one nearest-contour query per step for all poses); returns (poses, truncated RMS scores
    sqrt(mean(min(d^2, cut0^2))) at them)."""
    H, m = T.shape[0], p.shape[0]
    for it in range(iterations + 1):
        X = apply_transform(T, p).reshape(-1, 2)
        dev = deviations_2d(index, X)
        d = dev.signed.reshape(H, m)
        if it == iterations:
            break
        g = _gradient(X, dev.foot, dev.signed).reshape(H, m, 2)
        Xh = X.reshape(H, m, 2)  # per pose
        w = np.array([np.abs(dk) <= robust_cut(dk, sigmas, floor) for dk in d], float)
        c = (w[..., None] * Xh).sum(1) / np.maximum(w.sum(1), 1)[:, None]
        xt = Xh - c[:, None, :]
        J = pose_jacobian(Xh, g, c[:, None, :])
        Jw = J * w[..., None]
        length = np.sqrt((w * np.sum(xt * xt, axis=2)).sum(1) / np.maximum(w.sum(1), 1.0))
        delta = -min_norm_solve(Jw.transpose(0, 2, 1) @ J, (Jw * d[..., None]).sum(1), 1,
                                length)
        T = compose_updates(T, delta, c)
    return T, np.sqrt(np.mean(np.minimum(d * d, cut0 * cut0), axis=1))


def _spread(p: np.ndarray, m: int, seed: int) -> np.ndarray:
    """Indices of a seeded random choice of at most ``m`` of the points p (n, 2), sorted."""
    if p.shape[0] <= m:
        return np.arange(p.shape[0])
    return np.sort(rng(seed, SPREAD_SEED).choice(p.shape[0], m, replace=False))


def _reference(p: np.ndarray, seed: int):
    """A measured point near the centroid and the local direction of its neighbours: of the 16
    points nearest the centroid, the one whose 6 nearest neighbours lie most nearly on a line
    (at a corner, or where neighbours belong to different contours, the direction means
    nothing)."""
    q = p[_spread(p, 4096, seed)]
    k = min(6, q.shape[0])
    tree = cKDTree(q)
    _, near = tree.query(q.mean(axis=0), k=min(16, q.shape[0]))
    near = np.atleast_1d(near)
    _, nb = tree.query(q[near], k=k)
    nb = nb.reshape(near.size, k)
    c = q[nb] - q[nb].mean(axis=1, keepdims=True)
    w, vecs = np.linalg.eigh(np.einsum("mki,mkj->mij", c, c))
    # Thickness across the line over length along it; the nearest to the centroid on ties.
    flat = np.sqrt(np.maximum(w[:, 0], 0.0)) / np.maximum(np.sqrt(w[:, 1]), 1e-300)
    j = int(np.argmin(np.round(flat, 2)))
    return q[near[j]], vecs[j, :, -1]


def _icp2(T: np.ndarray, src: np.ndarray, S: _Samples, iterations: int):
    """Batched point-to-line ICP in 2D for H poses; returns (poses, trimmed scores)."""
    H, m = T.shape[0], src.shape[0]
    score = np.zeros(H)
    for _ in range(iterations):
        X = apply_transform(T, src)
        _, j = query(S.tree, X.reshape(-1, 2))
        j = j.reshape(H, m)
        r = X - S.pts[j]
        n = S.normal[j]
        rn = np.sum(r * n, axis=2)
        e2 = rn * rn
        k = max(1, int(0.75 * m))
        score = np.mean(np.partition(e2, k - 1, axis=1)[:, :k], axis=1)
        tau2 = np.maximum(9 * S.spacing ** 2, 6.25 * np.median(e2, axis=1))
        w = (e2 <= tau2[:, None]).astype(float)
        c = (w[..., None] * X).sum(1) / np.maximum(w.sum(1), 1)[:, None]
        xt = X - c[:, None, :]
        J = pose_jacobian(X, n, c[:, None, :])
        Jw = J * w[..., None]
        A = Jw.transpose(0, 2, 1) @ J
        b = (Jw * rn[..., None]).sum(1)
        length = np.sqrt((w * np.sum(xt * xt, axis=2)).sum(1) / np.maximum(w.sum(1), 1.0))
        delta = -min_norm_solve(A, b, 1, length)
        T = compose_updates(T, delta, c)
    return T, score


def _best_distinct(T, score, src, keep, tol):
    order = np.argsort(score, kind="stable")
    feat = np.einsum("hij,mj->hmi", T[:, :2, :2], src[:4]) + T[:, None, :2, 2]
    kept = []
    for i in order:
        if kept and np.min(np.max(np.linalg.norm(feat[kept] - feat[i][None], axis=2), axis=1)) <= tol:
            continue
        kept.append(int(i))
        if len(kept) >= keep:
            break
    return T[kept]


def _distinct(T1, T2, p, tol) -> bool:
    return float(np.max(np.linalg.norm(apply_transform(T1, p) - apply_transform(T2, p), axis=1))) > tol


def _least_squares(index: ContourIndex, p: np.ndarray, T: np.ndarray,
                   zone_width: float | None, floor: float, tol: float, max_iter: int) -> PoseFit:
    """The final fit: Gauss-Newton on the exact signed point-to-contour distance over every
    point of ``p`` (n, 2) but the gross outliers, from pose ``T``; a point is left out only if
    it is gross with it included too (engine.outliers.fit_without_gross: when _rounds2 leaves
    points out, least squares over every point, then _rounds2 again with only the points gross
    there allowed out). Returns the fit (iterations: of every fit run)."""
    used = 0

    def fit(T0, included):
        nonlocal used
        everything = included is not None and not included.any()
        out, gross = _rounds2(index, p, T0, zone_width, floor, tol,
                              min(max_iter, INCLUDED_FIT_ITERATIONS) if everything else max_iter,
                              included)
        used += out.iterations
        return out.T_nominal_measured, gross, out

    (_, _, out), _ = fit_without_gross(fit, T, p.shape[0])
    return replace(out, iterations=used)


def _rounds2(index: ContourIndex, p: np.ndarray, T: np.ndarray, zone_width: float | None,
             floor: float, tol: float, max_iter: int,
             included: np.ndarray | None) -> tuple[PoseFit, np.ndarray | None]:
    """Gauss-Newton on the exact signed point-to-contour distance over every point of ``p``
    (n, 2) but the gross outliers (only those True in ``included`` (n,) when given; all False:
    plain least squares over every point), from pose ``T``.

    At each pose the gross-outlier rule is applied again (until the left-out set has changed
    RULE_ROUNDS times); the fit has converged when the step over the points the rule keeps at
    this pose moves no point by more than ``tol`` + 1e-4 RMS (mm), or has stopped shrinking
    below 10 ``tol`` (rounding): the pose is then the least-squares optimum over them, and they
    are the rule's set at it. Each step is solved about the centroid of the fitted
    points, so its size does not depend on where the coordinates lie. The deviations returned
    are exact at the returned pose.

    Returns the fit and (n,) bool, the points gross by the rule alone at its pose (None when
    only some may be left out: not asked for).
    """
    everything = included is not None and not included.any()

    def rule_at(dev):
        rule = gross_rule(dev.signed, zone_width, floor)
        if everything:
            return rule, np.zeros(dev.signed.size, bool)
        gross = gross_outliers(dev.signed, dev.foot, rule)
        return rule, gross if included is None else gross & included

    changes = 0
    kept = None
    last = np.inf
    result = None
    for it in range(1, max_iter + 1):
        X = apply_transform(T, p)
        dev = deviations_2d(index, X)
        d = dev.signed
        # The set is the rule's at this very pose (until it has changed RULE_ROUNDS times).
        if changes <= RULE_ROUNDS or kept is None:
            rule, out = rule_at(dev)
            if kept is not None and not np.array_equal(~out, kept):
                changes += 1
            kept = ~out
        if kept.sum() < 3:
            result = PoseFit(T, False, it, kept, rule, dev)
            break
        delta, c, moved = _gn_step2(X, dev, kept)
        dk = d[kept]
        # Converged: the step is negligible, or it has stopped shrinking at a size that only
        # rounding can explain (Gauss-Newton steps shrink fast until they reach that floor).
        if (moved <= tol + 1e-4 * float(np.sqrt(np.mean(dk * dk)))
                or (moved <= 10.0 * tol and moved >= 0.5 * last)):
            result = PoseFit(T, True, it, kept, rule, dev)
            break
        last = moved
        T = apply_update(T, delta, c)
    if result is None:
        dev = deviations_2d(index, apply_transform(T, p))
        if changes <= RULE_ROUNDS or kept is None:
            rule, out = rule_at(dev)
            kept = ~out
        result = PoseFit(T, False, max_iter, kept, rule, dev)
    if everything:
        gross = gross_outliers(result.deviations.signed, result.deviations.foot, result.rule)
    elif included is None:
        gross = ~result.inlier
    else:
        gross = None  # not asked for
    return result, gross


def _gn_step2(X: np.ndarray, dev: Deviations2D, use: np.ndarray):
    """One Gauss-Newton step of the pose on the exact signed distances of points ``X[use]``
    (registered, (n, 2)), solved about their centroid c: returns (step [angle, tx, ty], c, the
    largest motion the step gives any of them, mm)."""
    Xk, gk, dk = X[use], _gradient(X[use], dev.foot[use], dev.signed[use]), dev.signed[use]
    delta, c = gauss_newton_step(Xk, gk, dk)
    xt = Xk - c
    reach = float(np.sqrt(np.max(np.sum(xt * xt, axis=1)))) if xt.size else 0.0
    return delta, c, abs(delta[0]) * reach + float(np.linalg.norm(delta[1:]))


def _gradient(X: np.ndarray, foot: np.ndarray, d: np.ndarray) -> np.ndarray:
    """Unit gradient of the signed distance: from the foot to the point, signed like d."""
    g = X - foot
    ln = np.linalg.norm(g, axis=1)
    return g / np.where(ln > 0, ln, 1.0)[:, None] * np.sign(np.where(d == 0, 1.0, d))[:, None]


def _cut(fit: RobustFit) -> float:
    """The robust cut of a 2D fit (mm), which :func:`_gauss_newton2` always sets."""
    if fit.cut is None:
        raise ValueError("a 2D robust fit without its cut")
    return fit.cut


def _gauss_newton2(index: ContourIndex, p: np.ndarray, T: np.ndarray, sigmas: float,
                   max_iter: int, h: float) -> RobustFit:
    """Least squares on the exact signed point-to-contour distance over the robust inliers.

    Returns the fit, with its robust cut (mm).
    """
    floor = 1e-6 * max(float(np.linalg.norm(np.ptp(index.tree.data, axis=0))), 1e-12)
    inlier = None
    cut = np.inf
    for it in range(1, max_iter + 1):
        X = apply_transform(T, p)
        dev = deviations_2d(index, X)
        d = dev.signed
        if inlier is None or it <= 3:
            cut = robust_cut(d, sigmas, floor)
            inlier = np.abs(d) <= cut
        if inlier.sum() < 3:
            return RobustFit(T, False, it, inlier, dev, cut=cut)
        delta, c, moved = _gn_step2(X, dev, inlier)
        if moved < 1e-7:
            return RobustFit(T, True, it, inlier, dev, cut=cut)
        T = apply_update(T, delta, c)
    X = apply_transform(T, p)
    dev = deviations_2d(index, X)
    if inlier is None:  # no iteration asked for: just measure, with the robust cut
        cut = robust_cut(dev.signed, sigmas, floor)
    return RobustFit(T, False, max_iter, np.abs(dev.signed) <= cut, dev, cut=cut)


@dataclass(frozen=True)
class PlaneFrame:
    """A plane fitted to 3D points: origin, in-plane axes u, v and normal w (rows of R).

    to_plane(p) gives (n, 3) coordinates (u, v, w): w is the out-of-plane residual.
    flatness : peak-to-valley of w (mm); rms_w : its RMS.
    """

    origin: np.ndarray
    R: np.ndarray
    flatness: float
    rms_w: float

    def to_plane(self, p: np.ndarray) -> np.ndarray:
        return (p - self.origin) @ self.R.T


def fit_plane(p: np.ndarray) -> PlaneFrame:
    """Least-squares plane through 3D points (n, 3)."""
    o = p.mean(axis=0)
    _, s, vt = np.linalg.svd(p - o, full_matrices=False)
    R = vt.copy()
    if np.linalg.det(R) < 0:
        R[2] *= -1
    w = (p - o) @ R[2]
    return PlaneFrame(o, R, float(np.ptp(w)), float(np.sqrt(np.mean(w * w))))
