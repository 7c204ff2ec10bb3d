"""What a registration takes (:class:`RegistrationSettings`) and returns
(:class:`RegistrationResult`), and the fits it is made of (:class:`RobustFit`,
:class:`PoseFit`): shared by the 3D registration (engine.registration), the fit
that finishes it (engine.surface_fit) and the 2D one (engine.registration2d)."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from .contour import Deviations2D
from .deviation import Deviations
from .outliers import GrossRule
from .pose import in_plane
from .seeds import DEFAULT_SEED


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
    patch_anchor_voxel: float = 0.05
    """When the measured points cover only part of the nominal (see ``patch_radius``) and the
    best pose found scores worse than the zone's width, the search is run again with the
    normal-aligned hypotheses alone, at anchors one per voxel of this fraction of the measured
    extent (a tenth the first time), …"""
    max_patch_anchors: int = 1024
    """… at most this many: a patch's point is put on an anchor, and a sparse patch's few points
    bring a start home only from within a few percent of its extent. (Denser anchors from the
    start took a seat bracket's two-face patch, sampled, to a pose slid 2 mm along its weak
    direction, INCONCLUSIVE, instead of the truth.)"""
    n_spins: int = 18
    """Spins about the normal tried at each anchor by the normal-aligned hypotheses (20 degrees
    apart: the right anchor's nearest spin starts within 10 degrees of the answer; 30 degrees
    apart left a cube with a boss, whose faces fit at 24 poses, without a start that the global
    search's few ICP iterations bring home, now and then)."""
    n_patch_rotations: int = 120
    """When the measured points cover only part of the nominal (their RMS radius about their
    centroid below ``patch_radius`` of the nominal's) and the reference point's neighbours are
    not on a plane (flatness above ``patch_flatness``), evenly spread rotations tried at every
    anchor as well: the normal-aligned hypotheses rest on that point's normal, which a sparse
    patch's neighbours cannot give (NIST FTC-06 and CTC-01, 90 points on 30% of the part: no
    neighbourhood of 8 points near the centroid lies on one face, flatness 0.08-0.78, their
    normals 37-88 degrees off, and no start came within 20 mm of the answer)."""
    patch_radius: float = 0.8
    """A measurement covers only part of the nominal when its RMS radius about its centroid is
    below this fraction of the nominal's (full coverage: about 1, in any pose) …"""
    patch_flatness: float = 0.01
    """… and the reference point's normal cannot be trusted when the least variance of its 8
    neighbours exceeds this fraction of their middle one (a sparse patch's neighbours span
    faces; so may a dense but noisy or strongly curved one's, which costs those starts too)."""
    coarse_size: int = 1000
    """Nominal points in the coarsest ICP level, at least …"""
    coarse_samples_per_area: float = 500.0
    """… and this x (nominal diagonal / measured extent)^2, at most 16 x coarse_size."""
    coarse_measured: int = 32
    """Measured points (farthest-point spread) used by the global search (half of them in its
    first iterations) …"""
    patch_measured: int = 64
    """… and by the search with denser anchors (``patch_anchor_voxel``): a patch's few points that
    tell its look-alikes apart (a pocket's wall, a step 1-2 mm high) are not always among 32
    spread points, and the ICP slid the starts along the rest (NIST CTC-03 and FTC-07, 90-point
    patches on 10-15% of the part: starts 6 mm from the truth ended 58-67 mm off on 16 then 32
    points, and the answers were confident REJECTs of perfect parts, 103-166 mm off)."""
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
    noise_mm: float | None = None
    """The measuring instrument's noise, mm (a standard deviation), when the measurement itself
    shows it (engine.scene: the spread of a scene's table about its plane); None: unknown. A
    point then lies *near* the nominal within ``near_noise_sigmas`` x this too, if that is
    wider: a 3D camera's points scatter millimetres about a part a few centimetres long."""
    near_noise_sigmas: float = 2.0
    """… (two standard deviations hold 95% of a normal noise's points)."""
    def near(self, diagonal: float) -> tuple[float, str]:
        """(distance, mm, within which a point lies near the nominal; the rule in words) for a
        nominal of bounding-box ``diagonal`` mm."""
        size = self.near_fraction_of_size * diagonal
        rule = f"{100 * self.near_fraction_of_size:g}% of the nominal's size"
        if self.noise_mm is not None and self.near_noise_sigmas * self.noise_mm > size:
            return (self.near_noise_sigmas * self.noise_mm,
                    f"{self.near_noise_sigmas:g} x the measurement's noise, "
                    f"{self.noise_mm:.3g} mm")
        return size, rule

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
    seed: int = DEFAULT_SEED
    """The inspection's seed, of every seeded subset of the points (engine.seeds)."""


SURFACE_RMS = ("RMS of signed point-to-surface deviations over the points used by the final fit: "
               "all but those excluded from the alignment as gross outliers (mm)")
CONTOUR_RMS = ("RMS of signed point-to-contour deviations over the points the final fit used: "
               "every point but the gross outliers (mm)")


@dataclass(frozen=True)
class RobustFit:
    """A Gauss-Newton fit over the points within a robust cut of the deviations (the short
    fits that bring a candidate pose into the least-squares basin)."""

    T_nominal_measured: np.ndarray
    """(4, 4) 3D, (3, 3) 2D: the pose reached, mapping measured points into the nominal's frame."""
    converged: bool
    """Whether a step became negligible within the iterations allowed."""
    iterations: int
    """Gauss-Newton iterations run."""
    inlier: np.ndarray
    """(n,) bool: the points fitted (inside the cut at the returned pose)."""
    deviations: Deviations | Deviations2D
    """Of every point fitted on, at the returned pose."""
    deviation_s: float = 0.0
    """Seconds the evaluation of ``deviations`` took (3D only; 0 in 2D)."""
    cut: float | None = None
    """The robust cut, mm (2D only: the candidates are scored with it)."""


@dataclass(frozen=True)
class PoseFit:
    """The final least-squares fit of a pose over every point but the gross outliers
    (engine.outliers), as the 3D finish (engine.surface_fit) and the 2D one
    (engine.registration2d) leave it; :meth:`RegistrationResult.from_fit` reads it."""

    T_nominal_measured: np.ndarray
    """(4, 4) 3D, (3, 3) 2D: the pose fitted, mapping measured points into the nominal's frame."""
    converged: bool
    """Whether the fit settled (and the points it leaves out with it) within its budget."""
    iterations: int
    """Gauss-Newton iterations of every fit run to reach it."""
    inlier: np.ndarray
    """(n,) bool: the points kept (not gross outliers) at the returned pose."""
    rule: GrossRule
    """The gross-outlier rule at the returned pose."""
    deviations: Deviations | Deviations2D
    """Of every point, at the returned pose."""
    deviation_s: float = 0.0
    """Seconds the last evaluation of ``deviations`` took (3D only; 0 in 2D)."""
    message: str = ""
    """Why the fit is not to be trusted, in words ("" when it converged)."""


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
        better; the same measure on the same points scores the runner-up pose (in 3D on a STEP
        model's exact faces, a runner-up too far behind for them to judge stays as far behind
        the pose as the sample scored it: engine.exact_fit.on_exact_scale).
    runner_up_score, runner_up_T : score and pose of the best pose distinct from the chosen one
        (None when the global search ended with a single distinct pose); in 3D below ``score``
        only when the runner-up, refined on a STEP model's exact faces, scores better there and
        its full fit does not (engine.exact_fit); engine.verdict.better_runner_up then makes
        the verdict INCONCLUSIVE.
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
    near_rule: str = "1% of the nominal's size"
    """How ``near_distance`` was chosen, in words (RegistrationSettings.near)."""
    rms_definition: str = SURFACE_RMS
    symmetric: bool = False
    candidates: tuple[np.ndarray, ...] = ()
    """The other poses (4, 4) the registration's last stage carried to its end that score
    within engine.registration.CANDIDATE_SCORE_RATIO of the chosen one, each distinct from it,
    the runner-up and each other, best score first (at their finished poses where they were
    finished); first of all, when a patch was searched again with denser anchors, the answer
    of the search not chosen, if distinct from them all, whatever it scores
    (engine.registration.register). engine.exact_fit judges them again on an exact surface,
    and leaves them as the registration found them (empty in 2D)."""

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
