"""The verdict: the tolerance zone's decision rules, the thresholds that decide when the pose can
be trusted, the nominal-sampling margins, the statistics, and the reasons in words.

Decision rules (the paper's L-infinity argument: one point out is a reject):

* ``simple``: ACCEPT only when every measured point lies inside the tolerance zone
  [lower, upper]; REJECT when any point, outliers of the fit included, lies outside.
* ``guarded`` (ISO 14253-1): each point's expanded measurement uncertainty U (k = 2; the
  instrument as stated, the registration's pose uncertainty at the point and the nominal-sampling
  margin, combined by engine.uncertainty) guards the limits: ACCEPT only when every point lies
  inside the zone shrunk by its U (the conformance zone), REJECT only when a point lies outside
  the zone grown by its U (the non-conformance zone), INCONCLUSIVE otherwise.

Whatever the deviations say, the verdict is INCONCLUSIVE when the pose cannot be trusted: the fit
did not converge, fewer than half of the points lie within 1% of the nominal's size of its
surface (the measurement is not of this part), the fit left more than a tenth of the points out
of the alignment as gross outliers (mis-probes are rarer; a wrong pose leaves good points off
the part to fit the rest), or another pose the registration found fits better than the one it
reports (it is not the best fit; engine.registration reports the best, so this is a safety
net). It is INCONCLUSIVE too when the verdict depends on a pose the measurement does not fix:
when moving the part along a direction the measured points leave unconstrained (within +-3
sigma of the pose's uncertainty, or far along a free direction) or to another pose that fits
about as well changes the verdict (engine.pose_sensitivity). A weak or free direction along
which the verdict holds (a cylinder measured all round, slid along its axis) and a runner-up at
which it is the same are reported, in plain words, and the verdict stands.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from .choices import DecisionRule, Verdict
from .nominal import Nominal
from .seeds import DEFAULT_SEED, rng
from .tolerance import Tolerance

if TYPE_CHECKING:
    from .pose_sensitivity import PoseSensitivity

ACCEPT, REJECT, INCONCLUSIVE = Verdict.ACCEPT, Verdict.REJECT, Verdict.INCONCLUSIVE
MIN_NEAR_FRACTION = 0.5
MAX_LEFT_OUT_FRACTION = 0.1
"""A pose whose fit leaves more than this fraction of the points out of the alignment as gross
outliers (engine.outliers: each far off and alone among its neighbours) cannot be trusted:
mis-probes are rarer (the sweep's 2% of 2,000 points planted millimetres off: 31-38 left out at
the right pose), and a pose that puts good points off the part leaves them out to fit the rest
(NIST CTC-01 (AP242), a 90-point patch 313 mm off the truth, issue 21: 21 points left out,
0.1-16 mm off, and a confident REJECT of a perfect part). More than LEFT_OUT_ALLOWED too: a
mis-probe or two among a few points (one of 9) leaves the verdict to the points, as ever."""
LEFT_OUT_ALLOWED = 2
DECISION_RULES = tuple(r.value for r in DecisionRule)


@dataclass(frozen=True)
class Statistics:
    """Statistics of the signed deviations over all measured points (outliers included), mm."""

    count: int
    min: float
    max: float
    mean: float
    std: float
    rms: float
    max_abs: float
    n_out: int
    fraction_in: float
    worst: tuple[int, ...]
    """Indices of up to 10 points farthest outside (or nearest to leaving) the zone, worst first."""

    @classmethod
    def of(cls, d: np.ndarray, tol: Tolerance, n_worst: int = 10) -> "Statistics":
        ex = tol.excess(d)
        out = ex > 0
        worst = np.argsort(-ex, kind="stable")[:n_worst]
        return cls(count=int(d.size), min=float(d.min()), max=float(d.max()),
                   mean=float(d.mean()), std=float(d.std()),
                   rms=float(np.sqrt(np.mean(d * d))), max_abs=float(np.abs(d).max()),
                   n_out=int(out.sum()), fraction_in=float(1.0 - out.mean()),
                   worst=tuple(int(i) for i in worst))


RESOLUTION_OF_ZONE = 0.25
"""A weak direction whose implied 1-sigma motion exceeds this fraction of the zone width leaves
the pose undetermined at the scale of the verdict (engine.trust.conditioning)."""
AMBIGUITY_SCORE_RATIO = 1.5
"""A runner-up pose scoring within this factor of the best one is a competitor …"""
AMBIGUITY_DEVIATION = 0.1
"""… and it is a material one when it moves some point's deviation by more than this fraction
of the zone's width."""


AMBIGUITY_POINTS = 16384
AMBIGUITY_SEED = 3
"""The random stream of the points compared beyond ``AMBIGUITY_POINTS`` (engine.seeds)."""
"""Points compared between the chosen and the runner-up pose (seeded subset beyond that): the
difference of two rigid poses' deviations varies smoothly over the part, so a subset spread
over it finds its largest value."""


SCORE_TIE = 1e-6
"""Scores within this fraction of each other are a tie: a runner-up refined on the exact surface
(engine.inspection) that lands on a turn of the chosen pose about a free axis (NIST FTC-11, a
part of revolution: both 0.0170363 mm, 2e-12 mm apart) does not fit better."""


def better_runner_up(reg) -> bool:
    """A distinct runner-up pose that scores better than the chosen one, beyond a tie (and is
    no symmetry of a 2D template): the chosen pose is not the best fit found, and nothing
    judged there stands."""
    return (reg.runner_up_score is not None and not reg.symmetric
            and reg.runner_up_score < (1.0 - SCORE_TIE) * reg.score)


def too_many_left_out(reg) -> int:
    """How many points the pose's fit left out as gross outliers, when that is more than
    MAX_LEFT_OUT_FRACTION of them and more than LEFT_OUT_ALLOWED (0 otherwise)."""
    k = int(np.sum(~np.asarray(reg.inlier, bool)))
    return k if k > max(MAX_LEFT_OUT_FRACTION * np.size(reg.inlier), LEFT_OUT_ALLOWED) else 0


def pose_trusted(reg) -> bool:
    """The pose can be trusted: the fit converged, at least MIN_NEAR_FRACTION of the points lie
    near the nominal, not too many were left out as gross outliers (:func:`too_many_left_out`),
    and no distinct pose found fits better."""
    return bool(reg.converged and reg.near_fraction >= MIN_NEAR_FRACTION
                and not too_many_left_out(reg)
                and not better_runner_up(reg))


def plausible_runner_up(reg) -> bool:
    """A distinct runner-up pose scoring within AMBIGUITY_SCORE_RATIO of the chosen one, and no
    symmetry of a 2D template (which leaves every deviation as it is)."""
    return (reg.runner_up_T is not None and reg.runner_up_score is not None
            and not reg.symmetric
            and reg.runner_up_score <= AMBIGUITY_SCORE_RATIO * reg.score)


def ambiguity(reg, d: np.ndarray, tol: Tolerance, deviations_at,
              seed: int = DEFAULT_SEED) -> tuple[bool, float]:
    """(ambiguous, spread): a nearly-as-good distinct runner-up pose (not a symmetry of a 2D
    template) that moves some deviation by more than a tenth of the zone width.

    deviations_at(T, idx) : signed deviations of measured points ``idx`` at pose T; seed : the
    inspection's (engine.seeds), of the points compared beyond ``AMBIGUITY_POINTS``."""
    if not (pose_trusted(reg) and plausible_runner_up(reg)):
        return False, 0.0
    idx = np.arange(d.size)
    if d.size > AMBIGUITY_POINTS:
        idx = np.sort(rng(seed, AMBIGUITY_SEED).choice(d.size, AMBIGUITY_POINTS, replace=False))
    spread = float(np.max(np.abs(deviations_at(reg.runner_up_T, idx) - d[idx])))
    return spread > AMBIGUITY_DEVIATION * tol.width, spread


MARGIN_NEIGHBOURS = 25
"""Samples around a point that the margin looks at: enough to see the curvature and the spacing
in every direction even where the sampling is 5:1 anisotropic."""


def margins_3d(nominal: Nominal, feet: np.ndarray) -> np.ndarray:
    """Per point, at its nearest nominal sample: max over the principal directions of
    curvature x (sample spacing along that direction)^2 / 8 — how far a chord between
    neighbouring samples sags below the curved surface. The same for every point near a sample,
    wherever its foot lies between them."""
    from .trust import sampling_margin

    _, near = nominal.tree.query(feet)
    near = np.atleast_1d(near)
    uniq, back = np.unique(near, return_inverse=True)
    k = min(MARGIN_NEIGHBOURS, nominal.n)
    S = nominal.shape_operators(uniq, k=k)
    curv, axes = np.linalg.eigh(0.5 * (S + np.swapaxes(S, 1, 2)))
    _, nb = nominal.tree.query(nominal.points[uniq], k=k)
    off = nominal.points[nb.reshape(len(uniq), -1)[:, 1:]] - nominal.points[uniq][:, None, :]
    dist = np.linalg.norm(off, axis=2)
    margin = np.zeros(len(uniq))
    for j in range(3):
        t = axes[:, :, j]
        along = np.abs(np.einsum("mkc,mc->mk", off, t))
        # The spacing along t: the nearest neighbour lying mostly in that direction (none in
        # view: the farthest neighbour, a bound).
        mostly = along >= 0.7 * np.maximum(dist, 1e-300)
        h = np.where(mostly.any(axis=1), np.where(mostly, along, np.inf).min(axis=1),
                     dist.max(axis=1))
        margin = np.maximum(margin, sampling_margin(curv[:, j], h))
    return margin[back]


def judge(d: np.ndarray, tol: Tolerance, reg, weak=(), ambiguous: bool = False,
          spread: float = 0.0, margin: np.ndarray | None = None,
          sensitivity: "PoseSensitivity | None" = None, statements: tuple[str, ...] = ()):
    """Verdict, reasons and per-point in-tolerance mask for deviations ``d`` at pose ``reg``.

    weak : unconstrained directions (engine.trust.WeakDirection); ambiguous : another pose fits
    about as well with deviations up to ``spread`` mm apart; margin : per-point guard band, mm,
    for the guarded decision rule: the expanded uncertainty U (None: the simple rule).
    sensitivity : whether the pointwise verdict holds over the poses the measurement allows
    (engine.pose_sensitivity), with ``statements`` saying so in plain words. Given, a weak
    direction or a runner-up makes the verdict INCONCLUSIVE only when the verdict differs at
    some of those poses (they are reported as facts otherwise); None: any of them does.
    """
    inside = (d >= tol.lower) & (d <= tol.upper)
    reasons = []
    if not reg.converged:
        reasons.append("registration did not converge: " + (reg.message or "no reason given"))
    if reg.near_fraction < MIN_NEAR_FRACTION:
        reasons.append(f"only {100 * reg.near_fraction:.0f}% of the {d.size} points lie within "
                       f"{reg.near_distance:.3g} mm ({reg.near_rule}) of the nominal at "
                       "the best pose found; the pose cannot be trusted")
    k = too_many_left_out(reg)
    if k:
        reasons.append(f"{k} of {d.size} points ({100 * k / d.size:.1f}%) were left out of "
                       "the alignment as gross outliers (each far off and alone among its "
                       f"neighbours); more than {100 * MAX_LEFT_OUT_FRACTION:.0f}% is more than "
                       "mis-probes explain: the pose may leave good points off the part and "
                       "cannot be trusted")
    if better_runner_up(reg):
        reasons.append(f"another pose fits better than the one found (score "
                       f"{reg.runner_up_score:.4g} mm against {reg.score:.4g} mm); the pose "
                       "cannot be trusted")
    if sensitivity is None:
        if ambiguous:
            reasons.append(f"the pose is ambiguous: another pose fits nearly as well (score "
                           f"{reg.runner_up_score:.4g} mm against {reg.score:.4g} mm) and moves "
                           f"deviations by up to {spread:.4g} mm")
        if weak:
            names = "; ".join(f"{w.type} {'along' if w.type == 'translation' else 'about'} "
                              f"({', '.join(f'{a:+.3f}' for a in w.axis)})" for w in weak)
            reasons.append(f"the measured points do not constrain the pose: {names}")
    if reasons:
        return INCONCLUSIVE, tuple(reasons), inside
    verdict, reason = pointwise_verdict(d, tol, margin)
    if sensitivity is not None and not sensitivity.verdict_stable:
        return INCONCLUSIVE, (
            f"the verdict depends on the pose: {verdict} at the fitted pose, but not at every "
            f"pose the measurement allows (deviations change by up to "
            f"{sensitivity.max_change_mm:.4g} mm; the point nearest a limit is "
            f"{abs(sensitivity.min_limit_margin_mm):.4g} mm from it)", *statements), inside
    return verdict, (reason, *statements), inside


def pointwise_verdict(d: np.ndarray, tol: Tolerance,
                      margin: np.ndarray | None = None) -> tuple[str, str]:
    """(verdict, reason) of the decision rule on deviations ``d`` (n,) alone, the pose taken as
    right: the simple rule (margin None) or the guarded one with per-point ``margin`` (n,) mm,
    each point's expanded uncertainty U (engine.uncertainty)."""
    if margin is None:
        n_out = int(((d < tol.lower) | (d > tol.upper)).sum())
        if n_out:
            return REJECT, f"{n_out} of {d.size} points lie outside the tolerance zone"
        return ACCEPT, f"all {d.size} points lie inside the tolerance zone"
    out_grown = (d < tol.lower - margin) | (d > tol.upper + margin)
    in_shrunk = (d >= tol.lower + margin) & (d <= tol.upper - margin)
    if out_grown.any():
        return REJECT, (f"{int(out_grown.sum())} of {d.size} points lie outside the tolerance "
                        "zone by more than their measurement uncertainty U")
    if in_shrunk.all():
        return ACCEPT, (f"all {d.size} points lie inside the tolerance zone by more than their "
                        "measurement uncertainty U")
    k = int((~in_shrunk).sum())
    reason = (f"{k} of {d.size} points lie within their measurement uncertainty U of a "
              "tolerance limit (guarded decision rule, ISO 14253-1): neither conformance nor "
              "non-conformance is proven")
    width = tol.width
    no_room = int((2.0 * np.asarray(margin) >= width).sum())
    if no_room:
        reason += (f"; at {no_room} points 2U ≥ the zone's width {width:.4g} mm: there "
                   "conformance cannot be proven for any part, the measurement is not capable "
                   "of this tolerance")
    return INCONCLUSIVE, reason
