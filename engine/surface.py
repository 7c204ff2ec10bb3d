"""The nominal surface as an inspection measures points against it: one :class:`Surface`
protocol that every kind of nominal implements, so that the judging flow (engine.inspection,
the plan layer engine.gdt) asks the same four questions of any of them:

- :class:`SampledSurface`: a grid, a mesh or bare points with normals (engine.nominal.Nominal),
  measured to its local facets, with each point's nominal-sampling margin;
- engine.step_model.ExactDistances: a STEP model's exact B-rep faces (no sampling margin);
- engine.contour.ContourSurface: a 2D template's lines and arcs, in its plane (no border).

Points are always given in the nominal's frame (``apply_transform(T_nominal_measured, ...)``);
:class:`Posed` binds a surface to the measured points so that a pose alone says where they are.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np

from .nominal import Nominal
from .pose import apply_transform


BORDER_COSINE = 0.5
"""A point lies past the nominal's border when the direction to it from its closest point
makes more than 60 degrees with the nominal's normal at the sample nearest that closest point
(over the surface the two agree within its curvature between samples): its closest point is on
the border (:meth:`SampledSurface.beyond`)."""
BORDER_MIN_MM = 1e-4
"""… and lies farther than this from it (closer, the direction is rounding)."""


class Surface(Protocol):
    """What the inspection measures against.

    exact : the deviations are to the design surface itself (a STEP model's faces, a
        template's lines and arcs), so that ``margins`` are 0 and the registration's pose is
        refined on them (engine.inspection.inspect).
    normals_source : where the normals come from, as the outputs say it (``"B-rep"``,
        ``"contour"``, or the nominal file's: engine.nominal.Nominal.normals_source).
    """

    @property
    def exact(self) -> bool: ...

    @property
    def normals_source(self) -> str: ...

    def deviations(self, X: np.ndarray):
        """Deviations of points X (n, 3) (a template: (n, 2)) in the nominal's frame:
        engine.deviation.Deviations (or engine.contour.Deviations2D) with ``signed`` (mm,
        positive along the outward normal), ``foot`` (closest surface point) and ``normal``."""
        ...

    def margins(self, dev) -> np.ndarray:
        """(n,) each point's nominal-sampling margin, mm, at its ``deviations`` ``dev``: how far
        the sample the deviations were measured on may lie from the design surface there."""
        ...

    def beyond(self, X: np.ndarray) -> np.ndarray:
        """(n,) bool: the points X (nominal frame) lie past the surface's border (a template's
        closed contours have none: all False)."""
        ...


@dataclass(frozen=True)
class SampledSurface:
    """A grid's, a mesh's or bare points' nominal measured to its local facets
    (engine.deviation.point_to_surface), each deviation with the sag of the chord between
    neighbouring samples as its margin (engine.verdict.margins_3d)."""

    nominal: Nominal
    exact = False

    @property
    def normals_source(self) -> str:
        return self.nominal.normals_source

    def deviations(self, X: np.ndarray):
        from .deviation import point_to_surface

        return point_to_surface(self.nominal, X)

    def margins(self, dev) -> np.ndarray:
        from .verdict import margins_3d

        return margins_3d(self.nominal, dev.foot)

    def beyond(self, X: np.ndarray) -> np.ndarray:
        """Past the border: the direction from a point's closest point on the sample to the
        point makes more than acos(BORDER_COSINE) with the nominal's normal at the sample
        nearest that closest point (past a mesh's or grid's border the distance is to its
        edge; past bare points' last facet, the facet continued ends too)."""
        from .deviation import point_to_surface
        X = np.asarray(X, dtype=np.float64)
        dv = point_to_surface(self.nominal, X)
        _, near = self.nominal.tree.query(dv.foot)
        off = X - dv.foot
        size = np.linalg.norm(off, axis=1)
        along = np.abs(np.einsum("ij,ij->i", self.nominal.normals(np.atleast_1d(near)), off))
        # A point on the surface (no offset to speak of) is over it.
        return (size > BORDER_MIN_MM) & (along < BORDER_COSINE * size)


@dataclass(frozen=True)
class Posed:
    """A surface and the measured points (n, 3), or (n, 2) in a template's plane: where the
    points lie, and their deviations, at a pose T (``T_nominal_measured``)."""

    surface: Surface
    points: np.ndarray

    def at(self, T: np.ndarray, idx=None):
        """(X, deviations): the points ``idx`` (None: all) at pose T, and their deviations."""
        X = apply_transform(T, self.points if idx is None else self.points[idx])
        return X, self.surface.deviations(X)

    def deviations_at(self, T: np.ndarray, idx) -> np.ndarray:
        """(len(idx),) the signed deviations (mm) of the points ``idx`` at pose T."""
        return self.at(T, idx)[1].signed

    def beyond_at(self, T: np.ndarray, idx) -> np.ndarray:
        """(len(idx),) bool: the points ``idx`` at pose T lie past the surface's border."""
        return self.surface.beyond(apply_transform(T, self.points[idx]))

    def margins_at(self, T: np.ndarray, idx=None) -> np.ndarray:
        """The nominal-sampling margins (mm) of the points ``idx`` (None: all) at pose T."""
        if self.surface.exact:
            return np.zeros(len(self.points) if idx is None else len(np.atleast_1d(idx)))
        return self.surface.margins(self.at(T, idx)[1])
