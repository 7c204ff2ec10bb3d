"""The inspection pipeline: register → (minimax refit) → measure deviations → judge, with the
verdict rules.

Decision rules (the paper's L-infinity argument: one point out is a reject):

* ``simple``: ACCEPT only when every measured point lies inside the tolerance zone
  [lower, upper]; REJECT when any point, outliers of the fit included, lies outside.
* ``guarded`` (ISO 14253-1 style): each point's nominal-sampling margin m (facets through sampled
  nominal points can miss the true surface by about curvature x spacing^2 / 8) guards the limits:
  ACCEPT only when every point lies inside the zone shrunk by its m, REJECT only when a point
  lies outside the zone grown by its m, INCONCLUSIVE otherwise.

Whatever the deviations say, the verdict is INCONCLUSIVE when the pose cannot be trusted: the fit
did not converge, or fewer than half of the points lie within 1% of the nominal's size of its
surface (the measurement is not of this part). It is INCONCLUSIVE too when the verdict depends on
a pose the measurement does not fix: when moving the part along a direction the measured points
leave unconstrained (within +-3 sigma of the pose's uncertainty, or far along a free direction)
or to another pose that fits about as well changes the verdict (engine.trust.pose_sensitivity).
A weak or free direction along which the verdict holds (a cylinder measured all round, slid along
its axis) and a runner-up at which it is the same are reported, in plain words, and the verdict
stands.

Fits: ``lsq`` (least squares of point-to-surface distances over the inliers) or ``minimax`` (the
pose minimising the largest normalised excursion from the zone's centre: "can this part be
placed inside its zone?"), started from the least-squares pose, gross outliers left out of the
objective but judged.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from .deviation import Deviations
from .errors import SettingsError
from .geometry import apply_transform
from .nominal import Nominal
from .registration import RegistrationResult, RegistrationSettings, register
from .tolerance import Tolerance

if TYPE_CHECKING:
    from .contour import ContourIndex, Template2D
    from .trust import Conditioning, PoseSensitivity

ACCEPT, REJECT, INCONCLUSIVE = "ACCEPT", "REJECT", "INCONCLUSIVE"
MIN_NEAR_FRACTION = 0.5


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


@dataclass(frozen=True)
class InspectionResult:
    """Everything one inspection produced.

    registered : (n, 3) measured points mapped into the nominal frame by
        ``registration.T_nominal_measured``.
    deviations : signed point-to-surface deviations at ``registered`` (see engine.deviation).
    in_tolerance : (n,) bool.
    """

    verdict: str
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
    fit: str = "lsq"
    decision_rule: str = "simple"
    conditioning: "Conditioning | None" = None
    """How well the points constrain the pose (engine.trust)."""
    ambiguous: bool = False
    """A nearly-as-good runner-up pose moves some deviation by over a tenth of the zone: a fact
    reported; it makes the verdict INCONCLUSIVE only when the verdict differs there
    (``pose_sensitivity``)."""
    ambiguity_spread: float = 0.0
    """Largest deviation change (mm) between the chosen pose and a nearly-as-good runner-up."""
    margin: np.ndarray | None = None
    """(n,) nominal-sampling margin per point, mm (the guarded decision rule only)."""
    pose_sensitivity: "PoseSensitivity | None" = None
    """Whether the verdict holds over the poses the measurement allows (engine.trust); None
    when the pose cannot be trusted at all (not converged, not this part)."""
    trust_statements: tuple[str, ...] = ()
    """What the measurement does not fix and what that does to the verdict, in plain words
    (engine.trust.trust_statements), for the certificate."""

    @property
    def outlier(self) -> np.ndarray:
        """(n,) bool: points the fit left out as gross outliers (they are judged all the same)."""
        return ~self.registration.inlier


FITS = ("lsq", "minimax")
DECISION_RULES = ("simple", "guarded")
RESOLUTION_OF_ZONE = 0.25
"""A weak direction whose implied 1-sigma motion exceeds this fraction of the zone width leaves
the pose undetermined at the scale of the verdict (engine.trust.conditioning)."""
AMBIGUITY_SCORE_RATIO = 1.5
"""A runner-up pose scoring within this factor of the best one is a competitor …"""
AMBIGUITY_DEVIATION = 0.1
"""… and it is a material one when it moves some point's deviation by more than this fraction
of the zone's width."""


def _check_options(fit: str, decision_rule: str) -> None:
    if fit not in FITS:
        raise SettingsError(f"unknown fit '{fit}'; choose one of {', '.join(FITS)}")
    if decision_rule not in DECISION_RULES:
        raise SettingsError(f"unknown decision rule '{decision_rule}'; choose one of "
                            f"{', '.join(DECISION_RULES)}")


def inspect(nominal: Nominal, measured: np.ndarray, tolerance: Tolerance,
            settings: RegistrationSettings = RegistrationSettings(), fit: str = "lsq",
            decision_rule: str = "simple") -> InspectionResult:
    """Register ``measured`` (n, 3) to ``nominal`` from any pose and judge it against ``tolerance``
    with the given ``fit`` ("lsq" or "minimax") and ``decision_rule`` ("simple" or "guarded")."""
    from .deviation import point_to_surface
    from .trust import conditioning

    _check_options(fit, decision_rule)
    t0 = time.perf_counter()
    reg = register(nominal, measured, settings, zone_width=tolerance.upper - tolerance.lower)
    t1 = time.perf_counter()
    dev = reg.deviations  # the fit's last evaluation: every point at the final pose
    T = reg.T_nominal_measured
    registered = apply_transform(T, measured)
    cond = conditioning(registered[reg.inlier], dev.normal[reg.inlier], reg.rms,
                        RESOLUTION_OF_ZONE * (tolerance.upper - tolerance.lower))

    def evaluate(Tc):
        X = apply_transform(Tc, measured)
        dv = point_to_surface(nominal, X)
        return X, dv.signed, dv.normal

    ambiguous, spread = _ambiguity(reg, dev.signed, tolerance, lambda Tc, idx: point_to_surface(
        nominal, apply_transform(Tc, measured[idx])).signed)
    extra: dict = {}
    if fit == "minimax":
        T = _minimax(evaluate, T, reg.inlier, tolerance, extra)
        registered = apply_transform(T, measured)
        dev = point_to_surface(nominal, registered)
    margin = _margins_3d(nominal, dev.foot) if decision_rule == "guarded" else None
    ts = time.perf_counter()
    deviations_at, beyond_at = _deviations_and_border(nominal, measured)
    sens, statements = _sensitivity(deviations_at, evaluate, T, dev.signed, cond, reg, tolerance,
                                    margin, fit, registered, beyond_at, dev.normal)
    ts = time.perf_counter() - ts
    verdict, reasons, inside = judge(dev.signed, tolerance, reg, cond.weak, ambiguous, spread,
                                     margin, sens, statements)
    stats = Statistics.of(dev.signed, tolerance)
    t2 = time.perf_counter()
    # The all-point deviations are the registration's last evaluation; they are counted as
    # deviation time, not registration time.
    timings = {"register": t1 - t0 - reg.deviation_s,
               "deviation": reg.deviation_s + t2 - t1 - ts, "pose_sensitivity": ts}
    if T is not reg.T_nominal_measured:
        reg = _with_pose(reg, T, dev)
    return InspectionResult(verdict, reasons, tolerance, reg, registered, dev, inside, stats,
                            nominal.normals_source, timings, extra, fit=fit,
                            decision_rule=decision_rule, conditioning=cond, ambiguous=ambiguous,
                            ambiguity_spread=spread, margin=margin, pose_sensitivity=sens,
                            trust_statements=statements)


def _deviations_and_border(nominal: Nominal, measured: np.ndarray):
    """(deviations_at, beyond_at)(T, idx) for engine.trust.pose_sensitivity: the signed
    deviations (mm) of measured points ``idx`` at pose T, and which of them lie past the
    nominal's border: the direction from its closest point to the point more than
    acos(BORDER_COSINE) from the nominal's normal at the sample nearest that closest point
    (past a mesh's or grid's border the distance is to its edge; past bare points' last facet,
    the facet continued ends too)."""
    from .deviation import point_to_surface
    from .trust import BORDER_COSINE, BORDER_MIN_MM

    def deviations_at(Tc, idx):
        return point_to_surface(nominal, apply_transform(Tc, measured[idx])).signed

    def beyond_at(Tc, idx):
        X = apply_transform(Tc, measured[idx])
        dv = point_to_surface(nominal, X)
        _, near = nominal.tree.query(dv.foot)
        off = X - dv.foot
        size = np.linalg.norm(off, axis=1)
        along = np.abs(np.einsum("ij,ij->i", nominal.normals(np.atleast_1d(near)), off))
        # A point on the surface (no offset to speak of) is over it.
        return (size > BORDER_MIN_MM) & (along < BORDER_COSINE * size)

    return deviations_at, beyond_at


AMBIGUITY_POINTS = 16384
"""Points compared between the chosen and the runner-up pose (seeded subset beyond that): the
difference of two rigid poses' deviations varies smoothly over the part, so a subset spread
over it finds its largest value."""


def _plausible_runner_up(reg) -> bool:
    """A distinct runner-up pose scoring within AMBIGUITY_SCORE_RATIO of the chosen one, and no
    symmetry of a 2D template (which leaves every deviation as it is)."""
    return (reg.runner_up_T is not None and reg.runner_up_score is not None
            and not getattr(reg, "symmetric", False)
            and reg.runner_up_score <= AMBIGUITY_SCORE_RATIO * reg.score)


def _ambiguity(reg, d: np.ndarray, tol: Tolerance, deviations_at) -> tuple[bool, float]:
    """(ambiguous, spread): a nearly-as-good distinct runner-up pose (not a symmetry of a 2D
    template) that moves some deviation by more than a tenth of the zone width.

    deviations_at(T, idx) : signed deviations of measured points ``idx`` at pose T."""
    if not (reg.converged and reg.near_fraction >= MIN_NEAR_FRACTION
            and _plausible_runner_up(reg)):
        return False, 0.0
    idx = np.arange(d.size)
    if d.size > AMBIGUITY_POINTS:
        idx = np.sort(np.random.default_rng(3).choice(d.size, AMBIGUITY_POINTS, replace=False))
    spread = float(np.max(np.abs(deviations_at(reg.runner_up_T, idx) - d[idx])))
    return spread > AMBIGUITY_DEVIATION * (tol.upper - tol.lower), spread


def _minimax(evaluate, T: np.ndarray, use: np.ndarray, tol: Tolerance,
             extra: dict) -> np.ndarray:
    """The minimax pose from the least-squares one (its facts go into ``extra``), fitted on the
    points ``use`` (n,) bool: the registration's ``inlier``, every point but the gross outliers
    (engine.outliers) it excluded from the alignment. A local defect stays in: it is what the
    minimax fit has to place."""
    from .progress import report
    from .trust import minimax_pose

    report("minimax fit (linear programs)", 0.97)
    mm = minimax_pose(evaluate, T, tol.lower, tol.upper, use=use)
    extra["minimax"] = _minimax_facts(mm)
    return mm.T


def _minimax_facts(mm) -> dict:
    return {"excursion": mm.excursion, "least_squares_excursion": mm.start_excursion,
            "iterations": mm.iterations, "linear_programs": mm.linear_programs,
            "excursion_definition": "max over the fitted points (all but those excluded from "
                                    "the alignment as gross outliers) of "
                                    "|d - (lower + upper)/2| / ((upper - lower)/2): <= 1 means "
                                    "they fit the zone"}


def _with_pose(reg, T, dev):
    from dataclasses import replace

    return replace(reg, T_nominal_measured=T, deviations=dev)


MARGIN_NEIGHBOURS = 25
"""Samples around a point that the margin looks at: enough to see the curvature and the spacing
in every direction even where the sampling is 5:1 anisotropic."""


def _margins_3d(nominal: Nominal, feet: np.ndarray) -> np.ndarray:
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
    about as well with deviations up to ``spread`` mm apart; margin : per-point sampling margin,
    mm, for the guarded decision rule (None: the simple rule).
    sensitivity : whether the pointwise verdict holds over the poses the measurement allows
    (engine.trust.pose_sensitivity), with ``statements`` saying so in plain words. Given, a weak
    direction or a runner-up makes the verdict INCONCLUSIVE only when the verdict differs at
    some of those poses (they are reported as facts otherwise); None: any of them does.
    """
    inside = (d >= tol.lower) & (d <= tol.upper)
    reasons = []
    if not reg.converged:
        reasons.append("registration did not converge: " + (reg.message or "no reason given"))
    if reg.near_fraction < MIN_NEAR_FRACTION:
        reasons.append(f"only {100 * reg.near_fraction:.0f}% of the {d.size} points lie within "
                       f"{reg.near_distance:.3g} mm (1% of the nominal's size) of the nominal at "
                       "the best pose found; the pose cannot be trusted")
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
    right: the simple rule (margin None) or the guarded one with per-point ``margin`` (n,) mm."""
    if margin is None:
        n_out = int(((d < tol.lower) | (d > tol.upper)).sum())
        if n_out:
            return REJECT, f"{n_out} of {d.size} points lie outside the tolerance zone"
        return ACCEPT, f"all {d.size} points lie inside the tolerance zone"
    out_grown = (d < tol.lower - margin) | (d > tol.upper + margin)
    in_shrunk = (d >= tol.lower + margin) & (d <= tol.upper - margin)
    if out_grown.any():
        return REJECT, (f"{int(out_grown.sum())} of {d.size} points lie outside the tolerance "
                        "zone by more than their nominal-sampling margin")
    if in_shrunk.all():
        return ACCEPT, (f"all {d.size} points lie inside the tolerance zone by more than their "
                        "nominal-sampling margin")
    k = int((~in_shrunk).sum())
    return INCONCLUSIVE, (f"{k} of {d.size} points lie within their nominal-sampling margin of "
                          "a tolerance limit (guarded decision rule)")


def _sensitivity(deviations_at, evaluate, T, d, cond, reg, tol: Tolerance, margin, fit: str,
                 points: np.ndarray | None = None, beyond_at=None,
                 normals: np.ndarray | None = None):
    """(PoseSensitivity, statements) of the pose T with deviations d (None, () when the pose
    cannot be trusted anyway). The runner-up is a plausible pose when it scores within
    AMBIGUITY_SCORE_RATIO of the chosen one and is no symmetry of a 2D template; with the
    minimax fit it is judged at its own minimax pose, as the chosen one is. points : the measured
    points at pose T (nominal frame), for the bound on how far a probed pose moves each;
    beyond_at(T, idx): which lie past the nominal's border (None: a closed 2D contour);
    normals : the nominal's normals at the points (with ``points``: the pose's uncertainty
    region, engine.trust.uncertainty_poses, is probed too)."""
    from .trust import pose_sensitivity, trust_statements, uncertainty_poses

    if not (reg.converged and reg.near_fraction >= MIN_NEAR_FRACTION):
        return None, ()
    alternatives = []
    if _plausible_runner_up(reg):
        Tr = reg.runner_up_T
        if fit == "minimax":
            Tr = _minimax(evaluate, Tr, reg.inlier, tol, {})
        alternatives.append(Tr)
    region = [] if points is None or normals is None else uncertainty_poses(
        points[reg.inlier], normals[reg.inlier], reg.rms, T, d[reg.inlier], tol.lower, tol.upper,
        cond, None if margin is None else margin[reg.inlier])
    sens = pose_sensitivity(deviations_at, T, d, tol.lower, tol.upper, cond,
                            lambda dd: pointwise_verdict(dd, tol, margin)[0], margin,
                            alternatives, points=points, beyond_at=beyond_at, region=region)
    return sens, trust_statements(sens, reg.score, reg.runner_up_score)


def inspect_2d(template: "Template2D", measured: np.ndarray, dim: int, tolerance: Tolerance,
               index: "ContourIndex | None" = None, fit: str = "lsq",
               decision_rule: str = "simple") -> InspectionResult:
    """Register measured points to a 2D contour template and judge them.

    measured : (n, 3) points; with ``dim == 2`` their x, y lie in the template plane already;
        otherwise they are a planar template measured in any 3D pose: a plane is fitted (its
        flatness reported), the points are taken into it, and both ways of laying the plane onto
        the template (face up, face down) are tried.
    The result's ``T_nominal_measured`` is the full 4x4 (measured → template frame, the template
    in its XY plane); ``registered[:, 2]`` is 0 or the out-of-plane coordinate.
    """
    from .contour import ContourIndex, deviations_2d
    from .registration2d import apply2, fit_plane, register_2d
    from .trust import conditioning

    _check_options(fit, decision_rule)
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
    best = None
    for F in frames:
        q = measured @ F[:3, :3].T + F[:3, 3]
        reg = register_2d(index, q[:, :2], zone_width=tolerance.upper - tolerance.lower)
        if best is None or reg.score < best[1].score:
            best = (F, reg)
    F, reg = best
    q2 = (measured @ F[:3, :3].T + F[:3, 3])[:, :2]
    dev2, T2 = reg.deviations, reg.T
    fitted = apply2(T2, q2)
    cond = conditioning(fitted[reg.inlier], dev2.normal[reg.inlier], reg.rms,
                        RESOLUTION_OF_ZONE * (tolerance.upper - tolerance.lower))

    def evaluate(Tc):
        X = apply2(Tc, q2)
        dv = deviations_2d(index, X)
        return X, dv.signed, dv.normal

    ambiguous, spread = _ambiguity(reg, dev2.signed, tolerance, lambda Tc, idx: deviations_2d(
        index, apply2(Tc, q2[idx])).signed)
    if fit == "minimax":
        T2 = _minimax(evaluate, T2, reg.inlier, tolerance, extra)
        dev2 = deviations_2d(index, apply2(T2, q2))
    E = np.eye(4)
    E[:2, :2] = T2[:2, :2]
    E[:2, 3] = T2[:2, 2]
    T = E @ F
    t1 = time.perf_counter()
    registered = measured @ T[:3, :3].T + T[:3, 3]
    d = dev2.signed
    zeros = np.zeros(d.size)
    dev = Deviations(d, np.column_stack([dev2.foot, zeros]),
                     np.column_stack([dev2.normal, zeros]), zeros.astype(bool))
    reg3 = RegistrationResult(
        T_nominal_measured=T, converged=reg.converged, iterations=reg.iterations, rms=reg.rms,
        n_inliers=reg.n_inliers, inlier=reg.inlier, outlier_cut=reg.outlier_cut,
        score=reg.score, hypotheses=reg.hypotheses, runner_up_score=reg.runner_up_score,
        runner_up_T=None, deviations=dev, deviation_s=0.0, near_fraction=reg.near_fraction,
        near_distance=reg.near_distance, message=reg.message, gross_rule=reg.gross_rule,
        rms_definition="RMS of signed point-to-contour deviations over the points the final fit "
                       "used: every point but the gross outliers (mm)")
    extra["template"]["symmetric"] = reg.symmetric
    # Lines and arcs are exact: no sampling margin (flattened splines are within 0.1 um).
    margin = np.zeros(d.size) if decision_rule == "guarded" else None
    ts = time.perf_counter()
    sens, statements = _sensitivity(
        lambda Tc, idx: deviations_2d(index, apply2(Tc, q2[idx])).signed, evaluate, T2, d, cond,
        reg, tolerance, margin, fit, apply2(T2, q2), None, dev2.normal)
    ts = time.perf_counter() - ts
    verdict, reasons, inside = judge(d, tolerance, reg3, cond.weak, ambiguous, spread, margin,
                                     sens, statements)
    stats = Statistics.of(d, tolerance)
    t2 = time.perf_counter()
    return InspectionResult(verdict, reasons, tolerance, reg3, registered, dev, inside, stats,
                            "contour", {"register": t1 - t0, "deviation": t2 - t1 - ts,
                                        "pose_sensitivity": ts}, extra,
                            fit=fit, decision_rule=decision_rule, conditioning=cond,
                            ambiguous=ambiguous, ambiguity_spread=spread, margin=margin,
                            pose_sensitivity=sens, trust_statements=statements)
