"""Hints added to a verdict that is not ACCEPT when the inputs look mistaken: the nominal and
the measured files swapped, 3D points given against a 2D template (engine.pipeline)."""

from __future__ import annotations

import numpy as np

from .inspection import InspectionResult
from .pointset import PointSet

SWAP_RATIO = 10
"""A measured file with this many times the nominal's points, carrying what a nominal carries
(normals, a grid, facets) while the nominal is a bare cloud, looks swapped."""
NOT_PLANAR = 0.1
"""3D points against a 2D template whose flatness exceeds this fraction of their extent in the
plane are not a planar contour."""


def _structure(ps: PointSet) -> str:
    """What ``ps`` carries besides points, in words ("" for a bare cloud)."""
    parts = []
    if ps.triangles is not None:
        parts.append(f"{ps.triangles.shape[0]:,} mesh facets")
    if ps.grid_shape is not None:
        parts.append(f"a {ps.grid_shape[0]} x {ps.grid_shape[1]} grid")
    if ps.normals is not None:
        parts.append("normals")
    return " and ".join(parts)


def swap_hint(nominal: PointSet, measured: PointSet) -> str | None:
    """A sentence saying the two files look swapped, or None.

    Only the files' make-up is used: a dense scan against a coarser nominal is normal, so the
    measured file must also carry a nominal's structure (normals, grid, facets) while the nominal
    carries none. The caller adds it only to a verdict that is not ACCEPT.
    """
    if measured.n < SWAP_RATIO * nominal.n or _structure(nominal) or not _structure(measured):
        return None
    return (f"the files look swapped: NOMINAL {nominal.path} has {nominal.n:,} points without "
            f"normals, grid or facets, MEASURED {measured.path} has {measured.n:,} points with "
            f"{_structure(measured)}; is the first argument the nominal?")


def not_planar_hint(result: InspectionResult, measured: PointSet, template_path: str
                    ) -> str | None:
    """A sentence saying 3D measured points are no planar contour (2D template), or None."""
    flat = result.extra.get("flatness")
    if flat is None:
        return None
    xy = result.registered[:, :2]
    extent = float(np.max(np.ptp(xy, axis=0))) if xy.shape[0] else 0.0
    if not flat["peak_to_valley"] > NOT_PLANAR * extent:
        return None
    return (f"the measured points {measured.path} are not a planar contour: they lie "
            f"{flat['peak_to_valley']:.4g} mm out of their best plane over {extent:.4g} mm "
            f"across, but the nominal {template_path} is a 2D template; a 3D part needs a 3D "
            "nominal")
