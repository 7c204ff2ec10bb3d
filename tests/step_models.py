"""STEP files written with OpenCascade from known primitives, and their exact geometry, for
tests/test_step.py.

The truth the tests compare with is computed here with numpy from the primitives' dimensions and
placements (the B-spline's points and normals with scipy's B-splines from its control points),
never by engine.io.step. OpenCascade only builds the solids and writes the files.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.interpolate import BSpline
from scipy.spatial.transform import Rotation

# The box with a hole: [0, 40] x [0, 30] x [0, 20] mm, a through hole of radius 5 along z at
# (20, 15).
BOX = np.array([40.0, 30.0, 20.0])
HOLE_CENTRE = np.array([20.0, 15.0])
HOLE_RADIUS = 5.0
# The hemisphere: radius 12 about the origin, z >= 0 (a spherical face and a planar disk).
SPHERE_RADIUS = 12.0
# The B-spline sheet: bicubic, 6 x 6 control points over [0, 50] x [0, 40].
BSPLINE_DEGREE = 3
BSPLINE_SIZE = (50.0, 40.0)


# ------------------------------------------------------------------------------ poses and files

def random_pose(seed: int) -> tuple[np.ndarray, np.ndarray]:
    """A seeded rigid pose (R (3, 3), t (3,)): any rotation, a translation of up to 200 mm."""
    rng = np.random.default_rng(seed)
    return Rotation.random(random_state=seed).as_matrix(), rng.uniform(-200, 200, 3)


def gp_trsf(R: np.ndarray, t: np.ndarray):
    from OCP.gp import gp_Trsf
    trsf = gp_Trsf()
    trsf.SetValues(*R[0], t[0], *R[1], t[1], *R[2], t[2])
    return trsf


def placed(shape, R: np.ndarray, t: np.ndarray):
    """A copy of the shape moved by x -> R x + t."""
    from OCP.BRepBuilderAPI import BRepBuilderAPI_Transform
    return BRepBuilderAPI_Transform(shape, gp_trsf(R, t), True).Shape()


def write_step(shape, path, unit: str = "MM") -> str:
    """Write one shape as a STEP file (AP214) in the given unit ('MM', 'INCH', 'M')."""
    from OCP.Interface import Interface_Static
    from OCP.STEPControl import STEPControl_AsIs, STEPControl_Writer
    writer = STEPControl_Writer()
    try:
        Interface_Static.SetCVal_s("write.step.unit", unit)
        writer.Transfer(shape, STEPControl_AsIs)
    finally:
        Interface_Static.SetCVal_s("write.step.unit", "MM")
    assert writer.Write(str(path)).name == "IFSelect_RetDone"
    return str(path)


def write_assembly(part, part_name: str, face_names: dict, placements, path) -> str:
    """Write an assembly of one part placed several times (an XDE document: the part named
    ``part_name``, its faces number k (1-based, exploration order) named face_names[k], one
    component per (R, t) in ``placements``)."""
    from OCP.Interface import Interface_Static
    from OCP.STEPCAFControl import STEPCAFControl_Writer
    from OCP.STEPControl import STEPControl_AsIs
    from OCP.TCollection import TCollection_ExtendedString
    from OCP.TDataStd import TDataStd_Name
    from OCP.TDocStd import TDocStd_Document
    from OCP.TopLoc import TopLoc_Location
    from OCP.XCAFDoc import XCAFDoc_DocumentTool

    doc = TDocStd_Document(TCollection_ExtendedString("XmlXCAF"))
    tool = XCAFDoc_DocumentTool.ShapeTool_s(doc.Main())
    label = tool.AddShape(part, False)
    TDataStd_Name.Set_s(label, TCollection_ExtendedString(part_name))
    for k, face in enumerate(faces_of(part), start=1):
        if k in face_names:
            sub = tool.AddSubShape(label, face)
            TDataStd_Name.Set_s(sub, TCollection_ExtendedString(face_names[k]))
    assembly = tool.NewShape()
    TDataStd_Name.Set_s(assembly, TCollection_ExtendedString("ASSEMBLY"))
    for R, t in placements:
        tool.AddComponent(assembly, label, TopLoc_Location(gp_trsf(R, t)))
    tool.UpdateAssemblies()
    writer = STEPCAFControl_Writer()
    writer.SetNameMode(True)
    # The writer's construction registers this setting: set it after.
    Interface_Static.SetIVal_s("write.stepcaf.subshapes.name", 1)
    assert writer.Transfer(doc, STEPControl_AsIs)
    assert writer.Write(str(path)).name == "IFSelect_RetDone"
    return str(path)


def faces_of(shape) -> list:
    from OCP.TopAbs import TopAbs_FACE
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopoDS import TopoDS
    out, ex = [], TopExp_Explorer(shape, TopAbs_FACE)
    while ex.More():
        out.append(TopoDS.Face(ex.Current()))
        ex.Next()
    return out


# ------------------------------------------------------------------------------ the box with a hole

def box_with_hole():
    from OCP.BRepAlgoAPI import BRepAlgoAPI_Cut
    from OCP.BRepPrimAPI import BRepPrimAPI_MakeBox, BRepPrimAPI_MakeCylinder
    from OCP.gp import gp_Ax2, gp_Dir, gp_Pnt
    box = BRepPrimAPI_MakeBox(*BOX).Shape()
    axis = gp_Ax2(gp_Pnt(*HOLE_CENTRE, -1.0), gp_Dir(0, 0, 1))
    hole = BRepPrimAPI_MakeCylinder(axis, HOLE_RADIUS, BOX[2] + 2).Shape()
    return BRepAlgoAPI_Cut(box, hole).Shape()


def featured_block():
    """Issue 21's plain block: 120 x 80 x 30 mm ([0, 120] x [0, 80] x [0, 30]) with a through
    hole (radius 8 along z at (30, 40)), a boss on top (radius 10, 12 high, at (90, 40)) and a
    slot in the top (x 45-75, y 35-45, 10 deep)."""
    from OCP.BRepAlgoAPI import BRepAlgoAPI_Cut, BRepAlgoAPI_Fuse
    from OCP.BRepPrimAPI import BRepPrimAPI_MakeBox, BRepPrimAPI_MakeCylinder
    from OCP.gp import gp_Ax2, gp_Dir, gp_Pnt

    block = BRepPrimAPI_MakeBox(120.0, 80.0, 30.0).Shape()
    hole = BRepPrimAPI_MakeCylinder(gp_Ax2(gp_Pnt(30, 40, -1), gp_Dir(0, 0, 1)), 8.0, 32.0)
    boss = BRepPrimAPI_MakeCylinder(gp_Ax2(gp_Pnt(90, 40, 30), gp_Dir(0, 0, 1)), 10.0, 12.0)
    slot = BRepPrimAPI_MakeBox(gp_Pnt(45, 35, 20), gp_Pnt(75, 45, 31)).Shape()
    shape = BRepAlgoAPI_Cut(block, hole.Shape()).Shape()
    shape = BRepAlgoAPI_Fuse(shape, boss.Shape()).Shape()
    return BRepAlgoAPI_Cut(shape, slot).Shape()


def box_face_samples(rng, n_per_face: int, margin: float = 1.5):
    """Points on the box-with-hole's faces at least ``margin`` from every edge: (feet (m, 3),
    outward normals (m, 3), which face: 'x-', 'x+', 'y-', 'y+', 'z-', 'z+' or 'hole')."""
    feet, normals, names = [], [], []
    for axis in range(3):
        a, b = [k for k in range(3) if k != axis]
        for side, value in (("-", 0.0), ("+", BOX[axis])):
            pts = np.zeros((0, 3))
            while len(pts) < n_per_face:
                p = np.zeros((4 * n_per_face, 3))
                p[:, a] = rng.uniform(margin, BOX[a] - margin, len(p))
                p[:, b] = rng.uniform(margin, BOX[b] - margin, len(p))
                p[:, axis] = value
                if axis == 2:  # the top and bottom faces have the hole's rim
                    p = p[np.hypot(*(p[:, :2] - HOLE_CENTRE).T) > HOLE_RADIUS + margin]
                pts = np.concatenate([pts, p])[:n_per_face]
            n = np.zeros(3)
            n[axis] = -1.0 if side == "-" else 1.0
            feet.append(pts)
            normals.append(np.tile(n, (n_per_face, 1)))
            names += ["xyz"[axis] + side] * n_per_face
    theta = rng.uniform(0, 2 * np.pi, n_per_face)
    radial = np.column_stack([np.cos(theta), np.sin(theta), np.zeros(n_per_face)])
    z = rng.uniform(margin, BOX[2] - margin, n_per_face)
    feet.append(np.column_stack([HOLE_CENTRE + HOLE_RADIUS * radial[:, :2], z]))
    normals.append(-radial)  # the material is outside the hole: outward points to the axis
    names += ["hole"] * n_per_face
    return np.concatenate(feet), np.concatenate(normals), np.array(names)


def box_hole_normal(points: np.ndarray, face_points_local: np.ndarray) -> np.ndarray:
    """The exact outward normal of the box-with-hole at points of one face (local frame),
    recognised from all that face's points: on the hole wall (radius 5 about the hole's axis) the
    normal points to the axis; a planar face is the one coordinate they all share."""
    rho = np.hypot(*(face_points_local[:, :2] - HOLE_CENTRE).T)
    if np.allclose(rho, HOLE_RADIUS, atol=1e-9):
        radial = np.column_stack([points[:, :2] - HOLE_CENTRE, np.zeros(len(points))])
        return -radial / np.linalg.norm(radial, axis=1, keepdims=True)
    axis = int(np.argmin(np.ptp(face_points_local, axis=0)))
    n = np.zeros(3)
    n[axis] = 1.0 if face_points_local[0, axis] > BOX[axis] / 2 else -1.0
    return np.tile(n, (len(points), 1))


def box():
    from OCP.BRepPrimAPI import BRepPrimAPI_MakeBox
    return BRepPrimAPI_MakeBox(*BOX).Shape()


def box_one_face_reversed():
    """A 40 x 30 x 20 box whose top face (z = 20) is put into its shell the wrong way round,
    as a careless exporter might write it; (solid, the reversed face)."""
    from OCP.BRep import BRep_Builder
    from OCP.TopoDS import TopoDS, TopoDS_Shell, TopoDS_Solid
    builder = BRep_Builder()
    shell, solid = TopoDS_Shell(), TopoDS_Solid()
    builder.MakeShell(shell)
    top = None
    for face in faces_of(box()):
        if abs(face_centre(face)[2] - BOX[2]) < 1e-9:
            top = face = TopoDS.Face(face.Reversed())
        builder.Add(shell, face)
    builder.MakeSolid(solid)
    builder.Add(solid, shell)
    return solid, top


def face_centre(face) -> np.ndarray:
    from OCP.BRepGProp import BRepGProp
    from OCP.GProp import GProp_GProps
    props = GProp_GProps()
    BRepGProp.SurfaceProperties_s(face, props)
    return np.array(props.CentreOfMass().Coord())


def oriented_normal_at_centre(face) -> np.ndarray:
    """The face's normal (its orientation applied) at its centre, as OpenCascade has it."""
    from OCP.BRepAdaptor import BRepAdaptor_Surface
    from OCP.BRepLProp import BRepLProp_SLProps
    from OCP.BRepTools import BRepTools
    from OCP.TopAbs import TopAbs_REVERSED
    u0, u1, v0, v1 = BRepTools.UVBounds_s(face)
    props = BRepLProp_SLProps(BRepAdaptor_Surface(face), (u0 + u1) / 2, (v0 + v1) / 2, 1, 1e-9)
    n = np.array(props.Normal().Coord())
    return -n if face.Orientation() == TopAbs_REVERSED else n


def wedge(angle_deg: float = 30.0, length: float = 40.0, height: float = 10.0):
    """A triangular prism whose edge along z through the origin is sharp: the faces y = 0 and
    the plane through z at ``angle_deg`` from +x meet there at that angle."""
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeFace, BRepBuilderAPI_MakePolygon
    from OCP.BRepPrimAPI import BRepPrimAPI_MakePrism
    from OCP.gp import gp_Pnt, gp_Vec
    a = math.radians(angle_deg)
    poly = BRepBuilderAPI_MakePolygon(gp_Pnt(0, 0, 0), gp_Pnt(length, 0, 0),
                                      gp_Pnt(length, length * math.tan(a), 0), True)
    base = BRepBuilderAPI_MakeFace(poly.Wire()).Face()
    return BRepPrimAPI_MakePrism(base, gp_Vec(0, 0, height)).Shape()


def read_faces(path):
    """A compound of all the faces of a STEP file as OpenCascade's plain reader gives them (for
    brute-force checks; the file's wireframe curves, if any, left out)."""
    from OCP.BRep import BRep_Builder
    from OCP.STEPControl import STEPControl_Reader
    from OCP.TopoDS import TopoDS_Compound
    reader = STEPControl_Reader()
    assert reader.ReadFile(str(path)).name == "IFSelect_RetDone"
    reader.TransferRoots()
    compound, builder = TopoDS_Compound(), BRep_Builder()
    builder.MakeCompound(compound)
    for face in faces_of(reader.OneShape()):
        builder.Add(compound, face)
    return compound


def outside_solid(path, points: np.ndarray) -> np.ndarray:
    """Per point: 1.0 outside the STEP file's (first) solid, 0.0 inside, NaN on it —
    OpenCascade's solid classifier (rays cast against the faces), independent of any normal."""
    from OCP.BRepClass3d import BRepClass3d_SolidClassifier
    from OCP.gp import gp_Pnt
    from OCP.STEPControl import STEPControl_Reader
    from OCP.TopAbs import TopAbs_IN, TopAbs_OUT, TopAbs_SOLID
    from OCP.TopExp import TopExp_Explorer
    reader = STEPControl_Reader()
    assert reader.ReadFile(str(path)).name == "IFSelect_RetDone"
    reader.TransferRoots()
    classifier = BRepClass3d_SolidClassifier(TopExp_Explorer(reader.OneShape(),
                                                             TopAbs_SOLID).Current())
    out = []
    for p in points:
        classifier.Perform(gp_Pnt(*p), 1e-7)
        state = classifier.State()
        out.append(1.0 if state == TopAbs_OUT else 0.0 if state == TopAbs_IN else np.nan)
    return np.array(out)


def distance_to_shape(shape, points: np.ndarray) -> np.ndarray:
    """Unsigned distances from points to a whole shape, one BRepExtrema_DistShapeShape each:
    no candidate faces, no bounds — the slow, obvious twin of StepNominal.deviations."""
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeVertex
    from OCP.BRepExtrema import BRepExtrema_DistShapeShape
    from OCP.gp import gp_Pnt
    out = []
    for p in points:
        dss = BRepExtrema_DistShapeShape(BRepBuilderAPI_MakeVertex(gp_Pnt(*p)).Vertex(), shape)
        assert dss.IsDone()
        out.append(dss.Value())
    return np.array(out)


def half_cylinder_sheet(radius: float = 10.0, height: float = 20.0):
    """An open sheet: the half of the cylinder x^2 + y^2 = r^2 with y >= 0, 0 <= z <= height."""
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeFace
    from OCP.Geom import Geom_CylindricalSurface
    from OCP.gp import gp_Ax3
    return BRepBuilderAPI_MakeFace(Geom_CylindricalSurface(gp_Ax3(), radius), 0.0, math.pi,
                                   0.0, height, 1e-7).Face()


def trough_sheet(half_width: float = 5.0, length: float = 20.0):
    """An open B-spline sheet, the parabolic trough z = x^2 / 4 for |x| <= half_width, 0 <= y <=
    length (a quadratic Bezier across, linear along: its control points are exact)."""
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeFace
    from OCP.collections import Array1_double, Array1_int, Array2_gp_Pnt
    from OCP.Geom import Geom_BSplineSurface
    from OCP.gp import gp_Pnt
    w = half_width
    across = [(-w, w * w / 4), (0.0, -w * w / 4), (w, w * w / 4)]
    poles = Array2_gp_Pnt(1, 3, 1, 2)
    for i, (x, z) in enumerate(across):
        for j, y in enumerate((0.0, length)):
            poles.SetValue(i + 1, j + 1, gp_Pnt(x, y, z))
    knots, ends = Array1_double(1, 2), Array1_int(1, 2)
    knots.SetValue(1, 0.0)
    knots.SetValue(2, 1.0)
    mults_u, mults_v = Array1_int(1, 2), Array1_int(1, 2)
    for k in (1, 2):
        mults_u.SetValue(k, 3)
        mults_v.SetValue(k, 2)
    surface = Geom_BSplineSurface(poles, knots, knots, mults_u, mults_v, 2, 1)
    return BRepBuilderAPI_MakeFace(surface, 1e-7).Face()


def cone_and_torus():
    """A solid cone frustum (semi-angle ~21.8 degrees) and a torus (radii 20 and 4), apart."""
    from OCP.BRep import BRep_Builder
    from OCP.BRepPrimAPI import BRepPrimAPI_MakeCone, BRepPrimAPI_MakeTorus
    from OCP.gp import gp_Ax2, gp_Dir, gp_Pnt
    from OCP.TopoDS import TopoDS_Compound
    compound, builder = TopoDS_Compound(), BRep_Builder()
    builder.MakeCompound(compound)
    builder.Add(compound, BRepPrimAPI_MakeCone(10.0, 2.0, 20.0).Shape())
    builder.Add(compound, BRepPrimAPI_MakeTorus(gp_Ax2(gp_Pnt(60, 0, 0), gp_Dir(0.3, 0.2, 0.9)),
                                                20.0, 4.0).Shape())
    return compound


# ------------------------------------------------------------------------------ the hemisphere

def hemisphere():
    """A solid hemisphere of radius 12 about the origin, z >= 0: a spherical face trimmed at the
    equator and a planar disk."""
    from OCP.BRepPrimAPI import BRepPrimAPI_MakeSphere
    return BRepPrimAPI_MakeSphere(SPHERE_RADIUS, 0.0, math.pi / 2).Shape()


def sphere_directions(rng, n: int, lat_lo: float, lat_hi: float) -> np.ndarray:
    lon, lat = rng.uniform(0, 2 * np.pi, n), rng.uniform(lat_lo, lat_hi, n)
    return np.column_stack([np.cos(lat) * np.cos(lon), np.cos(lat) * np.sin(lon), np.sin(lat)])


# ------------------------------------------------------------------------------ the B-spline sheet

def bspline_control_points(seed: int = 11) -> np.ndarray:
    """(6, 6, 3) control points: a grid over [0, 50] x [0, 40] with smooth heights of +-3 mm."""
    rng = np.random.default_rng(seed)
    x, y = np.meshgrid(np.linspace(0, BSPLINE_SIZE[0], 6), np.linspace(0, BSPLINE_SIZE[1], 6),
                       indexing="ij")
    z = 3.0 * np.sin(x / 15.0 + 0.3) * np.cos(y / 13.0) + rng.uniform(-0.5, 0.5, x.shape)
    return np.stack([x, y, z], axis=-1)


def bspline_knots(n_ctrl: int = 6, k: int = BSPLINE_DEGREE) -> np.ndarray:
    inner = np.linspace(0, 1, n_ctrl - k + 1)
    return np.concatenate([[0.0] * k, inner, [1.0] * k])


def bspline_face(ctrl: np.ndarray, reversed_: bool = False):
    """A single face on the clamped bicubic B-spline surface of these control points."""
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeFace
    from OCP.Geom import Geom_BSplineSurface
    from OCP.collections import Array1_double, Array1_int, Array2_gp_Pnt
    from OCP.gp import gp_Pnt
    from OCP.TopoDS import TopoDS
    nu, nv = ctrl.shape[:2]
    poles = Array2_gp_Pnt(1, nu, 1, nv)
    for i in range(nu):
        for j in range(nv):
            poles.SetValue(i + 1, j + 1, gp_Pnt(*ctrl[i, j]))

    def knots(n):
        inner = np.linspace(0, 1, n - BSPLINE_DEGREE + 1)
        values, mults = Array1_double(1, len(inner)), Array1_int(1, len(inner))
        for i, v in enumerate(inner):
            values.SetValue(i + 1, float(v))
            mults.SetValue(i + 1, BSPLINE_DEGREE + 1 if i in (0, len(inner) - 1) else 1)
        return values, mults

    (ku, mu), (kv, mv) = knots(nu), knots(nv)
    surface = Geom_BSplineSurface(poles, ku, kv, mu, mv, BSPLINE_DEGREE, BSPLINE_DEGREE)
    face = BRepBuilderAPI_MakeFace(surface, 1e-7).Face()
    return TopoDS.Face(face.Reversed()) if reversed_ else face


def bspline_eval(ctrl: np.ndarray, u: np.ndarray, v: np.ndarray):
    """Points (m, 3) and unit normals (Su x Sv) of the B-spline surface at (u, v), with scipy's
    B-spline bases: sum_ij N_i(u) N_j(v) P_ij."""
    t, k = bspline_knots(ctrl.shape[0]), BSPLINE_DEGREE
    eye_u, eye_v = np.eye(ctrl.shape[0]), np.eye(ctrl.shape[1])
    Nu, Nv = BSpline(t, eye_u, k)(u), BSpline(bspline_knots(ctrl.shape[1]), eye_v, k)(v)
    dNu = BSpline(t, eye_u, k).derivative()(u)
    dNv = BSpline(bspline_knots(ctrl.shape[1]), eye_v, k).derivative()(v)
    S = np.einsum("mi,mj,ijc->mc", Nu, Nv, ctrl)
    Su = np.einsum("mi,mj,ijc->mc", dNu, Nv, ctrl)
    Sv = np.einsum("mi,mj,ijc->mc", Nu, dNv, ctrl)
    n = np.cross(Su, Sv)
    return S, n / np.linalg.norm(n, axis=1, keepdims=True)
