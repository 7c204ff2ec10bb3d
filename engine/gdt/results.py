"""What a plan's evaluation returns: each characteristic's result, the plan's, the feature each
region is (RegionFeature), and the geometry a plan is judged on (Geometry)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from .datums import Alignment
from .plan import Characteristic

WORST = 10


@dataclass(frozen=True)
class CharacteristicResult:
    """One characteristic judged.

    value : in the drawing's convention (module docstring), mm; None when it could not be
    measured. indices : the measured points it used; deviations : their signed deviations at
    the characteristic's pose (profiles), mm. worst : up to 10 of ``indices`` farthest outside
    (or nearest to leaving) the zone, worst first. facts : what else the outputs show (fitted
    diameter, axis, the datums' fits, the freedom left).
    """

    characteristic: Characteristic
    value: float | None
    verdict: str
    reason: str
    indices: np.ndarray
    deviations: np.ndarray | None = None
    worst: tuple[int, ...] = ()
    facts: dict = field(default_factory=dict)


@dataclass(frozen=True)
class PlanResult:
    """A plan's outcome: the part's alignment, its deviations there, and every characteristic.

    alignment : the plan's ``[alignment]`` (None for best-fit: the registration's pose stands).
    T_nominal_measured : the pose of the per-point outputs; deviations : (n,) signed deviations
    there, mm; regions : (n,) each point's regions ('a+b', '' for none).
    """

    verdict: str
    reasons: tuple[str, ...]
    method: str
    alignment: Alignment | None
    T_nominal_measured: np.ndarray
    deviations: np.ndarray
    regions: np.ndarray
    members: dict
    characteristics: tuple[CharacteristicResult, ...]
    zone_in_verdict: bool = False
    """Whether the inspection's zone over all points is one of the characteristics (``tol``);
    else it is only the zone of the per-point statistics."""
    features: tuple = ()
    """RegionFeature of every region a datum or characteristic uses, in the plan's order."""


@dataclass(frozen=True)
class RegionFeature:
    """A region as the feature a drawing names (what exports such as QIF 3.0 write).

    feature : plane | cylinder | sphere (a datum's feature; flatness: a plane; position and
        size: a cylinder), or freeform (a profile's surface, or any region of a 2D template):
        no geometry.
    nominal : the least-squares feature of the region's nominal points, nominal frame, mm
        (plane: point, normal (outward); cylinder: point, direction, diameter, internal (a
        hole); sphere: centre, diameter, internal); None when they do not determine it.
    measured : the same (without internal) fitted to the region's measured points at the
        plan's alignment (the pose of the per-point outputs), with form_error (peak to valley
        of the residuals, mm) and n_points; None when they do not determine it.
    """

    region: str
    feature: str
    nominal: dict | None = None
    measured: dict | None = None
    datums: tuple[tuple[str, str], ...] = ()
    """(label, fit) of the plan's datums on this region."""


class Margin(Protocol):
    """Geometry.margin: the guard band (mm) of the measured points ``idx`` at pose T, or None
    (the simple rule)."""

    def __call__(self, idx: np.ndarray, T: np.ndarray,
                 form_only: bool = False) -> np.ndarray | None: ...


@dataclass(frozen=True)
class Geometry:
    """What the plan's evaluation needs of the part, whatever its kind (3D or a 2D template).

    evaluate(T, idx) -> (X, d, normals): measured points ``idx`` at pose T (nominal frame),
    signed deviations (mm) and the nominal's outward normals there. T0 : the registration's
    pose. margin(idx, T, form_only=False) -> the guarded rule's per-point guard band at T, mm:
    the expanded uncertainty U (engine.uncertainty) with the nominal-sampling margins there
    (``form_only``: without the registration's pose term); None (simple rule).
    nominal_points : (N, dim); nominal_normals(idx) -> their outward normals; nominal_masks :
    {region: (N,) bool}; centre, length: the measured points' centroid and RMS radius at T0
    (rotations are scaled by it); labels : (n,) the measured points' labels, or None.
    """

    evaluate: Callable[[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray, np.ndarray]]
    T0: np.ndarray
    margin: Margin
    nominal_points: np.ndarray
    nominal_normals: Callable[[np.ndarray], np.ndarray]
    nominal_masks: dict
    centre: np.ndarray
    length: float
    labels: np.ndarray | None = None
    exact_feature: Callable[[str, np.ndarray], dict | None] | None = None
    """exact_feature(kind, mask) -> a region's nominal feature (as :func:`_nominal_feature`)
    from the model's exact surface when its samples ``mask`` all lie on one surface of that
    kind (a STEP model's plane, cylinder or sphere faces), else None; None: always fitted."""
    points: np.ndarray | None = None
    """(n, dim) the measured points in their own frame (``evaluate``'s X is T applied to
    them); None: datums are fitted to the nominal surface only."""
