"""Compiled inner loops (numba) of the registration's global search and coarse-to-fine ICP: a
measured point paired with its nominal sample in constant time (the SampleLookup grid and walk),
its point-to-quadric residual, the 6 x 6 normal equations and their minimum-norm step, the rigid
update, for many poses at once; plus the spread and distinct-pose helpers of the search.

Per pose these run short, branchy computations: as numpy array chains they are memory-bound and
an order of magnitude slower. Each kernel has a slow, obvious twin in ``tests/naive.py`` or is
checked against analytic results in the tests. Compiled on first use and cached next to this
file (numba ``cache=True``).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from .kernels import dot3


@njit(cache=True, nogil=True, inline="always")
def _squared_distance(P, i, x, y, z):
    """Squared distance from row i of P (n, 3) to the point (x, y, z)."""
    return dot3(P[i, 0] - x, P[i, 1] - y, P[i, 2] - z, P[i, 0] - x, P[i, 1] - y, P[i, 2] - z)


@njit(cache=True, nogil=True, inline="always")
def _cell_index(x, lo, cell, n):
    """The cell of coordinate x along an axis of n cells from lo, clamped (NaN: the first)."""
    f = (x - lo) / cell
    if not f > 0.0:
        return 0
    if f >= n - 1:
        return n - 1
    return int(f)


@njit(cache=True, nogil=True)
def cell_owners(pts, lo, cell, nx, ny, nz):
    """(nx, ny, nz) int32: for each cell of the grid from ``lo`` in cubes of edge ``cell``, a
    sample of ``pts`` (L, 3) near its centre, for ``neighbours.SampleLookup``: each occupied
    cell's sample nearest its centre, then two raster sweeps (forward, backward) in which a
    cell takes the nearer to its centre of its own sample and those of the 13 neighbours the
    sweep has passed (the dead-reckoning distance transform: within about a cell of the nearest
    sample, which the lookup's walk then reaches). Twin: tests/naive.py cell_owners (scipy's
    kd-tree, the nearest sample exactly)."""
    owner = np.full((nx, ny, nz), -1, np.int32)
    best = np.full((nx, ny, nz), np.inf)
    for s in range(pts.shape[0]):
        i = _cell_index(pts[s, 0], lo[0], cell, nx)
        j = _cell_index(pts[s, 1], lo[1], cell, ny)
        k = _cell_index(pts[s, 2], lo[2], cell, nz)
        d = _squared_distance(pts, s, lo[0] + (i + 0.5) * cell, lo[1] + (j + 0.5) * cell,
                              lo[2] + (k + 0.5) * cell)
        if d < best[i, j, k]:
            best[i, j, k], owner[i, j, k] = d, s
    for sweep in range(2):
        step = 1 if sweep == 0 else -1
        for a in range(nx):
            i = a if step == 1 else nx - 1 - a
            for b in range(ny):
                j = b if step == 1 else ny - 1 - b
                for c in range(nz):
                    k = c if step == 1 else nz - 1 - c
                    x = lo[0] + (i + 0.5) * cell
                    y = lo[1] + (j + 0.5) * cell
                    z = lo[2] + (k + 0.5) * cell
                    for di in range(-1, 2):
                        for dj in range(-1, 2):
                            for dk in range(-1, 2):
                                # The 13 neighbours this sweep has passed already.
                                if (di * 9 + dj * 3 + dk) * step >= 0:
                                    continue
                                ii, jj, kk = i + di, j + dj, k + dk
                                if ii < 0 or ii >= nx or jj < 0 or jj >= ny or kk < 0 \
                                        or kk >= nz:
                                    continue
                                o = owner[ii, jj, kk]
                                if o < 0:
                                    continue
                                d = _squared_distance(pts, o, x, y, z)
                                if d < best[i, j, k]:
                                    best[i, j, k], owner[i, j, k] = d, o
    return owner


@njit(cache=True, nogil=True)
def nearest_sample(x, y, z, lo, cell, owner, graph, pts):
    """(sample index, squared distance) paired with the point (x, y, z) by a
    ``neighbours.SampleLookup`` (lo, cell, owner, graph over the samples pts): the owner of the
    point's cell (clamped to the grid), then steps to a graph neighbour nearer the point while
    there is one (the first such in the graph's order). Twin: tests/naive.py nearest_sample."""
    j = owner[_cell_index(x, lo[0], cell, owner.shape[0]),
              _cell_index(y, lo[1], cell, owner.shape[1]),
              _cell_index(z, lo[2], cell, owner.shape[2])]
    d = _squared_distance(pts, j, x, y, z)
    while True:
        best, bd = j, d
        for q in graph[j]:
            dq = _squared_distance(pts, q, x, y, z)
            if dq < bd:
                best, bd = q, dq
        if best == j:
            return j, d
        j, d = best, bd


@njit(cache=True, nogil=True)
def _rotation(wx, wy, wz, R):
    """Rodrigues, as engine.pose.rotation_from_rotvec, into R (3, 3)."""
    theta = math.sqrt(wx * wx + wy * wy + wz * wz)
    if theta < 1e-8:
        s, c = 1.0 - theta ** 2 / 6.0, 0.5 - theta ** 2 / 24.0
    else:
        s, c = math.sin(theta) / theta, (1.0 - math.cos(theta)) / theta ** 2
    # K = skew(w); K @ K = w w^T - |w|^2 I
    R[0, 0] = 1.0 + c * (wx * wx - theta * theta)
    R[1, 1] = 1.0 + c * (wy * wy - theta * theta)
    R[2, 2] = 1.0 + c * (wz * wz - theta * theta)
    R[0, 1] = -s * wz + c * wx * wy
    R[1, 0] = s * wz + c * wx * wy
    R[0, 2] = s * wy + c * wx * wz
    R[2, 0] = -s * wy + c * wx * wz
    R[1, 2] = -s * wx + c * wy * wz
    R[2, 1] = s * wx + c * wy * wz


@njit(cache=True, nogil=True)
def symmetric_eigen(A, w, V):
    """Eigenvalues w (n,) (in no particular order) and unit eigenvectors, the columns of V (n, n),
    of the symmetric A (n, n), which is overwritten: cyclic Jacobi rotations until the
    off-diagonal is below 1e-15 of the diagonal (at most 50 sweeps). For the 6 x 6 pose systems
    of the global search, solved some 10^4 times, where LAPACK's call costs several times the
    work. Twin: numpy.linalg.eigh in tests/test_registration_kernels.py."""
    n = A.shape[0]
    V[:] = 0.0
    for i in range(n):
        V[i, i] = 1.0
    for _ in range(50):
        off = 0.0
        diag = 0.0
        for i in range(n):
            diag += A[i, i] * A[i, i]
            for j in range(i + 1, n):
                off += A[i, j] * A[i, j]
        if off <= 1e-30 * diag or off == 0.0:
            break
        for p in range(n - 1):
            for q in range(p + 1, n):
                apq = A[p, q]
                if apq == 0.0:
                    continue
                theta = (A[q, q] - A[p, p]) / (2.0 * apq)
                t = (1.0 if theta >= 0.0 else -1.0) / (abs(theta) + math.sqrt(theta * theta + 1.0))
                c = 1.0 / math.sqrt(t * t + 1.0)
                s = t * c
                for k in range(n):
                    akp, akq = A[k, p], A[k, q]
                    A[k, p] = c * akp - s * akq
                    A[k, q] = s * akp + c * akq
                for k in range(n):
                    apk, aqk = A[p, k], A[q, k]
                    A[p, k] = c * apk - s * aqk
                    A[q, k] = s * apk + c * aqk
                for k in range(n):
                    vkp, vkq = V[k, p], V[k, q]
                    V[k, p] = c * vkp - s * vkq
                    V[k, q] = s * vkp + c * vkq
    for i in range(n):
        w[i] = A[i, i]


@njit(cache=True, nogil=True)
def _well_conditioned_solve(As, b, inv_len, L, out):
    """_min_norm_step's answer by Cholesky when that is provably the same: when
    trace(As) x trace(As^-1) < 1e6, every eigenvalue of the positive definite As (6, 6) exceeds
    1e-6 of the largest (the largest is below the trace, the smallest above 1 / trace of the
    inverse), so that the minimum-norm solution is the plain one. Returns False (out untouched)
    otherwise: the eigen-decomposition decides which directions to leave alone. L: work (6, 6)."""
    n = 6
    tr = 0.0
    for i in range(n):
        tr += As[i, i]
    L[:] = 0.0
    for j in range(n):
        d = As[j, j]
        for k in range(j):
            d -= L[j, k] * L[j, k]
        if not d > 1e-12 * tr:
            return False
        L[j, j] = math.sqrt(d)
        for i in range(j + 1, n):
            v = As[i, j]
            for k in range(j):
                v -= L[i, k] * L[j, k]
            L[i, j] = v / L[j, j]
    # trace(As^-1) = squared Frobenius norm of L^-1, column by column (forward substitution)
    inv_tr = 0.0
    y = np.empty(n)
    for e in range(n):
        for i in range(n):
            v = 1.0 if i == e else 0.0
            for k in range(i):
                v -= L[i, k] * y[k]
            y[i] = v / L[i, i]
            inv_tr += y[i] * y[i]
    if not tr * inv_tr < 1e6:
        return False
    for i in range(n):
        v = b[i] * (inv_len if i < 3 else 1.0)
        for k in range(i):
            v -= L[i, k] * y[k]
        y[i] = v / L[i, i]
    for i in range(n - 1, -1, -1):
        v = y[i]
        for k in range(i + 1, n):
            v -= L[k, i] * y[k]
        y[i] = v / L[i, i]
    for i in range(n):
        out[i] = -y[i] * (inv_len if i < 3 else 1.0)
    return True


@njit(cache=True, nogil=True)
def _min_norm_step(A, b, length, As, w, V, out):
    """out = -x, x = engine.pose.min_norm_solve(A (6, 6), b (6,), 3, length); As, w, V:
    work arrays (6, 6), (6,), (6, 6)."""
    inv_len = 1.0 / max(length, 1e-12)
    for i in range(6):
        si = inv_len if i < 3 else 1.0
        for j in range(6):
            As[i, j] = A[i, j] * si * (inv_len if j < 3 else 1.0)
    if _well_conditioned_solve(As, b, inv_len, V, out):
        return
    symmetric_eigen(As, w, V)
    top = max(np.max(w), 1e-300)
    for i in range(6):
        out[i] = 0.0
    for e in range(6):
        if w[e] > 1e-6 * top:
            acc = 0.0
            for j in range(6):
                acc += V[j, e] * b[j] * (inv_len if j < 3 else 1.0)
            acc /= w[e]
            for i in range(6):
                out[i] -= V[i, e] * acc
    for i in range(3):
        out[i] *= inv_len


@njit(cache=True, nogil=True)
def _residuals(X, j, far, pts, nrm, shape, by_pair, spacing, r, N, rn, e2):
    """Points X (m, 3) paired with samples pts[j] (m,), none within reach where ``far``: into r
    the residuals, N their directions (the samples' unit normals, curvature-corrected by their
    shape operators when ``shape`` has rows), rn the (second-order) distances along the
    normals, e2 the squared errors (infinite where far). The rows of nrm and shape are the
    samples' (j[i]), or with ``by_pair`` the pairs' (i)."""
    curved = shape.shape[0] > 0
    for i in range(X.shape[0]):
        row = i if by_pair else j[i]
        for a in range(3):
            r[i, a] = X[i, a] - pts[j[i], a]
            N[i, a] = nrm[row, a]
        along = dot3(r[i, 0], r[i, 1], r[i, 2], N[i, 0], N[i, 1], N[i, 2])
        lat2 = max(dot3(r[i, 0], r[i, 1], r[i, 2], r[i, 0], r[i, 1], r[i, 2]) - along * along,
                   0.0)
        if curved:
            q = 0.0
            for a in range(3):
                Sr = shape[row, a, 0] * r[i, 0] + shape[row, a, 1] * r[i, 1] \
                    + shape[row, a, 2] * r[i, 2]
                q += r[i, a] * Sr
                N[i, a] -= Sr
            along -= 0.5 * q
        rn[i] = along
        lat = max(math.sqrt(lat2) - 3.0 * spacing, 0.0)
        e2[i] = math.inf if far[i] else along * along + lat * lat


@njit(cache=True, nogil=True)
def _pair_points(P, src, lo, cell, owner, graph, pts, nrm, shape, spacing, reach, X, j, far,
                 N, r, rn, e2):
    """icp_poses' pairing of the points src at pose P (4, 4): into X the moved points, j their
    samples and far whether those lie beyond ``reach``, and by ``_residuals`` r, N, rn, e2."""
    for i in range(src.shape[0]):
        for a in range(3):
            X[i, a] = P[a, 0] * src[i, 0] + P[a, 1] * src[i, 1] + P[a, 2] * src[i, 2] + P[a, 3]
        j[i], d2 = nearest_sample(X[i, 0], X[i, 1], X[i, 2], lo, cell, owner, graph, pts)
        far[i] = d2 > reach * reach
    _residuals(X, j, far, pts, nrm, shape, False, spacing, r, N, rn, e2)


@njit(cache=True, nogil=True)
def _normal_equations(X, N, r, rn, e2, spacing, reach, lam2, srt, A, b, c, sxx):
    """icp_poses' trimmed least squares of the pairs: A (6, 6), b (6,) about the kept pairs'
    centroid c (3,); returns their RMS distance from it (the rotations' length scale)."""
    m = X.shape[0]
    srt[:] = e2
    srt.sort()
    med = srt[m // 2] if m % 2 else (srt[m // 2 - 1] + srt[m // 2]) / 2.0
    tau = min(max(3.0 * spacing, 2.5 * math.sqrt(med)), reach)
    sw = 0.0
    c[:] = 0.0
    for i in range(m):
        if e2[i] <= tau * tau:
            sw += 1.0
            for a in range(3):
                c[a] += X[i, a]
    norm = max(sw, 1.0)
    c /= norm
    A[:] = 0.0
    b[:] = 0.0
    sxx[:] = 0.0
    J = np.empty(6)
    t = np.empty(3)
    spread = 0.0
    for i in range(m):
        if not e2[i] <= tau * tau:
            continue
        for a in range(3):
            t[a] = X[i, a] - c[a]
        J[0] = t[1] * N[i, 2] - t[2] * N[i, 1]
        J[1] = t[2] * N[i, 0] - t[0] * N[i, 2]
        J[2] = t[0] * N[i, 1] - t[1] * N[i, 0]
        J[3], J[4], J[5] = N[i, 0], N[i, 1], N[i, 2]
        for a in range(6):
            b[a] += J[a] * rn[i]
            for k in range(6):
                A[a, k] += J[a] * J[k]
        spread += t[0] * t[0] + t[1] * t[1] + t[2] * t[2]
        if lam2:
            # Point-to-point term x' - m = r - [t]x w + u; the skew blocks of its normal
            # equations hold sum(t), zero about the centroid.
            for a in range(3):
                for k in range(3):
                    sxx[a, k] += t[a] * t[k]
            b[0] += lam2 * (t[1] * r[i, 2] - t[2] * r[i, 1])
            b[1] += lam2 * (t[2] * r[i, 0] - t[0] * r[i, 2])
            b[2] += lam2 * (t[0] * r[i, 1] - t[1] * r[i, 0])
            for a in range(3):
                b[3 + a] += lam2 * r[i, a]
    if lam2:
        tr = sxx[0, 0] + sxx[1, 1] + sxx[2, 2]
        for a in range(3):
            for k in range(3):
                A[a, k] += lam2 * ((tr if a == k else 0.0) - sxx[a, k])
            A[a + 3, a + 3] += lam2 * sw
    return math.sqrt(spread / norm)


@njit(cache=True, nogil=True)
def _apply_step(P, delta, c, R, Q):
    """P (4, 4) <- [R(delta[:3]), c - R c + delta[3:]] @ P, as engine.pose.compose_updates."""
    _rotation(delta[0], delta[1], delta[2], R)
    for a in range(3):
        ta = c[a] - (R[a, 0] * c[0] + R[a, 1] * c[1] + R[a, 2] * c[2]) + delta[3 + a]
        for k in range(4):
            Q[a, k] = R[a, 0] * P[0, k] + R[a, 1] * P[1, k] + R[a, 2] * P[2, k] \
                + (ta if k == 3 else 0.0)
    Q[3, :] = P[3, :]
    P[:] = Q


@njit(cache=True, nogil=True)
def icp_poses(T, src, lo, cell, owner, graph, pts, nrm, shape, spacing, iterations, lam2,
              reach, first, last, out_T, out_score):
    """The global search's ICP for poses T[first:last] (H, 4, 4) of the points src (m, 3) against
    samples pts (L, 3) with unit normals nrm (L, 3) and shape operators ``shape`` (L, 3, 3; or
    (0, 3, 3): the tangent plane), paired by ``nearest_sample``: ``iterations`` updates, then
    the poses into out_T and their truncated scores into out_score.

    The same computation as engine.registration._icp_batch (which pairs with scipy's kd-tree),
    one pose at a time, without its early stop: the squared error e2 of a point is its
    (second-order) distance along the sample's normal squared plus its sideways distance beyond
    3 spacings squared, infinite when the sample is farther than ``reach``; pairs with e2 above
    max(3 spacings, 2.5 x the pose's median e2^1/2) (at most ``reach``) are left out of the
    point-to-plane (-quadric) least squares, to which ``lam2`` > 0 adds a point-to-point term of
    that weight; the minimum-norm step is applied about the pairs' centroid. The score is the
    mean of min(e2, (3 spacings)^2) one pairing after the last update. Twin: tests/naive.py
    icp_batch paired by tests/naive.py LookupAsTree."""
    m = src.shape[0]
    X, N, r = np.empty((m, 3)), np.empty((m, 3)), np.empty((m, 3))
    rn, e2, srt = np.empty(m), np.empty(m), np.empty(m)
    j, far = np.empty(m, np.int64), np.empty(m, np.bool_)
    A, As, EV, sxx = np.empty((6, 6)), np.empty((6, 6)), np.empty((6, 6)), np.empty((3, 3))
    b, ev, delta, c = np.empty(6), np.empty(6), np.empty(6), np.empty(3)
    R, Q = np.empty((3, 3)), np.empty((4, 4))
    for h in range(first, last):
        P = T[h].copy()
        for k in range(iterations + 1):
            _pair_points(P, src, lo, cell, owner, graph, pts, nrm, shape, spacing, reach, X, j,
                         far, N, r, rn, e2)
            if k == iterations:
                break
            length = _normal_equations(X, N, r, rn, e2, spacing, reach, lam2, srt, A, b, c,
                                       sxx)
            _min_norm_step(A, b, length, As, ev, EV, delta)
            _apply_step(P, delta, c, R, Q)
        total = 0.0
        for i in range(m):
            total += min(e2[i], (3.0 * spacing) ** 2)
        out_score[h] = total / m
        out_T[h] = P


@njit(cache=True, nogil=True)
def farthest_points(P, centre, m):
    """Farthest-point sampling of m indices of the points P (n, 3): first the point nearest to
    ``centre`` (3,), then each time the point farthest from those chosen (the first of equals).
    Twin: tests/naive.py farthest_points."""
    n = P.shape[0]
    chosen = np.empty(m, np.int64)
    d = np.full(n, math.inf)  # distance to the nearest point chosen
    far, fd = 0, math.inf
    for i in range(n):
        e = math.sqrt(_squared_distance(P, i, centre[0], centre[1], centre[2]))
        if e < fd:
            far, fd = i, e
    for k in range(m):
        if k:
            far, fd = 0, -1.0
            for i in range(n):
                if d[i] > fd:
                    far, fd = i, d[i]
        chosen[k] = far
        for i in range(n):
            d[i] = min(d[i], math.sqrt(_squared_distance(P, i, P[far, 0], P[far, 1], P[far, 2])))
    return chosen


@njit(cache=True, nogil=True)
def distinct_first(feat, tol, keep):
    """Greedy pick over poses given best first by where they put a few points, feat (H, R, 3):
    a pose is kept unless some kept one puts every point within ``tol`` of it; at most ``keep``.
    Returns the kept positions (in feat's order). Twin: tests/naive.py distinct_first."""
    H, R = feat.shape[0], feat.shape[1]
    kept = np.empty(min(keep, H), np.int64)
    nk = 0
    for i in range(H):
        if nk >= keep:
            break
        duplicate = False
        for q in range(nk):
            gap = 0.0
            for k in range(R):
                a, b = feat[kept[q], k], feat[i, k]
                gap = max(gap, math.sqrt(dot3(a[0] - b[0], a[1] - b[1], a[2] - b[2],
                                              a[0] - b[0], a[1] - b[1], a[2] - b[2])))
            if gap <= tol:
                duplicate = True
                break
        if not duplicate:
            kept[nk] = i
            nk += 1
    return kept[:nk]


@njit(cache=True, nogil=True)
def shape_fit(N, dx, dn, S):
    """Per point i, the shape operator S[i] (3, 3) of Nominal.shape_operators from its unit
    normal N[i] and its k neighbours' offsets dx[i] (k, 3) and normal changes dn[i] (k, 3): the
    symmetric tangent curvature fitted to -dn = S dx by least squares (lightly regularised),
    zero where it bends by more than 0.3 over the neighbours' median tangent reach or a
    neighbour's normal turns by more than 0.3. Twin: tests/naive.py shape_operators."""
    m, k = dx.shape[0], dx.shape[1]
    reach = np.empty(k)
    for i in range(m):
        nx, ny, nz = N[i, 0], N[i, 1], N[i, 2]
        hx, hy, hz = (1.0, 0.0, 0.0) if abs(nx) < 0.9 else (0.0, 1.0, 0.0)
        ax, ay, az = ny * hz - nz * hy, nz * hx - nx * hz, nx * hy - ny * hx
        length = math.sqrt(ax * ax + ay * ay + az * az)
        if not length > 0.0:  # no normal: the tangent plane
            S[i] = 0.0
            continue
        ax, ay, az = ax / length, ay / length, az / length
        bx, by, bz = ny * az - nz * ay, nz * ax - nx * az, nx * ay - ny * ax
        s11 = s12 = s22 = r1 = r2 = r3 = turn = 0.0
        for j in range(k):
            u1 = dot3(dx[i, j, 0], dx[i, j, 1], dx[i, j, 2], ax, ay, az)
            u2 = dot3(dx[i, j, 0], dx[i, j, 1], dx[i, j, 2], bx, by, bz)
            g1 = dot3(dn[i, j, 0], dn[i, j, 1], dn[i, j, 2], ax, ay, az)
            g2 = dot3(dn[i, j, 0], dn[i, j, 1], dn[i, j, 2], bx, by, bz)
            s11 += u1 * u1
            s12 += u1 * u2
            s22 += u2 * u2
            r1 -= g1 * u1
            r2 -= g1 * u2 + g2 * u1
            r3 -= g2 * u2
            reach[j] = math.sqrt(u1 * u1 + u2 * u2)
            turn = max(turn, math.sqrt(dot3(dn[i, j, 0], dn[i, j, 1], dn[i, j, 2],
                                            dn[i, j, 0], dn[i, j, 1], dn[i, j, 2])))
        # A = [[s11, s12, 0], [s12, s11 + s22, s12], [0, s12, s22]] + eps I; Cramer's rule.
        eps = 1e-9 * (2.0 * (s11 + s22)) + 1e-300
        a11, a22, a33 = s11 + eps, s11 + s22 + eps, s22 + eps
        det = a11 * (a22 * a33 - s12 * s12) - s12 * (s12 * a33)
        if not det > 0.0:
            # Coincident neighbours (a pole row, points stored twice): det underflows to 0 and
            # nothing measures the curvature; the tangent plane.
            S[i] = 0.0
            continue
        k11 = (r1 * (a22 * a33 - s12 * s12) - s12 * (r2 * a33 - s12 * r3)) / det
        k12 = (a11 * (r2 * a33 - s12 * r3) - r1 * (s12 * a33)) / det
        k22 = (a11 * (a22 * r3 - s12 * r2) - s12 * (s12 * r3 - r2 * 0.0) + r1 * (s12 * s12)) / det
        reach.sort()
        mid = reach[k // 2] if k % 2 else 0.5 * (reach[k // 2 - 1] + reach[k // 2])
        kmax = abs(0.5 * (k11 + k22)) + math.sqrt(0.25 * (k11 - k22) ** 2 + k12 * k12)
        flat = not (kmax * mid <= 0.3 and turn <= 0.3)  # also where it overflowed (NaN)
        e = ((ax, ay, az), (bx, by, bz))
        for p in range(3):
            for q in range(3):
                S[i, p, q] = 0.0 if flat else (k11 * e[0][p] * e[0][q]
                                               + k12 * (e[0][p] * e[1][q] + e[1][p] * e[0][q])
                                               + k22 * e[1][p] * e[1][q])


@njit(cache=True, nogil=True)
def icp_paired(T, X, j, far, pts, nrm, shape, spacing, lam2, reach, update, out_T, out_e2,
               out_delta):
    """One iteration of engine.registration._icp_batch for poses T (H, 4, 4) whose points X
    (H, m, 3) are paired with samples j (H, m) of pts (L, 3) (scipy's kd-tree; ``far`` (H, m):
    none within reach), with unit normals nrm (H, m, 3) and shape operators ``shape``
    (H, m, 3, 3; or (0, m, 3, 3): the tangent plane) of those samples: the squared errors into
    out_e2 (H, m) and, with ``update``, the updated poses into out_T and the steps
    [rotation vector, translation] into out_delta (H, 6). The arithmetic is icp_poses'. Twin:
    tests/naive.py icp_batch."""
    H, m = X.shape[0], X.shape[1]
    N, r, rn, srt = np.empty((m, 3)), np.empty((m, 3)), np.empty(m), np.empty(m)
    A, As, EV, sxx = np.empty((6, 6)), np.empty((6, 6)), np.empty((6, 6)), np.empty((3, 3))
    b, ev, c = np.empty(6), np.empty(6), np.empty(3)
    R, Q = np.empty((3, 3)), np.empty((4, 4))
    no_shape = np.empty((0, 3, 3))
    for h in range(H):
        Xh, e2 = X[h], out_e2[h]
        Sh = shape[h] if shape.shape[0] > 0 else no_shape
        _residuals(Xh, j[h], far[h], pts, nrm[h], Sh, True, spacing, r, N, rn, e2)
        if not update:
            continue
        length = _normal_equations(Xh, N, r, rn, e2, spacing, reach, lam2, srt, A, b, c, sxx)
        _min_norm_step(A, b, length, As, ev, EV, out_delta[h])
        P = T[h].copy()
        _apply_step(P, out_delta[h], c, R, Q)
        out_T[h] = P
