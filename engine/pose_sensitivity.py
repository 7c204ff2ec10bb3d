"""Whether the verdict survives the pose's uncertainty (the conditioning it starts from is
engine.trust).

* :func:`pose_sensitivity`: the part moved along each weak direction (exact screw motions,
  +-3 sigma), scanned along each free one out to where the points stop fitting, moved to the edge
  of the full uncertainty region for each point near a limit (:func:`uncertainty_poses`) and to
  the runner-up pose, every deviation that can cross a limit evaluated exactly there;
* :func:`trust_statements` says in plain words what the measurement does not fix.

Shapes: points and normals are (n, 3) in 3D, (n, 2) for a 2D template (3 degrees of freedom:
the rotation about z and the two translations). Units mm; directions in the nominal frame.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from .choices import Verdict
from .pose import largest_speed, screw_motion
from .seeds import DEFAULT_SEED, rng
from .trust import Conditioning, WeakDirection


# ---------------------------------------------------------------------------- pose sensitivity
PROBE_SIGMAS = (1.5, 3.0)
"""A weak direction with a finite 1-sigma motion is probed at +- these multiples of it (the
outer one is the uncertainty region; the inner one catches a deviation that rises and falls
again within it)."""
FREE_REACH = 0.5
"""A free direction (no finite sigma) is probed up to this fraction of the fitted points' RMS
radius ``Conditioning.length`` (a translation in mm; a rotation by that arc at the RMS radius:
0.5 rad, about 29 degrees) — far enough to matter at the part's scale, short enough to keep the
points on the nominal they were measured on (a cylinder measured over 60% of its length)."""
FREE_FIRST = 0.01
"""A free direction is scanned outward from the fitted pose, each way, starting at this
fraction of that reach, …"""
FREE_GROWTH = 1.5
"""… each step at most this factor of the amplitude reached, and shorter where the deviations
change: short enough that, changing at FREE_SAFETY times the fastest rate seen so far, none
reaches a limit within it. A step onto a pose where the points stop fitting is halved, down to
FREE_RESOLUTION, so the scan ends next to where they stop fitting: a point that slides onto a
neighbouring face (the flat of a D-shaft) leaves the zone there, before the RMS gives way."""
FREE_SAFETY = 2.0
FREE_RESOLUTION = 0.1
"""The scan's finest step: the motion that moves the fastest point by this fraction of the zone
width."""
FREE_MAX_STEPS = 200
"""Poses tried at most each way along a free direction (the statement says how far it got)."""
INVARIANT_FRACTION = 0.02
"""A free direction is one the deviations are invariant along when no probe changes any
deviation by more than this fraction of the zone width (the nominal's sampling moves them by a
few micrometres at most)."""
PLAUSIBLE_RMS_RATIO = 1.5
"""A pose along a free direction is one the measurement allows only while the points still fit
there: the RMS of their deviations at most this factor (the runner-up's score ratio, see
engine.inspection) of the chosen pose's, plus INVARIANT_FRACTION of the zone width, and no
point that lay over the nominal carried past its border. Slid past the end of a cylinder, or
rotated into a sphere's unsampled pole, they do not: such a pose is not a place the part could
be (the points were measured on the nominal), and its verdict does not count."""
SENSITIVITY_POINTS = 16384
"""Points evaluated at every probed pose at most (a seeded subset beyond), for the RMS and the
scan's steps. The verdict at a probed pose is completed exactly for every other point that
the motion displaces by at least its distance to a limit (a deviation cannot change by more
than the point's displacement), so that it holds for every point: at every weak direction's
probe and the runner-up, and along a free direction at the first pose scanned beyond
FREE_EVERY_POINT of the reach and the farthest pose reached each way (on a large cloud every
point can move that far: checking every point at every scanned pose would cost the whole
cloud's deviations 20-odd times per direction)."""
SUBSET_SEED = 7
"""The random stream of that subset (engine.seeds)."""
FREE_EVERY_POINT = 0.1


UNCERTAINTY_SUBSET = 512
"""Points evaluated at each pose of the uncertainty region at most (a seeded part of the
SENSITIVITY_POINTS subset), for the largest change; the verdict there is completed exactly for
every other point the motion could carry across a limit, as at every probed pose. The region's
poses move points by micrometres, so few need it, and there are up to UNCERTAINTY_POINTS of
them: evaluating every point at each cost 29 exact evaluations of 2,000 points on the NIST
FTC-07 part with a bowed face, 2.5 s."""
REGION_SEED = 13
"""The random stream of that part (engine.seeds)."""
REJECT_SUBSET = 64
"""At a pose of the uncertainty region where a point outside the zone stays outside (it lies
farther beyond a limit than the pose moves it), the verdict is REJECT whatever the others do;
the largest change is then taken over this many of the UNCERTAINTY_SUBSET points (NIST FTC-08
with its largest face bowed 1 mm, 2,000 points, 1,072 out: 32 poses, 0.83 s of its 2.7 s
with all 512 and every point near a limit completed)."""


@dataclass(frozen=True)
class PoseProbe:
    """The part moved along one weak or free direction, or to the runner-up pose."""

    kind: str
    """"translation", "rotation", "runner-up" or "uncertainty" (the poses of
    :func:`uncertainty_poses`, one per point near a limit)."""
    axis: tuple[float, ...] | None
    """The direction (WeakDirection.axis); None for the runner-up."""
    free: bool
    """No finite 1-sigma motion: the measurement does not determine the pose along it at all."""
    amplitudes: tuple[float, ...]
    """The motions probed, mm at the fitted points' RMS radius (a rotation's angle is this over
    ``PoseSensitivity.length_mm``); () for the runner-up."""
    max_change_mm: float
    """Largest |deviation change| of any point evaluated, over the plausible poses probed."""
    verdicts: tuple[str, ...]
    """The pointwise verdict at each probed pose (one for the runner-up)."""
    invariant: bool
    """No deviation changes by more than INVARIANT_FRACTION of the zone width (plausible
    poses)."""
    plausible: tuple[bool, ...] = ()
    """Per probed pose: the points still fit there (always, within +-3 sigma of a weak
    direction; see PLAUSIBLE_RMS_RATIO for a free one). Only these count."""
    through: tuple[float, ...] | None = None
    """A rotation: a point of its axis (nominal frame, mm)."""
    sigma_mm: float | None = None
    """WeakDirection.sigma_mm (None: free or the runner-up)."""
    ends: tuple[bool, ...] = ()
    """A free direction, per side (negative, positive amplitudes): True where the scan ended
    next to where the points stop fitting (False: at the reach FREE_REACH, at a changed verdict,
    or after FREE_MAX_STEPS)."""
    every_point: tuple[bool, ...] = ()
    """Per probed pose: its verdict is that of every point (else of the SENSITIVITY_POINTS
    subset: between the scan's checks of every point, see FREE_EVERY_POINT)."""


@dataclass(frozen=True)
class PoseSensitivity:
    """Whether the verdict holds over the poses the measurement allows.

    The verdict is stable when the pointwise verdict (every point inside / some outside, with
    the guarded rule's margins) is the same at every probed pose and at the plausible runner-up
    pose as at the chosen one.
    """

    probes: tuple[PoseProbe, ...]
    verdict: str
    """The pointwise verdict at the chosen pose."""
    verdict_stable: bool
    max_change_mm: float
    """Largest |deviation change| over all probed poses and the runner-up, mm."""
    min_limit_margin_mm: float
    """Signed distance (mm, positive inside the zone) to its nearest limit of the point closest
    to one: a point can change the verdict only if the pose moves it by more than this."""
    worst_margin_mm: float
    """min over points of min(d - lower, upper - d), mm: negative when a point lies outside."""
    points_evaluated: int
    """Points whose deviations were evaluated at the probed poses (all, or the subset and
    those near a limit)."""
    length_mm: float = 0.0
    """The fitted points' RMS radius (the rotations' scale)."""


def _axis_point(twist, centre, length: float) -> tuple[float, ...]:
    """The point of a rotation twist's screw axis nearest the nominal's origin (nominal frame,
    mm): the axis passes through c + (w x v) / |w|^2."""
    v = np.asarray(twist, float)
    c = np.asarray(centre, float)
    if c.size == 3:
        w, t = v[:3] / length, v[3:]
        p = c + np.cross(w, t) / max(float(w @ w), 1e-300)
        a = w / max(float(np.linalg.norm(w)), 1e-300)
        p = p - a * float(a @ p)
    else:
        th, t = v[0] / length, v[1:]
        p = c + np.array([-t[1], t[0]]) / (th if th else 1e-300)
    return tuple(float(a) for a in p)


def pose_sensitivity(deviations_at: Callable, T: np.ndarray, d: np.ndarray, lower: float,
                     upper: float, cond: Conditioning, verdict_of: Callable[[np.ndarray], str],
                     margin: np.ndarray | None = None, alternatives=(),
                     max_points: int = SENSITIVITY_POINTS,
                     points: np.ndarray | None = None,
                     beyond_at: Callable | None = None, region=(),
                     seed: int = DEFAULT_SEED) -> PoseSensitivity:
    """Does the verdict survive the pose's uncertainty?

    deviations_at(T', idx) : (len(idx),) signed deviations (mm) of measured points ``idx`` at
        pose T' (the same kind of transform as ``T``: 4x4 measured -> nominal, or the 3x3 2D
        one), exactly (the flow's own deviation function).
    T, d : the chosen pose and the (n,) deviations there.
    cond : the fit's conditioning; each weak direction is probed by the exact screw motion
        along it (``WeakDirection.twist``) applied in the nominal frame before ``T``, at
        +-PROBE_SIGMAS x its sigma (capped at the free reach); a free one is scanned outward
        both ways from the fitted pose (FREE_FIRST, FREE_GROWTH, FREE_SAFETY, FREE_RESOLUTION)
        up to FREE_REACH x ``cond.length`` or to where the points stop fitting: their RMS above
        PLAUSIBLE_RMS_RATIO x the fitted one's (+ INVARIANT_FRACTION of the zone), or a point
        whose deviation changes (its pointwise verdict, or by INVARIANT_FRACTION of the zone)
        carried past the nominal's border. The verdict is checked at every step.
    verdict_of(d') : the pointwise verdict (the decision rule) of (n,) deviations d'; "REJECT"
        as soon as one point is out, whatever the others (both rules of engine.verdict).
    margin : (n,) guarded-rule margins (None: the simple rule): their limits count as limits.
    alternatives : other plausible poses (the runner-up), each judged as a whole.
    points : (n, 3) or (n, 2) the measured points at pose T (nominal frame, mm). With more
        than ``max_points`` points, a seeded subset is evaluated at every pose and, given
        ``points``, every other point that the motion displaces by at least its distance to a
        value where its pointwise verdict changes (a deviation, a distance to the nominal,
        cannot change by more than the point's displacement); without ``points``, every point.
        The verdict at every probed pose is thus that of every point.
    beyond_at(T', idx) : optional, (len(idx),) bool: the points lie past the nominal's border
        at pose T' (their closest point on it, not over the surface; see engine.inspection).
    region : poses on the edge of the pose's uncertainty region (:func:`uncertainty_poses`),
        judged together as one probe of kind "uncertainty".
    seed : the inspection's (engine.seeds), of the seeded subsets.
    """
    d = np.asarray(d, float)
    n = d.size
    signed = np.minimum(d - lower, upper - d)
    closest = float(signed[np.argmin(np.abs(signed))]) if n else 0.0
    worst = float(signed.min()) if n else 0.0
    base = verdict_of(d)
    weak = [w for w in cond.weak if w.twist]
    if not (weak or len(alternatives) or len(region)) or n == 0:
        return PoseSensitivity((), base, True, 0.0, closest, worst, 0, cond.length)
    judge = _PoseJudge(deviations_at, verdict_of, beyond_at, T, d, base, lower, upper, margin,
                       points, max_points, seed)
    probes = [_direction_probe(judge, w, cond) for w in weak]
    probes += [_runner_up_probe(judge, Ta) for Ta in alternatives]
    if len(region):
        probes.append(_uncertainty_probe(judge, region))
    stable = all(v == base for p in probes for v, o in zip(p.verdicts, p.plausible) if o)
    return PoseSensitivity(tuple(probes), base, stable, max(p.max_change_mm for p in probes),
                           closest, worst, int(judge.seen.sum()), cond.length)


class _PoseJudge:
    """The pointwise verdict of all n measured points at a probed pose, for
    :func:`pose_sensitivity`: a seeded subset (at most ``max_points``, all when fewer) is
    evaluated at every pose, and on request every other point the motion could carry across
    a cut, so that the verdict is that of every point.

    d : (n,) deviations (mm) at the chosen pose ``T``; base : their pointwise verdict.
    cuts : the four (n,) values where a point's pointwise verdict changes (the limits, each
        -+ the guarded rule's margin; margin None: 0); dist : (n,) each point's distance to
        its nearest cut at T (mm); width : the zone width (mm).
    idx : (k,) indices of the subset (full: all n); seen : (n,) bool, the points evaluated at
        some pose.
    fit_rms : the subset's deviation RMS (mm) above which the points no longer fit
        (PLAUSIBLE_RMS_RATIO, INVARIANT_FRACTION).
    points : (n, 3) or (n, 2) measured points at pose T (nominal frame, mm), or None.
    """

    def __init__(self, deviations_at: Callable, verdict_of: Callable[[np.ndarray], str],
                 beyond_at: Callable | None, T: np.ndarray, d: np.ndarray, base: str,
                 lower: float, upper: float, margin: np.ndarray | None,
                 points: np.ndarray | None, max_points: int, seed: int):
        n = d.size
        self.deviations_at, self.verdict_of, self.beyond_at = deviations_at, verdict_of, beyond_at
        self.d, self.base = d, base
        self.width = upper - lower
        m = np.zeros(n) if margin is None else np.asarray(margin, float)
        self.cuts = (lower - m, lower + m, upper - m, upper + m)
        self.dist = self.to_limit(d)
        if n <= max_points:
            self.idx = np.arange(n)
        else:
            self.idx = np.sort(rng(seed, SUBSET_SEED).choice(n, max_points, replace=False))
        self.region_idx = self.idx if self.idx.size <= UNCERTAINTY_SUBSET else np.sort(
            rng(seed, REGION_SEED).choice(self.idx, UNCERTAINTY_SUBSET, replace=False))
        self.seen = np.zeros(n, bool)
        self.seen[self.idx] = True
        self.seed = seed
        self._out: tuple[np.ndarray, np.ndarray] | None = None  # stays_out's points, gaps
        rms0 = float(np.sqrt(np.mean(d[self.idx] ** 2)))
        self.fit_rms = PLAUSIBLE_RMS_RATIO * rms0 + INVARIANT_FRACTION * self.width
        self.T = np.asarray(T, float)
        self.T_inv = np.linalg.inv(self.T)
        self.points = None if points is None else np.asarray(points, float)
        self.cat0 = self.category(d)
        self.full = self.idx.size == n

    def stays_out(self, P) -> bool:
        """Some point lies beyond a limit (the outer cut) at the chosen pose by more than pose P
        moves it: it is out at P too (a deviation cannot change by more than the point's
        displacement), and the verdict there is REJECT whatever the others do. Points past the
        nominal's border do not count: there the deviation's sign can flip."""
        if self._out is None:
            gap = np.maximum(self.cuts[0] - self.d, self.d - self.cuts[3])
            out = np.flatnonzero(gap > 0)
            if self.beyond_at is not None and out.size:
                out = out[~np.asarray(self.beyond_at(self.T, out), bool)]
            self._out = (out, gap[out])
        out, gap = self._out
        if self.points is None or not out.size:
            return False
        return bool(np.any(self.displacement(P, out) < gap))

    def displacement(self, P, idx=slice(None)) -> np.ndarray:
        """How far pose P moves the points ``idx`` (all by default) from pose T, mm (the
        points given)."""
        assert self.points is not None
        X = self.points[idx]
        G = P @ self.T_inv  # the motion, nominal frame
        k = X.shape[1]
        return np.linalg.norm(X @ G[:k, :k].T + G[:k, k] - X, axis=1)

    def to_limit(self, dd, sel=slice(None)):
        """Distance of each point to the nearest value where its pointwise verdict changes."""
        return np.min(np.abs(np.stack([dd - c[sel] for c in self.cuts])), axis=0)

    def category(self, dd):
        """Which side of each cut a deviation lies: its pointwise verdict's case."""
        return sum((dd > c).astype(np.int8) for c in self.cuts)

    def subset_at(self, P):
        """(the subset's deviations at pose P, their RMS)."""
        dI = np.asarray(self.deviations_at(P, self.idx), float)
        return dI, float(np.sqrt(np.mean(dI ** 2)))

    def with_subset(self, dI, idx=None):
        """(n,) deviations: the subset's ``dI`` (of the points ``idx``, by default the
        subset's), the chosen pose's for every other point."""
        dd = self.d.copy()
        dd[self.idx if idx is None else idx] = dI
        return dd

    def judge_at(self, P, dI, every=True, idx=None):
        """(verdict, largest |change|, a point whose deviation changes there lies past the
        nominal's border) at pose P: the subset's deviations dI (of the points ``idx``, by
        default the subset's), then (``every``) exactly every other point the motion displaces
        by at least its distance to a cut, so the verdict is that of every point."""
        d, X, n = self.d, self.points, self.d.size
        idx = self.idx if idx is None else idx
        dd = self.with_subset(dI, idx)
        v = self.verdict_of(dd)
        if every and idx.size < n and not (v == Verdict.REJECT and self.base != Verdict.REJECT):
            # (One point out makes a REJECT whatever the others do.)
            rest = np.ones(n, bool) if X is None else self.displacement(P) >= self.dist
            rest[idx] = False
            rest = np.flatnonzero(rest)
            if rest.size:
                dd[rest] = self.deviations_at(P, rest)
                self.seen[rest] = True
                v = self.verdict_of(dd)
        # Points whose deviation moved at all (a point past the border measures to its edge).
        changed = np.flatnonzero((self.category(dd) != self.cat0)
                                 | (np.abs(dd - d) > INVARIANT_FRACTION * self.width))
        left = False
        if self.beyond_at is not None and changed.size:
            left = bool(np.any(np.asarray(self.beyond_at(P, changed), bool)
                               & ~np.asarray(self.beyond_at(self.T, changed), bool)))
        return v, float(np.abs(dd - d).max()), left

    def judge_every(self, P):
        """:meth:`judge_at` pose P on every point."""
        return self.judge_at(P, self.subset_at(P)[0], True)


def _moved(T: np.ndarray, w: WeakDirection, amplitude: float,
           cond: Conditioning) -> np.ndarray:
    """Pose ``T`` moved by ``amplitude`` (mm at the RMS radius) along ``w``'s twist, in the
    nominal frame: 4x4, or 3x3 in 2D."""
    return screw_motion(w.twist, amplitude, cond.centre, cond.length) @ T


def _direction_probe(judge: _PoseJudge, w: WeakDirection, cond: Conditioning) -> PoseProbe:
    """The part moved along the weak or free direction ``w``: probed at +-PROBE_SIGMAS x its
    sigma, or scanned both ways when it is free (:func:`_scan_free`)."""
    width = judge.width
    reach = FREE_REACH * cond.length
    through = _axis_point(w.twist, cond.centre, cond.length) if w.type == "rotation" \
        else None
    ends: list[bool] = []
    if w.sigma_mm is not None:  # weak: the uncertainty region, every pose in it counts
        rec = []  # (amplitude, verdict, plausible, largest change, every point)
        for a in sorted({float(s * min(k * w.sigma_mm, reach)) for k in PROBE_SIGMAS
                         for s in (-1, 1)}):
            v, ch, _ = judge.judge_every(_moved(judge.T, w, a, cond))
            rec.append([a, v, True, ch, True])
    else:
        rec, ends = _scan_free(judge, w, cond, reach)
    rec.sort(key=lambda t: t[0])
    mx = max((c for _, _, o, c, _ in rec if o), default=0.0)
    return PoseProbe(w.type, w.axis, w.sigma_mm is None, tuple(r[0] for r in rec),
                     mx, tuple(r[1] for r in rec), mx <= INVARIANT_FRACTION * width,
                     tuple(r[2] for r in rec), through, w.sigma_mm, tuple(ends),
                     tuple(r[4] for r in rec))


def _scan_free(judge: _PoseJudge, w: WeakDirection, cond: Conditioning,
               reach: float) -> tuple[list[list], list[bool]]:
    """Scan the free direction ``w`` outward both ways from the chosen pose, up to ``reach``
    (mm at the RMS radius), to where the points stop fitting, or to a changed verdict
    (FREE_FIRST, FREE_GROWTH, FREE_SAFETY, FREE_RESOLUTION, FREE_MAX_STEPS).

    Returns the poses tried, each [signed amplitude, verdict, plausible, largest change (mm),
    judged on every point], and per side (negative, positive) whether the scan ended next to
    where the points stop fitting."""
    d, idx, X, width = judge.d, judge.idx, judge.points, judge.width
    rec = []  # (amplitude, verdict, plausible, largest change, every point)
    ends: list[bool] = []
    speed = 1.0 if X is None else max(
        largest_speed(w.twist, X[idx], cond.centre, cond.length), 1e-12)
    h_min = FREE_RESOLUTION * width / speed
    for sgn in (-1.0, 1.0):
        a, prev, rate, bad, h = 0.0, d[idx], 0.0, np.inf, FREE_FIRST * reach
        end, checked, last = False, False, None
        for _ in range(FREE_MAX_STEPS):
            if bad - a <= h_min:
                end = True  # next to where the points stop fitting
                break
            a_new = min(a + h, reach, 0.5 * (a + bad))
            P = _moved(judge.T, w, sgn * a_new, cond)
            dI, r = judge.subset_at(P)
            every = judge.full or (not checked and a_new >= FREE_EVERY_POINT * reach)
            v, ch, left = judge.judge_at(P, dI, every) if r <= judge.fit_rms \
                else (None, 0.0, True)
            if left:  # not a pose the part can be in
                rec.append([sgn * a_new, judge.verdict_of(judge.with_subset(dI)), False, 0.0,
                            False])
                bad = a_new
                continue
            checked |= every
            rec.append([sgn * a_new, v, True, ch, every])
            last = (len(rec) - 1, P, dI)
            rate = max(rate, float(np.abs(dI - prev).max()) / (a_new - a))
            prev, a = dI, a_new
            if v != judge.base or a >= reach:
                break
            # The next step may not let the deviations, changing at twice the fastest
            # rate seen so far, carry the point nearest a limit to it; it grows at
            # most geometrically and is never below the resolution.
            near = float(judge.to_limit(dI, idx).min())
            h_rate = near / (FREE_SAFETY * rate) if rate > 0 else np.inf
            h = max(h_min, min(h_rate, (FREE_GROWTH - 1.0) * a))
        if last is not None and not rec[last[0]][4]:
            # The farthest pose reached this way, judged on every point too.
            v, ch, left = judge.judge_at(last[1], last[2], True)
            rec[last[0]][1:] = [v, not left, ch, True]
        ends.append(end)
    return rec, ends


def _runner_up_probe(judge: _PoseJudge, Ta) -> PoseProbe:
    """The part at the runner-up pose ``Ta`` (the same kind of transform as the chosen one),
    judged on every point."""
    P = np.asarray(Ta, float)
    v, ch, _ = judge.judge_every(P)
    return PoseProbe("runner-up", None, False, (), ch, (v,),
                     ch <= INVARIANT_FRACTION * judge.width, (True,), None, None, (), (True,))


def _uncertainty_probe(judge: _PoseJudge, region) -> PoseProbe:
    """The part at each pose of ``region`` (:func:`uncertainty_poses`), judged on every point
    (UNCERTAINTY_SUBSET evaluated, and every point the pose could carry across a limit), as
    one probe."""
    idx = judge.region_idx
    few = idx[:REJECT_SUBSET] if idx.size <= REJECT_SUBSET else np.sort(
        rng(judge.seed, REGION_SEED).choice(idx, REJECT_SUBSET, replace=False))

    def judged_at(P):
        if judge.base == Verdict.REJECT and judge.stays_out(P):
            return (Verdict.REJECT,
                    float(np.abs(judge.deviations_at(P, few) - judge.d[few]).max()), False)
        return judge.judge_at(P, judge.deviations_at(P, idx), True, idx)

    judged = [judged_at(P) for P in region]
    ch = max(j[1] for j in judged)
    return PoseProbe("uncertainty", None, False, (), ch, tuple(j[0] for j in judged),
                     ch <= INVARIANT_FRACTION * judge.width, (True,) * len(judged), None,
                     None, (), (True,) * len(judged))


def _vec(a) -> str:
    return "(" + ", ".join(f"{round(x, 3) + 0.0:+.3f}" for x in a) + ")"  # no "-0.000"


def trust_statements(sens: PoseSensitivity | None, score: float | None = None,
                     runner_up_score: float | None = None) -> tuple[str, ...]:
    """What the measurement does not fix, and what that does to the verdict, in plain words:
    one sentence per weak or free direction and for a plausible runner-up pose that changes
    the deviations, then the nearest point's margin against the largest change."""
    if sens is None:
        return ()
    out = []
    for p in sens.probes:
        ok = p.plausible or (True,) * len(p.verdicts)
        changed = [v for v, o in zip(p.verdicts, ok) if o and v != sens.verdict]
        if p.kind == "uncertainty":
            k = len(p.verdicts)
            head = (f"{k} point{'s lie' if k > 1 else ' lies'} nearer a tolerance limit than 3 "
                    f"standard deviations of what the pose's uncertainty (from the fit's "
                    f"residuals) does to {'their deviations' if k > 1 else 'its deviation'}")
            out.append(head + (f"; at a pose within that uncertainty the verdict would be "
                               f"{changed[0]}, so it depends on the pose" if changed else
                               f"; at the poses 3σ away that move {'them' if k > 1 else 'it'} "
                               f"most towards the limit the verdict is the same"))
            continue
        if p.kind == "runner-up":
            if p.invariant and not changed:
                continue  # the same deviations: an equivalent pose (a symmetry), not news
            head = "another pose fits nearly as well"
            if score is not None and runner_up_score is not None:
                head += f" (score {runner_up_score:.4g} mm against {score:.4g} mm)"
            head += f" and moves deviations by up to {p.max_change_mm:.4g} mm"
            out.append(head + ("; the verdict is the same at both" if not changed else
                               f"; the pose is ambiguous: at that pose the verdict would be "
                               f"{changed[0]}, so it depends on which pose is right"))
            continue
        out.append(_direction_statement(p, changed, ok, sens.length_mm))
    if out:
        where = "inside" if sens.min_limit_margin_mm >= 0 else "outside"
        out.append(f"the point nearest a tolerance limit lies {abs(sens.min_limit_margin_mm):.4g}"
                   f" mm {where} it; the poses the measurement allows change deviations by up "
                   f"to {sens.max_change_mm:.4g} mm")
    return tuple(out)


def _direction_statement(p: PoseProbe, changed: list[str], ok: tuple[bool, ...],
                         length_mm: float) -> str:
    """The sentence for a weak or free direction's probe ``p``: how far the pose along it is
    fixed, how far it was probed, and what that does to the deviations and the verdict.
    changed : the verdicts at its plausible poses (``ok``, per amplitude) that differ from the
    chosen pose's; length_mm : PoseSensitivity.length_mm (the rotations' scale)."""
    reach = max((abs(a) for a, o in zip(p.amplitudes, ok) if o), default=0.0)
    lo = max((-a for a, o in zip(p.amplitudes, ok) if o and a < 0), default=0.0)
    hi = max((a for a, o in zip(p.amplitudes, ok) if o and a > 0), default=0.0)
    scale, unit = (1.0, " mm") if p.kind == "translation" else \
        (np.degrees(1.0 / (length_mm or 1.0)), "°")
    how = f"±{reach * scale:.3g}{unit}"
    stop = ", where the points stop fitting"
    ends = p.ends or (False, False)
    if f"{lo * scale:.3g}" == f"{hi * scale:.3g}" and ends[0] == ends[1]:
        span = "to " + how + (stop if ends[0] else "")
    else:
        span = (f"from −{lo * scale:.3g}{unit}{stop + ',' if ends[0] else ''} to "
                f"+{hi * scale:.3g}{unit}{stop if ends[1] else ''}")
    if p.kind == "translation":
        what, along = f"position along {_vec(p.axis)}", "along"
        every = "position"
    else:
        what = f"orientation about the axis {_vec(p.axis)} through {_vec(p.through)}"
        along, every = "about", "orientation"
    if p.free:
        fixed = f"{what} is not determined by the measured points"
    elif p.sigma_mm is not None and reach < 0.999 * PROBE_SIGMAS[-1] * p.sigma_mm:
        # 3 sigma beyond the free reach: probed as far as a free direction.
        fixed = f"{what} is hardly determined (3σ beyond {how}, the reach probed)"
    else:
        fixed = f"{what} is determined only to {how} (3σ)"
    if changed:
        return (f"the measured points do not constrain the pose: {fixed}; moving the part "
                f"{along} it (probed {span}) changes deviations by up to "
                f"{p.max_change_mm:.4g} mm and the verdict to {changed[0]}")
    elif p.free and p.invariant:
        return (f"{fixed}; the deviations do not change {along} it (probed {span}): "
                f"the verdict is about form and holds for every such {every}")
    elif p.free:
        return (f"{fixed}; moving the part {along} it (probed {span}) changes "
                f"deviations by up to {p.max_change_mm:.4g} mm, but the verdict is the "
                f"same at every {every} probed")
    else:
        return (f"{fixed}; moving the part over that range changes no deviation by "
                f"more than {p.max_change_mm:.4g} mm and the verdict holds over it")
