"""Signed point-to-surface deviations by the paper's local-facet method, curvature-corrected.

Sign and units, once for the whole product: a deviation is in millimetres, **positive along the
nominal's outward normal** (excess material), negative inside the material.

Method, for each registered point ``p`` (nominal frame):

1. Local facets. Bare nominal points: the 4 nearest points and the 4 triangles they form (the
   paper's Fig. 5); where these are slivers, fans from the nearest point to its neighbours (to
   neighbours spread in direction where the sampling is anisotropic, tested up to 15:1, and
   along a sample's border row).
   Meshes and u-v grids: their real triangles around the nearest point, widened to those
   around the 4 nearest points when the closest point lands on the rim of that first
   neighbourhood. The exact closest point on each triangle (face, edge or vertex) is computed and
   the nearest facet kept.
2. Curvature between samples. A flat facet cuts the chord of a curved surface, off by about
   curvature x spacing^2 / 8. With the nominal's normals (I J K, mesh or grid orientation, or
   estimated) the facet is lifted to the quadratic Phong surface with shape factor 1/2, which is
   exact for any quadratic surface patch, and the foot point is re-solved on it. Facets whose
   vertex normals disagree with the facet by more than ``MAX_NORMAL_TILT_DEG`` (sharp edges,
   coarse tessellation) stay flat.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import kernels
from .geometry import closest_point_on_triangles
from .neighbours import query
from .nominal import Nominal

MAX_NORMAL_TILT_DEG = 25.0
SPREAD_NEIGHBOURS = 48  # neighbours searched for directions where the 8 nearest are collinear
SPREAD_SECTORS = 12     # angular sectors of the tangent plane, 30 degrees each
_QUAD_TRIS = np.array([[0, 1, 2], [0, 1, 3], [0, 2, 3], [1, 2, 3]])


@dataclass(frozen=True)
class Deviations:
    """Deviation of each point from the nominal surface.

    signed : (n,) mm, positive along the outward normal.
    foot : (n, 3) closest point on the nominal surface, nominal frame.
    normal : (n, 3) outward unit normal of the surface at ``foot``.
    curved : (n,) bool, True where the curvature correction applied (else the flat facet).
    """

    signed: np.ndarray
    foot: np.ndarray
    normal: np.ndarray
    curved: np.ndarray


CHUNK = 8192


def point_to_surface(nominal: Nominal, pts: np.ndarray, curvature: bool = True) -> Deviations:
    """Signed deviations of ``pts`` (n, 3), already in the nominal frame, from ``nominal``."""
    pts = np.ascontiguousarray(pts, dtype=np.float64)
    if pts.shape[0] <= CHUNK:
        return _point_to_surface(nominal, pts, curvature)
    # Chunks small enough for the CPU caches (the kernels are long chains of array operations,
    # several times faster when their temporaries stay in cache), taken in Morton order so that
    # neighbouring queries touch neighbouring parts of the kd-tree and the nominal's arrays.
    order = morton_order(pts)
    parts = [_point_to_surface(nominal, pts[order[s:s + CHUNK]], curvature)
             for s in range(0, pts.shape[0], CHUNK)]
    out = []
    for f in ("signed", "foot", "normal", "curved"):
        joined = np.concatenate([getattr(p, f) for p in parts])
        back = np.empty_like(joined)
        back[order] = joined
        out.append(back)
    return Deviations(*out)


def morton_order(pts: np.ndarray, bits: int = 10) -> np.ndarray:
    """Indices that visit (n, 3) points along a Z-order (Morton) curve over their bounding box."""
    lo = pts.min(axis=0)
    span = np.maximum(pts.max(axis=0) - lo, 1e-300)
    cells = np.minimum((pts - lo) / span * (1 << bits), (1 << bits) - 1).astype(np.uint64)
    code = np.zeros(pts.shape[0], dtype=np.uint64)
    for axis in range(3):
        v = cells[:, axis]
        v = (v | (v << np.uint64(16))) & np.uint64(0x030000FF)
        v = (v | (v << np.uint64(8))) & np.uint64(0x0300F00F)
        v = (v | (v << np.uint64(4))) & np.uint64(0x030C30C3)
        v = (v | (v << np.uint64(2))) & np.uint64(0x09249249)
        code |= v << np.uint64(axis)
    return np.argsort(code, kind="stable")


def _point_to_surface(nominal: Nominal, pts: np.ndarray, curvature: bool) -> Deviations:
    if nominal.triangles is None:
        V, N, bary = _nearest_point_facets(nominal, pts)
        return _finish(pts, V, N, bary, curvature, extrapolate=True)
    V, N, bary = _mesh_facets(nominal, pts)
    return _finish(pts, V, N, bary, curvature, extrapolate=False)


def _nearest_point_facets(nominal: Nominal, pts: np.ndarray):
    """The paper's facets: the 4 triangles of the 4 nearest nominal points; the nearest wins.

    Where those facets are slivers (4 nearly collinear neighbours, as on a u-v grid) or the foot
    point falls on a facet's border, the fan of triangles from the nearest point to pairs of its
    8 nearest neighbours is searched as well, preferring a well-shaped facet that holds the foot.
    Where the choice is still a sliver (anisotropic sampling, the 8 nearest in one row; the
    border row of a sample), the fan to neighbours spread in direction (:func:`_spread_fan`) is
    searched: its nearest well-shaped facet holding the foot, else its nearest well-shaped one
    (the foot on a vertex of a convex sample, or beyond the border), replaces the sliver, whose
    own normal is meaningless. A well-shaped facet that does not hold the foot is replaced by
    that fan's only when it does and its vertex normals agree (one side of the material): over
    a gap of a sample drawn at random, the 8 nearest all on one side (0.4 mm measured sideways
    to a facet's edge, for a point on the surface).
    """
    k = min(4, nominal.n)
    _, nn = query(nominal.tree, pts, k=k)
    tris = nn[:, _QUAD_TRIS] if k == 4 else nn[:, None, :3]  # (n, t, 3) point indices
    sel, b, good, shaped = _pick_facet(nominal, pts, tris)
    bad = np.flatnonzero(~good)
    if bad.size and nominal.n > 4:
        k8 = min(8, nominal.n)
        _, nn8 = query(nominal.tree, pts[bad], k=k8)
        i, j = np.triu_indices(k8 - 1, 1)
        fan = np.stack([np.broadcast_to(nn8[:, :1], (bad.size, i.size)),
                        nn8[:, 1:][:, i], nn8[:, 1:][:, j]], axis=2)
        tris2 = np.concatenate([sel[bad][:, None, :], fan], axis=1)
        sel2, b2, good2, shaped2 = _pick_facet(nominal, pts[bad], tris2)
        sel[bad], b[bad], shaped[bad] = sel2, b2, shaped2
        bad = bad[~good2]
    if bad.size and nominal.n > 8:
        sel3, b3, good3, shaped3 = _pick_facet(nominal, pts[bad], _spread_fan(nominal, pts[bad]),
                                               shaped_next=True)
        # A sliver gives way to any well-shaped facet; a well-shaped facet that does not hold
        # the foot (a gap in a random sample, or beyond the sample's border) only to one that
        # does and lies on one side of the material: its vertex normals within 60 degrees of
        # its centre's (not across a thin wall, whose far side the fan may reach sideways).
        n3 = nominal.normals(sel3.ravel()).reshape(-1, 3, 3)
        one_side = np.all(np.einsum("mij,mj->mi", n3, n3[:, 0]) > 0.5, axis=1)
        better = np.where(shaped[bad], good3 & one_side, shaped3)
        take = bad[better]
        sel[take], b[take] = sel3[better], b3[better]
    return nominal.points[sel], nominal.normals(sel), b


def _spread_fan(nominal: Nominal, pts: np.ndarray) -> np.ndarray:
    """Fan facets (m, t, 3) from the nearest nominal point to neighbours spread in direction.

    On anisotropic bare points (a CAD u-v sample written without its grid: 0.35 mm apart along
    one direction, 2 mm along the other) the 8 nearest neighbours all lie in the same row, nearly
    collinear (so do those along a sample's border row), and every facet among them is a sliver.
    Here ``SPREAD_NEIGHBOURS`` neighbours are taken instead and, in ``SPREAD_SECTORS`` equal
    angular sectors of the tangent plane (the nominal normal at the nearest point), the nearest
    one in each sector is kept; the facets from the nearest point to each kept neighbour and the
    next (and the next but one) around it are returned (m, 2 x SPREAD_SECTORS, 3). Neighbours steeper than 45 degrees out of the tangent plane (the far side of a
    thin wall) and copies of the nearest point are left out; a missing neighbour repeats the
    nearest point (a degenerate facet, never chosen as well shaped).
    """
    m = pts.shape[0]
    k = min(SPREAD_NEIGHBOURS, nominal.n)
    _, nb = query(nominal.tree, pts, k=k)
    centre = nb[:, 0]
    n0 = nominal.normals(centre)
    c = nominal.points[centre]
    d = nominal.points[nb[:, 1:]] - c[:, None, :]  # (m, k-1, 3) mm
    h = np.einsum("mkj,mj->mk", d, n0)
    t = d - h[..., None] * n0[:, None, :]
    # Any orthonormal frame (e1, e2) of the tangent plane: the sectors need no particular start.
    helper = np.where(np.abs(n0[:, :1]) < 0.9, np.array([[1.0, 0, 0]]), np.array([[0, 1.0, 0]]))
    e1 = np.cross(n0, helper)
    e1 /= np.linalg.norm(e1, axis=1, keepdims=True)
    e2 = np.cross(n0, e1)
    ang = np.arctan2(np.einsum("mkj,mj->mk", t, e2), np.einsum("mkj,mj->mk", t, e1))
    sector = np.minimum(((ang + np.pi) / (2 * np.pi) * SPREAD_SECTORS).astype(np.int64),
                        SPREAD_SECTORS - 1)
    flat_enough = np.abs(h) < np.linalg.norm(t, axis=2)  # also drops copies of the centre
    sector = np.where(flat_enough, sector, SPREAD_SECTORS)  # a discard column
    # The nearest neighbour in each sector: the first column (neighbours come nearest first).
    first = np.full((m, SPREAD_SECTORS + 1), k - 1)
    rows = np.arange(m)
    np.minimum.at(first, (np.repeat(rows, k - 1), sector.ravel()), np.tile(np.arange(k - 1), m))
    found = first < k - 1
    col = np.minimum(first, k - 2)
    rep = np.where(found, np.take_along_axis(nb[:, 1:], col, axis=1), -1)
    rep_ang = np.take_along_axis(ang, col, axis=1)
    # The kept neighbours in angular order around the centre (missing ones last), and the ring
    # of facets between each and the next one and the one after (the closed star of the centre,
    # which holds any foot near it whatever side of the centre it falls on).
    order = np.argsort(np.where(rep[:, :-1] >= 0, rep_ang[:, :-1], np.inf), axis=1)
    ring = np.take_along_axis(rep, order, axis=1)
    count = np.sum(ring >= 0, axis=1, keepdims=True)
    slot = np.arange(SPREAD_SECTORS)
    ones: list[np.ndarray] = []
    twos: list[np.ndarray] = []
    for step in (1, 2):
        nxt = np.take_along_axis(ring, (slot + step) % np.maximum(count, 1), axis=1)
        usable = (slot < count) & (count > step)
        ones.append(np.where(usable, ring, centre[:, None]))
        twos.append(np.where(usable, nxt, centre[:, None]))
    one, two = np.concatenate(ones, axis=1), np.concatenate(twos, axis=1)
    return np.stack([np.broadcast_to(centre[:, None], one.shape), one, two], axis=2)


def _pick_facet(nominal: Nominal, pts: np.ndarray, tris: np.ndarray, shaped_next: bool = False):
    """Among candidate facets (n, t, 3) pick per point the nearest well-shaped one holding the foot.

    Where none holds the foot, the nearest facet (with ``shaped_next``, the nearest well-shaped
    one if any). Returns (chosen facet (n, 3) point indices, barycentrics (n, 3), good (n,),
    shaped (n,)) where ``good`` says the chosen facet is well shaped and its foot point interior,
    ``shaped`` that it is well shaped.
    """
    n, t = tris.shape[:2]
    P = np.repeat(pts, t, axis=0)
    Vt = nominal.points[tris.reshape(-1, 3)]
    q, b = closest_point_on_triangles(P, Vt[:, 0], Vt[:, 1], Vt[:, 2])
    d2 = np.einsum("ij,ij->i", P - q, P - q).reshape(n, t)
    area2 = np.linalg.norm(np.cross(Vt[:, 1] - Vt[:, 0], Vt[:, 2] - Vt[:, 0]), axis=1)
    edges2 = np.sum((Vt - np.roll(Vt, 1, axis=1)) ** 2, axis=(1, 2))
    quality = (2.0 * np.sqrt(3.0) * area2 / np.maximum(edges2, 1e-300)).reshape(n, t)
    shaped = quality > 0.1
    ok = shaped & np.all(b > 1e-9, axis=1).reshape(n, t)
    # Prefer facets that are well shaped and hold the foot; among them (or all) the nearest.
    key = np.where(ok, d2, d2 + np.inf)
    fallback = np.argmin(d2, axis=1)
    if shaped_next:
        # Then well-shaped facets: a sliver's own normal is meaningless.
        fallback = np.where(shaped.any(axis=1), np.argmin(np.where(shaped, d2, np.inf), axis=1),
                            fallback)
    best = np.where(ok.any(axis=1), np.argmin(key, axis=1), fallback)
    rows = np.arange(n)
    return (tris[rows, best], b.reshape(n, t, 3)[rows, best], ok[rows, best],
            shaped[rows, best])


def _mesh_facets(nominal: Nominal, pts: np.ndarray):
    tree = nominal.sample_tree
    n = pts.shape[0]
    # The 4 nearest samples at once: most points need the wider look below (one query costs
    # much less than two).
    k = min(4, tree.n)
    _, nn = query(tree, pts, k=k)
    nn = np.asarray(nn).reshape(n, k)
    centre = nn[:, 0]
    best_tri = np.zeros(n, np.int64)
    best_d2 = np.full(n, np.inf)
    best_b = np.zeros((n, 3))
    tris = nominal.mesh_triangles
    args = (nominal.star_ptr, nominal.star_tri, tris, nominal.points, best_tri, best_d2, best_b)
    kernels.best_in_stars(pts, np.arange(n), centre.astype(np.int64), *args)
    # Where the foot point lies on the outer rim of the nearest point's star (or the nearest
    # sample is an interior sample of one large triangle), look wider: the triangles around the
    # next three nearest points too.
    at_centre = np.where(tris[best_tri] == centre[:, None], best_b, 0.0).sum(axis=1)
    rim = np.flatnonzero((centre >= nominal.n) | (at_centre <= 1e-12))
    for col in range(1, k):
        if rim.size:
            kernels.best_in_stars(pts, rim, nn[rim, col].astype(np.int64), *args)
    sel = tris[best_tri]
    return nominal.points[sel], nominal.normals(sel), best_b


def _finish(pts, V, N, bary, curvature: bool, extrapolate: bool) -> Deviations:
    """Curvature-correct the chosen facets and sign the distances.

    Facets whose vertex normals tilt from the facet by more than ``MAX_NORMAL_TILT_DEG`` (or all,
    without ``curvature``) are treated as flat: their vertex normals are replaced by the facet
    normal, which makes the Phong lift vanish. With ``extrapolate`` (bare nominal points, whose
    sampling leaves gaps) a foot point that falls just outside its facet, by less than the
    facet's longest edge, stays on the facet's surface continued (the distance is measured
    along the normal); otherwise, and on meshes and grids whose borders are real, the distance
    is to the facet's nearest edge or vertex. The per-point work is ``kernels.phong_finish``.
    """
    n = pts.shape[0]
    signed = np.empty(n)
    foot = np.empty((n, 3))
    normal = np.empty((n, 3))
    curved = np.empty(n, dtype=bool)
    kernels.phong_finish(np.ascontiguousarray(pts), np.ascontiguousarray(V),
                         np.ascontiguousarray(N), np.ascontiguousarray(bary), bool(curvature),
                         float(np.cos(np.radians(MAX_NORMAL_TILT_DEG))), bool(extrapolate),
                         signed, foot, normal, curved)
    return Deviations(signed, foot, normal, curved)
