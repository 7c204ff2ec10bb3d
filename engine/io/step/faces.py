"""One face of a STEP model's B-rep: its record (:class:`StepFace`), the nearest points on its
surface (planes, cylinders, cones, spheres and tori in closed form, vectorised; other surfaces,
B-splines among them, by OpenCascade's extrema over the face's (u, v) box) and its trim in
(u, v) (polylines of its boundary, OpenCascade's classifier near them): :class:`FaceTools`,
made once per face and reused for every point; :class:`Surfaces` and :class:`Trims` hold every
face's for work in bulk (``engine.io.step.brep``).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field

import numpy as np

from engine.errors import InputError

from .boundary import PlaneBoundary

TRIM_DEFLECTION = 2e-4
"""A face's trim is drawn in its (u, v) domain as polylines within this fraction of the domain
box's diagonal of the boundary curves; a foot farther than ``TRIM_BAND`` x that from every
polyline is classified by them (even-odd), the others by OpenCascade's classifier."""
TRIM_BAND = 4.0
TRIM_CHECKS = 32
"""Seeded random (u, v) points on which the polylines must classify as OpenCascade does before
they are used for a face (else that face keeps OpenCascade's classifier)."""


@dataclass(frozen=True)
class StepFace:
    """One face of the B-rep.

    id : 1..F, the face's place in the file's reading order (stable for the same file).
    name : the face's own name in the file, or None.
    part : the name of the solid/shell or product the face belongs to, or None.
    surface : the kind of its surface: 'plane', 'cylinder', 'cone', 'sphere', 'torus',
        'bspline', 'bezier', 'revolution', 'extrusion', 'offset' or 'other'.
    reversed : True when the face's orientation is TopAbs_REVERSED (its outward normal is minus
        its surface's normal).
    geometry : the exact surface for planes (``point``, outward unit ``normal``), cylinders
        (``point`` on the axis, unit ``axis``, ``radius``, ``hole``: True when the outward normal
        points to the axis), spheres (``centre``, ``radius``, ``hole``), cones (``apex``, unit
        ``axis`` pointing from the apex into the cone, ``half_angle`` radians) and tori
        (``centre``, unit ``axis``, ``major``, ``minor`` radii); millimetres, the nominal frame.
        Empty for other surfaces.
    """

    id: int
    name: str | None
    part: str | None
    surface: str
    reversed: bool
    geometry: dict = field(default_factory=dict)


SURFACE_KINDS = {"Plane": "plane", "Cylinder": "cylinder", "Cone": "cone", "Sphere": "sphere",
                  "Torus": "torus", "BSplineSurface": "bspline", "BezierSurface": "bezier",
                  "SurfaceOfRevolution": "revolution", "SurfaceOfExtrusion": "extrusion",
                  "OffsetSurface": "offset"}


class _Elementary:
    """Nearest points on an elementary surface — plane, cylinder, cone, sphere or torus —
    unbounded, in closed form and vectorised, in OpenCascade's parametrisation (so that the
    face's trim, drawn in that (u, v), classifies them). The nearest point of the unbounded
    surface is its global minimum of distance: on the face it is the face's nearest point, off
    the face its distance bounds the face's from below."""

    KINDS = ("Plane", "Cylinder", "Cone", "Sphere", "Torus")
    PARAMETERS = ("o", "x", "y", "z", "R", "r", "alpha")

    def __init__(self, kind: str, adaptor):
        surface = getattr(adaptor, kind)()
        ax3 = surface.Position()
        self.kind = kind
        self.o = np.array(ax3.Location().Coord())
        self.x, self.y, self.z = (np.array(d.Coord()) for d in
                                  (ax3.XDirection(), ax3.YDirection(), ax3.Direction()))
        self.R = {"Plane": 0.0, "Cylinder": getattr(surface, "Radius", lambda: 0.0)(),
                  "Cone": getattr(surface, "RefRadius", lambda: 0.0)(),
                  "Sphere": getattr(surface, "Radius", lambda: 0.0)(),
                  "Torus": getattr(surface, "MajorRadius", lambda: 0.0)()}[kind]
        self.r = surface.MinorRadius() if kind == "Torus" else 0.0
        self.alpha = surface.SemiAngle() if kind == "Cone" else 0.0

    @classmethod
    def of(cls, adaptor) -> "_Elementary | None":
        kind = adaptor.GetType().name.removeprefix("GeomAbs_")
        if kind not in cls.KINDS:
            return None
        e = cls(kind, adaptor)
        return None if kind == "Torus" and e.r >= e.R else e  # a spindle torus: the general way

    @classmethod
    def stack(cls, surfaces: list["_Elementary"]) -> "_Elementary":
        """Surfaces of one kind as rows: each parameter an array over them (see :meth:`take`)."""
        s = object.__new__(cls)
        s.kind = surfaces[0].kind
        for name in cls.PARAMETERS:
            setattr(s, name, np.array([getattr(e, name) for e in surfaces], float))
        return s

    def take(self, rows: np.ndarray) -> "_Elementary":
        """Of stacked surfaces (:meth:`stack`), one per point: ``rows`` (m,) indices into them;
        :meth:`nearest` then projects the i-th point on the i-th surface."""
        s = object.__new__(type(self))
        s.kind = self.kind
        for name in self.PARAMETERS:
            setattr(s, name, getattr(self, name)[rows])
        return s

    def nearest(self, p: np.ndarray):
        """For points p (m, 3): distance (m,), u (m,), v (m,), foot (m, 3) and the surface's
        unit normal there (m, 3; the parametrisation's, before the face's orientation). The
        surface is one, or one per point (:meth:`take`)."""
        w = p - self.o
        lx, ly, lz = _rows_dot(w, self.x), _rows_dot(w, self.y), _rows_dot(w, self.z)
        if self.kind == "Plane":
            n = np.broadcast_to(np.cross(self.x, self.y), p.shape)
            h = _rows_dot(w, n)
            return np.abs(h), lx, ly, p - h[:, None] * n, n.copy()
        u = np.arctan2(ly, lx)
        rho = np.hypot(lx, ly)
        if self.kind == "Cylinder":
            v, radius, height = lz, np.broadcast_to(self.R, lz.shape), lz
            d = np.abs(rho - self.R)
        elif self.kind == "Sphere":
            v = np.arctan2(lz, rho)
            radius, height = self.R * np.cos(v), self.R * np.sin(v)
            d = np.abs(np.hypot(rho, lz) - self.R)
        elif self.kind == "Torus":
            v = np.arctan2(lz, rho - self.R)
            radius, height = self.R + self.r * np.cos(v), self.r * np.sin(v)
            d = np.abs(np.hypot(rho - self.R, lz) - self.r)
        else:
            u, v, d, radius, height = self._cone(u, rho, lz)
        e = np.cos(u)[:, None] * self.x + np.sin(u)[:, None] * self.y
        foot = self.o + radius[:, None] * e + height[:, None] * self.z
        return d, u, v, foot, self._normal(u, v, e, radius)

    def _cone(self, u, rho, lz):
        """The double cone's nearest generatrix in the meridian plane of each point: the one on
        the point's side (u) or the opposite one (u + pi), whichever is nearer."""
        sa, ca = np.sin(self.alpha), np.cos(self.alpha)
        d_near = np.abs((rho - self.R) * ca - lz * sa)
        d_far = np.abs((rho + self.R) * ca + lz * sa)
        near = d_near <= d_far
        v = np.where(near, (rho - self.R) * sa + lz * ca, lz * ca - (rho + self.R) * sa)
        u = np.where(near, u, u + np.pi)
        return u, v, np.minimum(d_near, d_far), self.R + v * sa, v * ca

    def _normal(self, u, v, e, radius):
        """D1U x D1V, normalised (its positive factors left out, so it is defined at poles)."""
        tangent_u = -np.sin(u)[:, None] * self.x + np.cos(u)[:, None] * self.y
        if self.kind == "Cylinder":
            dv = np.broadcast_to(self.z, tangent_u.shape)
        elif self.kind == "Cone":
            sa, ca = np.sin(self.alpha)[..., None], np.cos(self.alpha)[..., None]
            dv = sa * e + ca * self.z
            tangent_u = tangent_u * np.where(radius < 0, -1.0, 1.0)[:, None]
        else:  # sphere, torus: d/dv of (cos v e + sin v z), up to the radius
            dv = -np.sin(v)[:, None] * e + np.cos(v)[:, None] * self.z
        n = np.cross(tangent_u, dv)
        return n / np.linalg.norm(n, axis=1, keepdims=True)


class FaceTools:
    """What the exact distance needs of one face, made once and reused for every point: its
    (located) surface, the closed form of an elementary surface or else a projector over the
    face's (u, v) box, the classifier of its trimmed domain, its surface properties and a
    shape-to-shape distance with it loaded."""

    def __init__(self, face):
        from OCP.BRep import BRep_Tool
        from OCP.BRepTools import BRepTools
        from OCP.GeomAdaptor import GeomAdaptor_Surface
        from OCP.GeomAPI import GeomAPI_ProjectPointOnSurf
        from OCP.GeomLProp import GeomLProp_SLProps
        from OCP.IntTools import IntTools_FClass2d
        from OCP.TopAbs import TopAbs_REVERSED

        self.face = face
        self.reversed = face.Orientation() == TopAbs_REVERSED
        self.surface = BRep_Tool.Surface_s(face)
        self.uv_box = BRepTools.UVBounds_s(face)
        self.elementary = _Elementary.of(GeomAdaptor_Surface(self.surface))
        self.periods = (self.surface.UPeriod() if self.surface.IsUPeriodic() else 0.0,
                        self.surface.VPeriod() if self.surface.IsVPeriodic() else 0.0)
        self.projector = GeomAPI_ProjectPointOnSurf()
        self.projector.Init(self.surface, *self.uv_box)
        self.classifier = IntTools_FClass2d(face, max(BRep_Tool.Tolerance_s(face), 1e-7))
        self.props = GeomLProp_SLProps(self.surface, 1, 1e-12)
        self._distance = None

    def normal(self, u: float, v: float) -> np.ndarray | None:
        """The outward unit normal at (u, v), or None where the surface has none (a pole)."""
        self.props.SetParameters(u, v)
        if not self.props.IsNormalDefined():
            return None
        n = np.array(self.props.Normal().Coord())
        return -n if self.reversed else n

    def point(self, u: float, v: float) -> np.ndarray:
        return np.array(self.surface.Value(u, v).Coord())

    def project(self, pts: np.ndarray):
        """The nearest points of the face's surface to pts (m, 3), for the face's trim to judge:
        (distance, (u, v), found, bound). ``found``: the foot lies in the face's (u, v) box,
        at ``distance``; ``bound``: a lower bound of the distance to the trimmed face (an
        elementary surface's unbounded distance; NaN when there is none but the face's
        bounding box)."""
        if self.elementary is None:
            return self._project_general(pts)
        d, u, v, _, _ = self.elementary.nearest(pts)
        uv, found = in_box(u, v, np.asarray(self.uv_box, float), np.asarray(self.periods))
        return d, uv, found, d

    def _project_general(self, pts: np.ndarray):
        """OpenCascade's extrema over the face's (u, v) box, one point at a time: the nearest
        point of the surface over the box (its search takes the box's edges in), so on the
        face it is the face's nearest point."""
        from OCP.gp import gp_Pnt

        m = pts.shape[0]
        d, uv, found = np.full(m, np.nan), np.zeros((m, 2)), np.zeros(m, bool)
        proj = self.projector
        for j, (x, y, z) in enumerate(pts.tolist()):
            try:
                proj.Perform(gp_Pnt(x, y, z))
                if proj.IsDone() and proj.NbPoints():
                    d[j], uv[j] = proj.LowerDistance(), proj.LowerDistanceParameters()
                    found[j] = True
            except Exception:  # OpenCascade's StdFail: leave the point to the exact path
                found[j] = False
        return d, uv, found, np.full(m, np.nan)

    def at(self, pts: np.ndarray, uv: np.ndarray):
        """The feet at (u, v) of points pts (m, 3) whose nearest point lies inside the face:
        (feet (m, 3), outward unit normals (m, 3); NaN where the surface has none)."""
        if self.elementary is not None:
            _, _, _, foot, n = self.elementary.nearest(pts)
            return foot, -n if self.reversed else n
        foot, normal = np.zeros((len(pts), 3)), np.full((len(pts), 3), np.nan)
        for j, (u, v) in enumerate(uv.tolist()):
            foot[j] = self.point(u, v)
            n = self.normal(u, v)
            if n is not None:
                normal[j] = n
        return foot, normal

    @functools.cached_property
    def plane_boundary(self) -> PlaneBoundary | None:
        """A plane's edges for its nearest points in closed form (engine.io.step.boundary), made
        on first use; None for another surface or a plane with another kind of edge."""
        plane = self.elementary is not None and self.elementary.kind == "Plane"
        return PlaneBoundary.of(self.face) if plane else None

    @functools.cached_property
    def trim(self) -> tuple[np.ndarray, float] | None:
        """The face's trim polylines and band (:meth:`_trim_polylines`), drawn on first use."""
        return self._trim_polylines()

    def _trim_polylines(self) -> tuple[np.ndarray, float] | None:
        """The face's boundary in its (u, v) domain: (segments (E, 4) u0 v0 u1 v1 of the
        polylines of every edge's curve on the surface, within TRIM_DEFLECTION of it; the band
        within which the polylines do not decide), or None when a curve is missing, the
        polylines do not close, or they classify a check point unlike OpenCascade."""
        from OCP.BRepAdaptor import BRepAdaptor_Curve2d
        from OCP.GCPnts import GCPnts_UniformDeflection
        from OCP.TopAbs import TopAbs_EDGE
        from OCP.TopExp import TopExp_Explorer
        from OCP.TopoDS import TopoDS

        from engine.kernels import in_polygon

        u0, u1, v0, v1 = self.uv_box
        deflection = TRIM_DEFLECTION * float(np.hypot(u1 - u0, v1 - v0))
        if not deflection > 0:
            return None
        lines = []
        try:
            explorer = TopExp_Explorer(self.face, TopAbs_EDGE)
            while explorer.More():
                curve = BRepAdaptor_Curve2d(TopoDS.Edge(explorer.Current()), self.face)
                cut = GCPnts_UniformDeflection(curve, deflection, curve.FirstParameter(),
                                               curve.LastParameter())
                if not cut.IsDone() or cut.NbPoints() < 2:
                    return None
                lines.append(np.array([curve.Value(cut.Parameter(i)).Coord()
                                       for i in range(1, cut.NbPoints() + 1)]))
                explorer.Next()
        except Exception:  # a missing curve on the surface, OpenCascade's Standard_Failure
            return None
        band = TRIM_BAND * deflection
        joined = _joined(lines, band) if lines else None
        if joined is None:
            return None
        segments = np.concatenate([np.hstack([p[:-1], p[1:]]) for p in joined])
        rng = np.random.default_rng(3)
        check = np.column_stack([rng.uniform(u0, u1, TRIM_CHECKS),
                                 rng.uniform(v0, v1, TRIM_CHECKS)])
        inside, near = in_polygon(check, segments, band)
        if (inside != self.classify(check))[~near].any():
            return None
        return segments, band

    def classify(self, uv: np.ndarray) -> np.ndarray:
        """OpenCascade's classification of (u, v) points (m, 2): IN or ON the trimmed face."""
        from OCP.gp import gp_Pnt2d
        from OCP.TopAbs import TopAbs_IN, TopAbs_ON

        cls = self.classifier
        out = np.zeros(uv.shape[0], bool)
        for j, (u, v) in enumerate(uv.tolist()):
            try:
                out[j] = cls.Perform(gp_Pnt2d(u, v), True) in (TopAbs_IN, TopAbs_ON)
            except Exception:
                out[j] = False
        return out

    def nearest_on_face(self, xyz, outside: bool = False
                        ) -> tuple[float, np.ndarray, object] | None:
        """The nearest point of the trimmed face to xyz: distance, foot and its support (the
        face, an edge or a vertex); None when OpenCascade finds none. On a plane bounded by
        lines and circles, the foot on the plane if it lies in the face (not asked when the
        caller knows it lies ``outside``), else the nearest point of its boundary in closed
        form (engine.io.step.boundary); on other faces BRepExtrema_DistShapeShape."""
        from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeVertex
        from OCP.BRepExtrema import BRepExtrema_DistShapeShape
        from OCP.gp import gp_Pnt

        boundary = self.plane_boundary
        if boundary is not None and self.elementary is not None:
            if not outside:
                d, u, v, foot, _ = self.elementary.nearest(np.asarray(xyz, float).reshape(1, 3))
                if self.classify(np.column_stack([u, v]))[0]:
                    return float(d[0]), foot[0], self.face
            return boundary.nearest(xyz)
        if self._distance is None:
            self._distance = BRepExtrema_DistShapeShape()
            self._distance.LoadS2(self.face)
        dss = self._distance
        try:
            dss.LoadS1(BRepBuilderAPI_MakeVertex(gp_Pnt(*xyz)).Vertex())
            if not dss.Perform() or not dss.IsDone() or dss.NbSolution() == 0:
                return None
            return dss.Value(), np.array(dss.PointOnShape2(1).Coord()), dss.SupportOnShape2(1)
        except Exception:
            return None


class Surfaces:
    """Every face's surface by face id, for projecting many points on many faces with one
    vectorised call per kind of elementary surface (a NIST part has up to 338 faces, and a
    call per face cost more than its arithmetic).

    kind (F + 1,) : index into ``_Elementary.KINDS``, -1 for a general surface (and id 0);
    row (F + 1,) : the face's row in ``stacks[kind]`` (:meth:`_Elementary.stack`);
    uv_box (F + 1, 4), periods (F + 1, 2), reversed (F + 1,) : as ``FaceTools``'."""

    def __init__(self, tools: list[FaceTools]):
        m = len(tools) + 1
        self.kind = np.full(m, -1, np.int64)
        self.row = np.zeros(m, np.int64)
        self.uv_box = np.zeros((m, 4))
        self.periods = np.zeros((m, 2))
        self.reversed = np.zeros(m, bool)
        groups: dict[int, list] = {}
        for fid, t in enumerate(tools, 1):
            self.uv_box[fid], self.periods[fid], self.reversed[fid] = t.uv_box, t.periods, \
                t.reversed
            if t.elementary is not None:
                k = _Elementary.KINDS.index(t.elementary.kind)
                group = groups.setdefault(k, [])
                self.kind[fid], self.row[fid] = k, len(group)
                group.append(t.elementary)
        self.stacks = {k: _Elementary.stack(g) for k, g in groups.items()}


class Trims:
    """The faces' trim polylines (``FaceTools.trim``) drawn so far, in one segment array:
    face id f's are ``segments[start[f]:stop[f]]`` within ``band[f]``; stop[f] -1: not drawn
    yet, -2: none (OpenCascade's classifier decides)."""

    def __init__(self, n_faces: int):
        self.start = np.zeros(n_faces + 1, np.int64)
        self.stop = np.full(n_faces + 1, -1, np.int64)
        self.band = np.zeros(n_faces + 1)
        self.segments = np.zeros((0, 4))

    def add(self, fids: np.ndarray, tools) -> None:
        """Draw the trims of the faces ``fids`` not drawn yet; tools(fid) -> FaceTools."""
        new = [int(f) for f in fids if self.stop[f] == -1]
        if not new:
            return
        blocks, at = [self.segments], self.segments.shape[0]
        for f in new:
            trim = tools(f).trim
            if trim is None:
                self.stop[f] = -2
                continue
            segments, self.band[f] = trim
            self.start[f], self.stop[f] = at, at + segments.shape[0]
            at += segments.shape[0]
            blocks.append(segments)
        self.segments = np.ascontiguousarray(np.concatenate(blocks))


def _joined(lines: list[np.ndarray], tol: float) -> list[np.ndarray] | None:
    """The polylines (each (k, 2)) with the ends that meet made identical, or None when they do
    not join end to end into closed loops (an end meeting an even number of other ends within
    ``tol``). Ends computed from different curves differ in their last digits: left apart, a
    ray through the vertex would slip between them and miss or double a crossing."""
    ends = np.concatenate([p[[0, -1]] for p in lines])
    meets = np.linalg.norm(ends[:, None] - ends[None], axis=2) <= tol
    if not np.all((np.count_nonzero(meets, axis=1) - 1) % 2 == 1):
        return None
    shared = ends[np.argmax(meets, axis=1)]  # each end's first meeting end (itself at least)
    out = [p.copy() for p in lines]
    for k, p in enumerate(out):
        p[0], p[-1] = shared[2 * k], shared[2 * k + 1]
    return out


def _rows_dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise dot products of a (m, 3) with b (3,) or (m, 3)."""
    return np.einsum("ij,ij->i", a, np.broadcast_to(b, a.shape))


def in_period(t: np.ndarray, period, start) -> np.ndarray:
    """A periodic parameter t moved by whole periods into [start, start + period) (less 1e-9);
    unchanged where the period is 0 (not periodic). period, start: scalars or per t."""
    period = np.asarray(period, float)
    if not period.any():
        return t
    start = np.asarray(start, float) - 1e-9
    return np.where(period > 0, start + np.mod(t - start, np.where(period > 0, period, 1.0)), t)


def in_box(u: np.ndarray, v: np.ndarray, uv_box: np.ndarray, periods: np.ndarray):
    """Feet's (u, v) (m,) each into its face's (u, v) box u0 u1 v0 v1 ((4,) or (m, 4)) by whole
    periods ((2,) or (m, 2)): ((m, 2) wrapped (u, v), (m,) whether it lies in the box)."""
    u0, u1, v0, v1 = uv_box.T
    u, v = in_period(u, periods.T[0], u0), in_period(v, periods.T[1], v0)
    tol = 1e-9 * (1.0 + np.abs(uv_box).max(axis=-1))
    found = (u >= u0 - tol) & (u <= u1 + tol) & (v >= v0 - tol) & (v <= v1 + tol)
    return np.column_stack([u, v]), found


def geometry(t: FaceTools, kind: str) -> dict:
    """The exact surface of a plane, cylinder, sphere, cone or torus face (see
    StepFace.geometry)."""
    from OCP.BRepAdaptor import BRepAdaptor_Surface
    s = BRepAdaptor_Surface(t.face)
    u0, u1, v0, v1 = t.uv_box
    mid = t.point(0.5 * (u0 + u1), 0.5 * (v0 + v1))
    normal = t.normal(0.5 * (u0 + u1), 0.5 * (v0 + v1))
    if normal is None and kind in ("Plane", "Cylinder", "Sphere"):
        raise InputError(f"a STEP face ({kind}) has no normal at the middle of its (u, v) "
                         "box: its outward side is undefined")
    out = np.zeros(3) if normal is None else normal
    if kind == "Plane":
        pln = s.Plane()
        return {"point": pln.Location().Coord(), "normal": tuple(out.tolist())}
    if kind == "Cylinder":
        cyl = s.Cylinder()
        axis = cyl.Axis()
        a, o = np.array(axis.Direction().Coord()), np.array(axis.Location().Coord())
        radial = (mid - o) - np.dot(mid - o, a) * a
        return {"point": tuple(o.tolist()), "axis": tuple(a.tolist()), "radius": cyl.Radius(),
                "hole": bool(np.dot(out, radial) < 0)}
    if kind == "Sphere":
        sph = s.Sphere()
        c = np.array(sph.Location().Coord())
        return {"centre": tuple(c.tolist()), "radius": sph.Radius(),
                "hole": bool(np.dot(out, mid - c) < 0)}
    if kind == "Cone":
        cone = s.Cone()
        a, half = np.array(cone.Axis().Direction().Coord()), cone.SemiAngle()
        # OpenCascade's axis points the way the radius grows when the semi-angle is positive.
        a = a if half > 0 else -a
        return {"apex": cone.Apex().Coord(), "axis": tuple(a.tolist()), "half_angle": abs(half)}
    if kind == "Torus":
        torus = s.Torus()
        return {"centre": torus.Location().Coord(), "axis": torus.Axis().Direction().Coord(),
                "major": torus.MajorRadius(), "minor": torus.MinorRadius()}
    return {}
