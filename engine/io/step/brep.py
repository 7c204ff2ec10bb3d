"""The B-rep of a STEP model as a whole: its placed faces, their tessellation, and the exact signed
distance from points to them (:class:`StepNominal`, made by ``engine.io.step.reader``; one face's
geometry is ``engine.io.step.faces``).

Tessellation
    ``BRepMesh_IncrementalMesh`` with the chordal deflection :func:`deflection_for` (2.5e-5 of the
    model's diagonal, at least 1 µm and at most 10 µm) and 0.5 rad angular deflection. Points are
    the mesh nodes of each face (a node shared by two faces appears once per face, with each
    face's normal); a point's normal is the face's outward unit normal at the node's (u, v): the
    surface normal, reversed for a face whose orientation is ``TopAbs_REVERSED``.

Exact deviations
    See :meth:`StepNominal.deviations`. Measured on the three NIST test parts (2 cores):
    about 20-50 µs a point (CTC-01: 2,000 points 0.06 s, 200,000 points 4 s).
"""

from __future__ import annotations

import functools

import numpy as np

from engine.errors import NoDistanceError
from engine.neighbours import query
from engine.nominal import surface_tree
from engine.pointset import PointSet

from .faces import SURFACE_KINDS, FaceTools, StepFace, Surfaces, Trims, geometry, in_box, in_period
from .nearest import Best, unique_pairs

K_NEAREST = 8
"""Tessellation points whose faces are the first candidates of a measured point."""
UPPER_MARGIN_MM = 1e-6
"""The distance to the nearest tessellation node, plus this or the model's largest tolerance,
bounds the distance to the B-rep from above (nodes on edges lie on the edges' curves, which
stray from the faces' surfaces by up to the edges' tolerances)."""
TIE_MM = 1e-9
"""A face whose lower bound is within this of the best distance found is not measured: it could
improve the distance by no more."""

MAX_DEFLECTION_MM = 0.01
MIN_DEFLECTION_MM = 0.001
ANGULAR_DEFLECTION = 0.5


class StepNominal:
    """A STEP model read by :func:`read_step`: faces, a tessellation, exact deviations.

    path : the file. schema : its FILE_SCHEMA (e.g. 'AUTOMOTIVE_DESIGN { 1 0 10303 214 1 1 1 1 }').
    unit : the file's length unit as it names it; mm_per_unit : its size in mm (None when the
        name is not a known unit; OpenCascade converted it all the same).
    faces : tuple of :class:`StepFace`, ``faces[i].id == i + 1``.
    point_set : the tessellation (points (n, 3) mm, outward unit normals (n, 3), triangles
        (m, 3) with outward winding), for registration.
    face_ids : (n,) int64, the face id of every tessellation point.
    deflection : the tessellation's chordal deflection, mm.
    bounds : (2, 3) the B-rep's bounding box (min, max), mm.
    tolerance : the model's largest tolerance (of a face, edge or vertex), mm: how far its
        edges may stray from its faces' surfaces (the CTC-05 test part: 0.034 mm).
    warnings : what was ignored in reading: entities the shape does not use (PMI,
        presentation, properties) that failed OpenCascade's checks.
    """

    def __init__(self, path: str, schema: str, unit: str, mm_per_unit: float | None,
                 faces: tuple, point_set: PointSet, face_ids: np.ndarray, deflection: float,
                 bounds: np.ndarray, brep: "Brep", warnings: tuple[str, ...] = ()):
        self.path = path
        self.warnings = warnings
        self.schema = schema
        self.unit = unit
        self.mm_per_unit = mm_per_unit
        self.faces = faces
        self.point_set = point_set
        self.face_ids = face_ids
        self.deflection = deflection
        self.bounds = bounds
        self._brep = brep
        self.tolerance = brep.tolerance
        self._tree = surface_tree(point_set.points)

    @property
    def n_faces(self) -> int:
        return len(self.faces)

    @property
    def closed(self) -> bool:
        """No free edge: every edge (but a degenerate one, a cone's apex) bounds two faces, or
        one twice (a cylinder's seam): the model encloses a volume, and a measured point has
        no border of the surface to lie past."""
        return self._brep.closed

    def deviations(self, points, within: float | None = None
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Exact signed distances from ``points`` to the B-rep.

        points : (n, 3) float, mm, nominal frame.

        Returns ``signed`` (n,) mm, ``foot`` (n, 3) the nearest point of the B-rep, ``normal``
        (n, 3) the outward unit normal there, ``face`` (n,) the id of the face the foot lies on.
        ``signed`` is positive along the outward normal (excess material) and negative inside.

        For each point the candidate faces are those of its ``K_NEAREST`` nearest tessellation
        points, then every other face whose bounding box is nearer than the best distance found
        (or than the nearest tessellation point, which lies on the B-rep within the model's
        tolerance): no face that could be nearer is left out. A candidate's surface is projected
        on exactly: planes, cylinders, cones, spheres and tori in closed form (vectorised; the
        unbounded surface's nearest point, whose distance also bounds the face's from below),
        other surfaces with OpenCascade's extrema over the face's (u, v) box (one reused
        projector per face). The foot is kept when it lies on the face's trimmed domain
        (``IntTools_FClass2d``, IN or ON), nearest candidates first; when it lies outside, the
        nearest point of the trimmed face (on an edge, at a vertex, or another interior
        minimum) comes from ``BRepExtrema_DistShapeShape`` (on a plane bounded by lines and
        circles, from its edges in closed form: engine.io.step.boundary), asked only while
        the face's lower bound is below the best so far. The nearest wins. On a face the sign
        comes from the face's outward normal at the foot; at a foot on an edge or a vertex from
        the sum of the outward normals of the faces that meet there (right on either side of a
        sharp convex or concave edge).

        Exact to OpenCascade's precision (tested to 0.1 µm against analytic truth and against
        the distance to all faces at once); an extrema search over a general (B-spline) face's
        (u, v) box is OpenCascade's, a grid search refined by Newton steps.

        within : mm, or None. Given, no face farther than it is asked about, and a point with
        no foot within it gets NaN for each of its values (face 0): its distance is only known
        to exceed ``within``. The others' are exact as above.
        """
        p = np.ascontiguousarray(points, dtype=np.float64)
        if p.ndim != 2 or p.shape[1] != 3:
            raise ValueError(f"points of shape {p.shape}; expected (n, 3)")
        if not np.isfinite(p).all():
            raise ValueError("points hold NaN or infinity")
        n = p.shape[0]
        if n == 0:
            return np.zeros(0), np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0, np.int64)
        k = min(K_NEAREST, self._tree.n)
        dist, idx = query(self._tree, p, k=k)
        dist, idx = np.asarray(dist).reshape(n, k), np.asarray(idx).reshape(n, k)
        best = Best(n)
        best.upper = dist[:, 0] + max(UPPER_MARGIN_MM, self.tolerance)
        if within is not None:
            best.upper = np.minimum(best.upper, within)
        pairs = unique_pairs(np.repeat(np.arange(n), k), self.face_ids[idx].ravel())
        bound, inside = self._brep.project(p, pairs, best)
        more = self._brep.nearer_boxes(p, np.minimum(best.dist, best.upper), pairs)
        if more.shape[0]:
            more_bound, more_inside = self._brep.project(p, more, best)
            pairs = np.concatenate([pairs, more])
            bound = np.concatenate([bound, more_bound])
            inside = np.concatenate([inside, more_inside])
        self._brep.settle(p, pairs, bound, inside, best)
        if within is None:
            return self._brep.finish(p, best)
        near = np.flatnonzero((best.face > 0) & (best.dist <= within))
        signed, foot, normal, face = (np.full(n, np.nan), np.full((n, 3), np.nan),
                                      np.full((n, 3), np.nan), np.zeros(n, np.int64))
        if near.size:
            signed[near], foot[near], normal[near], face[near] = self._brep.finish(
                p[near], best.take(near))
        return signed, foot, normal, face

    def faces_within(self, points, reach, face, others) -> tuple[np.ndarray, np.ndarray]:
        """The other faces within each point's ``reach`` (mm), with their exact distances.

        points : (n, 3) mm, nominal frame; reach : (n,) mm; face : (n,) each point's own face
        id (its foot's, :meth:`deviations`), never listed; others(f, g) : (m,) bool, for face
        ids f and g (m,), whether face g is asked about for a point on face f.

        Returns (pairs (m, 2) of (point index, face id), distance (m,) mm), each face within
        its point's reach. Faces whose bounding box lies beyond the reach are skipped; an
        elementary surface's foot on its trimmed face gives the distance in closed form, any
        other OpenCascade's distance to the trimmed face (an edge or a vertex where the
        nearest point lies on one).
        """
        p = np.ascontiguousarray(points, dtype=np.float64)
        reach = np.asarray(reach, dtype=np.float64)
        n = p.shape[0]
        own = np.column_stack([np.arange(n), np.asarray(face, np.int64)])
        pairs = self._brep.nearer_boxes(p, reach, own) if n else own[:0]
        pairs = pairs[others(own[pairs[:, 0], 1], pairs[:, 1])] if len(pairs) else pairs
        if not len(pairs):
            return pairs, np.zeros(0)
        # Each pair measured alone: a scratch "best" that keeps nothing from one to the next.
        bound, inside = self._brep.project(p, pairs, Best(n))
        d = np.where(inside, bound, np.inf)
        for j in np.flatnonzero(~inside & (bound <= reach[pairs[:, 0]])):
            got = self._brep.tools(int(pairs[j, 1])).nearest_on_face(p[pairs[j, 0]])
            if got is not None:
                d[j] = got[0]
        keep = d <= reach[pairs[:, 0]]
        return pairs[keep], d[keep]

    def section(self, plane, chord_mm: float | None = None):
        """The B-rep's section by ``plane`` (engine.section.Plane): OpenCascade's, as ordered
        polylines (engine.io.step.section.brep_section)."""
        from .section import brep_section

        return brep_section(self, plane, chord_mm)

    def face_shape(self, fid: int):
        """Face ``fid``'s OpenCascade shape (a located TopoDS_Face), for checks on the exact
        surface."""
        return self._brep.faces[int(fid) - 1]

    def face_area(self, fid: int) -> float:
        """Face ``fid``'s area, mm² (OpenCascade's BRepGProp over its exact surface within its
        trim)."""
        from OCP.BRepGProp import BRepGProp
        from OCP.GProp import GProp_GProps

        props = GProp_GProps()
        BRepGProp.SurfaceProperties_s(self.face_shape(fid), props)
        return float(props.Mass())

    def face_distances(self, fid: int, points) -> np.ndarray:
        """(n,) the distance (mm) from each of ``points`` (n, 3), nominal frame, to the trimmed
        face ``fid`` alone (its surface within its boundary: an edge or a vertex where the
        nearest point lies on one); inf where OpenCascade finds none."""
        tools = self._brep.tools(int(fid))
        out = np.full(len(points), np.inf)
        for i, xyz in enumerate(np.asarray(points, dtype=np.float64).tolist()):
            got = tools.nearest_on_face(xyz)
            if got is not None:
                out[i] = got[0]
        return out


def deflection_for(diagonal_mm: float) -> float:
    """The tessellation's chordal deflection (mm) for a model of this bounding-box diagonal:
    2.5e-5 of it, between ``MIN_DEFLECTION_MM`` (1 µm) and ``MAX_DEFLECTION_MM`` (10 µm) — well
    below any profile zone; registration needs no finer, and the deviations do not use it."""
    return float(min(MAX_DEFLECTION_MM, max(MIN_DEFLECTION_MM, 2.5e-5 * diagonal_mm)))


class Brep:
    """The placed faces (id i is ``faces[i - 1]``), their names, tools, boxes and adjacency."""

    def __init__(self, placed: list[tuple]):
        from OCP.BRep import BRep_Builder
        from OCP.collections import IndexedMap_TopoDS_Shape_TopTools_ShapeMapHasher as ShapeMap
        from OCP.ShapeAnalysis import ShapeAnalysis_ShapeTolerance
        from OCP.TopoDS import TopoDS_Compound

        self.index = ShapeMap()
        self.faces: list = []  # OpenCascade's TopoDS_Face
        self.names: list[str | None] = []
        self.parts: list[str | None] = []
        for face, name, part in placed:
            if self.index.Add(face) > len(self.faces):  # an instance placed twice on itself once
                self.faces.append(face)
                self.names.append(name)
                self.parts.append(part)
        self.n = len(self.faces)
        compound, builder = TopoDS_Compound(), BRep_Builder()
        builder.MakeCompound(compound)
        for face in self.faces:
            builder.Add(compound, face)
        self.compound = compound
        self.tolerance = ShapeAnalysis_ShapeTolerance().Tolerance(compound, 1)
        self._tools: dict[int, FaceTools] = {}
        self._boxes: np.ndarray | None = None
        self._ancestors: tuple | None = None  # (edge -> faces, vertex -> faces)
        self._closed: bool | None = None
        self.mesh: tuple = (np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0, np.int64))

    def tools(self, fid: int) -> FaceTools:
        t = self._tools.get(fid)
        if t is None:
            t = self._tools[fid] = FaceTools(self.faces[fid - 1])
        return t

    @functools.cached_property
    def surfaces(self) -> "Surfaces":
        """The faces' elementary surfaces stacked by kind, for projections in bulk."""
        return Surfaces([self.tools(fid) for fid in range(1, self.n + 1)])

    def boxes(self) -> np.ndarray:
        """(F, 2, 3) each face's bounding box from its exact geometry (BRepBndLib.AddOptimal),
        widened by 1e-6 mm so that it bounds the face for sure."""
        if self._boxes is None:
            from OCP.Bnd import Bnd_Box
            from OCP.BRepBndLib import BRepBndLib
            boxes = np.zeros((self.n, 2, 3))
            for i, face in enumerate(self.faces):
                box = Bnd_Box()
                BRepBndLib.AddOptimal_s(face, box, False, False)
                boxes[i] = box.CornerMin().Coord(), box.CornerMax().Coord()
            self._boxes = boxes + np.array([-1e-6, 1e-6])[None, :, None]
        return self._boxes

    def bounds(self) -> np.ndarray:
        b = self.boxes()
        return np.array([b[:, 0].min(axis=0), b[:, 1].max(axis=0)])

    def face_record(self, fid: int) -> StepFace:
        from OCP.BRepAdaptor import BRepAdaptor_Surface
        kind = BRepAdaptor_Surface(self.faces[fid - 1]).GetType().name.removeprefix("GeomAbs_")
        t = self.tools(fid)
        return StepFace(fid, self.names[fid - 1], self.parts[fid - 1],
                        SURFACE_KINDS.get(kind, "other"), t.reversed, geometry(t, kind))

    # ---------------------------------------------------------------- tessellation
    def tessellate(self, deflection: float):
        """Mesh every face; (points (n, 3), outward normals (n, 3), triangles (m, 3) with
        outward winding, face id (n,)), faces in id order."""
        from OCP.BRepMesh import BRepMesh_IncrementalMesh

        BRepMesh_IncrementalMesh(self.compound, deflection, False, ANGULAR_DEFLECTION, True)
        parts, offset = [], 0
        for fid in range(1, self.n + 1):
            mesh = self._face_mesh(fid)
            if mesh is None:
                continue
            pts, nrm, tri = mesh
            parts.append((pts, nrm, tri + offset, np.full(len(pts), fid, np.int64)))
            offset += len(pts)
        if not parts:
            parts = [(np.zeros((0, 3)), np.zeros((0, 3)), np.zeros((0, 3), np.int64),
                      np.zeros(0, np.int64))]
        points, normals, triangles, ids = (np.concatenate(a) for a in zip(*parts))
        self.mesh = points, normals, ids
        return points, normals, triangles, ids

    def _face_mesh(self, fid: int):
        """One face's mesh: nodes (deduplicated), outward normals from the surface at the
        nodes' (u, v), triangles wound outward; None for a face BRepMesh left empty."""
        from OCP.BRep import BRep_Tool
        from OCP.TopLoc import TopLoc_Location

        loc = TopLoc_Location()
        tri = BRep_Tool.Triangulation_s(self.faces[fid - 1], loc)
        if tri is None or tri.NbNodes() < 3 or tri.NbTriangles() == 0:
            return None
        trsf = loc.Transformation()
        nodes = range(1, tri.NbNodes() + 1)
        pts = np.array([tri.Node(i).Transformed(trsf).Coord() for i in nodes])
        uv = np.array([tri.UVNode(i).Coord() for i in nodes]) if tri.HasUVNodes() else None
        tris = np.array([tri.Triangle(i).Get() for i in range(1, tri.NbTriangles() + 1)],
                        np.int64) - 1
        t = self.tools(fid)
        if t.reversed:
            tris = tris[:, [0, 2, 1]]
        pts, first, inverse = np.unique(pts, axis=0, return_index=True, return_inverse=True)
        tris = inverse.reshape(-1)[tris]
        tris = tris[(tris[:, 0] != tris[:, 1]) & (tris[:, 1] != tris[:, 2])
                    & (tris[:, 0] != tris[:, 2])]
        normals = np.full((len(pts), 3), np.nan)
        if uv is not None:
            for i, (u, v) in enumerate(uv[first]):
                n = t.normal(u, v)
                if n is not None:
                    normals[i] = n
        _fill_normals_from_triangles(pts, tris, normals)
        return pts, normals, tris

    # ---------------------------------------------------------------- exact distance
    def project(self, p: np.ndarray, pairs: np.ndarray, best: Best) -> tuple:
        """Project the points of the (point index, face id) ``pairs`` on their faces' surfaces
        and keep in ``best`` each point's nearest foot that lies on its trimmed face. Returns
        (bound, inside) per pair: ``bound`` is the distance to the untrimmed surface, exact
        where ``inside``, else a lower bound (the larger of it and the distance to the face's
        bounding box).

        Elementary surfaces are projected first, in bulk (``surfaces``); a general face (one
        projection at a time by OpenCascade's extrema, its projector reused) only where its
        bounding box is nearer than the best foot so far and the point's upper bound: elsewhere
        its box bounds it, for ``settle``. Feet are classified nearest first, per point, and
        only while nearer than the best: the costly classification of the others is skipped.
        (An elementary surface's distance bounds its face's from below; a general face whose
        foot falls outside it is bounded by its bounding box.)"""
        d, uv = np.full(len(pairs), np.inf), np.zeros((len(pairs), 2))
        found = np.zeros(len(pairs), bool)
        bound = _box_distance(self.boxes()[pairs[:, 1] - 1], p[pairs[:, 0]])
        table = self.surfaces
        kind = table.kind[pairs[:, 1]]
        for k in np.unique(kind[kind >= 0]):
            j = np.flatnonzero(kind == k)
            fid = pairs[j, 1]
            d[j], u, v, _, _ = table.stacks[k].take(table.row[fid]).nearest(p[pairs[j, 0]])
            uv[j], found[j] = in_box(u, v, table.uv_box[fid], table.periods[fid])
        bound[kind >= 0] = np.fmax(bound[kind >= 0], d[kind >= 0])
        inside = np.zeros(len(pairs), bool)
        self._keep_nearest_inside(pairs, d, uv, found.copy(), inside, best)
        limit = np.minimum(best.dist, best.upper)
        general = np.flatnonzero((kind < 0) & (bound < limit[pairs[:, 0]] - TIE_MM))
        for fid, block in _by_face(pairs[general]):
            j = general[block]
            d[j], uv[j], found[j], _ = self.tools(fid).project(p[pairs[j, 0]])
        if general.size:
            pending = np.zeros(len(pairs), bool)
            pending[general] = found[general]
            self._keep_nearest_inside(pairs, d, uv, pending, inside, best)
        return np.where(inside, d, bound), inside

    def _keep_nearest_inside(self, pairs: np.ndarray, d: np.ndarray, uv: np.ndarray,
                             pending: np.ndarray, inside: np.ndarray, best: Best) -> None:
        """Classify the ``pending`` pairs' feet (at distance ``d``, parameters ``uv``) nearest
        first per point, while nearer than the point's best; mark ``inside`` those on their
        trimmed face and keep the nearest in ``best``."""
        while pending.any():
            cand = np.flatnonzero(pending)
            cand = cand[np.lexsort((d[cand], pairs[cand, 0]))]
            cand = cand[np.unique(pairs[cand, 0], return_index=True)[1]]  # each point's nearest
            cand = cand[d[cand] < best.dist[pairs[cand, 0]] - TIE_MM]
            if cand.size == 0:
                break
            pending[cand] = False
            inside[cand] = self.contains(pairs[cand, 1], uv[cand])
            won = cand[inside[cand]]
            i = pairs[won, 0]
            best.dist[i], best.face[i], best.uv[i], best.on_face[i] = (d[won], pairs[won, 1],
                                                                       uv[won], True)

    def contains(self, fids: np.ndarray, uv: np.ndarray) -> np.ndarray:
        """Whether each (u, v) point (m, 2) lies on its trimmed face ``fids`` (m,) (IN or ON
        its boundary): by the face's trim polylines (``FaceTools.trim``, every face's in one
        call) away from them, by OpenCascade's classifier near them (or for a face whose
        polylines could not be drawn). A periodic parameter is first moved into the face's
        domain, as OpenCascade's classifier takes it."""
        from engine.kernels import in_polygons

        out = np.zeros(len(fids), bool)
        if len(fids) == 0:
            return out
        trims = self.trims
        trims.add(np.unique(fids), self.tools)
        drawn = np.flatnonzero(trims.stop[fids] >= 0)
        f = fids[drawn]
        table = self.surfaces
        wrapped = np.column_stack([in_period(uv[drawn, 0], table.periods[f, 0],
                                              table.uv_box[f, 0]),
                                   in_period(uv[drawn, 1], table.periods[f, 1],
                                              table.uv_box[f, 2])])
        out[drawn], near = in_polygons(wrapped, trims.segments, trims.start[f], trims.stop[f],
                                       trims.band[f])
        ask = np.union1d(drawn[near], np.flatnonzero(trims.stop[fids] < 0))
        for fid, block in _by_face(np.column_stack([ask, fids[ask]])):
            out[ask[block]] = self.tools(fid).classify(uv[ask[block]])
        return out

    @functools.cached_property
    def trims(self) -> "Trims":
        return Trims(self.n)

    def settle(self, p: np.ndarray, pairs: np.ndarray, bound: np.ndarray, inside: np.ndarray,
               best: Best) -> None:
        """For the pairs whose foot fell outside the face and whose lower ``bound`` is below the
        point's best (and its upper bound), measure the trimmed face (nearest_on_face), each
        point's candidates in increasing order of their bound, while the bound stays below."""
        limit = np.minimum(best.dist, best.upper)
        out = np.flatnonzero(~inside & (bound < limit[pairs[:, 0]] - TIE_MM))
        for j in out[np.lexsort((bound[out], pairs[out, 0]))]:
            i, fid = int(pairs[j, 0]), int(pairs[j, 1])
            if bound[j] >= min(best.dist[i], best.upper[i]) - TIE_MM:
                continue
            found = self.tools(fid).nearest_on_face(p[i], outside=True)
            if found is not None and found[0] < best.dist[i]:
                best.dist[i], best.face[i], best.foot[i], best.support[i] = found[0], fid, \
                    found[1], found[2]
                best.on_face[i] = False

    def nearer_boxes(self, p: np.ndarray, dist: np.ndarray, done: np.ndarray) -> np.ndarray:
        """(point index, face id) pairs not in ``done`` whose face's bounding box is nearer to
        the point than ``dist``: the faces that could still hold a nearer foot."""
        from engine.kernels import boxes_nearer

        done = done[np.argsort(done[:, 0], kind="stable")]
        start = np.searchsorted(done[:, 0], np.arange(p.shape[0] + 1))
        return boxes_nearer(p, self.boxes(), np.ascontiguousarray(dist, np.float64), start,
                            np.ascontiguousarray(done[:, 1]))

    def finish(self, p: np.ndarray, best: Best):
        """(signed, foot, normal, face) from each point's nearest foot (see deviations)."""
        if (best.face == 0).any():
            raise NoDistanceError(np.flatnonzero(best.face == 0), p[best.face == 0],
                                  "OpenCascade found no distance to any face")
        foot, normal = np.array(best.foot), np.zeros_like(p)
        on = np.flatnonzero(best.on_face)
        table = self.surfaces
        kind = table.kind[best.face[on]]
        for k in np.unique(kind[kind >= 0]):
            i = on[kind == k]
            fid = best.face[i]
            _, _, _, foot[i], n = table.stacks[k].take(table.row[fid]).nearest(p[i])
            normal[i] = np.where(table.reversed[fid][:, None], -n, n)
        general = on[kind < 0]
        for fid, block in _by_face(np.column_stack([general, best.face[general]])):
            i = general[block]
            foot[i], normal[i] = self.tools(fid).at(p[i], best.uv[i])
        for i in np.flatnonzero(~best.on_face):
            normal[i] = self._boundary_normal(best.support.get(int(i)), foot[i], int(best.face[i]))
        for i in np.flatnonzero(~np.isfinite(normal).all(axis=1)):  # a pole, an apex
            normal[i] = self._normal_near(int(best.face[i]), foot[i])
        delta = p - foot
        size = np.linalg.norm(delta, axis=1)
        side = np.einsum("ij,ij->i", delta, normal)
        return np.where(side < 0, -size, size), foot, normal, best.face.copy()

    def _boundary_normal(self, support, foot: np.ndarray, fid: int) -> np.ndarray:
        """The normal at a foot found on the trimmed face: inside the face its outward normal;
        on an edge or a vertex the sum of the outward normals there of the faces meeting at it
        (each face's normal at the foot's projection on its surface)."""
        total = np.zeros(3)
        for g in self.faces_at(support) or [fid]:
            t = self.tools(g)
            d, uv, found, _ = t.project(foot[None])
            nrm = t.normal(*uv[0]) if found[0] and d[0] < 1e-3 else None
            total += nrm if nrm is not None else 0.0
        size = np.linalg.norm(total)
        if size < 1e-9:
            return self._normal_near(fid, foot)
        return total / size

    def _normal_near(self, fid: int, foot: np.ndarray) -> np.ndarray:
        """Where the surface has no normal (a pole, an apex) or the faces' normals cancel: the
        face's outward normal at the nearest tessellation point of that face."""
        pts, normals, ids = self.mesh
        own = np.flatnonzero(ids == fid)
        j = own[np.argmin(np.linalg.norm(pts[own] - foot, axis=1))]
        return normals[j]

    def faces_at(self, support) -> list[int]:
        """The ids of the faces that hold an edge or a vertex (empty for anything else)."""
        from OCP.TopAbs import TopAbs_EDGE, TopAbs_VERTEX
        if support is None or support.ShapeType() not in (TopAbs_EDGE, TopAbs_VERTEX):
            return []
        ancestors = self._adjacency()[support.ShapeType() == TopAbs_VERTEX]
        k = ancestors.FindIndex(support)
        if k == 0:
            return []
        return sorted({self.index.FindIndex(f) for f in ancestors.FindFromIndex(k)} - {0})

    @property
    def closed(self) -> bool:
        """Every non-degenerate edge is held twice by the faces (StepNominal.closed)."""
        if self._closed is None:
            from OCP.BRep import BRep_Tool
            from OCP.TopoDS import TopoDS

            edges = self._adjacency()[0]
            self._closed = all(
                edges.FindFromIndex(i).Size() >= 2
                or BRep_Tool.Degenerated_s(TopoDS.Edge(edges.FindKey(i)))
                for i in range(1, edges.Extent() + 1))
        return self._closed

    def _adjacency(self):
        """(edge -> faces, vertex -> faces) maps over all placed faces, built once."""
        if self._ancestors is not None:
            return self._ancestors
        from OCP.collections import \
            IndexedDataMap_TopoDS_Shape_List_TopoDS_Shape_TopTools_ShapeMapHasher as Ancestors
        from OCP.TopAbs import TopAbs_EDGE, TopAbs_FACE, TopAbs_VERTEX
        from OCP.TopExp import TopExp

        edges, vertices = Ancestors(), Ancestors()
        TopExp.MapShapesAndAncestors_s(self.compound, TopAbs_EDGE, TopAbs_FACE, edges)
        TopExp.MapShapesAndAncestors_s(self.compound, TopAbs_VERTEX, TopAbs_FACE, vertices)
        self._ancestors = (edges, vertices)
        return self._ancestors


def _by_face(pairs: np.ndarray):
    """(face id, indices into pairs) for each face among the (point index, face id) pairs."""
    if len(pairs) == 0:
        return
    order = np.argsort(pairs[:, 1], kind="stable")
    starts = np.flatnonzero(np.diff(pairs[order, 1], prepend=-1))
    for block in np.split(order, starts[1:]):
        yield int(pairs[block[0], 1]), block


def _box_distance(boxes: np.ndarray, p: np.ndarray) -> np.ndarray:
    """Distances from points p (m, 3) to boxes (m or 1, 2, 3) (0 inside): a lower bound of the
    distance to anything in the box."""
    gap = np.maximum(np.maximum(boxes[:, 0] - p, p - boxes[:, 1]), 0.0)
    return np.sqrt(np.einsum("ij,ij->i", gap, gap))


def _fill_normals_from_triangles(pts: np.ndarray, tris: np.ndarray, normals: np.ndarray) -> None:
    """Give nodes without a surface normal (poles, apexes) the mean normal of their triangles."""
    missing = ~np.isfinite(normals).all(axis=1)
    if not missing.any():
        return
    fn = np.cross(pts[tris[:, 1]] - pts[tris[:, 0]], pts[tris[:, 2]] - pts[tris[:, 0]])
    acc = np.zeros_like(pts)
    for c in range(3):
        np.add.at(acc, tris[:, c], fn)
    size = np.linalg.norm(acc, axis=1, keepdims=True)
    ok = missing & (size[:, 0] > 0)
    normals[ok] = acc[ok] / size[ok]
    normals[missing & ~ok] = (0.0, 0.0, 1.0)  # a node of no triangle: unused by anything
