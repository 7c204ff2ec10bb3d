"""Soft registration: the rigid pose of the measured points in the nominal frame, from any start.

The method is the paper's modified ICP (section 4) with a global stage in front of it:

1. **Global search.** Pose hypotheses are the principal-axes alignments (the four proper sign
   combinations), an even spread of rotations over SO(3) placed at the centroid and at a few
   anchors, and -- what carries partial coverage -- the measured surface normal turned onto the
   nominal normal at anchors spread over the whole nominal, at 18 spins. Every hypothesis runs a
   few ICP iterations on a coarse sample of the nominal, paired point-to-quadric (each sample
   carries its local curvature, so a coarse sample still scores close fits correctly); poses
   that arrive at the same place merge and only the best distinct ones go on. These some
   10^5 pairings are compiled (icp_kernels.icp_poses) and find their sample in constant time
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
from collections.abc import Callable
from dataclasses import replace

import numpy as np
from scipy.spatial import cKDTree

from . import icp_kernels
from .deviation import point_to_surface
from .neighbours import (PARALLEL_QUERIES, SampleLookup, query, spread_subset,
                         voxel_spread)
from .nominal import Nominal
from .pose import (apply_transform, make_transform, rms_radius, rotation_angle_deg,
                   rotation_from_rotvec, uniform_rotations)
from .progress import report
from .registration_types import PoseFit, RegistrationResult, RegistrationSettings
from .surface_fit import (ALTERNATIVE_ITERATIONS, MAX_FINISHES, Watch, gross_floor,
                          point_to_surface_fit, pose_as_it_is, pose_score)
from .verdict import AMBIGUITY_SCORE_RATIO


def register(nominal: Nominal, measured: np.ndarray,
             settings: RegistrationSettings = RegistrationSettings(),
             zone_width: float | None = None) -> RegistrationResult:
    """Find ``T_nominal_measured`` for measured points (n, 3) lying in any pose.

    zone_width : the tolerance zone's width, mm, when known: a gross outlier lies beyond several
    zone widths (engine.outliers); without it, the robust spread and a floor of
    ``gross_floor_without_zone`` x the nominal's diagonal decide. With it, a patch whose best
    pose scores worse than the zone's width is searched again with denser anchors
    (:func:`search_densely`)."""
    measured = np.ascontiguousarray(measured, dtype=np.float64)
    coarse = _coarse_level(nominal, measured, settings)
    T, sub, n_hyp = _global_search(nominal, measured, coarse, settings)
    T, iters = _coarse_to_fine(nominal, measured, T, coarse, settings)
    found = _final_fit(nominal, measured, list(T), sub, settings, zone_width,
                       hypotheses=n_hyp, iterations=iters)
    if zone_width is None or found.score <= zone_width \
            or not covers_part_only(measured, nominal.level(settings.coarse_size)[0], settings):
        return found
    # A patch whose best pose leaves the typical point out of the zone: its starts may all
    # have been too far from the truth (NIST CTC-01 and FTC-06, 90 points on 30% of the part:
    # the nearest anchor with the reference point's normal lay 27 and 36 mm from its true
    # place, no start came within 20 mm, and the poses found put 85 and 90 of 90 points out,
    # sample scores 4.8 and 1.3 mm). The search again, with denser anchors (0.18 and 0.067 mm
    # there); its answer replaces the first only if it scores far better (RETRY_GAIN), and
    # the other is kept among the candidates, for an exact surface to judge
    # (engine.exact_fit.better_candidates).
    again = search_densely(nominal, measured, settings, zone_width)
    again = replace(again, hypotheses=n_hyp + again.hypotheses,
                    iterations=iters + again.iterations)
    chosen, other = (again, found) if again.score < RETRY_GAIN * found.score else (found, again)
    known = [chosen.T_nominal_measured, *chosen.candidates]
    if chosen.runner_up_T is not None:
        known.append(chosen.runner_up_T)
    if not all(distinct_poses(other.T_nominal_measured, K, measured[sub], nominal.diagonal)
               for K in known):
        return chosen
    return replace(chosen, candidates=(other.T_nominal_measured, *chosen.candidates))


def search_densely(nominal: Nominal, measured: np.ndarray, settings: RegistrationSettings,
                   zone_width: float | None) -> RegistrationResult:
    """The search for a patch again, with the normal-aligned starts alone at denser anchors
    (``RegistrationSettings.patch_anchor_voxel``), iterated on more measured points
    (``patch_measured``), refined and finished as :func:`register`'s
    own: its answer (hypotheses and iterations its own). register runs it when a patch's pose
    scores worse than the zone's width; engine.exact_fit when a patch's pose still calls points
    gross outliers on the exact faces (NIST CTC-05 (AP242), seed 5555: a look-alike 402 mm off
    fitting 85 of 90 points, 0.072 mm on the sample, under the zone's width, the best start 53
    mm from the truth; this search's answer, 0.2 mm from it, scores 0.056 mm there, and on the
    exact faces 0.0021 mm against the look-alike's 0.036)."""
    measured = np.ascontiguousarray(measured, dtype=np.float64)
    coarse = _coarse_level(nominal, measured, settings)
    T, sub, n = _global_search(nominal, measured, coarse, settings, dense=True)
    T, iters = _coarse_to_fine(nominal, measured, T, coarse, settings)
    return _final_fit(nominal, measured, list(T), sub, settings, zone_width, hypotheses=n,
                      iterations=iters)


def _coarse_level(nominal: Nominal, measured: np.ndarray, settings: RegistrationSettings) -> int:
    """The nominal's coarsest level for these measured points: it must still put a few hundred
    samples under the measured area."""
    extent = float(np.linalg.norm(measured.max(0) - measured.min(0)))
    ratio = nominal.diagonal / max(extent, 1e-12)
    return int(np.clip(settings.coarse_samples_per_area * ratio * ratio,
                       settings.coarse_size, 16 * settings.coarse_size))


def _global_search(nominal: Nominal, measured: np.ndarray, coarse: int,
                   settings: RegistrationSettings, dense: bool = False):
    """(T (k, 4, 4), sub, n_hypotheses): the best distinct poses of every hypothesis after ICP on
    the nominal's ``coarse`` level, and the measured subset ``sub`` (indices) they were kept on.

    Scores on a coarse sample cannot tell close fits apart (its chords are off by curvature x
    spacing^2), so several distinct poses are carried to the finer levels, where they can."""
    lvl_pts, lvl_nrm, _ = nominal.level(coarse)
    lvl_shape = nominal.level_shape(coarse)
    h0 = nominal.level_spacing(coarse)

    report("global search: pose hypotheses", 0.02)
    count = settings.patch_measured if dense else settings.coarse_measured
    sub = spread_subset(measured, count, settings.seed)
    T = _hypotheses(nominal, measured, lvl_pts, lvl_nrm, settings, dense)
    n_hyp = T.shape[0]
    # Every hypothesis iterates, poses that arrive at the same place merge, and only the best
    # distinct ones go on.
    first = sub[spread_subset(measured[sub], count // 2, settings.seed)]
    lookup = nominal.level_lookup(coarse)
    report(f"global search over {n_hyp} poses", 0.05)
    T, score = _icp_poses(T, measured[first], lookup, lvl_pts, lvl_nrm, lvl_shape, h0,
                          iterations=3, lam2=0.01)
    T = _best_distinct(T, score, measured[sub], settings.keep_per_level[0] * 2, settings.seed)
    report(f"global search, best {T.shape[0]} poses", 0.25)
    T, score = _icp_poses(T, measured[sub], lookup, lvl_pts, lvl_nrm, lvl_shape, h0,
                          iterations=6, lam2=0.01)
    return (_best_distinct(T, score, measured[sub], settings.keep_per_level[0], settings.seed),
            sub, n_hyp)


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
        nrm_l: np.ndarray | Callable[[np.ndarray], np.ndarray]
        if nominal.triangles is None and size >= nominal.n:
            # Normals looked up as needed: bare points get theirs estimated only where paired.
            pts_l, nrm_l, tree = nominal.points, nominal.normals, nominal.tree
        else:
            pts_l, nrm_l, tree = nominal.level(size)
        h = nominal.level_spacing(size)
        msub = spread_subset(measured, min(max(64, size // 32), settings.icp_measured),
                             settings.seed)
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
        tie = TIE * np.min(score) + (TIE_SPACING * h) ** 2
        if np.sum(score <= tie) > keep and msub.size < measured.shape[0]:
            # More tie than the level keeps: ranked on more points (one pairing each).
            msub = spread_subset(measured, settings.icp_measured, settings.seed)
            score = _icp_batch(T, measured[msub], tree, pts_l, nrm_l, h, iterations=0,
                               reach=10 * h, shape=shape)[1]
        T = _best_distinct(T, score, measured[msub], keep, settings.seed)
    return T, iters


TIE = 2.0
TIE_SPACING = 0.05
"""Candidates whose ICP scores (mean squared distances) on a level's measured points lie within
TIE x the best one's, or (TIE_SPACING x the level's sample spacing)^2 of it, tie. When more tie
than the level keeps, they are ranked on up to ``icp_measured`` points. A 50 mm cube with an R2
boss, 1,211 points (11 on the boss): 29 poses tied at 1.04e-6 mm^2 on 125 spread points with
none on the boss, and the 8 kept by the order of ties held none of the right one (rejected 62
mm off); with an R1.5 boss, samples 1.9 mm apart did not represent the boss: the right pose
scored 7.1e-4 mm^2, the look-alikes 1.1e-6 (a level cannot tell such fits apart)."""


RETRY_GAIN = 0.5
"""The search with denser anchors (``RegistrationSettings.patch_anchor_voxel``) replaces the
first one's answer only if it scores below this fraction of it: a CAD tessellation's chordal
error alone can put the right pose of a patch over the zone's width on the sample (NIST
CTC-03, 0.065-0.14 mm), and the second search's wrong poses may then score as well. The answer
not chosen is kept among the candidates, which an exact surface judges again."""


CANDIDATE_SCORE_RATIO = 3.0
"""The registration's result keeps the other candidate poses that score within this factor of
the pose chosen, for an exact surface to judge again (engine.exact_fit.better_candidates): the
sample's scores carry its chordal error, and a short finish leaves a pose near the right one
short of it (NIST FTC-07's 90-point patch: a candidate 0.27 mm from the truth at 1.86 x the
score of a pose 283 mm off, which the exact faces put at 12 x the truth's). Each costs a fit of
128 points on the exact faces, up to about 1 s when they lie millimetres off them (FTC-07
with 2,000 points: 2.1 s for two candidates at 54 x, which are not kept now)."""


def _final_fit(nominal: Nominal, measured: np.ndarray, refined: list, sub: np.ndarray,
               settings: RegistrationSettings, zone_width: float | None, hypotheses: int,
               iterations: int) -> RegistrationResult:
    """Score every refined candidate pose (4, 4) by its point-to-surface deviations (on a seeded
    subset of the measured points) with :func:`pose_score`; every candidate distinct from
    those finished gets the point-to-surface finish, best first, ``MAX_FINISHES`` at most (a
    finish may move a pose away: least squares over every point pulls a wrong pose towards the
    points it leaves off the part; and it brings a pose near the right one home). The finishes
    run on the points the candidates are scored on (at most ``icp_measured``), those after the
    best one ``ALTERNATIVE_ITERATIONS`` at most and given up, at the best pose they saw, once
    they score no better than where they started and worse than AMBIGUITY_SCORE_RATIO x the
    best finish's (surface_fit.Watch) (one that ends best unsettled is finished in full); the
    pose chosen is then fitted on every point. The answer is the best finished pose: no
    candidate scores better. The best distinct other pose is the runner-up; the
    candidates distinct from both that score within ``CANDIDATE_SCORE_RATIO`` of the pose are
    kept too (``candidates``)."""
    near, near_rule = settings.near(nominal.diagonal)
    ssub = spread_subset(measured, settings.icp_measured, settings.seed)
    report("comparing the candidate poses", 0.8)
    devs = [point_to_surface(nominal, apply_transform(Tc, measured[ssub])).signed
            for Tc in refined]
    scale = settings.outlier_floor * nominal.diagonal
    scores = [pose_score(d, scale) for d in devs]
    order = [int(i) for i in np.argsort(scores, kind="stable")]
    # Most points nowhere near the nominal at the best pose found: the measurement is not (only)
    # of this part. No fit can make that trustworthy; measure and say so.
    unfit = np.mean(np.abs(devs[order[0]]) <= near) < settings.min_near_fraction
    finished: dict[int, PoseFit] = {}  # candidate -> its finish
    final: dict[int, float] = {}  # candidate -> its finish's score
    # The candidates are finished on the points they are scored on (all of them up to
    # ``icp_measured``); the one chosen is then fitted on every point. (Each finish of a wrong
    # pose over 200,000 points ran its whole iteration budget: 425 s on a 1M-point nominal.)
    compared = measured[ssub]
    best: int | None = order[0]  # the next candidate to finish
    while best is not None:
        finished[best] = _finish(nominal, compared, refined[best], settings, zone_width, unfit,
                                 final, scale)
        final[best] = pose_score(finished[best].deviations.signed, scale)
        chosen = min(final, key=final.__getitem__)
        # Not only the candidates already scoring better are finished: one a millimetre off
        # the right pose scores worse before its finish than a wrong pose after its own (NIST
        # CTC-01 with 2% mis-probes: 0.64 against 0.50 mm; finished, 0.24 mm; CTC-03 with 2%
        # mis-probes: 2.44 mm, 8.7 mm off the truth, against a wrong pose's 0.17 mm).
        best = None if unfit or len(finished) >= MAX_FINISHES else next(
            (j for j in order if j not in finished
             and all(distinct_poses(refined[j], finished[i].T_nominal_measured, measured[sub],
                                    nominal.diagonal)
                     for i in finished)),
            None)
    # A short finish that did not settle and scores best is finished in full; that may leave
    # it worse than another, which is then the one chosen.
    complete = {order[0]}
    while chosen not in complete and not finished[chosen].converged and not unfit:
        finished[chosen] = point_to_surface_fit(
            nominal, compared, finished[chosen].T_nominal_measured, settings, zone_width)
        final[chosen] = pose_score(finished[chosen].deviations.signed, scale)
        complete.add(chosen)
        chosen = min(final, key=final.__getitem__)
    if ssub.size < measured.shape[0]:
        finished[chosen] = (_unfitted if unfit else point_to_surface_fit)(
            nominal, measured, finished[chosen].T_nominal_measured, settings, zone_width)
        final[chosen] = pose_score(finished[chosen].deviations.signed[ssub], scale)
    fit = finished[chosen]
    Tb = fit.T_nominal_measured
    # Every candidate at its finished pose and score where it was finished.
    poses = [finished[i].T_nominal_measured if i in finished else refined[i]
             for i in range(len(refined))]
    sampled = scores
    scores = [final.get(i, scores[i]) for i in range(len(refined))]
    runner, others = _runner_up(poses, scores, chosen, measured[sub], nominal.diagonal, sampled)
    return RegistrationResult.from_fit(
        Tb, fit.deviations, fit.inlier, fit.rule, near, converged=fit.converged,
        iterations=iterations + sum(f.iterations for f in finished.values()),
        score=final[chosen], hypotheses=hypotheses,
        runner_up_score=None if runner is None else scores[runner],
        runner_up_T=None if runner is None else poses[runner], deviation_s=fit.deviation_s,
        message=fit.message, near_rule=near_rule, candidates=others)


def _finish(nominal: Nominal, compared: np.ndarray, T: np.ndarray, settings: RegistrationSettings,
            zone_width: float | None, unfit: bool, final: dict, scale: float) -> PoseFit:
    """The finish of the candidate pose T on the points ``compared``, when the candidates
    finished before it scored ``final`` (candidate -> score at ``scale``): T as it is when no
    pose is worth fitting (``unfit``); the first candidate's with the whole iteration budget,
    the others' with a short one (a wrong pose does not settle, and ran the budget out: 50
    evaluations of 4,096 far points, 12 s on a 1M-point nominal), given up once it is plainly
    not going to beat the best, nor come within the ambiguity ratio of it, where it would be a
    competitor (surface_fit.Watch; engine.verdict.AMBIGUITY_SCORE_RATIO). A short finish chosen
    all the same is finished in full (_final_fit)."""
    if unfit:
        return _unfitted(nominal, compared, T, settings, zone_width)
    if not final:
        return point_to_surface_fit(nominal, compared, T, settings, zone_width)
    short = replace(settings, max_final_iterations=min(settings.max_final_iterations,
                                                       ALTERNATIVE_ITERATIONS))
    return point_to_surface_fit(nominal, compared, T, short, zone_width,
                                Watch(scale, AMBIGUITY_SCORE_RATIO * min(final.values())))


def _runner_up(poses: list, scores: list, chosen: int, src: np.ndarray, diagonal: float,
               sampled: list) -> tuple[int | None, tuple[np.ndarray, ...]]:
    """(runner, others) among the candidate poses (4, 4) with their ``scores``: the runner-up,
    the best-scoring one distinct (:func:`distinct_poses` on the points ``src``) from the
    ``chosen`` one (None: none is); the others, best first, those scoring within
    CANDIDATE_SCORE_RATIO of the chosen one, as finished or as ``sampled`` before any finish
    (a pose a millimetre off, unfinished, is not held against the chosen one's finish: NIST
    CTC-05's 90-point patch, seed 11305, 1.0 mm from the truth at 0.231 mm, the chosen pose
    400 mm off at 0.394 mm, 0.067 mm finished), each distinct from it, the runner-up and each
    other."""
    runner = min((j for j in range(len(poses))
                  if j != chosen and distinct_poses(poses[j], poses[chosen], src, diagonal)),
                 key=lambda j: scores[j], default=None)
    kept = [poses[chosen]] if runner is None else [poses[chosen], poses[runner]]
    others = []
    for j in sorted(range(len(poses)), key=lambda j: scores[j]):
        if j in (chosen, runner) or (scores[j] > CANDIDATE_SCORE_RATIO * scores[chosen]
                                     and sampled[j] > CANDIDATE_SCORE_RATIO * sampled[chosen]):
            continue
        if all(distinct_poses(poses[j], Tk, src, diagonal) for Tk in kept):
            others.append(poses[j])
            kept.append(poses[j])
    return runner, tuple(others)


def _unfitted(nominal: Nominal, measured: np.ndarray, T: np.ndarray,
              settings: RegistrationSettings, zone_width: float | None) -> PoseFit:
    """The candidate pose T measured as it is, unfitted (no pose there is worth fitting), in
    the form of point_to_surface_fit's result."""
    floor = gross_floor(nominal, settings, zone_width)
    return pose_as_it_is(nominal, measured, T, zone_width, floor, 0,
                         "the measured points do not match the nominal at any pose found")


# ---------------------------------------------------------------------------- global stage
def _hypotheses(nominal: Nominal, measured: np.ndarray, lvl_pts: np.ndarray,
                lvl_nrm: np.ndarray, settings: RegistrationSettings,
                dense: bool = False) -> np.ndarray:
    """(H, 4, 4) starting poses (``dense``: the normal-aligned ones alone, at
    ``patch_anchor_voxel``'s anchors).

    * the four principal-axes alignments, centroid on centroid (full coverage);
    * evenly spread rotations, centroid on centroid and with a measured point ``p0`` put on a few
      anchor points spread over the nominal;
    * ``p0``'s local normal turned onto the nominal normal at anchors spread over the whole
      nominal surface (about one per tenth of the measured extent), both ways round, at
      ``n_spins`` spins about it: with the right anchor, one of these starts within 10 degrees
      and a few millimetres of the answer, whatever part of the nominal was measured, if
      ``p0``'s normal is right;
    * when the measured points cover only part of the nominal and ``p0``'s neighbours are not
      on a plane, ``p0`` on each of those anchors at ``n_patch_rotations`` evenly spread
      rotations, whatever its normal.

    ``p0`` is a measured point near the measured centroid whose neighbours lie nearest a plane
    (so that its normal means something where they do); the centroid itself may be in the air
    (two faces of a bracket).
    """
    extent = float(np.linalg.norm(measured.max(0) - measured.min(0)))
    p0, n0, flatness = _reference_point(measured, extent, settings.seed)
    R_all: list[np.ndarray] = []
    t_all: list[np.ndarray] = []
    if not dense:
        cm = measured.mean(axis=0)
        cn = nominal.points.mean(axis=0)
        Em, _ = _principal_axes(measured - cm)
        En, _ = _principal_axes(lvl_pts - lvl_pts.mean(axis=0))
        pca = np.asarray([En @ np.diag(s) @ Em.T
                          for s in ([1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1])])
        U = uniform_rotations(settings.n_rotations)
        few = lvl_pts[spread_subset(lvl_pts, settings.min_anchors, settings.seed)]
        R_all += [pca, U, np.repeat(U, few.shape[0], axis=0)]
        t_all += [cn - pca @ cm, cn - U @ cm, np.tile(few, (U.shape[0], 1)) - R_all[-1] @ p0]

    voxel, cap = ((settings.patch_anchor_voxel, settings.max_patch_anchors) if dense
                  else (0.1, settings.max_anchors))
    anchor_idx = voxel_spread(lvl_pts, voxel * extent, cap)
    spins = np.linspace(0.0, 2 * np.pi, settings.n_spins, endpoint=False)
    a_pts, a_nrm = lvl_pts[anchor_idx], lvl_nrm[anchor_idx]
    spin = rotation_from_rotvec(a_nrm[:, None, :] * spins[None, :, None])  # (k, s, 3, 3)
    for sign in (1.0, -1.0):
        base = _rotation_between(sign * n0, a_nrm)  # (k, 3, 3)
        R = (spin @ base[:, None]).reshape(-1, 3, 3)
        R_all.append(R)
        t_all.append(np.repeat(a_pts, spins.size, axis=0) - R @ p0)
    if flatness > settings.patch_flatness and not dense \
            and covers_part_only(measured, lvl_pts, settings):
        U = uniform_rotations(settings.n_patch_rotations)
        R_all.append(np.repeat(U, a_pts.shape[0], axis=0))
        t_all.append(np.tile(a_pts, (U.shape[0], 1)) - R_all[-1] @ p0)
    return make_transform(np.concatenate(R_all), np.concatenate(t_all))


def covers_part_only(measured: np.ndarray, nominal_sample: np.ndarray,
                     settings: RegistrationSettings) -> bool:
    """Whether the measured points (n, 3) cover only part of the nominal, by a sample of its
    surface spread by area (m, 3): their RMS radius about their centroid is below
    ``settings.patch_radius`` of the sample's (full coverage: about 1, in any pose)."""
    return (rms_radius(measured - measured.mean(axis=0))
            < settings.patch_radius * rms_radius(nominal_sample - nominal_sample.mean(axis=0)))


def _reference_point(measured: np.ndarray, extent: float, seed: int):
    """(p0, n0, flatness): a measured point near the centroid whose neighbourhood is the
    flattest there, its unit normal, and how far from planar that neighbourhood is (the least
    variance of its 8 points over the middle one: 0 on a plane) (``seed``: the inspection's,
    engine.seeds)."""
    measured = measured[spread_subset(measured, 4096, seed)]
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
    return measured[near[best]], vecs[best, :, 0], float(flatness[best])


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


def _icp_batch(T: np.ndarray, src: np.ndarray, tree: cKDTree, pts: np.ndarray,
               nrm: np.ndarray | Callable[[np.ndarray], np.ndarray], spacing: float,
               iterations: int, stop_rad: float = 0.0, lam2: float = 0.0,
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
        # Pairs from scipy's kd-tree; the arithmetic compiled (icp_kernels.icp_paired).
        X = apply_transform(T, src)
        dist, j = query(tree, X.reshape(-1, 3),
                        distance_upper_bound=reach)
        far = ~np.isfinite(dist).reshape(H, m)
        j = np.minimum(j, pts.shape[0] - 1).reshape(H, m)
        n = nrm(j) if callable(nrm) else nrm[j]
        update = k < iterations
        if update and stage is not None:
            report(f"{stage[0]}, ICP iteration {k + 1}",
                   stage[1] + (stage[2] - stage[1]) * k / iterations)
        T_next = np.empty_like(T)
        icp_kernels.icp_paired(np.ascontiguousarray(T), np.ascontiguousarray(X), j, far, pts,
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
    """_icp_batch's iterations (without early stop) compiled (icp_kernels.icp_poses), the points
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
    threads = [threading.Thread(target=icp_kernels.icp_poses,
                                args=args + (int(a), int(b), out_T, out_s))
               for a, b in zip(bounds[1:-1], bounds[2:])]
    for t in threads:
        t.start()
    icp_kernels.icp_poses(*args, int(bounds[0]), int(bounds[1]), out_T, out_s)
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


def _best_distinct(T: np.ndarray, score: np.ndarray, src: np.ndarray, keep: int,
                   seed: int) -> np.ndarray:
    """The ``keep`` best-scoring poses (H, 4, 4), skipping any that lands within 1% of the
    measured extent of a better one (poses compared by where they put a few spread points;
    ``seed``: the inspection's, engine.seeds)."""
    ref = src[spread_subset(src, 4, seed)]
    extent = float(np.linalg.norm(src.max(0) - src.min(0)))
    tol = 0.01 * max(extent, 1e-12)
    order = np.argsort(score, kind="stable")
    feat = np.einsum("hij,mj->hmi", T[order, :3, :3], ref) + T[order, None, :3, 3]
    return T[order[icp_kernels.distinct_first(np.ascontiguousarray(feat), tol, keep)]]
