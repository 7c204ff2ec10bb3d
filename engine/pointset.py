"""The points an input file describes, as every reader returns them (engine.io) and the nominal
and the pipeline take them: numbers only, no file in sight."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class PointSet:
    """Points read from one file, in millimetres.

    points : (n, 3) float64. 2D files get z = 0 and ``dim == 2``.
    normals : (n, 3) float64 unit vectors (the file's I J K, or a mesh's vertex normals) or None.
    labels : (n,) str array of point labels, or None.
    grid_shape : (nu, nv) when the points form a u-v grid (u fastest), else None.
    triangles : (m, 3) int64 vertex indices of a mesh's triangles, or None.
    groups : {name: (k,) int64 ascending indices of its points}, the named groups of a mesh's
        faces (OBJ ``g``/``o``, a PLY face property; engine.io.obj, engine.io.ply) with the vertices of
        their faces: a vertex on the edge between faces of two groups is in both. None when
        the file names no group. Indices rather than (n,) masks: a CAD export may name a group
        per face, hundreds of them over a million vertices.
    intensity : (n,) float64, the scanner's return intensity of each point (E57, in the file's
        own scale), or None. Carried along, not used by the inspection.
    """

    points: np.ndarray
    normals: np.ndarray | None = None
    labels: np.ndarray | None = None
    grid_shape: tuple[int, int] | None = None
    triangles: np.ndarray | None = None
    dim: int = 3
    path: str = "<array>"
    groups: dict[str, np.ndarray] | None = None
    intensity: np.ndarray | None = None

    @property
    def n(self) -> int:
        return int(self.points.shape[0])

    def take(self, indices: np.ndarray) -> "PointSet":
        """The points ``indices`` (k,) int in that order, with their normals, labels and
        intensities. A subset of a grid or mesh is a bare point set: its grid, triangles and
        groups are dropped."""
        idx = np.asarray(indices, dtype=np.int64)

        def sub(a):
            return None if a is None else a[idx]

        return PointSet(self.points[idx], sub(self.normals), sub(self.labels), None, None,
                        self.dim, self.path, None, sub(self.intensity))
