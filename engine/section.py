"""Planar sections: the nominal's section curve and the measured points near the plane, with
their deviations (the paper's traditional sectional inspection, as whiskers on the curve).

A section is a :class:`Plane` (an axis and an offset in the nominal frame, ``z = 120``, or a
general plane through a point with a normal) with a 2D frame (u, v) in it. :func:`section_of`
returns a :class:`Section`:

* the nominal's section curve (:class:`SectionCurve`): ordered polylines in the nominal frame,
  with the outward unit normal in the plane at every vertex:

  - a STEP model: OpenCascade's section of the B-rep by the plane (``BRepAlgoAPI_Section``,
    engine.io.step.section), each edge discretised within a stated chord tolerance (the
    tessellation's, engine.io.step.deflection_for: 1 to 10 µm); the normals from the B-rep's
    outward normal at each chord's middle (StepNominal.deviations);
  - a mesh or a grid: the plane cut of its triangles (:func:`mesh_section`), exact: every
    vertex of the curve is where the plane crosses a triangle edge; the normals from the
    triangles' outward normals. A point nominal without triangles has no surface to cut;

* the measured points within ``band`` mm of the plane at the registered pose (default:
  ``DEFAULT_BAND_SPACINGS`` / 2 x the measured points' typical spacing, a band 1.5 spacings
  wide), with the inspection's own signed deviations (not recomputed), their feet on the
  nominal projected into the plane's frame and the whisker direction: the nominal's outward
  normal at the foot, in the plane (the curve's normal where the surface runs nearly along the
  plane and that normal has no direction in it).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from .errors import SettingsError
from .neighbours import coincident_pairs
from .tolerance import Tolerance

AXES = ("x", "y", "z")
DEFAULT_BAND_SPACINGS = 1.5
"""The default band is this many typical point spacings wide (half of it on each side)."""
CLOSING_MM = 1e-6
"""A closed chain's last point within this of its first is its first (a STEP section's edges
meet at shared vertices, whose points each edge's curve reaches to rounding)."""
IN_PLANE_MIN = 0.5
"""A foot's normal gives the whisker's direction when at least this much of it lies in the
plane (the surface within 60 degrees of square to the plane); else the curve's normal does."""


@dataclass(frozen=True)
class Plane:
    """A section plane, nominal frame: ``origin`` (3,), unit ``normal`` (3,), and the unit
    axes ``u``, ``v`` (3,) of its 2D frame (u x v = normal). ``name``: "z = 120 mm"."""

    origin: np.ndarray
    normal: np.ndarray
    u: np.ndarray
    v: np.ndarray
    name: str
    axis: str | None = None
    offset: float | None = None

    def to_2d(self, points: np.ndarray) -> np.ndarray:
        """(n, 3) nominal-frame points -> (n, 2) their projections' (u, v) coordinates, mm."""
        d = np.asarray(points, dtype=np.float64) - self.origin
        return np.column_stack([d @ self.u, d @ self.v])

    def distance(self, points: np.ndarray) -> np.ndarray:
        """(n,) signed distances of ``points`` (n, 3) from the plane, mm (along ``normal``)."""
        return (np.asarray(points, dtype=np.float64) - self.origin) @ self.normal

    def document(self) -> dict:
        out: dict = {"name": self.name, "origin": [float(c) for c in self.origin],
                     "normal": [float(c) for c in self.normal]}
        if self.axis is not None:
            out.update(axis=self.axis, offset=self.offset)
        return out


def axis_plane(axis: str, offset: float) -> Plane:
    """The plane ``axis = offset`` (axis "x", "y" or "z"; mm, nominal frame). Its 2D frame
    looks at it as a drawing does: x = c drawn (y, z), y = c drawn (x, z), z = c drawn (x, y)."""
    axis = axis.lower()
    if axis not in AXES:
        raise SettingsError(f"a section's axis is x, y or z, not '{axis}'")
    if not math.isfinite(offset):
        raise SettingsError(f"a section's offset must be a finite number, got {offset!r}")
    e = np.eye(3)
    k = AXES.index(axis)
    u, v = {0: (e[1], e[2]), 1: (e[0], e[2]), 2: (e[0], e[1])}[k]
    origin = np.zeros(3)
    origin[k] = float(offset)
    # Ten digits: the offset as given (z = -100.00001, not "-100" beside a part from -100).
    return Plane(origin, np.cross(u, v), u, v, f"{axis} = {float(offset):.10g} mm", axis,
                 float(offset))


def point_plane(point, normal) -> Plane:
    """The plane through ``point`` (3,) square to ``normal`` (3,), mm, nominal frame; its 2D
    frame's v is the z axis projected into the plane (the y axis for a plane square to z)."""
    p = np.asarray(point, dtype=np.float64).reshape(3)
    n = np.asarray(normal, dtype=np.float64).reshape(3)
    size = float(np.linalg.norm(n))
    if not (np.isfinite(p).all() and np.isfinite(n).all()) or size == 0:
        raise SettingsError("a section plane needs a finite point and a non-zero normal")
    n = n / size
    up = np.array([0.0, 0.0, 1.0]) if abs(n[2]) < 0.9 else np.array([0.0, 1.0, 0.0])
    v = up - (up @ n) * n
    v /= np.linalg.norm(v)
    u = np.cross(v, n)
    name = ("through ({}) mm, normal ({})".format(", ".join(f"{c:g}" for c in p),
                                                  ", ".join(f"{c:.4g}" for c in n)))
    return Plane(p, n, u, v, name)


@dataclass(frozen=True)
class SectionCurve:
    """The nominal's section: ``polylines`` (each (k, 3), nominal frame, in order along the
    curve), ``normals`` (each (k, 2): the outward unit normal in the plane's frame at every
    vertex: the bisector of its two chords' at a corner), ``closed`` (whether each polyline
    closes on itself: its last vertex joins its first, not repeated), ``chord_mm`` (how far the
    chords may stray from the exact curve: 0 for a mesh's cut, which is exact), ``source``
    ("step" or "mesh")."""

    polylines: tuple[np.ndarray, ...]
    normals: tuple[np.ndarray, ...]
    closed: tuple[bool, ...]
    chord_mm: float
    source: str

    @property
    def length(self) -> float:
        """The polylines' total length, mm (closing chords included)."""
        return float(sum(_length(p, c) for p, c in zip(self.polylines, self.closed)))

    @property
    def n_vertices(self) -> int:
        return int(sum(len(p) for p in self.polylines))


def _length(p: np.ndarray, closed: bool) -> float:
    q = np.vstack([p, p[:1]]) if closed and len(p) > 1 else p
    return float(np.linalg.norm(np.diff(q, axis=0), axis=1).sum())


# ---------------------------------------------------------------------------- the mesh's cut

def mesh_cut(points: np.ndarray, triangles: np.ndarray, plane: Plane
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The plane's cut of every triangle it crosses, unchained.

    A vertex on the plane counts as above it (a symbolic perturbation: the cut stays a set of
    closed or boundary-ending chains even through vertices and along edges on the plane);
    where that leaves nothing cut, the plane touching the mesh's low side, as below it.
    Returns (ends (s, 2, 3) each segment's two points, keys (s, 2) int64 the mesh edge each end
    lies on (a * n + b for its vertices a < b), triangle (s,) the triangle cut). An end is
    ``P[a] + t (P[b] - P[a])`` with ``t = d_a / (d_a - d_b)`` from the edge's lower vertex a,
    so a triangle and its neighbour give the bit-identical point on their shared edge.
    """
    P = np.asarray(points, dtype=np.float64)
    T = np.asarray(triangles, dtype=np.int64)
    d = plane.distance(P)
    above = d >= 0
    n_above = above[T].sum(axis=1)
    if not np.any((n_above == 1) | (n_above == 2)) and np.any(d[T] == 0):
        # The plane touches the mesh from below (its lowest vertices lie on it): those count as
        # below, as the highest do at the other end, so both ends are cut alike.
        above = d > 0
        n_above = above[T].sum(axis=1)
    tri = np.flatnonzero((n_above == 1) | (n_above == 2))
    T = _welded(P, T[tri])
    a_side = above[T]
    change = a_side != np.roll(a_side, -1, axis=1)  # edge k joins corners k and k + 1
    edges = np.stack([T, np.roll(T, -1, axis=1)], axis=2)  # (m, 3, 2)
    e = edges[change].reshape(-1, 2, 2)  # the two crossed edges of each triangle, in order
    lo, hi = e.min(axis=2), e.max(axis=2)
    t = d[lo] / (d[lo] - d[hi])
    ends = P[lo] + t[..., None] * (P[hi] - P[lo])
    return ends, lo * P.shape[0] + hi, tri


def _welded(P: np.ndarray, T: np.ndarray) -> np.ndarray:
    """Triangles ``T`` (m, 3) with every vertex replaced by the lowest-numbered vertex of
    exactly the same coordinates: a mesh written face by face (a STEP tessellation, an STL)
    repeats its shared vertices, and its cut must join across them."""
    pairs = coincident_pairs(P, np.unique(T))
    if not len(pairs):
        return T
    to = np.arange(P.shape[0])
    to[pairs[:, 1]] = pairs[:, 0]
    return to[T]


def mesh_section(points: np.ndarray, triangles: np.ndarray, plane: Plane) -> SectionCurve:
    """The exact plane cut of a triangle mesh (outward winding), chained into polylines."""
    ends, keys, tri = mesh_cut(points, triangles, plane)
    if not len(tri):
        return SectionCurve((), (), (), 0.0, "mesh")
    P = np.asarray(points, dtype=np.float64)
    T = np.asarray(triangles, dtype=np.int64)[tri]
    fn = np.cross(P[T[:, 1]] - P[T[:, 0]], P[T[:, 2]] - P[T[:, 0]])
    seg_normals = _unit_2d(np.column_stack([fn @ plane.u, fn @ plane.v]))
    _, nodes = np.unique(keys.ravel(), return_inverse=True)
    pieces = [ends[i] for i in range(len(tri))]
    return chained(pieces, [seg_normals[i:i + 1] for i in range(len(tri))],
                   nodes.reshape(-1, 2), plane, 0.0, "mesh")


def _unit_2d(v: np.ndarray) -> np.ndarray:
    size = np.linalg.norm(v, axis=1, keepdims=True)
    return np.where(size > 0, v / np.where(size > 0, size, 1.0), 0.0)


# ---------------------------------------------------------------------------- chaining

def chain_order(nodes: np.ndarray) -> list[tuple[list[tuple[int, bool]], bool]]:
    """Pieces joined end to end: ``nodes`` (m, 2) the node at each piece's start and end.
    Returns the chains, each (its pieces in order as (index, reversed), closed). A chain runs
    through nodes that join exactly two pieces; it ends at a node joining one (an open curve's
    end) or more than two (a non-manifold junction)."""
    nodes = np.asarray(nodes, dtype=np.int64).reshape(-1, 2)
    m = nodes.shape[0]
    if m == 0:
        return []
    flat = nodes.ravel()
    order = np.argsort(flat, kind="stable")
    count = np.bincount(flat)
    start = np.concatenate([[0], np.cumsum(count)])
    used = np.zeros(m, dtype=bool)
    out = []

    def other(node: int, piece: int) -> int:
        """The piece other than ``piece`` at a node of two, else -1."""
        if count[node] != 2:
            return -1
        a, b = order[start[node]] // 2, order[start[node] + 1] // 2
        return int(b if a == piece else a)

    def walk(piece: int, rev: bool) -> tuple[list[tuple[int, bool]], bool]:
        first = int(nodes[piece, 1 if rev else 0])
        got = []
        while True:
            used[piece] = True
            got.append((piece, rev))
            node = int(nodes[piece, 0 if rev else 1])
            if node == first and count[node] == 2:
                return got, True
            nxt = other(node, piece)
            if nxt < 0 or used[nxt]:
                return got, False
            rev = bool(nodes[nxt, 1] == node and nodes[nxt, 0] != node)
            piece = nxt

    # Open chains from their ends first, then the loops.
    for node in np.flatnonzero((count != 2) & (count > 0)):
        for k in range(start[node], start[node + 1]):
            piece, side = int(order[k] // 2), int(order[k] % 2)
            if not used[piece]:
                out.append(walk(piece, side == 1))
    for piece in range(m):
        if not used[piece]:
            out.append(walk(piece, False))
    return out


def chained(pieces: list[np.ndarray], piece_normals: list[np.ndarray], nodes: np.ndarray,
            plane: Plane, chord_mm: float, source: str) -> SectionCurve:
    """A :class:`SectionCurve` of ``pieces`` (each (k, 3) points along a piece of the curve)
    joined by :func:`chain_order` over ``nodes`` (m, 2); ``piece_normals`` (each (k - 1, 2)):
    the outward unit normal in the plane of each chord of a piece. Repeated points (a cut
    through a mesh vertex) are dropped with their empty chords; a vertex's normal is the
    bisector of its chords' normals."""
    polylines, normals, closed = [], [], []
    for order, is_closed in chain_order(nodes):
        pts, nrm = [], []
        for k, (i, rev) in enumerate(order):
            p, n = pieces[i], piece_normals[i]
            if rev:
                p, n = p[::-1], n[::-1]
            pts.append(p if k == 0 else p[1:])
            nrm.append(n)
        P = np.vstack(pts)
        N = np.vstack(nrm)
        keep = np.linalg.norm(np.diff(P, axis=0), axis=1) > 0
        P = np.vstack([P[:1], P[1:][keep]])
        N = N[keep]
        if is_closed and len(P) > 2:
            if np.linalg.norm(P[-1] - P[0]) <= CLOSING_MM:
                P = P[:-1]  # the loop's last chord now runs back to its first vertex
            else:
                N = np.vstack([N, N[-1:]])  # a closing chord, its neighbour's normal
        is_closed = is_closed and len(P) > 2
        if len(P) < 2:
            continue
        polylines.append(P)
        normals.append(_vertex_normals(N, len(P), is_closed))
        closed.append(bool(is_closed))
    return SectionCurve(tuple(polylines), tuple(normals), tuple(closed), chord_mm, source)


def _vertex_normals(chords: np.ndarray, k: int, closed: bool) -> np.ndarray:
    """(k, 2) unit normals at k vertices from their chords' ((k - 1, 2) open; (k, 2) closed,
    the last from vertex k - 1 back to vertex 0): the bisector of the two chords at a vertex."""
    c = chords[:k] if closed else chords[:k - 1]
    if closed:
        return _unit_2d(np.roll(c, 1, axis=0) + c)
    return _unit_2d(np.vstack([c[:1], c]) + np.vstack([c, c[-1:]]))


# ---------------------------------------------------------------------------- the section

@dataclass(frozen=True)
class Section:
    """One section of an inspection (:func:`section_of`).

    name : "A-A"; plane; curve : the nominal's; band : the half-width of the band of measured
    points, mm; index (p,) : the measured points within it (indices into the inspection's
    points, those with a deviation); signed (p,) : their deviations (the inspection's), mm;
    offset (p,) : their
    distances from the plane, mm; foot (p, 2) : their feet on the nominal in the plane's frame;
    direction (p, 2) : the unit whisker direction (outward normal in the plane); tolerance :
    the zone the whiskers and the envelope are drawn against.
    """

    name: str
    plane: Plane
    curve: SectionCurve
    band: float
    index: np.ndarray
    signed: np.ndarray
    offset: np.ndarray
    foot: np.ndarray
    direction: np.ndarray
    tolerance: Tolerance

    @property
    def title(self) -> str:
        return f"Section {self.name}, {self.plane.name}"

    def document(self) -> dict:
        """The section in the results JSON."""
        d = self.signed
        t = self.tolerance
        return {"name": self.name, "plane": self.plane.document(),
                "curve": {"source": self.curve.source, "length_mm": round(self.curve.length, 6),
                          "polylines": len(self.curve.polylines),
                          "closed": int(sum(self.curve.closed)), "chord_mm": self.curve.chord_mm},
                "band_mm": self.band, "n_points": int(d.size),
                "deviation_min": float(d.min()) if d.size else None,
                "deviation_max": float(d.max()) if d.size else None,
                "n_out_of_tolerance": int(np.count_nonzero((d < t.lower) | (d > t.upper)))}


def section_name(k: int) -> str:
    """The k-th section's name (0-based): A-A, B-B, ..., Z-Z, AA-AA, ..."""
    letters = ""
    k += 1
    while k:
        k, r = divmod(k - 1, 26)
        letters = chr(65 + r) + letters
    return f"{letters}-{letters}"


def nominal_curve(plane: Plane, nominal=None, step=None) -> SectionCurve:
    """The section curve of a STEP model ``step`` (engine.io.step.StepNominal; exact) or else of
    ``nominal``'s triangles (engine.nominal.Nominal: a mesh or a grid). Raises SettingsError
    for a nominal of bare points (no surface to cut) and for a plane that misses it."""
    if step is not None:
        curve = step.section(plane)
        what = f"the STEP model {step.path}"
    elif nominal is not None and nominal.triangles is not None:
        curve = mesh_section(nominal.points, nominal.triangles, plane)
        what = f"the nominal {nominal.path}"
    else:
        raise SettingsError("a section needs the nominal's surface: the nominal is bare points "
                            "(no mesh, grid or STEP model to cut)")
    if not curve.polylines:
        raise SettingsError(f"the section {plane.name} misses the part: the plane does not cut "
                            f"{what}" + _bounds_words(plane, nominal, step))
    return curve


def _bounds_words(plane: Plane, nominal, step) -> str:
    if plane.axis is None:
        return ""
    k = AXES.index(plane.axis)
    if step is not None:
        lo, hi = float(step.bounds[0, k]), float(step.bounds[1, k])
    elif nominal is not None:
        lo, hi = float(nominal.points[:, k].min()), float(nominal.points[:, k].max())
    else:
        return ""
    return f" (its {plane.axis} runs from {lo:g} to {hi:g} mm)"


def section_of(result, plane: Plane, name: str = "A-A", band: float | None = None,
               nominal=None, step=None, seed: int | None = None) -> Section:
    """The section of an inspection ``result`` (engine.inspection.InspectionResult) by
    ``plane``: the nominal's curve (:func:`nominal_curve`) and the measured points within
    ``band`` mm of the plane (None: :data:`DEFAULT_BAND_SPACINGS` / 2 typical spacings of the
    registered points) with the result's deviations."""
    curve = nominal_curve(plane, nominal, step)
    X = result.registered
    if band is None:
        from .scene import typical_spacing

        # Over distinct points, in their order: a point measured twice is no spacing.
        U = X[np.sort(np.unique(X, axis=0, return_index=True)[1])]
        spacing = (typical_spacing(U) if seed is None else typical_spacing(U, seed=seed))
        if not spacing > 0:
            raise SettingsError("the measured points give no spacing to set a section's band "
                                "by (fewer than two distinct points): give --section-band MM")
        band = 0.5 * DEFAULT_BAND_SPACINGS * spacing
    elif not (math.isfinite(band) and band > 0):
        raise SettingsError(f"a section's band must be a positive number of mm, got {band:g}")
    off = plane.distance(X)
    dev = result.deviations
    # (A point without a deviation, which OpenCascade could not measure, has no whisker.)
    idx = np.flatnonzero((np.abs(off) <= band) & np.isfinite(dev.signed))
    foot = plane.to_2d(dev.foot[idx])
    nrm = dev.normal[idx]
    direction = np.column_stack([nrm @ plane.u, nrm @ plane.v])
    inside = np.linalg.norm(direction, axis=1) >= IN_PLANE_MIN
    direction = _unit_2d(direction)
    if (~inside).any():
        direction[~inside] = _curve_normal_near(curve, plane, foot[~inside])
    return Section(name, plane, curve, float(band), idx, dev.signed[idx].copy(), off[idx],
                   foot, direction, result.tolerance)


def _curve_normal_near(curve: SectionCurve, plane: Plane, xy: np.ndarray) -> np.ndarray:
    """(n, 2) the curve's normal at its vertex nearest each of ``xy`` (n, 2)."""
    verts = np.vstack([plane.to_2d(p) for p in curve.polylines])
    normals = np.vstack(curve.normals)
    _, j = cKDTree(verts).query(xy)
    return normals[j]
