"""The inspection pipeline: register → measure deviations → judge, with the verdict rules.

Decision rule (pointwise, the paper's L-infinity argument): ACCEPT only when every measured point
lies inside the tolerance zone [lower, upper]; REJECT when any point, outliers included, lies
outside; INCONCLUSIVE when the pose cannot be trusted (the fit did not converge, or fewer than
half of the points lie within 1% of the nominal's size of its surface: the measurement is not of
this part), whatever the deviations say.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from .deviation import Deviations
from .geometry import apply_transform
from .nominal import Nominal
from .registration import RegistrationResult, RegistrationSettings, register
from .tolerance import Tolerance

if TYPE_CHECKING:
    from .contour import ContourIndex, Template2D

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
    """Kind-specific facts for the outputs (2D: the template's contours, symmetry, flatness)."""


def inspect(nominal: Nominal, measured: np.ndarray, tolerance: Tolerance,
            settings: RegistrationSettings = RegistrationSettings()) -> InspectionResult:
    """Register ``measured`` (n, 3) to ``nominal`` from any pose and judge it against ``tolerance``."""
    t0 = time.perf_counter()
    reg = register(nominal, measured, settings)
    t1 = time.perf_counter()
    registered = apply_transform(reg.T_nominal_measured, measured)
    dev = reg.deviations  # the fit's last evaluation: every point at the final pose
    verdict, reasons, inside = judge(dev.signed, tolerance, reg)
    stats = Statistics.of(dev.signed, tolerance)
    t2 = time.perf_counter()
    # The all-point deviations are the registration's last evaluation; they are counted as
    # deviation time, not registration time.
    timings = {"register": t1 - t0 - reg.deviation_s, "deviation": reg.deviation_s + t2 - t1}
    return InspectionResult(verdict, reasons, tolerance, reg, registered, dev, inside, stats,
                            nominal.normals_source, timings)


def judge(d: np.ndarray, tol: Tolerance, reg: RegistrationResult):
    """Verdict, reasons and per-point in-tolerance mask for deviations ``d`` at pose ``reg``."""
    inside = (d >= tol.lower) & (d <= tol.upper)
    reasons = []
    if not reg.converged:
        reasons.append("registration did not converge: " + (reg.message or "no reason given"))
    if reg.near_fraction < MIN_NEAR_FRACTION:
        reasons.append(f"only {100 * reg.near_fraction:.0f}% of the {d.size} points lie within "
                       f"{reg.near_distance:.3g} mm (1% of the nominal's size) of the nominal at "
                       "the best pose found; the pose cannot be trusted")
    if reasons:
        return INCONCLUSIVE, tuple(reasons), inside
    n_out = int((~inside).sum())
    if n_out:
        return REJECT, (f"{n_out} of {d.size} points lie outside the tolerance zone",), inside
    return ACCEPT, (f"all {d.size} points lie inside the tolerance zone",), inside


def inspect_2d(template: "Template2D", measured: np.ndarray, dim: int, tolerance: Tolerance,
               index: "ContourIndex | None" = None) -> InspectionResult:
    """Register measured points to a 2D contour template and judge them.

    measured : (n, 3) points; with ``dim == 2`` their x, y lie in the template plane already;
        otherwise they are a planar template measured in any 3D pose: a plane is fitted (its
        flatness reported), the points are taken into it, and both ways of laying the plane onto
        the template (face up, face down) are tried.
    The result's ``T_nominal_measured`` is the full 4x4 (measured → template frame, the template
    in its XY plane); ``registered[:, 2]`` is 0 or the out-of-plane coordinate.
    """
    from .contour import ContourIndex
    from .registration2d import fit_plane, register_2d

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
        reg = register_2d(index, q[:, :2])
        if best is None or reg.score < best[1].score:
            best = (F, reg)
    F, reg = best
    E = np.eye(4)
    E[:2, :2] = reg.T[:2, :2]
    E[:2, 3] = reg.T[:2, 2]
    T = E @ F
    t1 = time.perf_counter()
    registered = measured @ T[:3, :3].T + T[:3, 3]
    d = reg.deviations.signed
    zeros = np.zeros(d.size)
    dev = Deviations(d, np.column_stack([reg.deviations.foot, zeros]),
                     np.column_stack([reg.deviations.normal, zeros]), zeros.astype(bool))
    reg3 = RegistrationResult(
        T_nominal_measured=T, converged=reg.converged, iterations=reg.iterations, rms=reg.rms,
        n_inliers=reg.n_inliers, inlier=reg.inlier, outlier_cut=reg.outlier_cut,
        score=reg.score, hypotheses=reg.hypotheses, runner_up_score=reg.runner_up_score,
        runner_up_T=None, deviations=dev, deviation_s=0.0, near_fraction=reg.near_fraction,
        near_distance=reg.near_distance, message=reg.message,
        rms_definition="RMS of signed point-to-contour deviations over the inlier points used "
                       "by the final fit (mm)")
    extra["template"]["symmetric"] = reg.symmetric
    verdict, reasons, inside = judge(d, tolerance, reg3)
    stats = Statistics.of(d, tolerance)
    t2 = time.perf_counter()
    return InspectionResult(verdict, reasons, tolerance, reg3, registered, dev, inside, stats,
                            "contour", {"register": t1 - t0, "deviation": t2 - t1}, extra)
