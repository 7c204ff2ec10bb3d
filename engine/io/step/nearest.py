"""The nearest feet a query on a STEP model's faces has found so far (engine.io.step.brep)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass
class Best:
    """The nearest foot found so far, per point: distance, face id, and either the foot's (u, v)
    on the face's surface (``on_face``) or the foot found on the trimmed face with its support
    (an edge, a vertex or the face) for the boundary case."""

    n: int

    def __post_init__(self):
        self.dist = np.full(self.n, np.inf)
        self.face = np.zeros(self.n, np.int64)
        self.uv = np.zeros((self.n, 2))
        self.on_face = np.zeros(self.n, bool)
        self.foot = np.zeros((self.n, 3))
        self.upper = np.full(self.n, np.inf)
        self.support: dict[int, object] = {}

    def take(self, idx: np.ndarray) -> "Best":
        """The points ``idx`` alone, numbered from 0 in that order."""
        got = Best(len(idx))
        for name in ("dist", "face", "uv", "on_face", "foot", "upper"):
            setattr(got, name, getattr(self, name)[idx])
        got.support = {k: self.support[int(i)] for k, i in enumerate(idx)
                       if int(i) in self.support}
        return got


def unique_pairs(points: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """(m, 2) int64 unique (point index, face id) pairs, sorted by point then face."""
    key = np.unique(points.astype(np.int64) * (1 << 32) + faces.astype(np.int64))
    return np.stack([key >> 32, key & ((1 << 32) - 1)], axis=1)
