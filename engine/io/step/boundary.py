"""The nearest point of a planar face's boundary, in closed form, for a point whose foot on the
plane fell outside the trimmed face: the face's nearest point then lies on its boundary (the
distance to a point of the plane is the root of the height squared plus the in-plane distance
squared, and the in-plane distance from a point outside a region is least on its boundary).
Straight edges and circular arcs are measured in closed form, vectorised over the face's edges;
a face with any other kind of edge gets no :class:`PlaneBoundary` (its nearest point is
OpenCascade's shape-to-shape distance, ``FaceTools.nearest_on_face``).

OpenCascade's ``BRepExtrema_DistShapeShape`` took 0.5-0.9 ms a point on the planar faces of
NIST FTC-08 (holes in plates: lines and circles), 1,162 calls and 1.0 s of one inspection.
"""

from __future__ import annotations

import numpy as np


class PlaneBoundary:
    """The straight edges (segments a-b) and circular arcs of one planar face, in the nominal
    frame (mm), each with its OpenCascade edge and end vertices (the support of a foot found on
    it, engine.io.step.brep's ``faces_at``)."""

    def __init__(self, segments: list, arcs: list):
        self.seg_a = np.array([s[0] for s in segments], float).reshape(-1, 3)
        self.seg_b = np.array([s[1] for s in segments], float).reshape(-1, 3)
        self.seg_shapes = [(s[2], s[3]) for s in segments]  # (edge, its ends: _ends)
        self.arc_centre = np.array([a[0] for a in arcs], float).reshape(-1, 3)
        self.arc_x = np.array([a[1] for a in arcs], float).reshape(-1, 3)
        self.arc_y = np.array([a[2] for a in arcs], float).reshape(-1, 3)
        self.arc_r = np.array([a[3] for a in arcs], float)
        self.arc_first = np.array([a[4] for a in arcs], float)
        self.arc_span = np.array([a[5] for a in arcs], float)
        self.arc_shapes = [(a[6], a[7]) for a in arcs]  # (edge, its ends: _ends)

    @classmethod
    def of(cls, face) -> "PlaneBoundary | None":
        """The boundary of an OpenCascade face (located, as placed in the model), or None when
        an edge is neither a line nor a circle."""
        from OCP.BRep import BRep_Tool
        from OCP.BRepAdaptor import BRepAdaptor_Curve
        from OCP.GeomAbs import GeomAbs_Circle, GeomAbs_Line
        from OCP.TopAbs import TopAbs_EDGE
        from OCP.TopExp import TopExp, TopExp_Explorer
        from OCP.TopoDS import TopoDS

        segments, arcs = [], []
        explorer = TopExp_Explorer(face, TopAbs_EDGE)
        while explorer.More():
            edge = TopoDS.Edge(explorer.Current())
            explorer.Next()
            if BRep_Tool.Degenerated_s(edge):
                continue
            curve = BRepAdaptor_Curve(edge)
            first, last = curve.FirstParameter(), curve.LastParameter()
            a, b = (np.array(curve.Value(t).Coord()) for t in (first, last))
            ends = _ends(edge, a, b, TopExp, BRep_Tool)
            kind = curve.GetType()
            if kind == GeomAbs_Line:
                segments.append((a, b, edge, ends))
            elif kind == GeomAbs_Circle:
                circle = curve.Circle()
                position = circle.Position()
                arcs.append((np.array(circle.Location().Coord()),
                             np.array(position.XDirection().Coord()),
                             np.array(position.YDirection().Coord()), circle.Radius(),
                             first, last - first, edge, ends))
            else:
                return None
        return cls(segments, arcs) if segments or arcs else None

    def nearest(self, xyz) -> tuple[float, np.ndarray, object]:
        """The nearest point of the boundary to xyz: (distance, foot (3,), support: the edge,
        or the vertex at an end)."""
        p = np.asarray(xyz, float)
        best: tuple[float, np.ndarray, object] = (np.inf, p, None)
        if self.seg_a.shape[0]:
            ab = self.seg_b - self.seg_a
            length2 = np.einsum("ij,ij->i", ab, ab)
            t = np.einsum("ij,ij->i", p - self.seg_a, ab) / np.where(length2 > 0, length2, 1.0)
            t = np.clip(t, 0.0, 1.0)
            foot = self.seg_a + t[:, None] * ab
            d = np.linalg.norm(p - foot, axis=1)
            k = int(np.argmin(d))
            edge, ends = self.seg_shapes[k]
            best = (float(d[k]), foot[k], _support(edge, ends, t[k] == 0.0, t[k] == 1.0))
        if self.arc_r.shape[0]:
            w = p - self.arc_centre
            angle = np.arctan2(np.einsum("ij,ij->i", w, self.arc_y),
                               np.einsum("ij,ij->i", w, self.arc_x))
            s = np.mod(angle - self.arc_first, 2 * np.pi)  # from the arc's start, [0, 2 pi)
            # Beyond the arc, the nearer end: the one the angle is nearer to around the circle.
            past = s > self.arc_span
            s = np.where(past & (s - self.arc_span > 2 * np.pi - s), 0.0,
                         np.minimum(s, self.arc_span))
            u = self.arc_first + s
            foot = self.arc_centre + self.arc_r[:, None] * (
                np.cos(u)[:, None] * self.arc_x + np.sin(u)[:, None] * self.arc_y)
            d = np.linalg.norm(p - foot, axis=1)
            k = int(np.argmin(d))
            if d[k] < best[0]:
                whole = self.arc_span[k] >= 2 * np.pi - 1e-9  # (its one vertex: a seam)
                edge, ends = self.arc_shapes[k]
                best = (float(d[k]), foot[k], _support(edge, ends, not whole and s[k] == 0.0,
                                                       not whole and s[k] == self.arc_span[k]))
        return best


def _ends(edge, a: np.ndarray, b: np.ndarray, TopExp, BRep_Tool) -> tuple:
    """The edge's vertices at its curve's first and last points ``a`` and ``b``: each the one of
    its two vertices nearer to that point."""
    vertices = [TopExp.FirstVertex_s(edge), TopExp.LastVertex_s(edge)]
    where = np.array([BRep_Tool.Pnt_s(v).Coord() for v in vertices])
    return tuple(vertices[int(np.argmin(np.linalg.norm(where - q, axis=1)))] for q in (a, b))


def _support(edge, ends: tuple, at_first: bool, at_last: bool) -> object:
    """The support of a foot on ``edge``: the vertex at the end its foot was held to (the
    point lies beyond that end, as OpenCascade's shape-to-shape distance then names the
    vertex, whose faces all give the normal there: engine.io.step.brep), else the edge."""
    return ends[0] if at_first else ends[1] if at_last else edge
