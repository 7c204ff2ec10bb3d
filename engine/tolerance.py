"""The tolerance zone (a light module: the desktop app checks a zone in its GUI thread without
loading the registration machinery)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .errors import SettingsError


@dataclass(frozen=True)
class Tolerance:
    """Tolerance zone of the deviation, mm: ``lower`` <= d <= ``upper`` is in tolerance."""

    lower: float
    upper: float

    def __post_init__(self):
        if not (np.isfinite(self.lower) and np.isfinite(self.upper)):
            raise SettingsError("tolerance limits must be finite numbers")
        if not self.lower < self.upper:
            raise SettingsError(f"tolerance zone is empty: lower limit {self.lower:g} mm is not "
                                f"below upper limit {self.upper:g} mm")

    @classmethod
    def symmetric(cls, t: float) -> "Tolerance":
        if not t > 0:
            raise SettingsError(f"--tol must be positive, got {t:g}")
        return cls(-float(t), float(t))

    def excess(self, d: np.ndarray) -> np.ndarray:
        """How far each deviation lies outside the zone (mm; <= 0 inside)."""
        return np.maximum(d - self.upper, self.lower - d)
