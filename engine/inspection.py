"""The inspection flow: register → (minimax refit) → measure deviations → judge (engine.verdict
holds the decision rules, thresholds and reasons; engine.trust what the measurement fixes).

Fits: ``lsq`` (least squares of point-to-surface distances over the inliers) or ``minimax`` (the
pose minimising the largest normalised excursion from the zone's centre: "can this part be
placed inside its zone?"), started from the least-squares pose, gross outliers left out of the
objective but judged.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, TypeVar

import numpy as np

from .deviation import Deviations
from .errors import SettingsError
from .choices import DecisionRule, Fit, Verdict
from .fits import FITS, minimax
from .pose import apply_transform, apply_update, lower_along, pose_jacobian
from .nominal import Nominal
from .registration import distinct_poses, pose_score, register
from .registration_types import RegistrationResult, RegistrationSettings
from .seeds import DEFAULT_SEED, rng
from .surface import Posed, SampledSurface
from .tolerance import Tolerance
from .verdict import (DECISION_RULES, RESOLUTION_OF_ZONE, Statistics, ambiguity, judge,
                      plausible_runner_up, pointwise_verdict, pose_trusted)

if TYPE_CHECKING:
    from .surface import Surface
    from .contour import ContourIndex, Deviations2D, Template2D
    from .gdt.results import PlanResult
    from .pose_sensitivity import PoseSensitivity
    from .trust import Conditioning
    from .uncertainty import Instrument, UncertaintyBudget


@dataclass(frozen=True)
class InspectionResult:
    """Everything one inspection produced.

    registered : (n, 3) measured points mapped into the nominal frame by
        ``registration.T_nominal_measured``.
    deviations : signed point-to-surface deviations at ``registered`` (see engine.deviation).
    in_tolerance : (n,) bool.
    """

    verdict: Verdict
    reasons: tuple[str, ...]
    tolerance: Tolerance
    registration: RegistrationResult
    registered: np.ndarray
    deviations: Deviations
    in_tolerance: np.ndarray
    statistics: Statistics
    normals_source: str
    timings_s: dict = field(default_factory=dict)
    extra: dict = field(default_factory=dict)
    """Kind-specific facts for the outputs (2D: the template's contours, symmetry, flatness;
    the minimax fit's excursions)."""
    fit: Fit = Fit.LSQ
    decision_rule: DecisionRule = DecisionRule.SIMPLE
    conditioning: "Conditioning | None" = None
    """How well the points constrain the pose (engine.trust)."""
    ambiguous: bool = False
    """A nearly-as-good runner-up pose moves some deviation by over a tenth of the zone: a fact
    reported; it makes the verdict INCONCLUSIVE only when the verdict differs there
    (``pose_sensitivity``)."""
    ambiguity_spread: float = 0.0
    """Largest deviation change (mm) between the chosen pose and a nearly-as-good runner-up."""
    margin: np.ndarray | None = None
    """(n,) nominal-sampling margin per point, mm (with the guarded decision rule, or when an
    instrument is stated: see ``uncertainty``)."""
    uncertainty: "UncertaintyBudget | None" = None
    """Each point's expanded measurement uncertainty U (k = 2) and its budget
    (engine.uncertainty); the guarded decision rule's guard band. None with the simple rule
    when no instrument is stated."""
    pose_sensitivity: "PoseSensitivity | None" = None
    """Whether the verdict holds over the poses the measurement allows (engine.trust); None
    when the pose cannot be trusted at all (not converged, not this part)."""
    trust_statements: tuple[str, ...] = ()
    """What the measurement does not fix and what that does to the verdict, in plain words
    (engine.pose_sensitivity.trust_statements), for the certificate."""
    plan: "PlanResult | None" = None
    """The inspection plan's outcome (engine.gdt.characteristics), when one was given: then
    ``verdict`` and ``reasons`` are the plan's."""

    @property
    def outlier(self) -> np.ndarray:
        """(n,) bool: points the fit left out as gross outliers (they are judged all the same)."""
        return ~self.registration.inlier


def _check_options(fit: str, decision_rule: str) -> None:
    if fit not in FITS:
        raise SettingsError(f"unknown fit '{fit}'; choose one of {', '.join(FITS)}")
    if decision_rule not in DECISION_RULES:
        raise SettingsError(f"unknown decision rule '{decision_rule}'; choose one of "
                            f"{', '.join(DECISION_RULES)}")


def inspect(nominal: Nominal, measured: np.ndarray, tolerance: Tolerance,
            settings: RegistrationSettings = RegistrationSettings(), fit: Fit = Fit.LSQ,
            decision_rule: DecisionRule = DecisionRule.SIMPLE,
            surface: "Surface | None" = None,
            instrument: "Instrument | None" = None,
            guard: str = "uncertainty") -> InspectionResult:
    """Register ``measured`` (n, 3) to ``nominal`` from any pose and judge it against ``tolerance``
    with the given ``fit`` and ``decision_rule`` (engine.choices; their words are taken too).

    surface : what the deviations are measured on (engine.surface.Surface); None: the nominal's
    own sample (engine.surface.SampledSurface). An exact one (a STEP model's faces,
    engine.step_model.ExactDistances) is the true surface the nominal samples: the
    registration runs on the nominal's sample, its pose is then refined by least squares on the
    exact deviations, and every deviation judged is exact (no nominal-sampling margin).

    instrument : what the user states about the measuring instrument (engine.uncertainty);
    with the guarded rule each point is judged with its expanded uncertainty U (``guard``
    "uncertainty") or, as before uncertainty budgets, its nominal-sampling margin alone
    ("sampling": older certificates re-run)."""
    _check_options(fit, decision_rule)
    fit, decision_rule = Fit(fit), DecisionRule(decision_rule)
    surface = surface or SampledSurface(nominal)
    if surface.exact:
        # The exact least squares finishes the pose: the sample's final fit need only get near
        # it (a CAD tessellation's long facets make it creep, not converge, at its last digits).
        settings = replace(settings, max_final_iterations=min(settings.max_final_iterations,
                                                              EXACT_HANDOVER_ITERATIONS),
                           finish_on_all_points=False)
    t0 = time.perf_counter()
    reg = register(nominal, measured, settings, zone_width=tolerance.width)
    t1 = time.perf_counter()
    posed = Posed(surface, measured)
    extra: dict = {}
    # The flow starts from the registration's last evaluation: every point at its final pose.
    if surface.exact:
        reg = _exact_fit(reg, posed, tolerance.width, settings.seed)
        reg = _exact_runner_up(reg, posed, measured, nominal.diagonal, settings.outlier_floor,
                               tolerance.width, settings.seed)
    T = reg.T_nominal_measured
    dev = reg.deviations
    j = _judge_pose(reg, T, apply_transform(T, measured), dev, posed, tolerance, fit,
                    decision_rule, extra, instrument, guard, settings.seed)
    t2 = time.perf_counter()
    # The all-point deviations are the registration's last evaluation; they are counted as
    # deviation time, not registration time.
    timings = {"register": t1 - t0 - reg.deviation_s,
               "deviation": reg.deviation_s + t2 - t1 - j.sensitivity_s,
               "pose_sensitivity": j.sensitivity_s}
    dev = _of_kind(j.deviations, Deviations)
    if j.T is not reg.T_nominal_measured:
        reg = _with_pose(reg, j.T, dev)
    return InspectionResult(tolerance=tolerance, registration=reg, registered=j.points,
                            deviations=dev,
                            normals_source=surface.normals_source,
                            timings_s=timings, extra=extra, **j.verdict_fields)


EXACT_HANDOVER_ITERATIONS = 8
"""Iterations of the registration's final fit on the nominal's sample before the exact surface
takes over (engine.inspection.inspect with ``exact``)."""
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


def _exact_fit(reg, posed: Posed, zone_width: float, seed: int):
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


EXACT_SCORE_POINTS = 4096
"""The exact scores of the chosen and the runner-up pose are taken over a seeded random choice of
at most this many points (the registration scores on as many)."""
EXACT_SCORE_SEED = 17
"""The random stream of that choice (engine.seeds)."""
RUNNER_UP_FIT_ITERATIONS = 20
"""Gauss-Newton iterations at most of the runner-up's exact least squares."""


def _score_points(n: int, seed: int) -> np.ndarray:
    """The seeded points (indices, sorted) of ``n`` that the exact scores are taken over."""
    if n <= EXACT_SCORE_POINTS:
        return np.arange(n)
    return np.sort(rng(seed, EXACT_SCORE_SEED).choice(n, EXACT_SCORE_POINTS, replace=False))


def _exact_runner_up(reg, posed: Posed, measured: np.ndarray, diagonal: float, floor: float,
                     zone_width: float, seed: int):
    """A plausible runner-up (engine.verdict.plausible_runner_up) judged on the exact surface,
    as the chosen pose was: its pose finished by least squares of the exact deviations of the
    points the gross-outlier rule keeps there, then both poses scored (``pose_score`` at
    ``floor`` x the nominal's ``diagonal``) on the same seeded points; a runner-up that the
    finish brings onto the chosen pose is none. The sample's scores carry its chordal error, which on
    a CAD tessellation can exceed the noise a hundredfold: NIST CTC-03's 30% patch scored
    0.065 mm at the right pose and 0.090 mm at one 24 mm away, a near tie; exactly, 0.0019
    against 0.048 mm. An implausible runner-up stays as the sample judged it."""
    from .outliers import gross_outliers, gross_rule

    if not plausible_runner_up(reg):
        return reg
    n = reg.deviations.signed.size
    idx = _score_points(n, seed)
    _, dev = posed.at(reg.runner_up_T, idx)
    rule = gross_rule(dev.signed, zone_width, reg.gross_rule.floor_mm)
    use = np.zeros(n, bool)
    use[idx[~gross_outliers(dev.signed, dev.foot, rule)]] = True
    Tr = _subset_fit(posed, reg.runner_up_T, use, seed, RUNNER_UP_FIT_ITERATIONS)
    score = pose_score(reg.deviations.signed[idx], floor * diagonal)
    if not distinct_poses(Tr, reg.T_nominal_measured, measured[idx], diagonal):
        return replace(reg, score=score, runner_up_score=None, runner_up_T=None)
    _, dev_r = posed.at(Tr, idx)
    return replace(reg, score=score, runner_up_score=pose_score(dev_r.signed, floor * diagonal),
                   runner_up_T=Tr)


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


@dataclass(frozen=True)
class _Judged:
    """The pose judged: T the final pose (4x4 in 3D, 3x3 in the template plane), points and
    deviations there, the InspectionResult's verdict fields, when the fit ended (perf_counter,
    s) and the time the pose sensitivity took (s)."""

    T: np.ndarray
    points: np.ndarray
    deviations: Deviations | Deviations2D
    verdict_fields: dict
    fitted_at: float
    sensitivity_s: float


D = TypeVar("D", "Deviations", "Deviations2D")


def _of_kind(dev: object, kind: type[D]) -> D:
    """``dev``, checked to be the deviations of the kind (3D or 2D) the inspection measures."""
    if not isinstance(dev, kind):
        raise TypeError(f"{kind.__name__} expected, got {type(dev).__name__}")
    return dev


def _judge_pose(reg, T: np.ndarray, X: np.ndarray, dev, posed: Posed, tol: Tolerance,
                fit: str, decision_rule: str, extra: dict, instrument=None,
                guard_by: str = "uncertainty", seed: int = DEFAULT_SEED) -> _Judged:
    """The flow both kinds share from the registration's pose T (points X and deviations
    ``dev`` there): conditioning → ambiguity → (minimax refit, its facts into ``extra``) →
    margins and uncertainty → pose sensitivity → judge → statistics. The guarded rule's guard
    band is each point's expanded uncertainty U (engine.uncertainty), or its sampling margin
    alone (``guard_by`` "sampling")."""
    from .trust import conditioning

    cond = conditioning(X[reg.inlier], dev.normal[reg.inlier], reg.rms,
                        RESOLUTION_OF_ZONE * tol.width, seed)

    def evaluate(Tc):
        Xc, dv = posed.at(Tc)
        return Xc, dv.signed, dv.normal

    ambiguous, spread = ambiguity(reg, dev.signed, tol, posed.deviations_at, seed)
    if fit == Fit.MINIMAX:
        T = minimax(evaluate, T, reg.inlier, tol, extra)
        X, dev = posed.at(T)
    fitted_at = time.perf_counter()
    margin = unc = guard = None
    if guard_by == "sampling" and decision_rule == DecisionRule.GUARDED:
        margin = guard = posed.surface.margins(dev)
    elif decision_rule == DecisionRule.GUARDED or (instrument is not None and instrument.states_anything):
        from .uncertainty import budget

        margin = posed.surface.margins(dev)
        unc = budget(X, dev.normal, reg.inlier, robust_rms(dev.signed[reg.inlier], reg.rms),
                     cond, margin, instrument)
        guard = unc.expanded if decision_rule == DecisionRule.GUARDED else None
    ts = time.perf_counter()
    sens, statements = _sensitivity(posed.deviations_at, evaluate, T, dev.signed, cond, reg,
                                    tol, guard, fit, X, posed.beyond_at, dev.normal,
                                    pose_in_guard=unc is not None and guard is not None,
                                    seed=seed)
    ts = time.perf_counter() - ts
    verdict, reasons, inside = judge(dev.signed, tol, reg, cond.weak, ambiguous, spread, guard,
                                     sens, statements)
    fields = {"verdict": verdict, "reasons": reasons, "in_tolerance": inside,
              "statistics": Statistics.of(dev.signed, tol), "fit": fit,
              "decision_rule": decision_rule, "conditioning": cond, "ambiguous": ambiguous,
              "ambiguity_spread": spread, "margin": margin, "uncertainty": unc,
              "pose_sensitivity": sens,
              "trust_statements": statements}
    return _Judged(T, X, dev, fields, fitted_at, ts)


def _with_pose(reg, T, dev):
    from dataclasses import replace

    return replace(reg, T_nominal_measured=T, deviations=dev)


ROBUST_MIN_POINTS = 20
"""Fewer fitted points than this keep their RMS as the pose term's residual scale."""


def robust_rms(d: np.ndarray, rms: float) -> float:
    """The residual scale the pose's uncertainty is taken from: the fitted points' RMS, or a
    robust one (engine.outliers.robust_centre_sigma, the gross rule's) when smaller, so that
    a defect among the points (a real deviation, no noise of the fit) does not widen every
    other point's uncertainty. Below ROBUST_MIN_POINTS points the median is too unsteady to go
    under the RMS."""
    from .outliers import robust_centre_sigma

    if d.size < ROBUST_MIN_POINTS:
        return rms
    sigma = robust_centre_sigma(d)[1]
    return min(rms, sigma) if sigma > 0 else rms


def _sensitivity(deviations_at, evaluate, T, d, cond, reg, tol: Tolerance, margin, fit: str,
                 points: np.ndarray | None = None, beyond_at=None,
                 normals: np.ndarray | None = None, pose_in_guard: bool = False,
                 seed: int = DEFAULT_SEED):
    """(PoseSensitivity, statements) of the pose T with deviations d (None, () when the pose
    cannot be trusted anyway). The runner-up is a plausible pose when it scores within
    AMBIGUITY_SCORE_RATIO of the chosen one and is no symmetry of a 2D template; with the
    minimax fit it is judged at its own minimax pose, as the chosen one is. points : the measured
    points at pose T (nominal frame), for the bound on how far a probed pose moves each;
    beyond_at(T, idx): which lie past the nominal's border (a closed 2D contour: none);
    normals : the nominal's normals at the points (with ``points``: the pose's uncertainty
    region, engine.trust.uncertainty_poses, is probed too). pose_in_guard : the guard band
    (``margin``) is each point's expanded uncertainty, which holds the pose's own uncertainty
    already: neither the uncertainty region nor the weak directions' +-sigma are probed again
    (that would widen the band twice); free directions and the runner-up still are."""
    from .pose_sensitivity import pose_sensitivity, trust_statements
    from .trust import uncertainty_poses

    if not pose_trusted(reg):
        return None, ()
    alternatives = []
    if plausible_runner_up(reg):
        Tr = reg.runner_up_T
        if fit == Fit.MINIMAX:
            Tr = minimax(evaluate, Tr, reg.inlier, tol, {})
        alternatives.append(Tr)
    region = [] if points is None or normals is None or pose_in_guard else uncertainty_poses(
        points[reg.inlier], normals[reg.inlier], reg.rms, T, d[reg.inlier], tol.lower, tol.upper,
        cond, None if margin is None else margin[reg.inlier])
    probed = cond if not pose_in_guard else replace(
        cond, weak=tuple(w for w in cond.weak if w.sigma_mm is None))
    sens = pose_sensitivity(deviations_at, T, d, tol.lower, tol.upper, probed,
                            lambda dd: pointwise_verdict(dd, tol, margin)[0], margin,
                            alternatives, points=points, beyond_at=beyond_at, region=region,
                            seed=seed)
    return sens, trust_statements(sens, reg.score, reg.runner_up_score)


def inspect_2d(template: "Template2D", measured: np.ndarray, dim: int, tolerance: Tolerance,
               index: "ContourIndex | None" = None, fit: Fit = Fit.LSQ,
               decision_rule: DecisionRule = DecisionRule.SIMPLE,
               template_facts: dict | None = None,
               instrument: "Instrument | None" = None,
               guard: str = "uncertainty", seed: int = DEFAULT_SEED) -> InspectionResult:
    """Register measured points to a 2D contour template and judge them.

    measured : (n, 3) points; with ``dim == 2`` their x, y lie in the template plane already;
        otherwise they are a planar template measured in any 3D pose: a plane is fitted (its
        flatness reported), the points are taken into it, and both ways of laying the plane onto
        the template (face up, face down) are tried.
    template_facts : what reading the template file found (units, flattened curves, ignored
        entities), reported with the template's own facts in ``extra["template"]`` (the result
        is complete when built: nothing is added to it afterwards).
    The result's ``T_nominal_measured`` is the full 4x4 (measured → template frame, the template
    in its XY plane); ``registered[:, 2]`` is 0 or the out-of-plane coordinate.
    seed : the inspection's, of every seeded subset of the points (engine.seeds).
    """
    from .contour import ContourIndex, ContourSurface, Deviations2D
    from .registration2d import fit_plane, register_2d

    _check_options(fit, decision_rule)
    fit, decision_rule = Fit(fit), DecisionRule(decision_rule)
    t0 = time.perf_counter()
    index = index or ContourIndex(template)
    extra: dict = {"template": {"contours": int(template.closed.size),
                                "closed": int(template.closed.sum()),
                                "primitives": template.n_primitives}}
    if dim == 2:
        frames = [np.eye(4)]
    else:
        plane = fit_plane(measured)
        F = np.eye(4)
        F[:3, :3] = plane.R
        F[:3, 3] = -plane.R @ plane.origin
        flip = np.diag([1.0, -1.0, -1.0, 1.0])  # the plane seen from its other face
        frames = [F, flip @ F]
        extra["flatness"] = {"peak_to_valley": plane.flatness, "rms": plane.rms_w,
                             "n_points": int(measured.shape[0])}
    # The frame whose registration scores best (the first of equals).
    F, reg = min(((F, register_2d(index, (measured @ F[:3, :3].T + F[:3, 3])[:, :2],
                                  zone_width=tolerance.width, seed=seed)) for F in frames),
                 key=lambda frame: frame[1].score)
    q2 = (measured @ F[:3, :3].T + F[:3, 3])[:, :2]

    T2 = reg.T_nominal_measured
    j = _judge_pose(reg, T2, apply_transform(T2, q2), reg.deviations,
                    Posed(ContourSurface(index), q2), tolerance, fit, decision_rule, extra,
                    instrument, guard, seed)
    t1 = j.fitted_at
    reg3 = reg.lifted(F, j.T, _of_kind(j.deviations, Deviations2D))
    T = reg3.T_nominal_measured
    registered = measured @ T[:3, :3].T + T[:3, 3]
    extra["template"]["symmetric"] = reg.symmetric
    extra["template"].update(template_facts or {})
    t2 = time.perf_counter()
    timings = {"register": t1 - t0, "deviation": t2 - t1 - j.sensitivity_s,
               "pose_sensitivity": j.sensitivity_s}
    return InspectionResult(tolerance=tolerance, registration=reg3, registered=registered,
                            deviations=_of_kind(reg3.deviations, Deviations),
                            normals_source="contour", timings_s=timings,
                            extra=extra, **j.verdict_fields)
