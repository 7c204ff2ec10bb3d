"""2D contour templates: line segments and circular arcs, exact signed point-to-contour distance.

A template is a set of contours in the template plane (mm), each a chain of primitives in drawing
order. Primitives are kept exact: a line segment by its ends, a circular arc by its centre,
radius, start angle and signed sweep (positive counter-clockwise). Curves that are neither
(splines, ellipses) are brought in as segments by the reader, flattened to a stated chord error.

Sign convention (the 2D form of the product's rule, positive = excess material):

* closed contours: positive **outward**, away from the material. Nesting decides what is
  material: an outer profile (nesting depth 0) has the material inside, so outside is positive;
  a hole (depth 1) has the material outside, so positive points into the hole; an island in a
  hole (depth 2) is an outer profile again, and so on;
* open contours: positive to the **left** of the drawn direction.

The distance to a segment is the paper's equation (4), clamped to the segment's ends; to an arc,
|distance to the centre - radius| inside its sweep, else to the nearer end. At a corner where
two primitives meet, the side is taken from the bisector of their normals, so signs stay right on
both sides of convex and concave corners.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .neighbours import query

SEGMENT, ARC = 0, 1


@dataclass(frozen=True)
class Template2D:
    """Primitives of all contours, flattened into arrays (m primitives, c contours).

    kind : (m,) int8, SEGMENT or ARC.
    start, end : (m, 2) end points in drawing order.
    centre : (m, 2), radius : (m,), angle0 : (m,) rad, sweep : (m,) rad (signed, + CCW) for arcs
        (zeros for segments).
    contour : (m,) int, which contour each primitive belongs to; primitives of a contour are
        consecutive and in drawing order.
    closed : (c,) bool; side : (c,) +1 or -1, the factor that turns "left of the drawn direction"
        into the contour's positive side (see the module docstring).
    layer : (m,) int64, each primitive's index in ``layers`` (the DXF layer it is drawn on), or
        None for a template without layers (airfoil ordinates).
    layers : the layer names, sorted.
    """

    kind: np.ndarray
    start: np.ndarray
    end: np.ndarray
    centre: np.ndarray
    radius: np.ndarray
    angle0: np.ndarray
    sweep: np.ndarray
    contour: np.ndarray
    closed: np.ndarray
    side: np.ndarray
    layer: np.ndarray | None = None
    layers: tuple[str, ...] = ()

    @property
    def n_primitives(self) -> int:
        return int(self.kind.shape[0])


def segment(a, b) -> dict:
    """A line segment from a to b (2-vectors)."""
    return {"kind": SEGMENT, "start": np.asarray(a, float), "end": np.asarray(b, float)}


def arc(centre, radius, angle0, sweep) -> dict:
    """A circular arc from polar angle ``angle0`` (rad) through the signed ``sweep`` (rad)."""
    c = np.asarray(centre, float)
    a1 = angle0 + sweep
    return {"kind": ARC, "centre": c, "radius": float(radius), "angle0": float(angle0),
            "sweep": float(sweep),
            "start": c + radius * np.array([np.cos(angle0), np.sin(angle0)]),
            "end": c + radius * np.array([np.cos(a1), np.sin(a1)])}


def build_template(contours: list[tuple[list[dict], bool]]) -> Template2D:
    """Arrays of a template from contours given as (primitives in drawing order, closed); a
    primitive's ``"layer"`` (a name) gives the template's layers when every primitive has one."""
    rows = [(ci, p) for ci, (prims, _) in enumerate(contours) for p in prims]
    m = len(rows)
    kind = np.array([p["kind"] for _, p in rows], dtype=np.int8)
    start = np.array([p["start"] for _, p in rows], dtype=float).reshape(m, 2)
    end = np.array([p["end"] for _, p in rows], dtype=float).reshape(m, 2)
    centre = np.array([p.get("centre", (0.0, 0.0)) for _, p in rows], dtype=float).reshape(m, 2)
    radius = np.array([p.get("radius", 0.0) for _, p in rows], dtype=float)
    angle0 = np.array([p.get("angle0", 0.0) for _, p in rows], dtype=float)
    sweep = np.array([p.get("sweep", 0.0) for _, p in rows], dtype=float)
    contour = np.array([ci for ci, _ in rows], dtype=np.int64)
    closed = np.array([c for _, c in contours], dtype=bool)
    t = Template2D(kind, start, end, centre, radius, angle0, sweep, contour, closed,
                   np.ones(len(contours)))
    layer: np.ndarray | None = None
    layers: tuple[str, ...] = ()
    if rows and all("layer" in p for _, p in rows):
        layers = tuple(sorted({p["layer"] for _, p in rows}))
        index = {name: i for i, name in enumerate(layers)}
        layer = np.array([index[p["layer"]] for _, p in rows], dtype=np.int64)
    return Template2D(kind, start, end, centre, radius, angle0, sweep, contour, closed,
                      _positive_sides(t), layer, layers)


def diagonal(t: Template2D) -> float:
    """The template's size, mm: the diagonal of a box around its primitives (their ends, and each
    arc's whole circle: an upper bound of the contours' own bounding box, never below it)."""
    arcs = t.kind == ARC
    r = t.radius[arcs, None]
    pts = np.concatenate([t.start, t.end, t.centre[arcs] - r, t.centre[arcs] + r])
    return float(np.linalg.norm(np.ptp(pts, axis=0)))


def signed_area(t: Template2D, c: int) -> float:
    """Signed area of closed contour ``c`` (positive counter-clockwise), arcs included exactly."""
    sel = t.contour == c
    s, e = t.start[sel], t.end[sel]
    area = 0.5 * np.sum(s[:, 0] * e[:, 1] - e[:, 0] * s[:, 1])
    a = sel & (t.kind == ARC)
    # Circular segment between each arc and its chord: r^2/2 (theta - sin theta), signed by sweep.
    th = t.sweep[a]
    area += np.sum(0.5 * t.radius[a] ** 2 * (th - np.sin(th)))
    return float(area)


def _positive_sides(t: Template2D) -> np.ndarray:
    side = np.ones(t.closed.shape[0])
    closed = [int(c) for c in np.flatnonzero(t.closed)]
    for c in closed:
        # Depth: how many other closed contours contain this one (tested at a point on it).
        probe = t.start[np.flatnonzero(t.contour == c)[0]][None]
        depth = sum(bool(contains(t, o, probe)[0]) for o in closed if o != c)
        ccw = signed_area(t, c) > 0
        # Left of a CCW contour is its inside; an outer profile's positive side is outside.
        inside_positive = depth % 2 == 1
        side[c] = 1.0 if ccw == inside_positive else -1.0
    return side


def contains(t: Template2D, c: int, pts: np.ndarray) -> np.ndarray:
    """Whether points (n, 2) lie inside closed contour ``c`` (even-odd rule; arcs as polygons
    with 2-degree steps, so the answer is exact for points farther than 1.5e-4 x radius from an
    arc). Used for nesting, never for the sign of a deviation."""
    poly = _polygon(t, c)
    x, y = pts[:, 0][:, None], pts[:, 1][:, None]
    x0, y0 = poly[:-1, 0][None], poly[:-1, 1][None]
    x1, y1 = poly[1:, 0][None], poly[1:, 1][None]
    dy = np.where(y1 != y0, y1 - y0, 1.0)
    crosses = ((y0 > y) != (y1 > y)) & (x < x0 + (y - y0) * (x1 - x0) / dy)
    return (np.sum(crosses, axis=1) % 2) == 1


def _polygon(t: Template2D, c: int) -> np.ndarray:
    pts = []
    for i in np.flatnonzero(t.contour == c):
        if t.kind[i] == SEGMENT:
            pts.append(t.start[i][None])
        else:
            k = max(2, int(np.ceil(abs(t.sweep[i]) / np.radians(2.0))))
            a = t.angle0[i] + t.sweep[i] * np.arange(k) / k
            pts.append(t.centre[i] + t.radius[i] * np.column_stack([np.cos(a), np.sin(a)]))
    poly = np.vstack(pts)
    return np.vstack([poly, poly[:1]])


def point_to_primitives(p: np.ndarray, t: Template2D, idx: np.ndarray):
    """Exact closest point of each p (n, 2) on primitive ``idx`` (n,).

    Returns (foot (n, 2), distance (n,), left normal at the foot (n, 2), at_end (n,) -1 at the
    primitive's start, +1 at its end, 0 inside it).
    """
    n = p.shape[0]
    foot = np.empty((n, 2))
    left = np.empty((n, 2))
    at_end = np.zeros(n, dtype=np.int8)
    seg = t.kind[idx] == SEGMENT
    if seg.any():
        i = idx[seg]
        a, b = t.start[i], t.end[i]
        ab = b - a
        L2 = np.einsum("ij,ij->i", ab, ab)
        u = np.einsum("ij,ij->i", p[seg] - a, ab) / np.where(L2 > 0, L2, 1.0)
        at_end[seg] = np.where(u <= 0, -1, np.where(u >= 1, 1, 0))
        u = np.clip(u, 0.0, 1.0)
        foot[seg] = a + u[:, None] * ab
        L = np.sqrt(L2)[:, None]
        left[seg] = np.column_stack([-ab[:, 1], ab[:, 0]]) / np.where(L > 0, L, 1.0)
    arcs = ~seg
    if arcs.any():
        i = idx[arcs]
        c, r, a0, sw = t.centre[i], t.radius[i], t.angle0[i], t.sweep[i]
        q = p[arcs] - c
        ang = np.arctan2(q[:, 1], q[:, 0])
        # Position along the sweep, in [0, |sweep|) measured in the arc's own direction.
        rel = np.mod((ang - a0) * np.sign(sw), 2 * np.pi)
        inside = rel <= np.abs(sw)
        # Outside the sweep: the nearer end point.
        ps = c + r[:, None] * np.column_stack([np.cos(a0), np.sin(a0)])
        pe = c + r[:, None] * np.column_stack([np.cos(a0 + sw), np.sin(a0 + sw)])
        ds = np.linalg.norm(p[arcs] - ps, axis=1)
        de = np.linalg.norm(p[arcs] - pe, axis=1)
        on = c + r[:, None] * np.column_stack([np.cos(ang), np.sin(ang)])
        f = np.where(inside[:, None], on, np.where((ds <= de)[:, None], ps, pe))
        end_flag = np.where(inside, 0, np.where(ds <= de, -1, 1))
        foot[arcs] = f
        at_end[arcs] = end_flag
        fa = np.where(inside, ang, np.where(ds <= de, a0, a0 + sw))
        radial = np.column_stack([np.cos(fa), np.sin(fa)])
        # Left of a CCW arc is toward the centre; of a CW arc, away from it.
        left[arcs] = -np.sign(sw)[:, None] * radial
    dist = np.linalg.norm(p - foot, axis=1)
    return foot, dist, left, at_end


@dataclass(frozen=True)
class Deviations2D:
    """signed (n,) mm, positive on the contour's positive side; foot (n, 2) closest point;
    normal (n, 2) unit normal at the foot toward the positive side (at a joint, the bisector);
    primitive (n,) index of the nearest primitive."""

    signed: np.ndarray
    foot: np.ndarray
    normal: np.ndarray
    primitive: np.ndarray


class ContourIndex:
    """Nearest-primitive search over a template: points sampled along every primitive in a
    kd-tree; a query's candidates are the primitives of its nearest samples, and the answer is
    certified exact (else every primitive is tried for that query)."""

    def __init__(self, t: Template2D):
        from scipy.spatial import cKDTree

        self.t = t
        lengths = np.where(t.kind == SEGMENT, np.linalg.norm(t.end - t.start, axis=1),
                           np.abs(t.sweep) * t.radius)
        total = float(lengths.sum())
        self.lengths = lengths
        self.centroid = contour_centroid(t)
        self.spacing = max(total / 20000.0, float(np.median(lengths)) / 8.0, 1e-9)
        counts = np.maximum(1, np.ceil(lengths / self.spacing).astype(np.int64))
        owner = np.repeat(np.arange(t.n_primitives), counts + 1)
        frac = np.concatenate([np.arange(k + 1) / k for k in counts])
        pts = np.empty((owner.size, 2))
        seg = t.kind[owner] == SEGMENT
        o = owner[seg]
        pts[seg] = t.start[o] + frac[seg, None] * (t.end[o] - t.start[o])
        o = owner[~seg]
        a = t.angle0[o] + frac[~seg] * t.sweep[o]
        pts[~seg] = t.centre[o] + t.radius[o, None] * np.column_stack([np.cos(a), np.sin(a)])
        # Half the largest gap between consecutive samples bounds how far a foot point can be
        # from a sample of its own primitive.
        self.reach = 0.5 * float(np.max(lengths / counts)) * (1.0 + 1e-9)
        self.owner = owner
        self.tree = cKDTree(pts)

    def nearest(self, p: np.ndarray):
        """For points (n, 2): (primitive index, foot, distance, left normal, at_end), exact."""
        k = min(8, self.owner.size)
        d, j = query(self.tree, p, k=k)
        d = d.reshape(p.shape[0], -1)
        cand = self.owner[j.reshape(p.shape[0], -1)]
        n = p.shape[0]
        best = np.full(n, np.inf)
        best_i = np.zeros(n, np.int64)
        for col in range(cand.shape[1]):
            _, dist, _, _ = point_to_primitives(p, self.t, cand[:, col])
            better = dist < best
            best = np.where(better, dist, best)
            best_i = np.where(better, cand[:, col], best_i)
        # Exact unless a nearer primitive could hide beyond the k-th sample: then every
        # primitive with a sample inside the ball of radius best + reach is tried.
        if k < self.owner.size:
            unsure = np.flatnonzero(d[:, -1] < best + self.reach)
            if unsure.size:
                lists = self.tree.query_ball_point(p[unsure], r=best[unsure] + self.reach)
                counts = np.array([len(x) for x in lists])
                rows = np.repeat(unsure, counts)
                cand = self.owner[np.concatenate([np.asarray(x, dtype=np.int64)
                                                  for x in lists])]
                pair = np.unique(np.column_stack([rows, cand]), axis=0)
                _, dist, _, _ = point_to_primitives(p[pair[:, 0]], self.t, pair[:, 1])
                order = np.lexsort((dist, pair[:, 0]))
                first = order[np.r_[True, pair[order[1:], 0] != pair[order[:-1], 0]]]
                best_i[pair[first, 0]] = pair[first, 1]
        foot, dist, left, at_end = point_to_primitives(p, self.t, best_i)
        return best_i, foot, dist, left, at_end


def deviations_2d(index: ContourIndex, pts: np.ndarray) -> Deviations2D:
    """Signed deviations of points (n, 2), in the template frame, from the template's contours."""
    t = index.t
    prim, foot, dist, left, at_end = index.nearest(np.asarray(pts, float))
    normal = left.copy()
    # At a joint between two primitives of one contour, the bisector of both normals decides.
    joint = np.flatnonzero(at_end != 0)
    if joint.size:
        nb = _neighbour(t, prim[joint], at_end[joint])
        ok = nb >= 0
        if ok.any():
            rows, other = joint[ok], nb[ok]
            # The neighbour's left normal at the shared point.
            _, _, n_other, _ = point_to_primitives(foot[rows], t, other)
            normal[rows] = left[rows] + n_other
    side = np.sign(np.einsum("ij,ij->i", pts - foot, normal))
    side = np.where(side == 0, 1.0, side)
    positive = t.side[t.contour[prim]]
    signed = dist * side * positive
    ln = np.linalg.norm(normal, axis=1, keepdims=True)
    unit = normal / np.where(ln > 0, ln, 1.0) * positive[:, None]
    return Deviations2D(signed, foot, unit, prim)


@dataclass(frozen=True)
class ContourSurface:
    """A 2D template as the inspection measures against it (engine.surface.Surface): its lines
    and arcs are exact (flattened splines within 0.1 um), so no sampling margin; points in
    its plane have no border to lie past."""

    index: ContourIndex
    exact = True
    normals_source = "contour"

    def deviations(self, X: np.ndarray) -> Deviations2D:
        return deviations_2d(self.index, X)

    def margins(self, dev: Deviations2D) -> np.ndarray:
        return np.zeros(dev.signed.size)

    def beyond(self, X: np.ndarray) -> np.ndarray:
        return np.zeros(len(X), bool)


def contour_centroid(t: Template2D) -> np.ndarray:
    """(2,) centroid of the contours as curves (mm, template frame): every unit of length weighs
    alike, exactly for segments and arcs. A sampling of the contours is no substitute: a
    flattened ellipse brings thousands of short primitives, each with samples of its own."""
    seg = t.kind == SEGMENT
    L = np.where(seg, np.linalg.norm(t.end - t.start, axis=1), np.abs(t.sweep) * t.radius)
    moment = np.where(seg[:, None], 0.5 * (t.start + t.end) * L[:, None], 0.0)
    # An arc: integral of c + r (cos a, sin a) over r |da|, a from angle0 through sweep.
    a0, a1, r = t.angle0, t.angle0 + t.sweep, t.radius
    arc_m = (L[:, None] * t.centre + (r * r * np.sign(t.sweep))[:, None]
             * np.column_stack([np.sin(a1) - np.sin(a0), np.cos(a0) - np.cos(a1)]))
    moment = np.where(seg[:, None], moment, arc_m)
    total = float(L.sum())
    if total <= 0:
        return np.vstack([t.start, t.end]).mean(axis=0)
    return moment.sum(axis=0) / total


def points_on(t: Template2D, n: int, rng: np.random.Generator,
              weight: np.ndarray | None = None) -> np.ndarray:
    """n points (n, 2) on the template, spread over its primitives by length (times ``weight``
    per primitive when given), uniformly along each: for test data and sample parts."""
    L = np.where(t.kind == SEGMENT, np.linalg.norm(t.end - t.start, axis=1),
                 np.abs(t.sweep) * t.radius)
    if weight is not None:
        L = L * weight
    i = rng.choice(len(L), n, p=L / L.sum())
    u = rng.uniform(0.0, 1.0, n)
    a = t.angle0[i] + u * t.sweep[i]
    return np.where((t.kind[i] == SEGMENT)[:, None],
                    t.start[i] + u[:, None] * (t.end[i] - t.start[i]),
                    t.centre[i] + t.radius[i, None] * np.column_stack([np.cos(a), np.sin(a)]))


def _neighbour(t: Template2D, prim: np.ndarray, at_end: np.ndarray) -> np.ndarray:
    """The primitive joined to ``prim`` at its start (at_end -1) or end (+1), or -1 at the free
    end of an open contour."""
    c = t.contour[prim]
    first = np.searchsorted(t.contour, c, side="left")
    last = np.searchsorted(t.contour, c, side="right") - 1
    nxt = np.where(prim == last, np.where(t.closed[c], first, -1), prim + 1)
    prv = np.where(prim == first, np.where(t.closed[c], last, -1), prim - 1)
    return np.where(at_end > 0, nxt, prv)
