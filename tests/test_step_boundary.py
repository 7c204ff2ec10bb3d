"""The nearest point of a planar face's boundary in closed form (engine.io.step.boundary),
against OpenCascade's shape-to-shape distance to the trimmed face, on the real faces of NIST
test parts (plates with holes: straight edges and circular arcs, whole and partial)."""

from __future__ import annotations

import os

import numpy as np
import pytest

import step_models as sm
from engine.io.step.boundary import PlaneBoundary

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
PARTS = [os.path.join(ROOT, "tests", "data", "step", f)
         for f in ("nist_ftc_08_asme1_ap242-e1.stp", "nist_ctc_01_asme1_ap203.stp")]


def _distance_to(shape, p) -> float:
    """OpenCascade's distance from point p to a shape (step_models.distance_to_shape)."""
    return float(sm.distance_to_shape(shape, np.asarray(p, float)[None])[0])


def _tolerance(shape) -> float:
    """OpenCascade's tolerance of an edge or a vertex: how far its curve's end may lie from it."""
    from OCP.BRep import BRep_Tool
    from OCP.TopAbs import TopAbs_VERTEX
    from OCP.TopoDS import TopoDS
    if shape.ShapeType() == TopAbs_VERTEX:
        return BRep_Tool.Tolerance_s(TopoDS.Vertex(shape))
    return BRep_Tool.Tolerance_s(TopoDS.Edge(shape))


def _sub_shapes(face) -> list:
    from OCP.TopAbs import TopAbs_EDGE, TopAbs_VERTEX
    from OCP.TopExp import TopExp_Explorer
    out = []
    for kind in (TopAbs_EDGE, TopAbs_VERTEX):
        ex = TopExp_Explorer(face, kind)
        while ex.More():
            out.append(ex.Current())
            ex.Next()
    return out


@pytest.mark.parametrize("path", PARTS, ids=os.path.basename)
def test_the_nearest_point_of_a_planar_face_s_boundary_is_opencascade_s(path):
    """Points around each planar face bounded by lines and circles, their foot on the plane
    outside the face: the distance is OpenCascade's to the trimmed face, to 0.1 µm; the foot
    lies on the face; its support is one of the face's own edges or vertices, and the foot lies
    on it (the faces meeting there give the normal, engine.io.step.brep)."""
    from OCP.BRepAdaptor import BRepAdaptor_Surface
    from OCP.BRepClass import BRepClass_FaceClassifier
    from OCP.GeomAbs import GeomAbs_Plane
    from OCP.gp import gp_Pnt
    from OCP.TopAbs import TopAbs_OUT

    rng = np.random.default_rng(3)
    faces = arcs = checked = 0
    for face in sm.faces_of(sm.read_faces(path)):
        surface = BRepAdaptor_Surface(face)
        if surface.GetType() != GeomAbs_Plane:
            continue
        boundary = PlaneBoundary.of(face)
        if boundary is None:
            continue
        faces += 1
        arcs += boundary.arc_r.size
        plane = surface.Plane()
        o, n = np.array(plane.Location().Coord()), np.array(plane.Axis().Direction().Coord())
        ends = np.concatenate([boundary.seg_a, boundary.seg_b, boundary.arc_centre])
        lo, hi = ends.min(axis=0) - 5.0, ends.max(axis=0) + 5.0
        own = _sub_shapes(face)
        for p in rng.uniform(lo, hi, (12, 3)):
            on_plane = p - np.dot(p - o, n) * n
            if BRepClass_FaceClassifier(face, gp_Pnt(*on_plane), 1e-7).State() != TopAbs_OUT:
                continue
            distance, foot, support = boundary.nearest(p)
            truth = _distance_to(face, p)
            assert abs(distance - truth) < 1e-7, (path, p, distance, truth)
            assert abs(np.linalg.norm(p - foot) - distance) < 1e-9
            assert _distance_to(face, foot) < 1e-7
            assert any(support.IsSame(s) for s in own)
            assert _distance_to(support, foot) < 1e-7 + _tolerance(support)
            checked += 1
    assert faces > 20 and arcs > 20 and checked > 300, (faces, arcs, checked)


def test_a_face_with_a_curve_other_than_a_line_or_a_circle_has_no_closed_form():
    """An ellipse among a plane's edges: no PlaneBoundary (OpenCascade's distance is used)."""
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeEdge, BRepBuilderAPI_MakeFace, \
        BRepBuilderAPI_MakeWire
    from OCP.gp import gp_Ax2, gp_Dir, gp_Elips, gp_Pnt

    ellipse = gp_Elips(gp_Ax2(gp_Pnt(0, 0, 0), gp_Dir(0, 0, 1)), 20.0, 10.0)
    face = BRepBuilderAPI_MakeFace(
        BRepBuilderAPI_MakeWire(BRepBuilderAPI_MakeEdge(ellipse).Edge()).Wire()).Face()
    assert PlaneBoundary.of(face) is None


def test_analytic_feet_beyond_a_corner_an_edge_and_over_a_hole():
    """The top face of the box with a hole (z = its height): beyond a corner the foot is the
    corner, its support the vertex (three faces give the normal there); beyond an edge's middle
    the foot is on that edge, its support the edge; over the hole, on its circle."""
    from OCP.TopAbs import TopAbs_EDGE, TopAbs_VERTEX

    BOX = sm.BOX
    cx, cy = sm.HOLE_CENTRE[:2]
    top = next(f for f in sm.faces_of(sm.box_with_hole())
               if (b := PlaneBoundary.of(f)) is not None and b.arc_r.size
               and np.allclose(np.concatenate([b.seg_a, b.seg_b, b.arc_centre])[:, 2], BOX[2]))
    boundary = PlaneBoundary.of(top)
    z = BOX[2]
    cases = [((-3.0, -4.0, z + 1.0), (0.0, 0.0, z), TopAbs_VERTEX),
             ((BOX[0] / 2, -2.0, z + 1.0), (BOX[0] / 2, 0.0, z), TopAbs_EDGE),
             ((cx, cy + 0.4 * sm.HOLE_RADIUS, z + 0.5), (cx, cy + sm.HOLE_RADIUS, z),
              TopAbs_EDGE)]
    for p, foot, kind in cases:
        distance, got, support = boundary.nearest(np.array(p))
        assert np.allclose(got, foot, atol=1e-9), (p, got, foot)
        assert abs(distance - np.linalg.norm(np.subtract(p, foot))) < 1e-9
        assert support.ShapeType() == kind, (p, support.ShapeType())


@pytest.mark.parametrize("path", PARTS, ids=os.path.basename)
def test_a_face_s_own_distance_is_opencascade_s_over_its_inside_and_beyond_it(path):
    """StepNominal.face_distances, one face at a time, for points over each planar face's inside
    and beyond its edges alike (QIF face matching and a point's rival faces ask so): the
    distance is OpenCascade's to the trimmed face, to 0.1 µm. Over the inside that is the
    height above the plane, not the distance to the edges."""
    from engine.io.step import read_step

    nominal = read_step(path)
    rng = np.random.default_rng(5)
    over = checked = 0
    for fid, record in enumerate(nominal.faces, 1):
        if record.surface != "plane":
            continue
        face = nominal.face_shape(fid)
        boundary = PlaneBoundary.of(face)
        if boundary is None:
            continue
        on = nominal.point_set.points[nominal.face_ids == fid]
        m = min(4, len(on))
        p = on[rng.choice(len(on), m, replace=False)] + rng.normal(0, 1.0, (m, 3))
        got = nominal.face_distances(fid, p)
        for q, d in zip(p, got):
            truth = _distance_to(face, q)
            assert abs(d - truth) < 1e-7, (path, fid, q, d, truth)
            over += boundary.nearest(q)[0] > truth + 1e-6
            checked += 1
    assert checked > 200 and over > 50, (checked, over)
