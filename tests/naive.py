"""Slow, obvious twins of the fast kernels; used only to check them."""

from __future__ import annotations

import math

import numpy as np


def closest_point_on_segment(p, a, b):
    ab = [b[i] - a[i] for i in range(3)]
    L2 = sum(c * c for c in ab)
    if L2 == 0.0:
        return list(a)
    t = sum((p[i] - a[i]) * ab[i] for i in range(3)) / L2
    t = min(1.0, max(0.0, t))
    return [a[i] + t * ab[i] for i in range(3)]


def closest_point_on_triangle(p, a, b, c):
    """Project onto the plane; keep the projection if it is inside (same-side tests), else the
    nearest of the three edges."""
    p, a, b, c = (np.asarray(v, float) for v in (p, a, b, c))
    n = np.cross(b - a, c - a)
    nn = float(n @ n)
    best = None
    if nn > 1e-24 * max(float((b - a) @ (b - a)) * float((c - a) @ (c - a)), 1e-300):
        q = p - ((p - a) @ n) / nn * n
        inside = all(np.cross(v1 - v0, q - v0) @ n >= 0 for v0, v1 in ((a, b), (b, c), (c, a)))
        if inside:
            best = q
    if best is None:
        cands = [np.asarray(closest_point_on_segment(p, s0, s1)) for s0, s1 in ((a, b), (b, c), (c, a))]
        best = min(cands, key=lambda q: float((p - q) @ (p - q)))
    return best


def distance_to_mesh(p, points, triangles):
    """Unsigned distance from p to a triangle mesh: every triangle tried, by the rule of
    :func:`closest_point_on_triangle` written over all triangles at once (projection onto each
    plane where it falls inside by the same-side tests, else the nearest point of the three
    edges)."""
    p = np.asarray(p, float)
    a, b, c = (np.asarray(points, float)[np.asarray(triangles)[:, i]] for i in range(3))
    n = np.cross(b - a, c - a)
    nn = np.einsum("ij,ij->i", n, n)
    scale = np.einsum("ij,ij->i", b - a, b - a) * np.einsum("ij,ij->i", c - a, c - a)
    flat = nn > 1e-24 * np.maximum(scale, 1e-300)
    h = np.einsum("ij,ij->i", p - a, n) / np.where(flat, nn, 1.0)
    q = p - h[:, None] * n
    inside = flat.copy()
    for v0, v1 in ((a, b), (b, c), (c, a)):
        inside &= np.einsum("ij,ij->i", np.cross(v1 - v0, q - v0), n) >= 0
    d2 = np.where(inside, np.einsum("ij,ij->i", p - q, p - q), np.inf)
    for s0, s1 in ((a, b), (b, c), (c, a)):
        e = s1 - s0
        L2 = np.einsum("ij,ij->i", e, e)
        t = np.clip(np.einsum("ij,ij->i", p - s0, e) / np.where(L2 > 0, L2, 1.0), 0.0, 1.0)
        r = p - (s0 + t[:, None] * e)
        d2 = np.minimum(d2, np.where(inside, np.inf, np.einsum("ij,ij->i", r, r)))
    return float(np.sqrt(d2.min()))


def boxes_nearer(p, boxes, limit, done):
    """Slow twin of engine.kernels.boxes_nearer: the set of (point, box number 1-based) pairs
    whose box is nearer than limit[i] to p[i], minus the pairs in ``done``."""
    out = set()
    for i in range(len(p)):
        for f in range(len(boxes)):
            gap = [max(boxes[f][0][a] - p[i][a], p[i][a] - boxes[f][1][a], 0.0) for a in range(3)]
            if (gap[0] ** 2 + gap[1] ** 2 + gap[2] ** 2) ** 0.5 < limit[i]:
                out.add((i, f + 1))
    return out - {tuple(d) for d in done}


def cell_owners(pts, lo, cell, shape):
    """Each grid cell's sample nearest its centre, exactly (scipy's kd-tree): the twin of
    engine.icp_kernels.cell_owners (which is within about a cell of it)."""
    from scipy.spatial import cKDTree

    axes = [lo[i] + cell * (np.arange(shape[i]) + 0.5) for i in range(3)]
    centres = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    return cKDTree(pts).query(centres)[1].reshape(shape), centres.reshape(*shape, 3)


def nearest_sample(p, lookup, pts):
    """Slow twin of engine.icp_kernels.nearest_sample: (sample, squared distance) -- the owner of the
    point's cell (clamped to the grid), then the first nearer graph neighbour while there is
    one."""
    cell = []
    for a in range(3):
        f = (p[a] - lookup.lo[a]) / lookup.cell
        n = lookup.owner.shape[a]
        cell.append(0 if not f > 0.0 else n - 1 if f >= n - 1 else int(f))
    j = int(lookup.owner[tuple(cell)])
    d = sum((p[a] - pts[j][a]) ** 2 for a in range(3))
    while True:
        best, bd = j, d
        for q in lookup.graph[j]:
            dq = sum((p[a] - pts[q][a]) ** 2 for a in range(3))
            if dq < bd:
                best, bd = int(q), dq
        if best == j:
            return j, d
        j, d = best, bd


class LookupAsTree:
    """A kd-tree stand-in whose ``query`` pairs by ``nearest_sample`` above: run through the numpy
    ICP below (icp_batch), it is the twin of the compiled one that pairs so
    (engine.registration._icp_poses)."""

    def __init__(self, lookup, pts):
        self.lookup, self.pts = lookup, np.asarray(pts)

    def query(self, X, workers=1, distance_upper_bound=np.inf):
        found = [nearest_sample(x, self.lookup, self.pts) for x in np.asarray(X)]
        j = np.array([f[0] for f in found], np.int64)
        d = np.sqrt(np.array([f[1] for f in found]))
        far = d > distance_upper_bound
        return np.where(far, np.inf, d), np.where(far, len(self.pts), j)


def farthest_points(P, centre, m):
    """Slow twin of engine.icp_kernels.farthest_points."""
    d0 = [math.dist(p, centre) for p in P]
    chosen = [d0.index(min(d0))]
    d = [math.dist(p, P[chosen[0]]) for p in P]
    while len(chosen) < m:
        far = d.index(max(d))
        chosen.append(far)
        d = [min(d[i], math.dist(P[i], P[far])) for i in range(len(P))]
    return chosen


def distinct_first(feat, tol, keep):
    """Slow twin of engine.icp_kernels.distinct_first."""
    kept = []
    for i in range(len(feat)):
        if len(kept) < keep and all(
                max(math.dist(a, b) for a, b in zip(feat[q], feat[i])) > tol for q in kept):
            kept.append(i)
    return kept


def shape_operators(n, dx, dn):
    """Slow twin of engine.icp_kernels.shape_fit (numpy over all points at once, LAPACK's solve): the
    shape operators (m, 3, 3) from unit normals n (m, 3), neighbour offsets dx (m, k, 3) and
    normal changes dn (m, k, 3)."""
    helper = np.where(np.abs(n[:, :1]) < 0.9, np.array([[1.0, 0, 0]]), np.array([[0, 1.0, 0]]))
    e1 = np.cross(n, helper)
    e1 /= np.linalg.norm(e1, axis=1, keepdims=True)
    e2 = np.cross(n, e1)
    u1, u2 = np.einsum("mkj,mj->mk", dx, e1), np.einsum("mkj,mj->mk", dx, e2)
    g1, g2 = np.einsum("mkj,mj->mk", dn, e1), np.einsum("mkj,mj->mk", dn, e2)
    # Least squares for symmetric K (k11, k12, k22) in  -g1 = k11 u1 + k12 u2,
    # -g2 = k12 u1 + k22 u2.
    A = np.zeros((n.shape[0], 3, 3))
    A[:, 0, 0] = np.sum(u1 * u1, 1)
    A[:, 0, 1] = A[:, 1, 0] = np.sum(u1 * u2, 1)
    A[:, 1, 1] = np.sum(u2 * u2 + u1 * u1, 1)
    A[:, 1, 2] = A[:, 2, 1] = np.sum(u1 * u2, 1)
    A[:, 2, 2] = np.sum(u2 * u2, 1)
    rhs = -np.stack([np.sum(g1 * u1, 1), np.sum(g1 * u2 + g2 * u1, 1), np.sum(g2 * u2, 1)], 1)
    tr = np.trace(A, axis1=1, axis2=2)
    kk = np.linalg.solve(A + (1e-9 * tr + 1e-300)[:, None, None] * np.eye(3),
                         rhs[..., None])[..., 0]
    S = (kk[:, 0, None, None] * np.einsum("mi,mj->mij", e1, e1)
         + kk[:, 1, None, None] * (np.einsum("mi,mj->mij", e1, e2)
                                   + np.einsum("mi,mj->mij", e2, e1))
         + kk[:, 2, None, None] * np.einsum("mi,mj->mij", e2, e2))
    reach = np.median(np.sqrt(u1 * u1 + u2 * u2), axis=1)
    kmax = np.abs(0.5 * (kk[:, 0] + kk[:, 2])) + np.sqrt(0.25 * (kk[:, 0] - kk[:, 2]) ** 2
                                                          + kk[:, 1] ** 2)
    turn = np.max(np.linalg.norm(dn, axis=2), axis=1)
    S[(kmax * reach > 0.3) | (turn > 0.3)] = 0.0
    return S


def icp_batch(T, src, tree, pts, nrm, spacing, iterations, stop_rad=0.0, lam2=0.0,
              reach=np.inf, shape=None):
    """Slow twin of engine.registration._icp_batch and of the compiled ICP kernels
    (icp_kernels.icp_paired, icp_kernels.icp_poses): the same ICP in numpy over all poses at once, LAPACK
    for the steps; pairing by ``tree.query`` (scipy's kd-tree, or LookupAsTree). Returns (poses,
    truncated scores, iterations run)."""
    from engine.pose import skew
    from engine.pose import compose_updates, min_norm_solve

    def pairs(T):
        H, m = T.shape[0], src.shape[0]
        X = src @ T[:, :3, :3].transpose(0, 2, 1) + T[:, None, :3, 3]
        dist, j = tree.query(X.reshape(-1, 3), distance_upper_bound=reach)
        far = ~np.isfinite(dist).reshape(H, m)
        j = np.minimum(j, pts.shape[0] - 1).reshape(H, m)
        mp, n = pts[j], (nrm(j) if callable(nrm) else nrm[j])
        r = X - mp
        rn = np.sum(r * n, axis=2)
        lat2 = np.maximum(np.sum(r * r, axis=2) - rn * rn, 0.0)
        if shape is not None:
            Sr = np.einsum("hmij,hmj->hmi", shape[j], r)
            rn = rn - 0.5 * np.sum(r * Sr, axis=2)
            n = n - Sr
        lat = np.maximum(np.sqrt(lat2) - 3 * spacing, 0.0)
        return X, r, rn, n, np.where(far, np.inf, rn * rn + lat * lat)

    def step(X, r, rn, n, e2):
        H = X.shape[0]
        tau = np.minimum(np.maximum(3 * spacing, 2.5 * np.sqrt(np.median(e2, axis=1))), reach)
        w = (e2 <= (tau * tau)[:, None]).astype(np.float64)
        sw = w.sum(1)
        c = (w[..., None] * X).sum(1) / np.maximum(sw, 1.0)[:, None]
        xt = X - c[:, None, :]
        Jp = np.concatenate([np.cross(xt, n), n], axis=2)
        Jw = Jp * w[..., None]
        A = Jw.transpose(0, 2, 1) @ Jp
        b = (Jw * rn[..., None]).sum(1)
        if lam2:
            xw = xt * w[..., None]
            sx = xw.sum(1)
            sxx = xw.transpose(0, 2, 1) @ xt
            A_pp = np.zeros((H, 6, 6))
            A_pp[:, :3, :3] = np.trace(sxx, axis1=1, axis2=2)[:, None, None] * np.eye(3) - sxx
            A_pp[:, :3, 3:] = skew(sx)
            A_pp[:, 3:, :3] = np.transpose(A_pp[:, :3, 3:], (0, 2, 1))
            A_pp[:, 3:, 3:] = sw[:, None, None] * np.eye(3)
            b_pp = np.concatenate([np.cross(xw, r).sum(1), (r * w[..., None]).sum(1)], axis=1)
            A = A + lam2 * A_pp
            b = b + lam2 * b_pp
        length = np.sqrt((w * np.sum(xt * xt, axis=2)).sum(1) / np.maximum(sw, 1.0))
        return -min_norm_solve(A, b, 3, length), c

    done = 0
    for k in range(iterations + 1):
        X, r, rn, n, e2 = pairs(T)
        if k == iterations:
            break
        delta, c = step(X, r, rn, n, e2)
        T = compose_updates(T, delta, c)
        done += 1
        if stop_rad and np.all(np.linalg.norm(delta[:, :3], axis=1) < stop_rad) and \
                np.all(np.linalg.norm(delta[:, 3:], axis=1) < stop_rad * 100 * spacing):
            X, r, rn, n, e2 = pairs(T)
            break
    return T, np.mean(np.minimum(e2, (3 * spacing) ** 2), axis=1), done


def grid_triangles(points, nu, nv):
    """Slow twin of engine.kernels.grid_triangles (numpy, in cache-sized bands of rows): the
    grid's triangles of non-zero area."""
    C = [np.ascontiguousarray(points[:, k]).reshape(nv, nu) for k in range(3)]
    m = (nv - 1) * (nu - 1)
    use1 = np.empty((nv - 1, nu - 1), dtype=bool)
    ok = np.empty((2, nv - 1, nu - 1), dtype=bool)
    rows = max(1, 32768 // nu)  # cache-sized bands of cell rows
    for r0 in range(0, nv - 1, rows):
        r1 = min(r0 + rows, nv - 1)
        # Per coordinate, the four corner arrays of the band's cells.
        p00 = [c[r0:r1, :-1] for c in C]
        p10 = [c[r0:r1, 1:] for c in C]
        p01 = [c[r0 + 1:r1 + 1, :-1] for c in C]
        p11 = [c[r0 + 1:r1 + 1, 1:] for c in C]
        u = sum((a - b) ** 2 for a, b in zip(p00, p11)) <= sum((a - b) ** 2
                                                                for a, b in zip(p10, p01))
        use1[r0:r1] = u
        third = [np.where(u, a, b) for a, b in zip(p11, p01)]   # triangle 1: v00 v10 (v11|v01)
        first = [np.where(u, a, b) for a, b in zip(p00, p10)]   # triangle 2: (v00|v10) v11 v01
        ok[0, r0:r1] = nonzero_area_xyz(p00, p10, third)
        ok[1, r0:r1] = nonzero_area_xyz(first, p11, p01)
    use1 = use1.ravel()
    j, i = np.divmod(np.arange(m, dtype=np.int64), nu - 1)
    v00 = j * nu + i
    tris = np.empty((2 * m, 3), dtype=np.int64)
    tris[:m, 0] = v00
    tris[:m, 1] = v00 + 1
    tris[:m, 2] = np.where(use1, v00 + nu + 1, v00 + nu)
    tris[m:, 0] = np.where(use1, v00, v00 + 1)
    tris[m:, 1] = v00 + nu + 1
    tris[m:, 2] = v00 + nu
    ok = ok.reshape(-1)
    return tris if ok.all() else tris[ok]


def nonzero_area_xyz(a, b, c):
    """Slow twin of engine.kernels._nonzero_area (numpy): non-zero area for triangles given as
    per-coordinate arrays [x, y, z] of their corners."""
    e1 = [bb - aa for aa, bb in zip(a, b)]
    e2 = [cc - aa for aa, cc in zip(a, c)]
    cx = e1[1] * e2[2] - e1[2] * e2[1]
    cy = e1[2] * e2[0] - e1[0] * e2[2]
    cz = e1[0] * e2[1] - e1[1] * e2[0]
    area2sq = cx * cx + cy * cy + cz * cz
    scale = np.maximum(sum(e * e for e in e1), sum(e * e for e in e2))
    return area2sq > 1e-24 * np.maximum(scale, 1e-300) ** 2


def plane_cut_segments(points, triangles, origin, normal):
    """The plane's cut of a triangle mesh, one triangle at a time in plain Python: for each
    triangle, the points where its edges cross the plane (a vertex on the plane counts as
    above it), each edge's crossing computed from its lower-numbered vertex. Returns a list of
    segments ((x, y, z), (x, y, z))."""
    o = [float(c) for c in origin]
    n = [float(c) for c in normal]
    P = [[float(c) for c in p] for p in points]
    d = [sum((p[i] - o[i]) * n[i] for i in range(3)) for p in P]
    out = []
    for tri in triangles:
        ends = []
        for k in range(3):
            a, b = int(tri[k]), int(tri[(k + 1) % 3])
            if (d[a] >= 0) == (d[b] >= 0):
                continue
            lo, hi = min(a, b), max(a, b)
            t = d[lo] / (d[lo] - d[hi])
            ends.append(tuple(P[lo][i] + t * (P[hi][i] - P[lo][i]) for i in range(3)))
        if len(ends) == 2:
            out.append((ends[0], ends[1]))
    return out


def radial_extremes(X, kind: str, starts) -> float:
    """The minimum-zone radial separation ("zone": two coaxial cylinders, or circles for 2D
    points), the smallest circumscribed ("outer") or largest inscribed ("inner") diameter of
    points X about an axis near z: the epigraph program (zone or radius bounding every point's
    exact distance from the axis) solved by SLSQP from each of ``starts`` (x, y at the points'
    mean height, and in 3D the axis's tilts dx, dz / dy, dz), the best kept. An optimiser of
    smooth constraints on the exact distances: independent of the engine's linear programs."""
    from scipy.optimize import minimize

    X = np.asarray(X, float)
    z0 = X[:, 2].mean() if X.shape[1] == 3 else 0.0

    def rho(p):
        if X.shape[1] == 2:
            return np.linalg.norm(X - p[:2], axis=1)
        d = np.array([p[2], p[3], 1.0]) / math.sqrt(p[2] ** 2 + p[3] ** 2 + 1.0)
        w = X - np.array([p[0], p[1], z0])
        return np.linalg.norm(w - np.outer(w @ d, d), axis=1)

    k = 2 if X.shape[1] == 2 else 4
    best = math.inf
    for s in starts:
        s = np.asarray(s, float)[:k]
        r = rho(s)
        # Variables: the axis (k), then the two radii (lo, hi); "outer" minimises hi, "inner"
        # maximises lo, "zone" minimises hi - lo.
        x0 = np.concatenate([s, [r.min(), r.max()]])
        goal = {"zone": lambda x: x[k + 1] - x[k], "outer": lambda x: x[k + 1],
                "inner": lambda x: -x[k]}[kind]
        cons = [{"type": "ineq", "fun": lambda x: rho(x[:k]) - x[k]},
                {"type": "ineq", "fun": lambda x: x[k + 1] - rho(x[:k])}]
        got = minimize(goal, x0, method="SLSQP", constraints=cons,
                       options={"ftol": 1e-16, "maxiter": 1000})
        r = rho(got.x[:k])  # the program's answer, read off the exact distances
        value = {"zone": r.max() - r.min(), "outer": 2 * r.max(), "inner": -2 * r.min()}[kind]
        best = min(best, float(value))
    return abs(best)


def rigid_motion(X, M) -> np.ndarray:
    """The 4x4 rigid motion taking the points X (n, 3) onto M (Kabsch: the least-squares
    rotation by SVD, no reflection)."""
    cm, cx = M.mean(axis=0), X.mean(axis=0)
    U, _, Vt = np.linalg.svd((M - cm).T @ (X - cx))
    R = U @ np.diag([1.0, 1.0, np.linalg.det(U @ Vt)]) @ Vt
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, cm - R @ cx
    return T
