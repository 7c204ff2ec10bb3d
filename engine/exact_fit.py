"""The registration finished on an exact surface (a STEP model's faces,
engine.step_model.ExactDistances): the pose found on the nominal's sample refined by least
squares of the exact deviations (engine.exact_lsq), its runner-up and other candidates judged
the same way, and a pose that scores better kept where one is found: the runner-up, another
candidate, or the pose slid along a direction its points leave free (engine.weak_search)
(:func:`finish_exactly`, which engine.inspection.inspect runs).

The sample's scores carry its chordal error, which on a CAD tessellation can exceed the noise a
hundredfold; on the exact faces the poses compare as they are.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from .exact_lsq import exact_fit, kept_fit
from .nominal import Nominal
from .progress import within
from .registration import covers_part_only, distinct_poses, search_densely
from .registration_types import RegistrationSettings
from .seeds import rng
from .surface import Posed
from .surface_fit import pose_score, robust_cut
from .verdict import SCORE_TIE, better_runner_up, plausible_runner_up
from .weak_search import half_turns, jumped_poses, shifted_poses, slid_poses, twin_turns

SLID_FITS = 3
"""Places found along free directions (engine.weak_search), best first, that the exact least
squares fits at most: each fit costs as much as the pose's own."""


def finish_exactly(reg, posed: Posed, nominal: Nominal, settings: RegistrationSettings,
                   zone_width: float):
    """The registration ``reg`` (on the nominal's sample) finished on the exact surface of
    ``posed``: its pose fitted by the exact least squares (:func:`exact_fit`), its runner-up
    fitted and scored alike (:func:`exact_runner_up`), then a pose that scores better kept
    (:func:`better_pose`): the runner-up, then the registration's other candidates
    (:func:`better_candidates`), then the places engine.weak_search finds.
    zone_width : the tolerance zone's, mm."""
    measured = posed.points
    seed = settings.seed
    scale = settings.outlier_floor * nominal.diagonal
    sample_score = reg.score
    reg = exact_fit(reg, posed, zone_width, seed)
    judged = plausible_runner_up(reg)  # the sample's judgement of both poses
    reg = exact_runner_up(reg, posed, measured, nominal.diagonal, settings.outlier_floor,
                          zone_width, seed)
    # Scored on the exact surface, as every pose compared with it will be, whether or not the
    # runner-up was (the sample's score at the handover pose outlived the fit: NIST CTC-01's
    # patch, 1.29 mm at a pose whose every exact deviation is within 0.01 mm).
    if not judged:
        reg = on_exact_scale(reg, pose_score(
            reg.deviations.signed[_score_points(measured.shape[0], seed)], scale), sample_score)

    def better(reg, starts):
        return better_pose(reg, starts, posed, measured, nominal.diagonal,
                           settings.outlier_floor, zone_width, seed)

    # The runner-up scores better on the exact faces than the pose the sample chose (NIST
    # FTC-07 bowed 1 mm chose a pose 10 mm off, 0.0858 mm exactly, its runner-up at the truth
    # 0.0769 mm): it is fitted on every point, and it is the pose if it still scores better.
    if better_runner_up(reg):
        reg = better(reg, [reg.runner_up_T])
    # Then the registration's other candidates, judged on the exact faces too.
    reg = better(reg, better_candidates(reg, posed, nominal.diagonal, settings.outlier_floor,
                                        zone_width, seed))
    # Then the places the points the pose leaves out say it may be (engine.weak_search).
    return _search_left_out(reg, posed, nominal, settings, zone_width, better)


SEARCH_ROUNDS = 3
"""Rounds of :func:`_search_left_out` at most: a pose found may leave other points out, which
say where to look next (NIST CTC-03's 90-point patch, seed 6305, 6.6 mm off: the first round's
grid of shifts brought it within 1.2 mm, where a direction is weak, and the second round's
slide home)."""


RUNNER_TIGHTER = 1.5
"""A patch's runner-up that leaves points out is searched from (:func:`_search_left_out`) when
the RMS of the points within its robust cut is below the pose's by this factor: two estimates of
one noise from 50-90 points differ by 10-20 % (at the truth, the runner-up's kept points fit at
1.0-1.15 x the pose's RMS on five NIST patches, and searching from each cost 1.2-4.0 s for
nothing), while a look-alike that fits every point of CTC-03's patch (seed 26004) at 0.0046 mm
beat a runner-up slid along the patch's plane that fits 89 of them at 0.0021 mm."""


LEFT_OUT_MARGIN = 0.2
"""A pose that the points left out suggest (a jump or a shift, engine.weak_search) is fitted on
every point only if, fitted on a few (:func:`screened`), it scores better than the pose by
more than this fraction: the poses they stray from score 10-20 x the truth (NIST CTC-03's
90-point patches), while on a face bowed 1 mm its points left out suggest poses that a least
squares brings back where it was, each full fit 0.34 s for nothing (FTC-07, 2,000 points)."""


def _search_left_out(reg, posed: Posed, nominal: Nominal, settings: RegistrationSettings,
                     zone_width: float, better):
    """``reg`` with the pose that scores best of those where the points the pose leaves out
    meet the nominal (``better``: finish_exactly's better_pose): the pose slid along a direction
    the points fitting it leave free (:func:`engine.weak_search.slid_poses`), jumped along the
    others' normals onto the nominal (``jumped_poses``), shifted to where they fit too
    (``shifted_poses``); again from a pose found, ``SEARCH_ROUNDS`` at most; on a patch (as the
    grid of shifts), from the runner-up too when it may be nearer (:func:`_runner_up_to_search`);
    and when the pose calls some points gross outliers, the other candidates fitted on every
    point (:func:`_from_other_candidates`).
    The points left out: the gross outliers of the fit, and the points it kept beyond the
    robust cut of its deviations. (CTC-03's patch, seed 6105: its exact least squares stalled
    1.23 mm from the truth along a free direction, 28 edge points 0.06-1.2 mm off and kept, rms
    0.18 mm against the truth's 0.002 mm; the other 571 leave that direction wholly free.)"""
    measured = posed.points
    scale = settings.outlier_floor * nominal.diagonal

    def fitting(reg) -> np.ndarray:
        d = reg.deviations.signed
        return reg.inlier & (np.abs(d) <= robust_cut(d[reg.inlier], settings.outlier_sigmas,
                                                     scale))

    # A pose a few millimetres off with all but a few points at the noise is a patch's trap: a
    # whole part's features pin the pose, and a look-alike leaves many points off. The grid of
    # shifts costs 0.4-0.8 s where points lie millimetres off (bench_sweep's gross outliers and
    # bumps on whole parts), so it is only searched for a patch.
    patch = covers_part_only(measured, nominal.level(settings.coarse_size)[0], settings)

    def worth(r, starts):
        return screened(r, starts, posed, nominal.diagonal, settings.outlier_floor,
                        zone_width, settings.seed, LEFT_OUT_MARGIN)

    searches = (
        lambda r: slid_poses(nominal, measured, r.T_nominal_measured, r.deviations, fitting(r),
                             r.rms, posed.surface, scale)[:SLID_FITS],
        lambda r: worth(r, jumped_poses(measured, r.T_nominal_measured, r.deviations,
                                        fitting(r), posed.surface, scale)),
        # The costliest last: a grid of shifts, scored on the exact faces.
        lambda r: worth(r, shifted_poses(nominal, measured, r.T_nominal_measured,
                                         r.deviations, fitting(r), posed.surface, scale)
                        if patch else []))

    def rounds(r):
        for _ in range(SEARCH_ROUNDS):
            start = r.T_nominal_measured
            for search in searches:
                r = better(r, search(r))
            if r.T_nominal_measured is start:
                break
        return r

    reg = rounds(reg)
    # The runner-up may rest near a pose that fits every point, however it scores.
    there = _runner_up_to_search(reg, posed, bool(fitting(reg).all()), settings.outlier_sigmas,
                                 scale) if patch and reg.runner_up_T is not None else None
    if there is not None:
        found = rounds(exact_fit(replace(reg, T_nominal_measured=reg.runner_up_T,
                                         deviations=there), posed, zone_width, settings.seed))
        reg = better(reg, [found.T_nominal_measured])
    # Points off the part still (gross outliers, not a defect's region), on a patch: the pose
    # may be a look-alike, and a candidate the screen's few points could not lead home may come
    # home on every point, or the search with denser anchors find one. (A defect's region is no
    # gross outlier: a 0.5 mm bump on 600-point patches of five NIST parts costs nothing here.
    # On the nominal's sample, right poses of patches call points gross outliers, its chordal
    # error: 4-9 of CTC-05's 90 at the truth.)
    if patch and not reg.inlier.all():
        reg = _from_other_candidates(reg, posed, nominal, settings, zone_width, better,
                                     fitting(reg))
    # A twin tied with the pose: a third turn about their axis may fit better (twin_turns).
    if patch and _tied_twin(reg):
        reg = better(reg, twin_turns(nominal, measured, reg.T_nominal_measured,
                                     reg.deviations, reg.runner_up_T, posed.surface, scale)[:1])
    return reg


def _runner_up_to_search(reg, posed: Posed, pose_fits: bool, sigmas: float, scale: float):
    """The deviations at ``reg``'s runner-up when :func:`_search_left_out` should fit it and
    search from it, else None: when the pose leaves points out (not ``pose_fits``), or when
    the runner-up leaves points out beyond its robust cut (``sigmas``, never below ``scale``)
    while those within it fit ``RUNNER_TIGHTER`` x tighter than the pose's.

    (NIST CTC-03's 90-point patch, seed 11305: the pose 313 mm off, 0.052 mm exactly, 6 points
    out; the runner-up 0.49 mm from the truth, 0.174 mm on the sample, its chordal error, so
    never fitted on the exact faces; fitted and searched from, it comes home, 0.0018 mm.
    CTC-01 (AP242), seed 9455: the pose 643 mm off, 0.096 mm, 8 points out; the runner-up
    3.25 mm off at 1.30 mm, 13 x, comes home. With denser anchors from the start, FTC-07's seed
    6305: a look-alike 220 mm off chosen, the runner-up 5.0 mm off, slid home. CTC-03's
    90-point patch, seed 26004: a look-alike 393 mm off, rms 0.0046 mm, none out; the runner-up
    4.8 mm off, 89 points at 0.0021 mm, one 0.6 mm off, slid along the patch's plane; searched
    from, it slides home.)"""
    there = posed.at(reg.runner_up_T)[1]
    if not pose_fits:
        return there
    d = there.signed
    kept = np.abs(d) <= robust_cut(d, sigmas, scale)
    if kept.all() or RUNNER_TIGHTER * float(np.sqrt(np.mean(d[kept] ** 2))) >= reg.rms:
        return None
    return there


def _tied_twin(reg) -> bool:
    """The runner-up of ``reg`` scores as its pose does, to SCORE_TIE: a twin (the part
    repeats about the axis between them)."""
    return (reg.runner_up_T is not None and reg.runner_up_score is not None
            and abs(reg.runner_up_score - reg.score) <= SCORE_TIE * reg.score)


def _from_other_candidates(reg, posed: Posed, nominal: Nominal,
                           settings: RegistrationSettings, zone_width: float, better,
                           fits: np.ndarray):
    """``reg`` with the pose that one of the registration's other candidates, the pose turned
    half way about an axis (:func:`half_turns`), or the answer, runner-up or a candidate
    of its search with denser anchors (engine.registration.search_densely), distinct from the pose
    and its runner-up, reaches and that scores better (taken as better_pose takes one,
    :func:`_adopted`): each fitted by the exact least squares on every point, not on the
    screen's few (:func:`better_candidates`), which may not lead a pose tens of millimetres off
    home; when none scores better, the places near the best of them (:func:`_near_fitted`;
    ``fits``: the pose's points that fit).

    (NIST CTC-05 (AP242), its 600-point patch, seed 8855: the pose 372 mm off, 0.051 mm
    exactly, 19 points out; candidates 28.5 and 20.6 mm off stalled 27.4 and 15.2 mm off on the
    screen's 128 points, 0.17 and 0.14 mm; fitted on all 600, each comes home, 0.0020 mm,
    0.13 s. CTC-05 (AP242), seed 5555: search_densely's answer comes home. FTC-08 (AP242),
    its 90-point patch, seed 5455: the pose 279 mm off, 0.054 mm, 12 points out; its one
    candidate, 1.53 mm off, fits to 1.33 mm off at 0.25 mm, turned 2° with a flange's
    underside on its top face, every point within its robust cut of 2.4 mm; 12 points lie at
    the noise along the hinge, and turned about it, the pose comes home.)"""
    measured = posed.points
    scale = settings.outlier_floor * nominal.diagonal
    idx = _score_points(measured.shape[0], settings.seed)
    score = pose_score(reg.deviations.signed[idx], scale)
    known = [T for T in (reg.T_nominal_measured, reg.runner_up_T) if T is not None]
    found = list(known)  # the poses the registration itself came to
    fitted = []

    def fit(starts, against=known):
        for T in starts:
            if not all(distinct_poses(T, K, measured, nominal.diagonal) for K in against):
                continue
            f = exact_fit(replace(reg, T_nominal_measured=T, deviations=posed.at(T)[1]),
                          posed, zone_width, settings.seed)
            known.append(T)  # (register's own second search may have found it already)
            fitted.append((pose_score(f.deviations.signed[idx], scale), f))
            if fitted[-1][0] < (1.0 - SCORE_TIE) * score:
                return fitted[-1]
        return None

    # The candidates first; the search again (0.1-0.3 s on the NIST patches) only when none
    # comes home.
    home = fit(reg.candidates or ())
    if home is None:
        home = fit(half_turns(nominal, reg.T_nominal_measured, measured))
    if home is None:
        with within(0.8, 0.8):  # its stages named, the bar held where registration left it
            again = search_densely(nominal, measured, settings, zone_width)
        # Its answer, its runner-up and its other candidates, each fitted unless the
        # registration came to it: the sample's chordal error may rank the truth second or
        # lower (NIST FTC-07's 90-point patch, seed 12705, noise 10 µm: the answer, the pose
        # 10.2 mm off again; its runner-up 0.06 mm off, within 1 % of the patch's extent of a
        # candidate that stalls 5.4 mm off. Seed 26003: the answer 145 mm off, the runner-up
        # the pose, and a candidate 0.07 mm from the truth).
        home = fit([T for T in (again.T_nominal_measured, again.runner_up_T) if T is not None]
                   + list(again.candidates), found)
    if home is not None:
        return _adopted(reg, score, home[1], home[0], posed, measured[idx], idx, scale,
                        nominal.diagonal)
    return _near_fitted(reg, [f for _, f in sorted(fitted, key=lambda c: c[0])], posed,
                        nominal, settings, zone_width, better, fits)


def _near_fitted(reg, fitted: list, posed: Posed, nominal: Nominal,
                 settings: RegistrationSettings, zone_width: float, better, fits: np.ndarray):
    """``reg`` with a better pose found near the best ``NEAR_FITTED`` of the ``fitted``
    candidates (best first), taken as :func:`better_pose` takes one: each slid a short way
    along the directions its points at the pose's noise leave weak (``fits``: the pose's points
    that fit, whose spread says what the noise is), reaching ``SHORT_SLIDE_REACH`` x the
    largest deviation of a point beyond that noise, if that is near (``SHORT_SLIDE_OF_DIAGONAL``),
    and shifted to where its points left out meet the nominal (engine.weak_search's
    shifted_poses, screened as :func:`_search_left_out` screens them); beyond the best one's
    slide (tried whatever it leaves out, as it was before the others were searched: FTC-08
    (AP242)'s 90-point patch, seed 5455, its candidate 1.33 mm off turned about a hinge of 12
    points at the noise, once slid home so), only a candidate that leaves out at most
    ``NEAR_MORE_OUT`` points more than the pose does. The first that scores better ends it.

    (NIST FTC-07's 90-point patch, seed 26000: the pose a look-alike 136 mm off, 1 point
    3.9 mm out; the candidate the search with denser anchors found 13.8 mm off fits to 8.2 mm
    off along x, 87 points at the noise, 3 out, the third best of the candidates fitted; its
    shifts along x, where the point 4.15 mm out crosses a face, come home, 0.21 s.)"""
    measured = posed.points
    scale = settings.outlier_floor * nominal.diagonal
    cut = robust_cut(reg.deviations.signed[fits], settings.outlier_sigmas, scale)
    start = reg.T_nominal_measured
    distinct: list = []  # (candidates often fit to one pose)
    for f in fitted:
        if all(distinct_poses(f.T_nominal_measured, g.T_nominal_measured, measured,
                              nominal.diagonal) for g in distinct):
            distinct.append(f)
    for rank, f in enumerate(distinct[:NEAR_FITTED]):
        d = np.abs(f.deviations.signed)
        kept = d <= cut
        reach = SHORT_SLIDE_REACH * float(d[~kept].max(initial=0.0))
        few = (np.count_nonzero(kept) >= 6
               and np.count_nonzero(~kept) <= np.count_nonzero(~fits) + NEAR_MORE_OUT)
        if kept.all() or not (few or rank == 0):
            continue
        T = f.T_nominal_measured
        if reach <= SHORT_SLIDE_OF_DIAGONAL * nominal.diagonal:
            rms = float(np.sqrt(np.mean(d[kept] ** 2)))
            reg = better(reg, slid_poses(nominal, measured, T, f.deviations, kept, rms,
                                         posed.surface, scale, reach)[:SLID_FITS])
        if few and reg.T_nominal_measured is start:
            reg = better(reg, screened(f, shifted_poses(nominal, measured, T, f.deviations, kept,
                                                        posed.surface, scale),
                                       posed, nominal.diagonal, settings.outlier_floor,
                                       zone_width, settings.seed, LEFT_OUT_MARGIN))
        if reg.T_nominal_measured is not start:
            return reg
    return reg


NEAR_FITTED = 6
"""Candidates fitted on every point that :func:`_near_fitted` searches near at most, best
first, distinct poses (NIST FTC-07's 90-point patch, seed 19600: the sixth comes home) …"""
NEAR_MORE_OUT = 2
"""… each leaving out at most this many points more than the pose does: a pose with a
mis-probe or two leaves them out, and so does every look-alike, with more of its own (on six
NIST parts' 90-point patches with two mis-probes, the candidates left out 2-84 points; searching
near each of the best six cost 0.5-1.9 s a patch for nothing)."""
SHORT_SLIDE_REACH = 2.0
"""A candidate's short slide (:func:`_near_fitted`) reaches this x the largest deviation of a
point beyond the pose's noise (FTC-08's seed 5455: 3.1 mm, 0.65 s; a whole turn, 8.4 s) …"""
SHORT_SLIDE_OF_DIAGONAL = 0.02
"""… and is tried only when that is within this fraction of the nominal's bounding-box
diagonal: a candidate near the truth. (Look-alikes put points further off: on 90-point
patches with two mis-probes each, the pose right, the fitted candidates of CTC-01, CTC-03,
CTC-05 and FTC-08 needed reaches of 2 % of the diagonal and more; without this limit, they
slid for nothing, 1.4 s on CTC-01 and 0.7 s on CTC-03.)"""


def on_exact_scale(reg, score: float, sample_score: float):
    """``reg`` with ``score``, its pose's exact score, mm, in place of ``sample_score``, the
    sample's; a runner-up that the exact faces did not judge (implausible on the sample) stays
    as far behind the pose as the sample scored it: its score the pose's plus the sample's
    difference. So it never scores better than the pose, and it becomes plausible only if the
    exact score exceeds twice that difference (then it is probed as a competitor). (Its own
    exact score would cost a fit on points that lie off the part: about 1 ms an evaluation
    each. Compared as it was, the sample's score of a runner-up could look better than an exact
    score that the sample's facets had flattered; its ratio to the pose would make it a tie
    with a pose that fits exactly, score 0.)"""
    runner = reg.runner_up_score
    if runner is not None:
        runner = score + max(runner - sample_score, 0.0)
    return replace(reg, score=score, runner_up_score=runner)


EXACT_HANDOVER_ITERATIONS = 8
"""Iterations of the registration's final fit on the nominal's sample before the exact surface
takes over (engine.inspection.inspect with an exact surface)."""
EXACT_SCORE_POINTS = 4096
"""The exact scores of the chosen and the runner-up pose are taken over a seeded random choice of
at most this many points (the registration scores on as many)."""
EXACT_SCORE_SEED = 17
"""The random stream of that choice (engine.seeds)."""
RUNNER_UP_FIT_ITERATIONS = 20
"""Gauss-Newton iterations at most of the runner-up's exact least squares."""


def _score_points(n: int, seed: int, count: int = EXACT_SCORE_POINTS,
                  stream: int = EXACT_SCORE_SEED) -> np.ndarray:
    """The seeded points (indices, sorted) of ``n`` that the exact scores are taken over: all of
    them up to ``count``, else a random choice of ``count`` from random ``stream``."""
    if n <= count:
        return np.arange(n)
    return np.sort(rng(seed, stream).choice(n, count, replace=False))


def exact_runner_up(reg, posed: Posed, measured: np.ndarray, diagonal: float, floor: float,
                    zone_width: float, seed: int):
    """A plausible runner-up (engine.verdict.plausible_runner_up) judged on the exact surface,
    as the chosen pose was: its pose finished by least squares of the exact deviations of the
    points the gross-outlier rule keeps there, then both poses scored (``pose_score`` at
    ``floor`` x the nominal's ``diagonal``) on the same seeded points; a runner-up that the
    finish brings onto the chosen pose is none. The sample's scores carry its chordal error,
    which on a CAD tessellation can exceed the noise a hundredfold: NIST CTC-03's 30% patch scored
    0.065 mm at the right pose and 0.090 mm at one 24 mm away, a near tie; exactly, 0.0019
    against 0.048 mm. An implausible runner-up stays as the sample judged it."""
    if not plausible_runner_up(reg):
        return reg
    idx = _score_points(reg.deviations.signed.size, seed)
    Tr = kept_fit(posed, reg.runner_up_T, idx, reg.gross_rule.floor_mm, zone_width, seed,
                  RUNNER_UP_FIT_ITERATIONS)
    score = pose_score(reg.deviations.signed[idx], floor * diagonal)
    if not distinct_poses(Tr, reg.T_nominal_measured, measured[idx], diagonal):
        return replace(reg, score=score, runner_up_score=None, runner_up_T=None)
    _, dev_r = posed.at(Tr, idx)
    return replace(reg, score=score, runner_up_score=pose_score(dev_r.signed, floor * diagonal),
                   runner_up_T=Tr)


SCREEN_POINTS = 128
"""The registration's other candidates are fitted and scored on the exact surface over a seeded
random choice of at most this many points (:func:`better_candidates`): a point off the exact
faces costs 0.1-1 ms an evaluation."""
SCREEN_SEED = 19
"""The random stream of that choice (engine.seeds)."""
SCREEN_FIT_ITERATIONS = 8
"""Gauss-Newton iterations at most of a candidate's exact least squares on those points."""


def better_candidates(reg, posed: Posed, diagonal: float, floor: float, zone_width: float,
                      seed: int) -> list[np.ndarray]:
    """The registration's other candidate poses (``reg.candidates``) that score better than the
    pose of ``reg`` beyond a tie once fitted on the exact surface, best first: each fitted by
    least squares of the exact deviations of the points the gross-outlier rule keeps there,
    then scored (``pose_score`` at ``floor`` x ``diagonal``) with the pose on the same
    ``SCREEN_POINTS`` seeded points. (NIST FTC-07's 90-point patch, seed 1505: the sample chose
    a pose 283 mm off, 0.024 mm exactly, and ranked a candidate 0.27 mm off the truth third,
    behind a runner-up 151 mm off; fitted exactly, that candidate fits at the noise.)"""
    return screened(reg, reg.candidates, posed, diagonal, floor, zone_width, seed, SCORE_TIE)


def screened(reg, starts, posed: Posed, diagonal: float, floor: float, zone_width: float,
             seed: int, margin: float) -> list[np.ndarray]:
    """The poses ``starts`` that score better than the pose of ``reg`` by more than the fraction
    ``margin`` once fitted on the exact surface, best first: each fitted by least squares of
    the exact deviations of the points the gross-outlier rule keeps there, then scored
    (``pose_score`` at ``floor`` x ``diagonal``) with the pose on the same ``SCREEN_POINTS``
    seeded points."""
    if not starts:
        return []
    idx = _score_points(reg.deviations.signed.size, seed, SCREEN_POINTS, SCREEN_SEED)
    scale = floor * diagonal
    score = pose_score(reg.deviations.signed[idx], scale)
    found = []
    for Tc in starts:
        Tf = kept_fit(posed, Tc, idx, reg.gross_rule.floor_mm, zone_width, seed,
                      SCREEN_FIT_ITERATIONS)
        fitted = pose_score(posed.deviations_at(Tf, idx), scale)
        if fitted < (1.0 - margin) * score:
            found.append((fitted, Tf))
    return [T for _, T in sorted(found, key=lambda f: f[0])]


def better_pose(reg, starts, posed: Posed, measured: np.ndarray, diagonal: float,
                floor: float, zone_width: float, seed: int):
    """The first of the poses ``starts`` that, fitted by the exact least squares
    (:func:`exact_fit`), scores better than the pose of ``reg`` beyond a tie on the seeded
    points of the exact scores: it becomes the pose, and the runner-up is the better of the pose
    it replaces and the runner-up found before, of those distinct from it (none: no runner-up).
    ``reg`` as it is when none does. (A better pose need not be distinct: CTC-03's patch, seed
    6105, stalled 1.23 mm from the truth, within the 1% of the points' extent that tells poses
    apart.)"""
    if not starts:
        return reg
    scale = floor * diagonal
    idx = _score_points(measured.shape[0], seed)
    score = pose_score(reg.deviations.signed[idx], scale)
    for Ts in starts:
        best = exact_fit(replace(reg, T_nominal_measured=Ts, deviations=posed.at(Ts)[1]),
                         posed, zone_width, seed)
        best_score = pose_score(best.deviations.signed[idx], scale)
        if best_score < (1.0 - SCORE_TIE) * score:
            return _adopted(reg, score, best, best_score, posed, measured[idx], idx, scale,
                            diagonal)
    return reg


def _adopted(reg, score: float, best, best_score: float, posed: Posed, src: np.ndarray,
             idx: np.ndarray, scale: float, diagonal: float):
    """``best`` (an exact fit scoring ``best_score`` on the points ``idx``, ``src`` where they
    were measured) as the pose in place of that of ``reg`` (scoring ``score``), its runner-up
    the better of that pose and the runner-up of ``reg`` distinct from it (:func:`better_pose`)."""
    others = [(score, reg.T_nominal_measured)]
    if reg.runner_up_T is not None:
        # Scored again as the others are (an implausible runner-up's score is the sample's
        # difference from the pose, engine.exact_fit.on_exact_scale, not its own).
        others.append((pose_score(posed.deviations_at(reg.runner_up_T, idx), scale),
                       reg.runner_up_T))
    others = [(s, T) for s, T in others
              if distinct_poses(T, best.T_nominal_measured, src, diagonal)]
    runner_score, runner_T = min(others, key=lambda o: o[0], default=(None, None))
    return replace(best, score=best_score, runner_up_T=runner_T, runner_up_score=runner_score)
