"""The tolerance zone (a light module: the desktop app checks a zone in its GUI thread without
loading the registration machinery), and the one rule every zone obeys (:func:`check_zone`):
the command line's --tol/--tol-lower/--tol-upper, a plan's characteristics and a session's zone
all pass through it."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .errors import SettingsError

ZONE_LIMIT_MM = 1e6
"""No limit of a zone lies farther than this from the nominal (1 km). A larger one is a slip of
the keyboard, not a requirement, and its arithmetic overflows (1e308 squared); as coordinates
beyond 1e9 mm are refused (engine.io.points.COORD_LIMIT_MM), so are such zones."""
PART_SIZE_RATIO = 1000.0
"""Nor farther than this many times the part's size (its nominal's bounding-box diagonal): a
zone a thousand times wider than the part accepts any measurement of it, whatever its pose."""


def check_zone(lower: float, upper: float, size: float | None = None) -> None:
    """Raise SettingsError for a zone [lower, upper] (mm) that no drawing gives: a limit that is
    not a finite number, an empty zone, or a limit beyond ``ZONE_LIMIT_MM``; and, when the
    part's ``size`` is known (its nominal's bounding-box diagonal, mm), a limit beyond
    ``PART_SIZE_RATIO`` x size. Only the first three can be checked before the nominal is
    read (engine.pipeline.load_nominal checks the last)."""
    if not (np.isfinite(lower) and np.isfinite(upper)):
        raise SettingsError("tolerance limits must be finite numbers")
    if not lower < upper:
        raise SettingsError(f"tolerance zone is empty: lower limit {lower:g} mm is not "
                            f"below upper limit {upper:g} mm")
    reach = max(abs(lower), abs(upper))
    if reach > ZONE_LIMIT_MM:
        raise SettingsError(f"tolerance zone {lower:g} … {upper:g} mm: a limit {reach:g} mm "
                            f"from the nominal is beyond 1e6 mm (1 km); no part "
                            "has such a tolerance")
    if size is not None and reach > PART_SIZE_RATIO * size:
        raise SettingsError(f"tolerance zone {lower:g} … {upper:g} mm: a limit {reach:g} mm "
                            f"from the nominal is beyond {PART_SIZE_RATIO:g} × the part's size "
                            f"({size:.4g} mm, its nominal's bounding-box diagonal); a zone "
                            "that wide accepts anything")


@dataclass(frozen=True)
class Tolerance:
    """Tolerance zone of the deviation, mm: ``lower`` <= d <= ``upper`` is in tolerance."""

    lower: float
    upper: float

    def __post_init__(self):
        check_zone(self.lower, self.upper)

    @classmethod
    def symmetric(cls, t: float) -> "Tolerance":
        if not t > 0:
            raise SettingsError(f"--tol must be positive, got {t:g}")
        return cls(-float(t), float(t))

    @property
    def width(self) -> float:
        """upper - lower, mm."""
        return self.upper - self.lower

    @property
    def centre(self) -> float:
        """The zone's middle, (lower + upper) / 2, mm: a profile's value is twice the largest
        distance of a deviation from it."""
        return 0.5 * (self.lower + self.upper)

    def excess(self, d: np.ndarray) -> np.ndarray:
        """How far each deviation lies outside the zone (mm; <= 0 inside)."""
        return np.maximum(d - self.upper, self.lower - d)
