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
from .pose import apply_transform
from .exact_fit import EXACT_HANDOVER_ITERATIONS, finish_exactly
from .nominal import Nominal
from .registration import register
from .registration_types import RegistrationResult, RegistrationSettings
from .seeds import DEFAULT_SEED
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
        reg = finish_exactly(reg, posed, nominal, settings, tolerance.width)
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
