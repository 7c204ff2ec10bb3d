"""Soft registration: the rigid pose of the measured points in the nominal frame, from any start.

The method is the paper's modified ICP (section 4) with a global stage in front of it:

1. **Global search.** Pose hypotheses are the principal-axes alignments (the four proper sign
   combinations), an even spread of rotations over SO(3) placed at the centroid and at a few
   anchors, and -- what carries partial coverage -- the measured surface normal turned onto the
   nominal normal at anchors spread over the whole nominal, at 18 spins. Every hypothesis runs a
   few ICP iterations on a coarse sample of the nominal, paired point-to-quadric (each sample
   carries its local curvature, so a coarse sample still scores close fits correctly); poses
   that arrive at the same place merge and only the best distinct ones go on. These some
   10^5 pairings are compiled (kernels.icp_poses) and find their sample in constant time
   (neighbours.SampleLookup: the owner of the point's grid cell, then a walk to nearer
   neighbours), not by a kd-tree query each. A pose scores the
   mean over every point of its squared distance, each point's capped at 3 sample spacings: a
   point off the part costs the same whatever the pose, and every point counts, so that a
   feature carried by a few points (a boss on a cube, whose faces fit at 24 poses) decides.
2. **Modified ICP, coarse to fine.** The surviving distinct poses are refined while the nominal
   sample is made denser level by level (x4 each level, then the full nominal), the paper's
   Fig. 4 argument: a coarse sample finds the basin cheaply, density only matters at the end.
   Each iteration is a closed-form rigid update: linearised point-to-plane (or point-to-quadric)
   least squares, with a small point-to-point term in the global stage that keeps sliding
   directions in check far from the solution.
3. **Point-to-surface finish.** The remaining candidates are compared by the score of their
   point-to-surface deviations (:func:`pose_score`: their RMS while they are small, each point
   counting by the logarithm of its distance beyond ``outlier_floor`` x the nominal's diagonal),
   so that neither a few gross outliers nor a quarter of the points fitting exactly at a wrong
   pose decide. The best gets Gauss-Newton on the signed point-to-surface deviations of
   :mod:`engine.deviation` (local facets, curvature-corrected), so that the final pose is the
   least-squares optimum of point-to-surface distance over every measured point but the gross
   outliers, not of the distance to the nearest sample. Should that finish score worse than
   another distinct candidate, the candidate is finished too and the better finished pose is
   the answer: no pose found scores better than the one reported.

The coarse stages weight robustly (trimmed pairs in the ICP updates; a robust cut of
``outlier_sigmas`` x 1.4826 x median absolute deviation, never below ``outlier_floor`` x the
nominal's diagonal, in the first ``ROBUST_ITERATIONS`` point-to-surface iterations) so that they
reach the right basin.
The final fit is plain least squares: the only points it excludes from the alignment are the
gross outliers of :mod:`engine.outliers` (a mis-probed point, far beyond any plausible deviation
of the part and isolated from its neighbours, both at the fit without it and at the fit with
every point; a dent or bump, in or out of tolerance, is never excluded). Excluded points stay in
the deviation table and the verdict.
"""

from __future__ import annotations

import os
import threading
import time
import dataclasses
from dataclasses import dataclass, replace

import numpy as np
from scipy.spatial import cKDTree

from .contour import Deviations2D
from .deviation import Deviations, point_to_surface
from . import kernels
from .neighbours import PARALLEL_QUERIES, SampleLookup, query_workers
from .pose import (apply_transform, apply_update, gauss_newton_step, make_transform,
                   rotation_angle_deg, rotation_from_rotvec, uniform_rotations)
from .nominal import Nominal
from .outliers import (INCLUDED_FIT_ITERATIONS, GrossRule, fit_without_gross, gross_outliers,
                       gross_rule, robust_centre_sigma)
from .progress import report

_SEED = 7


@dataclass(frozen=True)
class RegistrationSettings:
    """Settings of :func:`register`; the defaults need no tuning for parts from 10 mm to 5 m."""

    n_rotations: int = 24
    """Evenly spread rotations tried by the global search (plus 4 principal-axes alignments)."""
    min_anchors: int = 4
    """Anchors (spread over the nominal) where the evenly spread rotations are tried."""
    max_anchors: int = 256
    """At most this many anchors for the normal-aligned hypotheses (one per voxel of a tenth of
    the measured extent, the voxel grown until no more remain)."""
    n_spins: int = 18
    """Spins about the normal tried at each anchor by the normal-aligned hypotheses (20 degrees
    apart: the right anchor's nearest spin starts within 10 degrees of the answer; 30 degrees
    apart left a cube with a boss, whose faces fit at 24 poses, without a start that the global
    search's few ICP iterations bring home, now and then)."""
    coarse_size: int = 1000
    """Nominal points in the coarsest ICP level, at least …"""
    coarse_samples_per_area: float = 500.0
    """… and this x (nominal diagonal / measured extent)^2, at most 16 x coarse_size."""
    coarse_measured: int = 32
    """Measured points (farthest-point spread) used by the global search."""
    quadric_max_level: int = 4096
    """Levels up to this many nominal points use point-to-quadric pairing; denser ones the plane
    (their spacing makes the curvature term negligible)."""
    icp_measured: int = 4096
    """Measured points (seeded random subset) used by the ICP levels, at most."""
    fit_measured: int = 16384
    """Measured points the point-to-surface fit iterates on before its last full-set steps."""
    keep_per_level: tuple[int, ...] = (32, 8, 4, 2)
    """Distinct poses kept after the coarsest level, the next, …; the last number repeats."""
    max_final_iterations: int = 50
    """Point-to-surface Gauss-Newton iterations at most."""
    outlier_sigmas: float = 6.0
    """Robust cut of the coarse point-to-surface iterations, in robust standard deviations of
    the deviations (the final fit uses the gross-outlier rule)."""
    near_fraction_of_size: float = 0.01
    """A point lies *near* the nominal within this fraction of its bounding-box diagonal …"""
    min_near_fraction: float = 0.5
    """… and a pose is only worth fitting (and trusting) when at least this fraction of the
    measured points lies near the nominal."""
    outlier_floor: float = 1e-4
    """The robust cut, and the gross-outlier threshold when the tolerance zone is known, are never
    below this fraction of the nominal's bounding-box diagonal; it is also the scale of the
    candidates' scores (:func:`pose_score`: least squares below it, logarithmic beyond)."""
    gross_floor_without_zone: float = 1e-3
    """Without a tolerance zone (the registration used on its own), the gross-outlier threshold
    is never below this fraction of the nominal's diagonal: nothing then says what deviation is
    plausible, and a dent's slope between sparse points must not look isolated."""
    convergence_mm: float = 1e-6
    """The point-to-surface fit has converged when a step would move no point by more than this."""
    finish_step_mm: float = 0.01
    """The single all-point step after a subset fit is taken, with deviations updated to first
    order, when it moves no point by more than this (error ~ step^2 x curvature); otherwise
    iteration over all points continues."""
    finish_on_all_points: bool = True
    """After a subset fit, finish over every point (the step or iterations above). False when
    another fit finishes the pose (engine.inspection.inspect on a STEP model's exact surface):
    every point is then only evaluated and judged by the gross-outlier rule at the subset's
    pose."""


SURFACE_RMS = ("RMS of signed point-to-surface deviations over the points used by the final fit: "
               "all but those excluded from the alignment as gross outliers (mm)")
CONTOUR_RMS = ("RMS of signed point-to-contour deviations over the points the final fit used: "
               "every point but the gross outliers (mm)")


@dataclass(frozen=True)
class RegistrationResult:
    """Outcome of :func:`register` (3D) and of :func:`engine.registration2d.register_2d` (2D): one
    type for both, so the verdict, the trust statements and the outputs read either alike.

    T_nominal_measured : homogeneous transform mapping measured coordinates into the nominal
        frame: (4, 4) in 3D; in 2D (3, 3), from the measured points' plane coordinates (x, y as
        given, or in their fitted plane's frame) into the template's (``inspect_2d`` lifts it to
        (4, 4) with :meth:`lifted`).
    rms : root mean square of the signed deviations over the ``n_inliers`` points the final fit
        used (every point but the gross outliers), mm; ``rms_definition`` says it in words.
    inlier : (n,) bool, the points the final least-squares fit used: False only on the gross
        outliers of ``gross_rule``, which are excluded from the alignment (and judged).
    outlier_cut : the gross-outlier threshold (``gross_rule.threshold_mm``), mm.
    score : how well the pose fits, mm, over a seeded subset of at most 4,096 measured points
        (all of them when fewer), outliers included: in 3D :func:`pose_score` (the RMS of the
        deviations while they are small against ``outlier_floor`` x the nominal's diagonal, a
        point beyond that counting by the logarithm of its distance); in 2D the truncated RMS
        sqrt(mean(min(d^2, cut^2))) at the smallest robust cut among the candidates; lower is
        better; the same measure on the same points scores the runner-up pose.
    runner_up_score, runner_up_T : score and pose of the best pose distinct from the chosen one
        (None when the global search ended with a single distinct pose); in 3D never below
        ``score`` (engine.verdict.better_runner_up makes the verdict INCONCLUSIVE if it were).
    symmetric : the runner-up fits as well and maps the nominal onto itself, so that every
        deviation is the same at both poses (tested for 2D templates; always False in 3D, where
        weak and free directions are the concern of engine.trust).
    """

    T_nominal_measured: np.ndarray
    converged: bool
    iterations: int
    rms: float
    n_inliers: int
    inlier: np.ndarray
    outlier_cut: float
    score: float
    hypotheses: int
    runner_up_score: float | None
    runner_up_T: np.ndarray | None
    deviations: Deviations | Deviations2D
    """Signed deviations of every measured point at ``T_nominal_measured``."""
    deviation_s: float
    """Seconds the evaluation of ``deviations`` took (part of the registration's run time)."""
    near_distance: float
    """A small fraction of the nominal's size, mm (``near_fraction_of_size`` x the bounding-box
    diagonal in 3D, 1% of the template's extent in 2D)."""
    gross_rule: GrossRule
    """The gross-outlier rule at the final pose (engine.outliers): which points were excluded
    from the alignment, and why."""
    message: str = ""
    rms_definition: str = SURFACE_RMS
    symmetric: bool = False

    @property
    def near_fraction(self) -> float:
        """Fraction of all measured points within ``near_distance`` of the nominal at
        ``T_nominal_measured``: derived from ``deviations``, so that it describes the pose
        reported however often the pose is refined (a stored fraction outlived the exact fit
        that moved a STEP model's pose 11 mm: "only 24% of the points lie within 3.07 mm" with
        max |d| 0.006 mm, issue 22)."""
        d = self.deviations.signed
        return float(np.mean(np.abs(d) <= self.near_distance)) if d.size else 0.0

    @classmethod
    def from_fit(cls, T_nominal_measured: np.ndarray, deviations, inlier: np.ndarray,
                 rule: GrossRule, near_distance: float, **fields) -> "RegistrationResult":
        """The result of a final fit at ``T_nominal_measured``: rms, inlier count and outlier
        cut follow from its deviations, inliers and gross rule; ``fields`` gives
        the rest (converged, iterations, score, hypotheses, runner_up_score, runner_up_T, ...)."""
        d_in = deviations.signed[inlier]
        rms = float(np.sqrt(np.mean(d_in * d_in))) if inlier.any() else float("nan")
        fields.setdefault("deviation_s", 0.0)
        return cls(T_nominal_measured=T_nominal_measured, rms=rms, n_inliers=int(inlier.sum()),
                   inlier=inlier, outlier_cut=rule.threshold_mm, deviations=deviations,
                   near_distance=near_distance, gross_rule=rule, **fields)

    def lifted(self, F: np.ndarray, T2: np.ndarray, deviations: Deviations2D
               ) -> "RegistrationResult":
        """A 2D result in 3D: ``T_nominal_measured`` (4, 4) = the in-plane pose T2 (3, 3; the
        registered pose or a refit of it) after the plane frame F (4, 4) that carried the
        measured points into the template's plane; ``deviations`` (2D, at T2) gain a zero z
        component; the runner-up pose is lifted alike."""
        zeros = np.zeros(deviations.signed.size)
        dev = Deviations(deviations.signed, np.column_stack([deviations.foot, zeros]),
                         np.column_stack([deviations.normal, zeros]), zeros.astype(bool))
        runner = None if self.runner_up_T is None else in_plane(self.runner_up_T) @ F
        return dataclasses.replace(self, T_nominal_measured=in_plane(T2) @ F, deviations=dev,
                                   runner_up_T=runner)


def in_plane(T2: np.ndarray) -> np.ndarray:
    """The 2D homogeneous transform T2 (3, 3) as the 3D one (4, 4) that leaves z alone."""
    E = np.eye(4)
    E[:2, :2] = T2[:2, :2]
    E[:2, 3] = T2[:2, 2]
    return E


def register(nominal: Nominal, measured: np.ndarray,
             settings: RegistrationSettings = RegistrationSettings(),
             zone_width: float | None = None) -> RegistrationResult:
    """Find ``T_nominal_measured`` for measured points (n, 3) lying in any pose.

    zone_width : the tolerance zone's width, mm, when known: a gross outlier lies beyond several
    zone widths (engine.outliers); without it, the robust spread and a floor of
    ``gross_floor_without_zone`` x the nominal's diagonal decide."""
    measured = np.ascontiguousarray(measured, dtype=np.float64)
    # The coarsest level must still put a few hundred samples under the measured area.
    extent = float(np.linalg.norm(measured.max(0) - measured.min(0)))
    ratio = nominal.diagonal / max(extent, 1e-12)
    coarse = int(np.clip(settings.coarse_samples_per_area * ratio * ratio,
                         settings.coarse_size, 16 * settings.coarse_size))
    T, sub, n_hyp = _global_search(nominal, measured, coarse, settings)
    T, iters = _coarse_to_fine(nominal, measured, T, coarse, settings)
    return _final_fit(nominal, measured, list(T), sub, settings, zone_width,
                      hypotheses=n_hyp, iterations=iters)


def _global_search(nominal: Nominal, measured: np.ndarray, coarse: int,
                   settings: RegistrationSettings):
    """(T (k, 4, 4), sub, n_hypotheses): the best distinct poses of every hypothesis after ICP on
    the nominal's ``coarse`` level, and the measured subset ``sub`` (indices) they were kept on.

    Scores on a coarse sample cannot tell close fits apart (its chords are off by curvature x
    spacing^2), so several distinct poses are carried to the finer levels, where they can."""
    lvl_pts, lvl_nrm, _ = nominal.level(coarse)
    lvl_shape = nominal.level_shape(coarse)
    h0 = nominal.level_spacing(coarse)

    report("global search: pose hypotheses", 0.02)
    sub = _spread_subset(measured, settings.coarse_measured)
    T = _hypotheses(nominal, measured, lvl_pts, lvl_nrm, settings)
    n_hyp = T.shape[0]
    # Every hypothesis iterates, poses that arrive at the same place merge, and only the best
    # distinct ones go on.
    first = sub[_spread_subset(measured[sub], settings.coarse_measured // 2)]
    lookup = nominal.level_lookup(coarse)
    report(f"global search over {n_hyp} poses", 0.05)
    T, score = _icp_poses(T, measured[first], lookup, lvl_pts, lvl_nrm, lvl_shape, h0,
                          iterations=3, lam2=0.01)
    T = _best_distinct(T, score, measured[sub], settings.keep_per_level[0] * 2)
    report(f"global search, best {T.shape[0]} poses", 0.25)
    T, score = _icp_poses(T, measured[sub], lookup, lvl_pts, lvl_nrm, lvl_shape, h0,
                          iterations=6, lam2=0.01)
    return _best_distinct(T, score, measured[sub], settings.keep_per_level[0]), sub, n_hyp


def _coarse_to_fine(nominal: Nominal, measured: np.ndarray, T: np.ndarray, coarse: int,
                    settings: RegistrationSettings):
    """(T (k, 4, 4), iterations): the candidate poses refined level by level, the nominal
    sample growing x4 per level from ``coarse`` and the measured subset with it; the count
    includes the global stage's iterations."""
    size = coarse
    level = 0
    iters = 10
    finest = nominal.finest_level
    while size < finest:
        # x4 per level; past the last quadric level straight to the finest (bare points: the
        # full nominal, whose kd-tree the deviations need anyway; big intermediate levels would
        # cost trees, not accuracy).
        size = min(size * 4 if size * 4 <= settings.quadric_max_level else finest, finest)
        level += 1
        if nominal.triangles is None and size >= nominal.n:
            # Normals looked up as needed: bare points get theirs estimated only where paired.
            pts_l, nrm_l, tree = nominal.points, nominal.normals, nominal.tree
        else:
            pts_l, nrm_l, tree = nominal.level(size)
        h = nominal.level_spacing(size)
        msub = _spread_subset(measured, min(max(64, size // 32), settings.icp_measured))
        last = size >= finest
        shape = nominal.level_shape(size) if size <= settings.quadric_max_level and not last \
            else None
        frac = 0.4 + 0.35 * min(level, 4) / 4
        T, score, done = _icp_batch(T, measured[msub], tree, pts_l, nrm_l, h,
                                    iterations=4, stop_rad=1e-6 if last else 0.0,
                                    reach=10 * h, shape=shape,
                                    stage=(f"ICP on {size:,} nominal samples", frac,
                                           frac + 0.08))
        iters += done
        keep = settings.keep_per_level[min(level, len(settings.keep_per_level) - 1)]
        T = _best_distinct(T, score, measured[msub], keep)
    return T, iters


def _final_fit(nominal: Nominal, measured: np.ndarray, refined: list, sub: np.ndarray,
               settings: RegistrationSettings, zone_width: float | None, hypotheses: int,
               iterations: int) -> RegistrationResult:
    """Score every refined candidate pose (4, 4) by its point-to-surface deviations (on a seeded
    subset of the measured points) with :func:`pose_score`; every candidate distinct from
    those finished gets the point-to-surface finish, best first, ``MAX_FINISHES`` at most (a
    finish may move a pose away: least squares over every point pulls a wrong pose towards the
    points it leaves off the part; and it brings a pose near the right one home). The finishes
    run on the points the candidates are scored on (at most ``icp_measured``), those after the
    best one ``ALTERNATIVE_ITERATIONS`` at most (one that ends best unsettled is finished in
    full); the pose chosen is then fitted on every point. The answer is the best finished
    pose: no candidate scores better. The best distinct other pose is the runner-up."""
    near = settings.near_fraction_of_size * nominal.diagonal
    ssub = _spread_subset(measured, settings.icp_measured)
    report("comparing the candidate poses", 0.8)
    devs = [point_to_surface(nominal, apply_transform(Tc, measured[ssub])).signed
            for Tc in refined]
    scale = settings.outlier_floor * nominal.diagonal
    scores = [pose_score(d, scale) for d in devs]
    order = [int(i) for i in np.argsort(scores, kind="stable")]
    best = order[0]
    # Most points nowhere near the nominal at the best pose found: the measurement is not (only)
    # of this part. No fit can make that trustworthy; measure and say so.
    unfit = np.mean(np.abs(devs[best]) <= near) < settings.min_near_fraction
    finished, final = {}, {}
    # The candidates are finished on the points they are scored on (all of them up to
    # ``icp_measured``); the one chosen is then fitted on every point. (Each finish of a wrong
    # pose over 200,000 points ran its whole iteration budget: 425 s on a 1M-point nominal.)
    compared = measured[ssub]
    # The best candidate's finish has the whole iteration budget, the others' a short one: a
    # wrong pose does not settle, and ran the budget out (50 evaluations of 4,096 far points,
    # 12 s on a 1M-point nominal). A short finish chosen all the same is finished in full.
    short = replace(settings, max_final_iterations=min(settings.max_final_iterations,
                                                       ALTERNATIVE_ITERATIONS))
    while best is not None:
        finished[best] = (_unfitted if unfit else _point_to_surface_fit)(
            nominal, compared, refined[best], short if finished else settings, zone_width)
        final[best] = pose_score(finished[best][5].signed, scale)
        chosen = min(final, key=final.get)
        # Not only the candidates already scoring better are finished: one a millimetre off
        # the right pose scores worse before its finish than a wrong pose after its own (NIST
        # CTC-01 with 2% mis-probes: 0.64 against 0.50 mm; finished, 0.24 mm; CTC-03 with 2%
        # mis-probes: 2.44 mm, 8.7 mm off the truth, against a wrong pose's 0.17 mm).
        best = None if unfit or len(finished) >= MAX_FINISHES else next(
            (j for j in order if j not in finished
             and all(distinct_poses(refined[j], finished[i][0], measured[sub], nominal.diagonal)
                     for i in finished)),
            None)
    # A short finish that did not settle and scores best is finished in full; that may leave
    # it worse than another, which is then the one chosen.
    complete = {order[0]}
    while chosen not in complete and not finished[chosen][1] and not unfit:
        finished[chosen] = _point_to_surface_fit(nominal, compared, finished[chosen][0],
                                                 settings, zone_width)
        final[chosen] = pose_score(finished[chosen][5].signed, scale)
        complete.add(chosen)
        chosen = min(final, key=final.get)
    if ssub.size < measured.shape[0]:
        finished[chosen] = (_unfitted if unfit else _point_to_surface_fit)(
            nominal, measured, finished[chosen][0], settings, zone_width)
        final[chosen] = pose_score(finished[chosen][5].signed[ssub], scale)
    Tb, converged, _, inlier, rule, dev_b, dev_s, message = finished[chosen]
    # Every candidate at its finished pose and score where it was finished.
    poses = [finished[i][0] if i in finished else refined[i] for i in range(len(refined))]
    scores = [final.get(i, scores[i]) for i in range(len(refined))]
    runner = min((j for j in range(len(refined)) if j != chosen
                  and distinct_poses(poses[j], Tb, measured[sub], nominal.diagonal)),
                 key=lambda j: scores[j], default=None)
    return RegistrationResult.from_fit(
        Tb, dev_b, inlier, rule, near, converged=converged,
        iterations=iterations + sum(f[2] for f in finished.values()), score=final[chosen],
        hypotheses=hypotheses, runner_up_score=None if runner is None else scores[runner],
        runner_up_T=None if runner is None else poses[runner], deviation_s=dev_s,
        message=message)


def _unfitted(nominal: Nominal, measured: np.ndarray, T: np.ndarray,
              settings: RegistrationSettings, zone_width: float | None):
    """The candidate pose T measured as it is, unfitted (no pose there is worth fitting), in
    the form of _point_to_surface_fit's result."""
    X = apply_transform(T, measured)
    t0 = time.perf_counter()
    dev = point_to_surface(nominal, X)
    dev_s = time.perf_counter() - t0
    rule = gross_rule(dev.signed, zone_width, _gross_floor(nominal, settings, zone_width))
    inlier = ~gross_outliers(dev.signed, dev.foot, rule)
    return (T, False, 0, inlier, rule, dev, dev_s,
            "the measured points do not match the nominal at any pose found")


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
    return float(np.sqrt(max(np.exp(np.mean(np.log(d * d + s2))) - s2, 0.0)))


# ---------------------------------------------------------------------------- global stage
def _hypotheses(nominal: Nominal, measured: np.ndarray, lvl_pts: np.ndarray,
                lvl_nrm: np.ndarray, settings: RegistrationSettings) -> np.ndarray:
    """(H, 4, 4) starting poses.

    * the four principal-axes alignments, centroid on centroid (full coverage);
    * evenly spread rotations, centroid on centroid and with a measured point ``p0`` put on a few
      anchor points spread over the nominal;
    * ``p0``'s local normal turned onto the nominal normal at anchors spread over the whole
      nominal surface (about one per tenth of the measured extent), both ways round, at
      ``n_spins`` spins about it: with the right anchor, one of these starts within 10 degrees
      and a few millimetres of the answer, whatever part of the nominal was measured.

    ``p0`` is a measured point near the measured centroid whose neighbours lie on a plane (so that
    its normal means something); the centroid itself may be in the air (two faces of a bracket).
    """
    cm = measured.mean(axis=0)
    cn = nominal.points.mean(axis=0)
    Em, _ = _principal_axes(measured - cm)
    En, _ = _principal_axes(lvl_pts - lvl_pts.mean(axis=0))
    pca = np.asarray([En @ np.diag(s) @ Em.T
                      for s in ([1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1])])
    extent = float(np.linalg.norm(measured.max(0) - measured.min(0)))
    p0, n0 = _reference_point(measured, extent)

    U = uniform_rotations(settings.n_rotations)
    few = lvl_pts[_spread_subset(lvl_pts, settings.min_anchors)]
    R_all = [pca, U, np.repeat(U, few.shape[0], axis=0)]
    t_all = [cn - pca @ cm, cn - U @ cm, np.tile(few, (U.shape[0], 1)) - R_all[-1] @ p0]

    anchor_idx = _voxel_anchors(lvl_pts, 0.1 * extent, settings.max_anchors)
    spins = np.linspace(0.0, 2 * np.pi, settings.n_spins, endpoint=False)
    a_pts, a_nrm = lvl_pts[anchor_idx], lvl_nrm[anchor_idx]
    spin = rotation_from_rotvec(a_nrm[:, None, :] * spins[None, :, None])  # (k, s, 3, 3)
    for sign in (1.0, -1.0):
        base = _rotation_between(sign * n0, a_nrm)  # (k, 3, 3)
        R = (spin @ base[:, None]).reshape(-1, 3, 3)
        R_all.append(R)
        t_all.append(np.repeat(a_pts, spins.size, axis=0) - R @ p0)
    return make_transform(np.concatenate(R_all), np.concatenate(t_all))


def _reference_point(measured: np.ndarray, extent: float):
    """A measured point near the centroid whose neighbourhood is planar, and its unit normal."""
    measured = measured[_spread_subset(measured, 4096)]
    n = measured.shape[0]
    k = min(8, n)
    cm = measured.mean(axis=0)
    near = np.argsort(np.linalg.norm(measured - cm, axis=1), kind="stable")[: min(n, 16)]
    _, nb = cKDTree(measured).query(measured[near], k=k)
    c = measured[nb] - measured[nb].mean(axis=1, keepdims=True)
    vals, vecs = np.linalg.eigh(np.einsum("mki,mkj->mij", c, c))
    flatness = vals[:, 0] / np.maximum(vals[:, 1], 1e-300)
    dist = np.linalg.norm(measured[near] - cm, axis=1) / max(extent, 1e-12)
    best = int(np.argmin(dist + 5.0 * flatness))
    return measured[near[best]], vecs[best, :, 0]


def _voxel_anchors(pts: np.ndarray, voxel: float, cap: int) -> np.ndarray:
    """One point per occupied voxel (the one nearest the voxel centre), the voxel grown until at
    most ``cap`` remain: anchors spread by area over the surface, whatever its shape."""
    voxel = max(voxel, 1e-9)
    lo = pts.min(axis=0)
    while True:
        cell = np.floor((pts - lo) / voxel).astype(np.int64)
        centre = lo + (cell + 0.5) * voxel
        d = np.linalg.norm(pts - centre, axis=1)
        order = np.lexsort((d, cell[:, 2], cell[:, 1], cell[:, 0]))
        c = cell[order]
        first = order[np.r_[True, np.any(c[1:] != c[:-1], axis=1)]]
        if first.size <= cap:
            return np.sort(first)
        voxel *= 1.25


def _rotation_between(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(k, 3, 3) rotations turning the unit vector a (3,) onto each unit vector b (k, 3)."""
    v = np.cross(a[None, :], b)
    s = np.linalg.norm(v, axis=1)
    c = b @ a
    angle = np.arctan2(s, c)
    axis = np.where(s[:, None] > 1e-12, v / np.maximum(s, 1e-300)[:, None], 0.0)
    # Opposite vectors: any axis perpendicular to a.
    opposite = (s <= 1e-12) & (c < 0)
    if opposite.any():
        perp = np.cross(a, [1.0, 0, 0] if abs(a[0]) < 0.9 else [0, 1.0, 0])
        axis[opposite] = perp / np.linalg.norm(perp)
    return rotation_from_rotvec(axis * angle[:, None])


def _principal_axes(c: np.ndarray):
    """Principal axes (columns, largest first, right-handed) and their variances."""
    vals, vecs = np.linalg.eigh(c.T @ c / max(c.shape[0], 1))
    E = vecs[:, ::-1].copy()
    if np.linalg.det(E) < 0:
        E[:, 2] *= -1
    return E, vals[::-1]


def _spread_subset(pts: np.ndarray, m: int) -> np.ndarray:
    """Indices of up to ``m`` points spread over ``pts``: farthest-point sampling for small ``m``,
    a seeded random subset for large ``m`` (where it spreads well enough and costs nothing)."""
    n = pts.shape[0]
    if n <= m:
        return np.arange(n)
    if m > 128:
        return np.sort(np.random.default_rng(_SEED).choice(n, m, replace=False))
    pool = np.arange(n)
    if n > 8192:
        pool = np.sort(np.random.default_rng(_SEED).choice(n, 8192, replace=False))
    P = np.ascontiguousarray(pts[pool], np.float64)
    return np.sort(pool[kernels.farthest_points(P, P.mean(0), m)])


def _icp_batch(T: np.ndarray, src: np.ndarray, tree: cKDTree, pts: np.ndarray, nrm: np.ndarray,
               spacing: float, iterations: int, stop_rad: float = 0.0, lam2: float = 0.0,
               reach: float = np.inf, shape: np.ndarray | None = None,
               stage: tuple[str, float, float] | None = None):
    """Run ICP iterations for H poses at once; returns (poses, truncated scores, iterations run).

    stage : (name, first fraction, last fraction) for progress reports, one per iteration.

    T : (H, 4, 4) poses; src : (m, 3) measured points; nrm : (L, 3) sample normals, or a function
    giving the normals of sample indices. Each iteration pairs every transformed
    point with its nearest sample and solves the linearised point-to-plane problem (point-to-
    quadric when the samples' ``shape`` operators are given; plus, with
    ``lam2`` > 0, a point-to-point term of that weight that keeps flat directions from drifting
    while far from the solution), trimming pairs
    farther than max(3 x spacing, 2.5 x the pose's median distance). Stops early once every
    update rotates less than ``stop_rad`` and moves less than ``stop_rad`` x 100 x spacing.
    Points farther than ``reach`` from every sample are left unpaired (it bounds the search).
    The score (of the poses returned: one more pairing after the last update) is the mean over
    every point of min(e^2, (3 spacing)^2), where e combines the distance along the sample's
    normal with the sideways distance beyond 3 x the sample spacing (a point hanging off the
    nominal's border): a point off the part costs the same at every pose, however far off, so
    gross outliers do not decide which pose wins; and every point counts, so a feature carried
    by a few points (a boss on a cube, whose faces fit at 24 poses) does.
    """
    done = 0
    H, m = T.shape[0], src.shape[0]
    no_shape = np.empty((0, m, 3, 3))
    e2, delta = np.empty((H, m)), np.empty((H, 6))
    for k in range(iterations + 1):
        # Pairs from scipy's kd-tree; the arithmetic compiled (kernels.icp_paired).
        X = apply_transform(T, src)
        dist, j = tree.query(X.reshape(-1, 3), workers=query_workers(H * m),
                             distance_upper_bound=reach)
        far = ~np.isfinite(dist).reshape(H, m)
        j = np.minimum(j, pts.shape[0] - 1).reshape(H, m)
        n = nrm(j) if callable(nrm) else nrm[j]
        update = k < iterations
        if update and stage is not None:
            report(f"{stage[0]}, ICP iteration {k + 1}",
                   stage[1] + (stage[2] - stage[1]) * k / iterations)
        T_next = np.empty_like(T)
        kernels.icp_paired(np.ascontiguousarray(T), np.ascontiguousarray(X), j, far, pts,
                           np.ascontiguousarray(n, np.float64),
                           no_shape if shape is None else np.ascontiguousarray(shape[j]),
                           float(spacing), float(lam2), float(reach), update, T_next, e2, delta)
        if not update:
            break
        T = T_next
        done += 1
        if stop_rad and np.all(np.linalg.norm(delta[:, :3], axis=1) < stop_rad) and \
                np.all(np.linalg.norm(delta[:, 3:], axis=1) < stop_rad * 100 * spacing):
            stop_rad, iterations = 0.0, k + 1  # one more pairing scores the poses returned
    return T, np.mean(np.minimum(e2, (3 * spacing) ** 2), axis=1), done


def _icp_poses(T: np.ndarray, src: np.ndarray, lookup: SampleLookup, pts: np.ndarray,
               nrm: np.ndarray, shape: np.ndarray | None, spacing: float, iterations: int,
               lam2: float = 0.0, reach: float = np.inf):
    """_icp_batch's iterations (without early stop) compiled (kernels.icp_poses), the points
    paired by the constant-time ``lookup`` of the samples ``pts`` instead of their kd-tree:
    (poses (H, 4, 4), truncated scores (H,)). The poses are split over the cores' threads; each
    is computed alone, so the answer does not depend on the split."""
    H = T.shape[0]
    out_T = np.empty((H, 4, 4))
    out_s = np.empty(H)
    args = (np.ascontiguousarray(T, np.float64), np.ascontiguousarray(src, np.float64),
            lookup.lo, lookup.cell, lookup.owner, lookup.graph,
            np.ascontiguousarray(pts, np.float64), np.ascontiguousarray(nrm, np.float64),
            _NO_SHAPE if shape is None else np.ascontiguousarray(shape, np.float64),
            float(spacing), int(iterations), float(lam2), float(reach))
    chunks = max(1, min(os.cpu_count() or 1, H * src.shape[0] // PARALLEL_QUERIES))
    bounds = np.linspace(0, H, chunks + 1).astype(int)
    threads = [threading.Thread(target=kernels.icp_poses,
                                args=args + (int(a), int(b), out_T, out_s))
               for a, b in zip(bounds[1:-1], bounds[2:])]
    for t in threads:
        t.start()
    kernels.icp_poses(*args, int(bounds[0]), int(bounds[1]), out_T, out_s)
    for t in threads:
        t.join()
    return out_T, out_s


_NO_SHAPE = np.zeros((0, 3, 3))


def distinct_poses(T1: np.ndarray, T2: np.ndarray, src: np.ndarray, diagonal: float) -> bool:
    """Two poses differ when they rotate apart by over 2 degrees or move the points apart by over
    1% of the measured extent (the nominal's diagonal when smaller)."""
    extent = min(float(np.linalg.norm(src.max(0) - src.min(0))), diagonal)
    x1 = apply_transform(T1, src)
    x2 = apply_transform(T2, src)
    move = float(np.sqrt(np.mean(np.sum((x1 - x2) ** 2, axis=1))))
    return rotation_angle_deg(T1[:3, :3] @ T2[:3, :3].T) > 2.0 or move > 0.01 * extent


def _best_distinct(T: np.ndarray, score: np.ndarray, src: np.ndarray, keep: int) -> np.ndarray:
    """The ``keep`` best-scoring poses (H, 4, 4), skipping any that lands within 1% of the
    measured extent of a better one (poses compared by where they put a few spread points)."""
    ref = src[_spread_subset(src, 4)]
    extent = float(np.linalg.norm(src.max(0) - src.min(0)))
    tol = 0.01 * max(extent, 1e-12)
    order = np.argsort(score, kind="stable")
    feat = np.einsum("hij,mj->hmi", T[order, :3, :3], ref) + T[order, None, :3, 3]
    return T[order[kernels.distinct_first(np.ascontiguousarray(feat), tol, keep)]]


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


def _point_to_surface_fit(nominal: Nominal, measured: np.ndarray, T: np.ndarray,
                          settings: RegistrationSettings, zone_width: float | None):
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
    a nanometre). Returns (T, converged, iterations, kept mask
    (all points), GrossRule at T, Deviations of all points at T, seconds the evaluation of those
    deviations took, message).
    """
    floor = settings.outlier_floor * nominal.diagonal
    n = measured.shape[0]
    fsub = _spread_subset(measured, settings.fit_measured)
    sub = measured[fsub]
    budget = settings.max_final_iterations
    T, _, total, _, dev, dev_s = _gauss_newton(nominal, sub, T, settings, None, floor,
                                               min(ROBUST_ITERATIONS, budget))
    floor = _gross_floor(nominal, settings, zone_width)
    # On a subset, the final stage over every point checks the points left out.
    rounds = _confirmed_rounds if fsub.size == n else _least_squares_rounds
    T, converged, it, keep, rule, dev, dev_s = rounds(
        nominal, sub, T, dev, dev_s, settings, zone_width, floor, budget - total)[:7]
    total += it
    if fsub.size < n:
        X = apply_transform(T, measured)
        t0 = time.perf_counter()
        dev = point_to_surface(nominal, X)
        dev_s = time.perf_counter() - t0
        rule = gross_rule(dev.signed, zone_width, floor)
        keep = ~gross_outliers(dev.signed, dev.foot, rule)
        finished = not settings.finish_on_all_points
        if not finished and converged and keep.sum() >= 6:
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
                    T = apply_update(T, delta, c)
                    dev, rule, finished = moved, rule_m, True
        if not finished:
            T, converged, it, keep, rule, dev, dev_s = _confirmed_rounds(
                nominal, measured, T, dev, dev_s, settings, zone_width, floor, budget)
            total += it
    message = ""
    if not converged:
        message = (f"the point-to-surface fit did not settle within "
                   f"{settings.max_final_iterations} iterations (or the points it excludes as "
                   f"gross outliers within {MAX_ROUNDS} fits)")
    if keep.sum() < 6:
        converged = False
        message = (f"only {int(keep.sum())} points are not gross outliers (beyond "
                   f"{rule.threshold_mm:.3g} mm)")
    return T, converged, total, keep, rule, dev, dev_s, message


def _gross_floor(nominal: Nominal, settings: RegistrationSettings,
                 zone_width: float | None) -> float:
    """The gross-outlier threshold's floor, mm."""
    fraction = settings.outlier_floor if zone_width is not None else \
        settings.gross_floor_without_zone
    return fraction * nominal.diagonal


def _confirmed_rounds(nominal, pts, T, dev, dev_s, settings, zone_width, floor, budget):
    """Least squares over every point of ``pts`` but the gross outliers, a point left out only
    if it is gross with it included too (engine.outliers.fit_without_gross): _least_squares_rounds
    once, and when it leaves points out, the rule at the least-squares pose over every point (the
    probe: one linear step when that suffices, else at most ``INCLUDED_FIT_ITERATIONS``
    iterations), and then _least_squares_rounds again. Same arguments and returns as
    _least_squares_rounds (iterations: of every fit run; ``budget`` for all)."""
    used = 0

    def fit(start, included, cap=None):
        nonlocal used
        left = budget - used if cap is None else min(budget - used, cap)
        out = _least_squares_rounds(nominal, pts, *start, settings, zone_width, floor, left,
                                    included)
        used += out[2]
        T1, converged, _, keep, _, d1, s1, gross = out
        return (T1, d1, s1), gross, keep, converged, out

    def probe(start):
        nonlocal used
        T0, d0, _ = start
        # Every point included usually moves the pose so little that the deviations can
        # follow to first order: no new evaluation (mis-probes among many points). Only which
        # points are gross there is used: the final fit is a real one.
        gross = _gross_included(apply_transform(T0, pts), d0, zone_width, floor)
        used += 1
        if gross is not None:
            return start, gross
        return fit(start, np.zeros(len(pts), bool), INCLUDED_FIT_ITERATIONS)[:2]

    (_, _, _, converged, out), _ = fit_without_gross(fit, (T, dev, dev_s), pts.shape[0], probe)
    T1, _, _, keep, rule, d1, s1, _ = out
    return T1, converged and used <= budget, used, keep, rule, d1, s1


def _least_squares_rounds(nominal, pts, T, dev, dev_s, settings, zone_width, floor, budget,
                          included=None):
    """Least squares over the points of ``pts`` the gross-outlier rule keeps at pose ``T``
    (whose deviations ``dev`` are given; ``floor``: the rule's floor, mm), the rule applied again
    at each new optimum until the kept set is stable (at most ``MAX_ROUNDS`` fits and ``budget``
    Gauss-Newton iterations in all). included : (m,) bool, only these may be left out (None:
    any; all False: plain least squares over every point). Returns (T, converged, iterations,
    kept mask, GrossRule, Deviations at T, seconds their evaluation took, (m,) bool gross by the
    rule alone at T)."""
    total, converged, keep = 0, False, None
    for _ in range(MAX_ROUNDS):
        rule = gross_rule(dev.signed, zone_width, floor)
        gross = _gross(dev, rule, included)
        new = ~gross if included is None else ~(gross & included)
        if keep is not None and converged and np.array_equal(new, keep):
            break
        keep = new
        if total >= budget:
            converged = False
            break
        T, converged, it, _, dev, dev_s = _gauss_newton(nominal, pts, T, settings, keep, floor,
                                                        budget - total, dev, dev_s)
        total += it
    else:
        # The last fit's set is the one its pose was fitted on; the rule at that pose may
        # differ by a point at the threshold (the fit is reported as not settled then).
        rule = gross_rule(dev.signed, zone_width, floor)
        gross = _gross(dev, rule, included)
        if not np.array_equal(~gross if included is None else ~(gross & included), keep):
            converged = False
    if included is not None and not included.any():
        gross = gross_outliers(dev.signed, dev.foot, rule)
    return T, converged, total, keep, rule, dev, dev_s, gross


def _gross(dev, rule, included):
    """The rule's gross outliers at ``dev`` (none looked for where ``included`` is all False)."""
    if included is not None and not included.any():
        return np.zeros(dev.signed.size, bool)
    return gross_outliers(dev.signed, dev.foot, rule)


def _moved(dev: Deviations, X: np.ndarray, delta: np.ndarray, c: np.ndarray):
    """The deviations ``dev`` of the points ``X`` (n, 3) after the small step ``delta`` about
    ``c`` (from gauss_newton_step), to first order (exact to ~step^2 x curvature), and the moved points."""
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


def _gauss_newton(nominal, pts, T, settings, use, floor, max_iter, dev=None, dev_s=0.0):
    """Iterate the linearised point-to-surface least squares on ``pts`` (m, 3) from pose ``T``.

    use : (m,) bool, the fixed set of points fitted (the iteration converges to the
    least-squares optimum over them); None: the robust cut (``outlier_sigmas`` robust standard
    deviations, at least ``floor`` mm) re-estimated at every iteration (the coarse iterations
    only). Converged when a step would move no fitted point by more than ``convergence_mm``;
    that last step is not applied, so the returned deviations belong to the returned pose.
    ``dev`` (and the seconds ``dev_s`` it took): the deviations at ``T`` when known already.
    Returns (T, converged, iterations, fitted mask, Deviations of ``pts`` at T, seconds their
    evaluation took).
    """
    mask = use
    for it in range(1, max_iter + 1):
        report(f"point-to-surface fit on {pts.shape[0]:,} points, iteration {it}",
               0.85 + 0.1 * it / max(max_iter, 10))
        X = apply_transform(T, pts)
        if dev is None:
            t0 = time.perf_counter()
            dev = point_to_surface(nominal, X)
            dev_s = time.perf_counter() - t0
        d = dev.signed
        if use is None:
            mask = np.abs(d) <= robust_cut(d, settings.outlier_sigmas, floor)
        if mask.sum() < 6:
            return T, False, it, mask, dev, dev_s
        delta, c = gauss_newton_step(X[mask], dev.normal[mask], d[mask])
        if _largest_motion(delta, X[mask] - c) < settings.convergence_mm:
            return T, True, it, mask, dev, dev_s
        T = apply_update(T, delta, c)
        dev = None
    X = apply_transform(T, pts)
    t0 = time.perf_counter()
    dev = point_to_surface(nominal, X)
    dev_s = time.perf_counter() - t0
    if use is None:
        mask = np.abs(dev.signed) <= robust_cut(dev.signed, settings.outlier_sigmas, floor)
    return T, False, max_iter, mask, dev, dev_s


def robust_cut(d: np.ndarray, sigmas: float, floor: float) -> float:
    """Outlier cut for deviations d (mm): |median| + ``sigmas`` x 1.4826 x median absolute
    deviation, never below ``floor``. Shared by the 3D and 2D fits."""
    med, sigma = robust_centre_sigma(d)
    return float(max(abs(med) + sigmas * sigma, floor))
