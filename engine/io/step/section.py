"""The section of a STEP model's B-rep by a plane: OpenCascade's ``BRepAlgoAPI_Section`` of all
its placed faces with the plane, each edge of the section discretised within a chord tolerance,
the edges joined at their shared vertices into ordered polylines (engine.section.chained).

Every vertex of the polylines is a point OpenCascade evaluates on a section edge's curve
(``GCPnts_QuasiUniformDeflection``: no chord strays from its edge by more than the tolerance; a
straight edge is its two ends). The outward normal in the plane of each chord is the B-rep's
outward unit normal at the chord's middle (:meth:`StepNominal.deviations`' normal there: on an
edge between two faces, the sum of theirs), projected into the plane.
"""

from __future__ import annotations

import numpy as np

from engine.section import Plane, SectionCurve, chained

from .brep import StepNominal, deflection_for

JOIN_MM = 1e-4
"""Section edges whose ends lie within this of each other are joined there (their shared
vertex; OpenCascade's vertices of one section are shared, so this only absorbs rounding)."""


def brep_section(step: StepNominal, plane: Plane, chord_mm: float | None = None) -> SectionCurve:
    """The section curve of ``step`` by ``plane`` (chord_mm: the discretisation's chord
    tolerance, mm; default the model's tessellation deflection, :func:`deflection_for` its
    bounding-box diagonal: 1 to 10 µm)."""
    if chord_mm is None:
        chord_mm = deflection_for(float(np.linalg.norm(step.bounds[1] - step.bounds[0])))
    pieces = section_edges(step, plane, chord_mm)
    if not pieces:
        return SectionCurve((), (), (), float(chord_mm), "step")
    nodes = _join_nodes(pieces)
    mids = np.vstack([0.5 * (p[1:] + p[:-1]) for p in pieces])
    _, _, normal, _ = step.deviations(mids)
    n2 = np.column_stack([normal @ plane.u, normal @ plane.v])
    size = np.linalg.norm(n2, axis=1, keepdims=True)
    n2 = np.where(size > 0, n2 / np.where(size > 0, size, 1.0), 0.0)
    split = np.cumsum([len(p) - 1 for p in pieces])[:-1]
    return chained(pieces, np.split(n2, split), nodes, plane, float(chord_mm), "step")


def section_edges(step: StepNominal, plane: Plane, chord_mm: float) -> list[np.ndarray]:
    """Each edge of OpenCascade's section of the model's faces by ``plane``, as (k, 3) points
    along it (from its first parameter to its last), mm."""
    from OCP.BRepAdaptor import BRepAdaptor_Curve
    from OCP.BRepAlgoAPI import BRepAlgoAPI_Section
    from OCP.GCPnts import GCPnts_QuasiUniformDeflection
    from OCP.GeomAbs import GeomAbs_Line
    from OCP.gp import gp_Dir, gp_Pln, gp_Pnt
    from OCP.TopAbs import TopAbs_EDGE
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopoDS import TopoDS

    section = BRepAlgoAPI_Section(faces_compound(step),
                                  gp_Pln(gp_Pnt(*map(float, plane.origin)),
                                         gp_Dir(*map(float, plane.normal))), False)
    section.Approximation(False)
    section.Build()
    if not section.IsDone():
        return []
    out = []
    explorer = TopExp_Explorer(section.Shape(), TopAbs_EDGE)
    while explorer.More():
        curve = BRepAdaptor_Curve(TopoDS.Edge(explorer.Current()))
        explorer.Next()
        t0, t1 = curve.FirstParameter(), curve.LastParameter()
        if curve.GetType() == GeomAbs_Line:
            params = [t0, t1]
        else:
            d = GCPnts_QuasiUniformDeflection(curve, chord_mm, t0, t1)
            if not d.IsDone() or d.NbPoints() < 2:
                continue
            params = [d.Parameter(i) for i in range(1, d.NbPoints() + 1)]
        pts = np.array([curve.Value(t).Coord() for t in params])
        if len(pts) >= 2 and np.linalg.norm(np.diff(pts, axis=0), axis=1).sum() > 0:
            out.append(pts)
    return out


def faces_compound(step: StepNominal):
    """A compound of the model's placed faces (each once)."""
    from OCP.BRep import BRep_Builder
    from OCP.TopoDS import TopoDS_Compound

    compound, builder = TopoDS_Compound(), BRep_Builder()
    builder.MakeCompound(compound)
    for fid in range(1, step.n_faces + 1):
        builder.Add(compound, step.face_shape(fid))
    return compound


def _join_nodes(pieces: list[np.ndarray]) -> np.ndarray:
    """(m, 2) node ids of the pieces' first and last points: ends within ``JOIN_MM`` of each
    other are one node."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree

    ends = np.array([[p[0], p[-1]] for p in pieces]).reshape(-1, 3)
    pairs = cKDTree(ends).query_pairs(JOIN_MM, output_type="ndarray")
    n = len(ends)
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    _, labels = connected_components(graph, directed=False)
    return labels.reshape(-1, 2)
