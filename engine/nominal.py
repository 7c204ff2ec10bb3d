"""The nominal surface: sampled CAD points, a u-v grid, or a triangle mesh, with outward normals.

A :class:`Nominal` owns what registration and deviation measurement need from it:

* ``points`` (N, 3) in millimetres, nominal frame;
* outward unit ``normals`` per point, from the file's I J K columns, the mesh/grid orientation, or
  estimated from neighbours (then ``normals_source == "estimated"`` and the sign convention rests
  on that estimate: normals are made consistent over the surface and point away from its centre);
* ``triangles`` (M, 3) for meshes and grids (grid cells are split along their shorter diagonal),
  or None for bare points, where the paper's facets of the 4 nearest points are used instead;
* a kd-tree over the points and coarse levels for coarse-to-fine ICP: seeded random points spread
  over the triangles by area (meshes and grids), seeded random subsets (bare points).
"""

from __future__ import annotations

import functools

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import breadth_first_order, connected_components, minimum_spanning_tree
from scipy.spatial import cKDTree

from . import icp_kernels, kernels
from .errors import InputError
from .neighbours import SampleLookup, coincident_pairs, query
from .pointset import PointSet
from .seeds import DEFAULT_SEED, rng

NORMAL_NEIGHBOURS = 12
MAX_SUBDIVISION = 16  # a large triangle gets at most 16 x 16 / 2 interior sample points
AREA_SAMPLES = 16384
"""Area samples of a mesh or grid (:attr:`Nominal.area_samples`): as many as the largest coarse
level the registration asks for (16 x its ``coarse_size``)."""
EVEN_EDGE_RATIO = 8.0
"""A mesh's vertices cover its surface evenly (:attr:`Nominal.vertices_cover`) when its
triangles' area-weighted mean squared longest edge is at most this many times the area per
vertex."""
LEVELS_SEED = 20240607
"""The random stream of a nominal's seeded permutation and area samples (engine.seeds)."""


def surface_tree(points: np.ndarray) -> cKDTree:
    """A kd-tree over samples of a surface (points (n, 3)).

    Built unbalanced (midpoint splits) with uncompacted nodes: on samples of a thin shell, a
    query off the surface (a clutter point, a wrong candidate pose) meets many cells at about its
    distance, and the default tree's data-tight boxes were up to 12x slower there (the SICK
    housing's 1.5 M samples: 2,577 against 211 us a point inside its box; FTC-06's 1.1 M: 93
    against 57; the fairing's 60k: 115 against 43), and no more than 2 us faster near it
    (benchmarks/README.md)."""
    return cKDTree(points, balanced_tree=False, compact_nodes=False)


class Nominal:
    """The nominal geometry; build it with :meth:`from_point_set`."""

    def __init__(self, points: np.ndarray, normals: np.ndarray | None, normals_source: str,
                 triangles: np.ndarray | None = None, kind: str = "points",
                 grid_shape: tuple[int, int] | None = None, path: str = "<array>",
                 seed: int = DEFAULT_SEED):
        self.points = np.ascontiguousarray(points, dtype=np.float64)
        self.n = self.points.shape[0]
        self.kind = kind
        self.grid_shape = grid_shape
        self.path = path
        self.seed = seed
        """The inspection's seed (engine.seeds), of the coarse levels' random choices."""
        self.triangles = None if triangles is None else np.ascontiguousarray(triangles, np.int64)
        self.normals_source = normals_source
        if normals is None:
            self._normals = np.full((self.n, 3), np.nan)
            self._have_normal = np.zeros(self.n, dtype=bool)
        else:
            self._normals = np.ascontiguousarray(normals, dtype=np.float64)
            self._have_normal = np.ones(self.n, dtype=bool)
        lo, hi = self.points.min(0), self.points.max(0)
        self.centre = 0.5 * (lo + hi)
        self.diagonal = float(np.linalg.norm(hi - lo))
        self._tree: cKDTree | None = None
        self._levels: dict = {}
        self._perm = rng(seed, LEVELS_SEED).permutation(self.n)
        self._area_samples: tuple | None = None
        self._orient_ref: tuple[cKDTree, np.ndarray] | None = None
        if self.triangles is not None:
            self._build_stars()

    # ------------------------------------------------------------------ construction
    @classmethod
    def from_point_set(cls, ps: PointSet, seed: int = DEFAULT_SEED) -> "Nominal":
        """Build the nominal from a read file: a mesh, a declared grid, or bare points (``seed``:
        the inspection's, engine.seeds)."""
        if ps.dim != 3:
            raise InputError("a 3D nominal needs x y z columns (a 2-column file is a 2D contour)",
                             ps.path)
        if ps.triangles is not None:
            tris = _drop_degenerate(ps.points, ps.triangles)
            if tris.shape[0] == 0:
                raise InputError("the mesh has no triangle of non-zero area", ps.path)
            tris, normals = _orient_mesh(ps.points, tris, ps.normals)
            return cls(ps.points, normals, "file" if ps.normals is not None else "mesh", tris,
                       "mesh", None, ps.path, seed)
        if ps.grid_shape is not None:
            tris = _closed_grid_triangles(ps.points, *ps.grid_shape)
            tris, normals = _orient_mesh(ps.points, tris, ps.normals, closed_check=False)
            return cls(ps.points, normals, "file" if ps.normals is not None else "grid", tris,
                       "grid", ps.grid_shape, ps.path, seed)
        return cls(ps.points, ps.normals, "file" if ps.normals is not None else "estimated",
                   None, "points", None, ps.path, seed)

    # ------------------------------------------------------------------ neighbours
    @property
    def tree(self) -> cKDTree:
        if self._tree is None:
            self._tree = surface_tree(self.points)
        return self._tree

    def level(self, size: int) -> tuple[np.ndarray, np.ndarray, cKDTree]:
        """A coarse level of ``size`` samples: (points (m, 3), outward unit normals (m, 3), their
        kd-tree).

        The levels of a mesh whose vertices leave parts of its surface empty (not
        :attr:`vertices_cover`) are the first ``size`` of its area samples
        (:attr:`area_samples`: points drawn over its triangles by area), so that every level
        covers the surface evenly: a CAD tessellation puts its vertices along edges and around
        holes, none inside a plane. Other levels (bare points, grids, even meshes) are the
        first ``size`` of a seeded permutation of the points (``size >= n``: all of them, with
        their tree)."""
        size = self._level_size(size)
        if size >= self.n and (self.triangles is None or self.vertices_cover):
            return self.points, self.normals(np.arange(self.n)), self.tree
        if size not in self._levels:
            if self.triangles is not None and not self.vertices_cover:
                pts, nrm, _ = self.area_samples
                pts, nrm = pts[:size], nrm[:size]
            else:
                idx = np.sort(self._perm[:size])
                pts, nrm = self.points[idx], self.normals(idx)
            self._levels[size] = (pts, nrm, surface_tree(pts))
        return self._levels[size]

    @property
    def finest_level(self) -> int:
        """The size of the finest level: every area sample (meshes and grids whose vertices
        leave parts of the surface empty: a CAD tessellation's planes, where a point measured
        pairs with another face's edge), or every point (bare points, and meshes and grids whose
        vertices cover the surface evenly, :attr:`vertices_cover`: a u-v grid, a scan's
        mesh)."""
        return self.n if self.triangles is None or self.vertices_cover else AREA_SAMPLES

    @functools.cached_property
    def vertices_cover(self) -> bool:
        """A mesh's or grid's vertices spread over its surface about as evenly as area samples:
        its triangles' longest edges, squared and averaged by area, are at most
        ``EVEN_EDGE_RATIO`` x the area per vertex (2 for a square grid: its diagonals; a CAD
        tessellation's fans across a plane reach hundreds)."""
        P, tris = self.points, self.triangles
        if tris is None or not len(tris) or self.kind == "grid":
            return True  # (a grid's cells are its neighbouring vertices')
        a, b, c = P[tris[:, 0]], P[tris[:, 1]], P[tris[:, 2]]
        area = self.triangle_areas
        longest = np.max([np.einsum("ij,ij->i", e, e) for e in (b - a, c - b, a - c)], axis=0)
        total = float(area.sum())
        return total <= 0 or float(area @ longest) / total <= EVEN_EDGE_RATIO * total / self.n

    @functools.cached_property
    def triangle_areas(self) -> np.ndarray:
        """(m,) each triangle's area, mm² (meshes and grids)."""
        P, tris = self.points, self.mesh_triangles
        return 0.5 * np.linalg.norm(np.cross(P[tris[:, 1]] - P[tris[:, 0]],
                                             P[tris[:, 2]] - P[tris[:, 0]]), axis=1)

    @property
    def mesh_triangles(self) -> np.ndarray:
        """(m, 3) the triangles of a mesh or grid; raises ValueError for bare points."""
        if self.triangles is None:
            raise ValueError("the nominal is bare points: it has no triangles")
        return self.triangles

    def _level_size(self, size: int) -> int:
        """The size of the level asked for as ``size``: at most :attr:`finest_level`."""
        return int(min(size, self.finest_level))

    @property
    def area_samples(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``AREA_SAMPLES`` seeded random points on the triangles, each triangle drawn by its
        area (a mesh's or grid's coarse levels): (points (s, 3), outward unit normals (s, 3),
        interpolated from the triangle's vertex normals, triangle index (s,))."""
        if self._area_samples is None:
            tris = self.mesh_triangles
            P = self.points
            area = self.triangle_areas
            gen = rng(self.seed, LEVELS_SEED)
            t = np.searchsorted(np.cumsum(area), gen.uniform(0, area.sum(), AREA_SAMPLES))
            t = np.minimum(t, len(tris) - 1)
            r1, r2 = np.sqrt(gen.uniform(size=AREA_SAMPLES)), gen.uniform(size=AREA_SAMPLES)
            w = np.column_stack([1.0 - r1, r1 * (1.0 - r2), r1 * r2])
            corner = tris[t]
            pts = np.einsum("sc,scj->sj", w, P[corner])
            nrm = np.einsum("sc,scj->sj", w, self.normals(corner))
            size = np.linalg.norm(nrm, axis=1, keepdims=True)
            flat = np.cross(P[corner[:, 1]] - P[corner[:, 0]], P[corner[:, 2]] - P[corner[:, 0]])
            nrm = np.where(size > 1e-12, nrm / np.maximum(size, 1e-300),
                           flat / np.linalg.norm(flat, axis=1, keepdims=True))
            self._area_samples = (pts, nrm, t.astype(np.int64))
        return self._area_samples

    def level_spacing(self, size: int) -> float:
        """A level's typical sample spacing, mm: the median distance from a spread sample of
        its points (about 1,000) to their nearest other point of the level."""
        key = ("spacing", self._level_size(size))
        if key not in self._levels:
            pts, _, tree = self.level(size)
            d, _ = tree.query(pts[:: max(1, pts.shape[0] // 1000)], k=2)
            self._levels[key] = float(np.median(d[:, 1]))
        return self._levels[key]

    def level_lookup(self, size: int) -> SampleLookup:
        """The constant-time nearest-sample lookup of a coarse level (neighbours.SampleLookup)."""
        key = ("lookup", self._level_size(size))
        if key not in self._levels:
            pts, _, tree = self.level(size)
            self._levels[key] = SampleLookup.build(pts, tree, self.level_spacing(size))
        return self._levels[key]

    def level_shape(self, size: int) -> np.ndarray:
        """(m, 3, 3) shape operators of a coarse level's points (see :meth:`shape_operators`)."""
        key = ("shape", self._level_size(size))
        if key not in self._levels:
            pts, nrm, _ = self.level(size)
            self._levels[key] = self.shape_at(pts, nrm)
        return self._levels[key]

    def shape_operators(self, idx: np.ndarray, k: int = 9) -> np.ndarray:
        """(m, 3, 3) local curvature of the surface at points ``idx``, in the nominal frame.

        Near point m with outward normal n the surface is m + u + 1/2 (u^T S u) n for tangent u,
        so a point x lies ``n.(x - m) - 1/2 (x - m)^T S (x - m)`` above it: a second-order distance
        that stays accurate on a coarse sample, where the tangent plane alone is off by
        curvature x spacing^2 / 2. S is fitted to how the neighbours' normals turn
        (dn = -S du). Where the normals turn by more than ~17 degrees between neighbours (sharp
        edges) S is zero: the tangent plane is the honest approximation there.
        """
        idx = np.asarray(idx)
        return self.shape_at(self.points[idx], self.normals(idx), k)

    def shape_at(self, p: np.ndarray, n: np.ndarray, k: int = 9) -> np.ndarray:
        """(m, 3, 3) :meth:`shape_operators` at surface points p (m, 3) with outward unit
        normals n (m, 3) (a level's area samples), from their ``k`` nearest nominal points."""
        k = min(k, self.n)
        _, nb = query(self.tree, p, k=k)
        dx = self.points[nb] - p[:, None, :]
        dn = self.normals(nb) - n[:, None, :]
        S = np.empty((p.shape[0], 3, 3))
        icp_kernels.shape_fit(np.ascontiguousarray(n), dx, dn, S)
        return S

    # ------------------------------------------------------------------ normals
    def normals(self, idx) -> np.ndarray:
        """Outward unit normals of the points ``idx`` (estimated on first use for bare points)."""
        idx = np.asarray(idx)
        flat = idx.ravel()
        missing = flat[~self._have_normal[flat]]
        if missing.size:
            self._estimate_normals(np.unique(missing))
        return self._normals[flat].reshape(idx.shape + (3,))

    def _estimate_normals(self, idx: np.ndarray) -> None:
        k = min(NORMAL_NEIGHBOURS, self.n)
        _, nb = self.tree.query(self.points[idx], k=k)
        nrm = _quadric_normals(self.points[idx], self.points[nb])
        ref_tree, ref_normals = self._orientation_reference()
        _, j = ref_tree.query(self.points[idx])
        flip = np.einsum("ij,ij->i", nrm, ref_normals[j]) < 0
        nrm[flip] *= -1
        self._normals[idx] = nrm
        self._have_normal[idx] = True

    def _orientation_reference(self):
        """Consistently oriented normals on a coarse level (Hoppe et al.: spanning-tree propagation).

        Each connected piece of the surface is then turned so that most of its normals point away
        from the centre of the whole nominal.
        """
        if self._orient_ref is not None:
            return self._orient_ref
        idx = np.sort(self._perm[: min(self.n, 4000)])
        pts = self.points[idx]
        tree = cKDTree(pts)
        k = min(NORMAL_NEIGHBOURS, self.n)
        _, nb = self.tree.query(pts, k=k)
        nrm = _pca_normals(self.points[nb])
        kk = min(8, len(idx) - 1)
        dist, nbr = tree.query(pts, k=kk + 1)
        rows = np.repeat(np.arange(len(idx)), kk)
        cols = nbr[:, 1:].ravel()
        w = 1.0 - np.abs(np.einsum("ij,ij->i", nrm[rows], nrm[cols])) + 1e-9
        g = coo_matrix((w, (rows, cols)), shape=(len(idx), len(idx))).tocsr()
        g = g.maximum(g.T)
        mst = minimum_spanning_tree(g)
        mst = mst.maximum(mst.T)
        ncomp, labels = connected_components(mst, directed=False)
        for c in range(ncomp):
            members = np.flatnonzero(labels == c)
            order, pred = breadth_first_order(mst, members[0], directed=False)
            for node in order[1:]:
                if nrm[node] @ nrm[pred[node]] < 0:
                    nrm[node] *= -1
            out = np.einsum("ij,ij->i", pts[order] - self.centre, nrm[order])
            if np.sum(out > 0) < np.sum(out < 0):
                nrm[order] *= -1
        self._orient_ref = (tree, nrm)
        return self._orient_ref

    # ------------------------------------------------------------------ mesh topology
    def _build_stars(self) -> None:
        """Per point, the triangles around it (CSR), plus extra sample points on large triangles.

        Candidate facets for a query are the triangles around its nearest sample points; a large
        triangle (longer than twice the typical edge) gets interior samples, on a barycentric
        grid of up to ``MAX_SUBDIVISION`` steps per edge, so that a query near its middle still
        finds it.
        """
        tris = self.mesh_triangles
        P = self.points
        longest = kernels.longest_edges(P, tris)
        s = float(np.median(longest[:: max(1, longest.size // 100000)]))
        big = np.flatnonzero(longest > 2.0 * s)
        extra_pts = [np.empty((0, 3))]
        extra_tri = [np.empty(0, np.int64)]
        if big.size:
            steps = np.minimum(np.ceil(longest[big] / s), MAX_SUBDIVISION).astype(np.int64)
            for m in np.unique(steps):
                # Interior points of the barycentric grid with m steps per edge, for every big
                # triangle that gets m steps at once.
                ii, jj = np.meshgrid(np.arange(1, m), np.arange(1, m), indexing="ij")
                keep = ii + jj < m
                bc = np.column_stack([m - ii[keep] - jj[keep], ii[keep], jj[keep]]) / m
                group = big[steps == m]
                v = P[tris[group]]  # (g, 3, 3)
                pts = np.einsum("kc,gcj->gkj", bc, v).reshape(-1, 3)
                extra_pts.append(pts)
                extra_tri.append(np.repeat(group, bc.shape[0]).astype(np.int64))
        self.extra_points = np.concatenate(extra_pts)
        extra_tri_arr = np.concatenate(extra_tri)
        # Vertex -> triangles in CSR form; scipy's COO -> CSR conversion is a counting sort.
        nt = tris.shape[0]
        incidence = coo_matrix((np.ones(3 * nt, dtype=np.int8),
                                (tris.ravel(), np.broadcast_to(
                                    np.arange(nt, dtype=np.int64)[:, None], (nt, 3)).ravel())),
                               shape=(self.n, nt)).tocsr()
        incidence = _weld_incidence(incidence, self._coincident_points())
        star_ptr = np.zeros(self.n + len(extra_tri_arr) + 1, np.int64)
        star_ptr[: self.n + 1] = incidence.indptr
        star_ptr[self.n + 1:] = star_ptr[self.n] + np.arange(1, len(extra_tri_arr) + 1)
        self.star_ptr = star_ptr
        self.star_tri = (incidence.indices if not len(extra_tri_arr) else
                         np.concatenate([incidence.indices, extra_tri_arr.astype(incidence.indices.dtype)]))
        self._sample_tree: cKDTree | None = None

    def _coincident_points(self) -> np.ndarray:
        """(k, 2) pairs (representative, copy) of points with exactly the same coordinates: a
        closed grid's seam (a revolved surface whose last
        column repeats its first), a pole row, a mesh written without welding its vertices. Only
        a grid's border can hold them; a mesh is searched whole
        (engine.neighbours.coincident_pairs)."""
        if self.kind == "grid" and self.grid_shape is not None:
            nu, nv = self.grid_shape
            ids = np.arange(self.n).reshape(nv, nu)
            cand = np.unique(np.concatenate([ids[0], ids[-1], ids[:, 0], ids[:, -1]]))
        else:
            cand = None
        return coincident_pairs(self.points, cand)

    @property
    def sample_tree(self) -> cKDTree:
        """kd-tree over the points plus the extra samples on large triangles (meshes and grids)."""
        if not len(self.extra_points):
            return self.tree
        if self._sample_tree is None:
            self._sample_tree = surface_tree(np.vstack([self.points, self.extra_points]))
        return self._sample_tree


def _weld_incidence(incidence, pairs: np.ndarray):
    """Point -> triangle incidence (CSR, n x nt) where each of the coincident ``pairs`` (k, 2)
    also owns the other's triangles: a query near a seam whose nearest sample is one copy of a
    seam point must see the facets on both sides of it."""
    if not len(pairs):
        return incidence
    from scipy.sparse import coo_matrix as _coo

    n = incidence.shape[0]
    both = np.concatenate([pairs, pairs[:, ::-1]])
    # Pairs link every copy to its group's representative: the representative gathers the
    # copies' facets in the first pass, the copies get them from it in the second.
    S = _coo((np.ones(len(both)), (both[:, 0], both[:, 1])), shape=(n, n)).tocsr()
    out = incidence.astype(np.int64)
    for _ in range(2):
        grown = ((out + S @ out) > 0).astype(np.int64)
        if grown.nnz == out.nnz:
            break
        out = grown
    out = out.astype(np.int8)
    out.sort_indices()
    return out


def _pca_normals(nbh: np.ndarray) -> np.ndarray:
    """(m, k, 3) neighbourhoods → (m, 3) unit normals (smallest principal axis), unoriented."""
    c = nbh - nbh.mean(axis=1, keepdims=True)
    cov = np.einsum("mki,mkj->mij", c, c)
    _, vecs = np.linalg.eigh(cov)
    return vecs[:, :, 0]


def _quadric_normals(centre: np.ndarray, nbh: np.ndarray) -> np.ndarray:
    """Unoriented unit normals at ``centre`` (m, 3) from a quadric fitted to its neighbours (m, k, 3).

    The plane normal (PCA) is tilted by the slope of a height field z = a + b x + c y + d x^2 +
    e x y + f y^2 fitted in that frame: PCA alone is off by about curvature x spacing where the
    neighbourhood is lopsided, the quadric's slope at the centre only to second order.
    """
    n0 = _pca_normals(nbh)
    k = nbh.shape[1]
    if k < 8:
        return n0
    # An orthonormal frame (e1, e2, n0) per point.
    helper = np.where(np.abs(n0[:, :1]) < 0.9, np.array([[1.0, 0, 0]]), np.array([[0, 1.0, 0]]))
    e1 = np.cross(n0, helper)
    e1 /= np.linalg.norm(e1, axis=1, keepdims=True)
    e2 = np.cross(n0, e1)
    d = nbh - centre[:, None, :]
    x = np.einsum("mkj,mj->mk", d, e1)
    y = np.einsum("mkj,mj->mk", d, e2)
    z = np.einsum("mkj,mj->mk", d, n0)
    scale = np.sqrt(np.mean(x**2 + y**2, axis=1, keepdims=True)) + 1e-300
    x, y, z = x / scale, y / scale, z / scale
    A = np.stack([np.ones_like(x), x, y, x * x, x * y, y * y], axis=2)
    AtA = np.einsum("mki,mkj->mij", A, A) + 1e-9 * np.eye(6)
    Atz = np.einsum("mki,mk->mi", A, z)
    coef = np.linalg.solve(AtA, Atz[..., None])[..., 0]
    nrm = n0 - coef[:, 1:2] * e1 - coef[:, 2:3] * e2
    return nrm / np.linalg.norm(nrm, axis=1, keepdims=True)


CLOSING_GAP = 1.5
"""A grid whose last column lies within this many times the typical column spacing of its first,
in every row, wraps round (a revolved surface sampled over [0, 2 pi) without repeating the seam);
likewise for rows."""


def _closed_grid_triangles(points: np.ndarray, nu: int, nv: int) -> np.ndarray:
    """The grid's triangles, with the cells across the seam added where the grid wraps round in
    u or v (see CLOSING_GAP): without them the strip between the last and the first column would
    hold no facet, and a point measured on it would be judged against the grid's border."""
    P = points.reshape(nv, nu, 3)
    wrap_u = nu > 2 and _wraps(P)
    wrap_v = nv > 2 and _wraps(np.swapaxes(P, 0, 1))
    if not (wrap_u or wrap_v):
        return _grid_triangles(points, nu, nv)
    iu = np.r_[np.arange(nu), 0] if wrap_u else np.arange(nu)
    iv = np.r_[np.arange(nv), 0] if wrap_v else np.arange(nv)
    ids = (iv[:, None] * nu + iu[None, :]).ravel()
    tris = _grid_triangles(points[ids], iu.size, iv.size)
    return ids[tris]


def _wraps(P: np.ndarray) -> bool:
    """(nv, nu, 3) grid: does its last column close onto its first, in every row?"""
    gap = np.linalg.norm(P[:, -1] - P[:, 0], axis=1)
    # The typical spacing next to the seam, on both sides (the whole grid would cost a second
    # for 5 million points, and the spacing that matters is the seam's).
    k = min(4, P.shape[1] - 1)
    step = np.concatenate([np.linalg.norm(np.diff(P[:, :k + 1], axis=1), axis=2),
                           np.linalg.norm(np.diff(P[:, -(k + 1):], axis=1), axis=2)], axis=1)
    typical = np.median(step, axis=1)
    # A repeated seam (gap 0) is closed already; its copies share their facets (_build_stars).
    return bool(np.all((gap > 0) & (typical > 0) & (gap <= CLOSING_GAP * typical)))


def _grid_triangles(points: np.ndarray, nu: int, nv: int) -> np.ndarray:
    """Split each u-v grid cell into two triangles along its shorter diagonal (u fastest);
    triangles of zero area (collapsed rows or columns, as at a pole) are left out."""
    tris, ok = kernels.grid_triangles(np.ascontiguousarray(points, np.float64), int(nu), int(nv))
    return tris if ok.all() else tris[ok]


def _drop_degenerate(points: np.ndarray, tris: np.ndarray) -> np.ndarray:
    """Triangles of (numerically) non-zero area: the grid's rule (kernels.nonzero_areas)."""
    keep = kernels.nonzero_areas(np.ascontiguousarray(points, np.float64),
                                 np.ascontiguousarray(tris, np.int64))
    return tris if keep.all() else tris[keep]


def face_normals(points: np.ndarray, tris: np.ndarray) -> np.ndarray:
    """(M, 3) area-weighted (unnormalised, length = 2 x area) face normals by winding."""
    v = points[tris]
    return np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0])


def _vertex_normals(n: int, tris: np.ndarray, fn: np.ndarray) -> np.ndarray:
    vn = np.zeros((n, 3))
    for c in range(3):
        np.add.at(vn, tris[:, c], fn)
    norm = np.linalg.norm(vn, axis=1)
    vn[norm > 0] /= norm[norm > 0, None]
    return vn


def _orient_mesh(points, tris, file_normals, closed_check=True):
    """Orient the winding outward and return (triangles, vertex normals).

    With I J K normals in the file the winding is turned to agree with them and the file's normals
    are kept. Otherwise a closed mesh is turned so its signed volume is positive (outward winding);
    an open mesh keeps the winding it has.
    """
    if file_normals is not None:
        # A global sign decision: a spread sample of the triangles votes.
        vote = tris[:: max(1, tris.shape[0] // 20000)]
        if np.einsum("ij,ij->i", face_normals(points, vote),
                     file_normals[vote].sum(axis=1)).sum() < 0:
            tris = tris[:, ::-1].copy()
        return tris, file_normals
    fn = face_normals(points, tris)
    if closed_check and _is_closed(tris):
        v = points[tris] - points.mean(axis=0)
        volume = np.einsum("ij,ij->i", v[:, 0], np.cross(v[:, 1], v[:, 2])).sum() / 6.0
        if volume < 0:
            tris = tris[:, ::-1].copy()
            fn = -fn
    vn = _vertex_normals(points.shape[0], tris, fn)
    # Points used by no triangle get the normal of their nearest used point.
    unused = np.linalg.norm(vn, axis=1) == 0
    if unused.any():
        used = np.flatnonzero(~unused)
        _, j = cKDTree(points[used]).query(points[unused])
        vn[unused] = vn[used[j]]
    return tris, vn


def _is_closed(tris: np.ndarray) -> bool:
    """Every edge is shared by exactly two triangles."""
    e = np.sort(np.concatenate([tris[:, [0, 1]], tris[:, [1, 2]], tris[:, [2, 0]]]), axis=1)
    # One int64 key per undirected edge: a 1-D sort, 6x faster than unique rows.
    key = e[:, 0].astype(np.int64) * (int(tris.max()) + 1) + e[:, 1]
    _, counts = np.unique(key, return_counts=True)
    return bool(np.all(counts == 2))


COPY_PROBE = 64
"""Measured points checked first for being the nominal's own (:func:`copies_nominal`): a
measurement differs from the nominal at once, and only a copy is checked whole."""


def copies_nominal(points: np.ndarray, nominal: Nominal) -> bool:
    """Whether every one of the measured ``points`` (n, 3) is, coordinate for coordinate
    (exactly equal floats), one of the ``nominal``'s points: the nominal's own samples, not a
    measurement of the part. False for no points."""
    points = np.asarray(points, dtype=np.float64)
    if points.shape[0] == 0 or nominal.n == 0:
        return False
    for probe in (points[:COPY_PROBE], points):
        _, near = query(nominal.tree, probe, k=1)
        if not np.array_equal(nominal.points[near], probe):
            return False
        if len(probe) == len(points):
            break
    return True
