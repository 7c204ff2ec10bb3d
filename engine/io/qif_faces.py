"""A QIF 3.0 document's own B-rep faces, and which faces of a STEP nominal they are.

A QIF MBD's features name the faces of its own B-rep (``EntityInternalIds``), whose labels and
ids have nothing to do with the STEP file's entities: the faces are matched by geometry. A QIF
face (:class:`QifFace`) is its surface (plane, cylinder, cone, sphere, torus, or another kind
without closed form) and points on its boundary: its loops' vertices and the middle of each
edge's curve (segments, circular arcs, NURBS). A STEP face is the QIF face when

* its surface is the same (:func:`same_surface`: normals and axes parallel within
  ``tol / size`` radians, points, apexes, centres and radii within ``tol`` mm), and
* every boundary point of the QIF face lies on the trimmed STEP face within ``tol`` (its
  exact distance: :meth:`engine.io.step.StepNominal.face_distances`): a face on the same
  surface next to it (the other half of a split cylinder, a coplanar pad) shares an edge at
  most, never the whole boundary.

``tol`` is ``MATCH_FRACTION`` of the model's size (its bounding box's diagonal). Units: the
QIF file's length unit converted to mm (``mm_per_unit``) before any comparison.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

MATCH_FRACTION = 1e-4
"""The geometry-match tolerance as a fraction of the STEP model's bounding-box diagonal (a
900 mm part: 0.09 mm; normals and axes within 1e-4 rad). The NIST parts' QIF faces lie on the
STEP AP242 faces within 1e-6 mm and on the AP203 exports' within 3e-5 mm."""

ELEMENTARY = ("plane", "cylinder", "cone", "sphere", "torus")
"""Surfaces compared by their parameters; any other kind (NURBS …) by its boundary points."""

_SURFACES = {"Plane23": "plane", "Cylinder23": "cylinder", "Cone23": "cone",
             "Sphere23": "sphere", "Torus23": "torus"}


@dataclass(frozen=True)
class QifFace:
    """One face of a QIF document's B-rep, mm.

    id : its QIF id. kind : plane | cylinder | cone | sphere | torus | other.
    geometry : as engine.io.step.StepFace.geometry for that kind (a plane's unit ``normal``
        either way round, a cylinder's ``radius``, a cone's ``apex``, ``axis`` into the cone and
        ``half_angle``, a torus' ``major`` and ``minor`` radii); empty for ``other``.
    points : (k, 3) points on its boundary: the vertices and each edge's middle.
    """

    id: str
    kind: str
    geometry: dict
    points: np.ndarray


def _vec(e, tag: str) -> np.ndarray:
    """The numbers of child ``tag`` of element ``e`` (any namespace)."""
    return np.array(e.findtext("{*}" + tag).split(), dtype=np.float64)


def surface_of(e, mm: float) -> tuple[str, dict]:
    """(kind, geometry in mm) of a QIF surface element (``Plane23`` …)."""
    kind = _SURFACES.get(e.tag.rsplit("}", 1)[-1], "other")
    core = e[0] if len(e) else e
    if kind == "other":
        return kind, {}
    if kind == "plane":
        n = np.cross(_vec(core, "DirU"), _vec(core, "DirV"))
        return kind, {"point": _vec(core, "Origin") * mm, "normal": n / np.linalg.norm(n)}
    if kind == "sphere":
        return kind, {"centre": _vec(core, "Location") * mm,
                      "radius": float(core.findtext("{*}Diameter")) * mm / 2}
    axis = core.find("{*}Axis")
    a = _vec(axis, "Direction")
    a, p = a / np.linalg.norm(a), _vec(axis, "AxisPoint") * mm
    if kind == "cylinder":
        return kind, {"point": p, "axis": a, "radius": float(core.findtext("{*}Diameter")) * mm / 2}
    if kind == "torus":
        return kind, {"centre": p, "axis": a,
                      "major": float(core.findtext("{*}DiameterMajor")) * mm / 2,
                      "minor": float(core.findtext("{*}DiameterMinor")) * mm / 2}
    if kind == "cone":  # AxisPoint is the centre of the bottom; the top is Length along the axis
        r0, r1 = (float(core.findtext("{*}" + k)) * mm / 2 for k in ("DiameterBottom",
                                                                      "DiameterTop"))
        length = float(core.findtext("{*}Length")) * mm
        slope = (r1 - r0) / length
        if slope == 0.0:
            return "cylinder", {"point": p, "axis": a, "radius": r0}
        return kind, {"apex": p - a * (r0 / slope), "axis": a * np.sign(slope),
                      "half_angle": float(np.arctan(abs(slope)))}
    return kind, {}


def curve_middle(e) -> np.ndarray | None:
    """The point in the middle of a QIF 3D curve's domain (``Segment13``, ``ArcCircular13``,
    ``Nurbs13``), in the file's unit; None for other curves (their edge's vertices stand)."""
    tag = e.tag.rsplit("}", 1)[-1]
    core = e[0] if len(e) else e
    domain = core.get("domain")
    t0, t1 = (float(v) for v in domain.split()) if domain else (0.0, 1.0)
    t = 0.5 * (t0 + t1)
    if tag == "Segment13":
        return 0.5 * (_vec(core, "StartPoint") + _vec(core, "EndPoint"))
    if tag == "ArcCircular13":
        b, n = _vec(core, "DirBeg"), _vec(core, "Normal")
        b, n = b / np.linalg.norm(b), n / np.linalg.norm(n)
        r = float(core.findtext("{*}Radius"))
        return _vec(core, "Center") + r * (np.cos(t) * b + np.sin(t) * np.cross(n, b))
    if tag == "Nurbs13":
        from scipy.interpolate import BSpline

        degree = int(core.findtext("{*}Order")) - 1
        knots = _vec(core, "Knots")
        cps = _vec(core, "CPs").reshape(-1, 3)
        weights = core.find("{*}Weights")
        w = _vec(core, "Weights") if weights is not None else np.ones(len(cps))
        num = BSpline(knots, cps * w[:, None], degree)(t)
        return num / BSpline(knots, w, degree)(t)
    return None


def face_of(face, index: dict, mm: float) -> QifFace:
    """A QIF ``Face`` element as a :class:`QifFace`; ``index``: the document's elements by id."""
    surface = index[face.findtext("{*}Surface/{*}Id")]
    kind, geometry = surface_of(surface, mm)
    points = []
    for loop_id in face.iterfind("{*}LoopIds/{*}Id"):
        for edge_id in index[loop_id.text].iterfind("{*}CoEdges/{*}CoEdge/{*}EdgeOriented/{*}Id"):
            edge = index[edge_id.text]
            for end in ("VertexBeg", "VertexEnd"):
                vertex = index[edge.findtext(f"{{*}}{end}/{{*}}Id")]
                points.append(_vec(index[vertex.findtext("{*}Point/{*}Id")], "XYZ"))
            middle = curve_middle(index[edge.findtext("{*}Curve/{*}Id")])
            if middle is not None:
                points.append(middle)
    pts = np.unique(np.round(np.array(points).reshape(-1, 3), 12), axis=0) * mm
    return QifFace(face.get("id"), kind, geometry, pts)


def _parallel(a: np.ndarray, b: np.ndarray, angle: float, signed: bool = False) -> bool:
    c = float(np.dot(a, b)) / (np.linalg.norm(a) * np.linalg.norm(b))
    return (c if signed else abs(c)) >= np.cos(angle)


def _off_axis(p: np.ndarray, q: np.ndarray, a: np.ndarray) -> float:
    d = p - q
    return float(np.linalg.norm(d - np.dot(d, a) * a))


def same_surface(kind: str, q: dict, s: dict, tol: float, angle: float) -> bool:
    """Whether a QIF surface ``q`` and a STEP face's surface ``s`` (both ``kind``, mm) are one:
    directions parallel within ``angle`` rad, lengths within ``tol`` mm."""
    g = {k: np.asarray(v, dtype=np.float64) for k, v in s.items()}
    if kind == "plane":
        return (_parallel(q["normal"], g["normal"], angle)
                and abs(float(np.dot(q["point"] - g["point"], g["normal"]))) <= tol)
    if kind == "cylinder":
        return (_parallel(q["axis"], g["axis"], angle) and abs(q["radius"] - g["radius"]) <= tol
                and _off_axis(q["point"], g["point"], g["axis"]) <= tol)
    if kind == "sphere":
        return (float(np.linalg.norm(q["centre"] - g["centre"])) <= tol
                and abs(q["radius"] - g["radius"]) <= tol)
    if kind == "cone":
        return (_parallel(q["axis"], g["axis"], angle, signed=True)
                and abs(q["half_angle"] - float(g["half_angle"])) <= angle
                and float(np.linalg.norm(q["apex"] - g["apex"])) <= tol)
    if kind == "torus":
        return (_parallel(q["axis"], g["axis"], angle)
                and float(np.linalg.norm(q["centre"] - g["centre"])) <= tol
                and abs(q["major"] - g["major"]) <= tol and abs(q["minor"] - g["minor"]) <= tol)
    return False


class FaceMatcher:
    """Finds the faces of a STEP nominal (engine.io.step.StepNominal) a QIF face is.

    tol : the match tolerance, mm (``MATCH_FRACTION`` of the model's diagonal); angle :
    ``tol / size`` radians."""

    def __init__(self, step):
        self.step = step
        self.size = float(np.linalg.norm(np.ptp(step.bounds, axis=0))) or 1.0
        self.tol = MATCH_FRACTION * self.size
        self.angle = MATCH_FRACTION
        ids = np.asarray(step.face_ids)
        pts = step.point_set.points
        self.boxes = np.empty((step.n_faces, 2, 3))
        self.boxes[:, 0], self.boxes[:, 1] = np.inf, -np.inf
        np.minimum.at(self.boxes[:, 0], ids - 1, pts)
        np.maximum.at(self.boxes[:, 1], ids - 1, pts)
        # A curved face bulges past its tessellation's nodes by the chordal deflection at most.
        margin = self.tol + 2.0 * step.deflection
        self.boxes += np.array([-margin, margin])[None, :, None]

    def faces(self, face: QifFace) -> list[int]:
        """The STEP face ids (ascending) that are ``face``: the same surface holding every one
        of its boundary points within ``tol``; empty when none is."""
        inside = np.all((face.points[:, None, :] >= self.boxes[None, :, 0])
                        & (face.points[:, None, :] <= self.boxes[None, :, 1]), axis=(0, 2))
        out = []
        for fid in np.flatnonzero(inside) + 1:
            record = self.step.faces[fid - 1]
            if face.kind in ELEMENTARY:
                if record.surface != face.kind or not same_surface(
                        face.kind, face.geometry, record.geometry, self.tol, self.angle):
                    continue
            elif record.surface in ELEMENTARY:
                continue
            if np.all(self.step.face_distances(fid, face.points) <= self.tol):
                out.append(int(fid))
        return out
