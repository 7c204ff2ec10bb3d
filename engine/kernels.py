"""Compiled inner loops (numba) of the deviation measurement and the nominal's construction (the
registration's ICP is engine.icp_kernels).

Per measured point these run a short, branchy computation (which triangle of a star is nearest,
which Voronoi region of that triangle holds the foot point, a few Phong iterations; a pairing, a
residual and a 6 x 6 step per ICP pose): as numpy array chains they are memory-bound and an
order of magnitude slower. Each kernel has a slow,
obvious twin in ``tests/naive.py`` or is checked against analytic geometry in the tests.

Compiled on first use and cached next to this file (numba ``cache=True``).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True, nogil=True, inline="always")
def dot3(ax, ay, az, bx, by, bz):
    return ax * bx + ay * by + az * bz


@njit(cache=True, nogil=True)
def _segment_t(px, py, pz, ax, ay, az, bx, by, bz):
    ex, ey, ez = bx - ax, by - ay, bz - az
    den = dot3(ex, ey, ez, ex, ey, ez)
    if den <= 0.0:
        return 0.0
    t = dot3(px - ax, py - ay, pz - az, ex, ey, ez) / den
    return min(1.0, max(0.0, t))


@njit(cache=True, nogil=True)
def closest_bary(px, py, pz, ax, ay, az, bx, by, bz, cx, cy, cz):
    """Barycentrics (u, v, w) of the closest point to p on the solid triangle a b c.

    Ericson's Voronoi-region tests; a zero-area triangle reduces to the nearest of its edges.
    """
    abx, aby, abz = bx - ax, by - ay, bz - az
    acx, acy, acz = cx - ax, cy - ay, cz - az
    ab2 = dot3(abx, aby, abz, abx, aby, abz)
    ac2 = dot3(acx, acy, acz, acx, acy, acz)
    abac = dot3(abx, aby, abz, acx, acy, acz)
    if ab2 * ac2 - abac * abac <= 1e-12 * max(ab2 * ac2, 1e-300):
        best = np.inf
        u = v = w = 0.0
        for e in range(3):
            if e == 0:
                t = _segment_t(px, py, pz, ax, ay, az, bx, by, bz)
                qx, qy, qz = ax + t * (bx - ax), ay + t * (by - ay), az + t * (bz - az)
            elif e == 1:
                t = _segment_t(px, py, pz, bx, by, bz, cx, cy, cz)
                qx, qy, qz = bx + t * (cx - bx), by + t * (cy - by), bz + t * (cz - bz)
            else:
                t = _segment_t(px, py, pz, cx, cy, cz, ax, ay, az)
                qx, qy, qz = cx + t * (ax - cx), cy + t * (ay - cy), cz + t * (az - cz)
            d = dot3(px - qx, py - qy, pz - qz, px - qx, py - qy, pz - qz)
            if d < best:
                best = d
                if e == 0:
                    u, v, w = 1.0 - t, t, 0.0
                elif e == 1:
                    u, v, w = 0.0, 1.0 - t, t
                else:
                    u, v, w = t, 0.0, 1.0 - t
        return u, v, w
    apx, apy, apz = px - ax, py - ay, pz - az
    d1 = dot3(abx, aby, abz, apx, apy, apz)
    d2 = dot3(acx, acy, acz, apx, apy, apz)
    if d1 <= 0.0 and d2 <= 0.0:
        return 1.0, 0.0, 0.0
    bpx, bpy, bpz = px - bx, py - by, pz - bz
    d3 = dot3(abx, aby, abz, bpx, bpy, bpz)
    d4 = dot3(acx, acy, acz, bpx, bpy, bpz)
    if d3 >= 0.0 and d4 <= d3:
        return 0.0, 1.0, 0.0
    vc = d1 * d4 - d3 * d2
    if vc <= 0.0 and d1 >= 0.0 and d3 <= 0.0:
        t = d1 / (d1 - d3)
        return 1.0 - t, t, 0.0
    cpx, cpy, cpz = px - cx, py - cy, pz - cz
    d5 = dot3(abx, aby, abz, cpx, cpy, cpz)
    d6 = dot3(acx, acy, acz, cpx, cpy, cpz)
    if d6 >= 0.0 and d5 <= d6:
        return 0.0, 0.0, 1.0
    vb = d5 * d2 - d1 * d6
    if vb <= 0.0 and d2 >= 0.0 and d6 <= 0.0:
        t = d2 / (d2 - d6)
        return 1.0 - t, 0.0, t
    va = d3 * d6 - d5 * d4
    if va <= 0.0 and (d4 - d3) >= 0.0 and (d5 - d6) >= 0.0:
        t = (d4 - d3) / ((d4 - d3) + (d5 - d6))
        return 0.0, 1.0 - t, t
    den = 1.0 / (va + vb + vc)
    v = vb * den
    w = vc * den
    return 1.0 - v - w, v, w


@njit(cache=True, nogil=True)
def closest_bary_batch(p, a, b, c, out):
    """Row-wise :func:`closest_bary`: p, a, b, c (n, 3) → out (n, 3)."""
    for i in range(p.shape[0]):
        u, v, w = closest_bary(p[i, 0], p[i, 1], p[i, 2], a[i, 0], a[i, 1], a[i, 2],
                               b[i, 0], b[i, 1], b[i, 2], c[i, 0], c[i, 1], c[i, 2])
        out[i, 0] = u
        out[i, 1] = v
        out[i, 2] = w


@njit(cache=True, nogil=True)
def best_in_stars(pts, rows, samples, star_ptr, star_tri, triangles, points,
                  best_tri, best_d2, best_bary):
    """For each query ``rows[k]``, try every triangle around sample point ``samples[k]``.

    Keeps, per query, the nearest triangle seen so far in ``best_tri`` / ``best_d2`` (squared
    distance) / ``best_bary`` (initialise best_d2 to inf before the first call); a sample of -1
    is skipped.
    """
    for k in range(rows.shape[0]):
        i = rows[k]
        s = samples[k]
        if s < 0:
            continue
        px, py, pz = pts[i, 0], pts[i, 1], pts[i, 2]
        for j in range(star_ptr[s], star_ptr[s + 1]):
            t = star_tri[j]
            a, b, c = triangles[t, 0], triangles[t, 1], triangles[t, 2]
            u, v, w = closest_bary(px, py, pz, points[a, 0], points[a, 1], points[a, 2],
                                   points[b, 0], points[b, 1], points[b, 2],
                                   points[c, 0], points[c, 1], points[c, 2])
            qx = u * points[a, 0] + v * points[b, 0] + w * points[c, 0]
            qy = u * points[a, 1] + v * points[b, 1] + w * points[c, 1]
            qz = u * points[a, 2] + v * points[b, 2] + w * points[c, 2]
            d2 = dot3(px - qx, py - qy, pz - qz, px - qx, py - qy, pz - qz)
            if d2 < best_d2[i]:
                best_d2[i] = d2
                best_tri[i] = t
                best_bary[i, 0] = u
                best_bary[i, 1] = v
                best_bary[i, 2] = w


@njit(cache=True, nogil=True)
def _phong(V, N, b0, b1, b2, fnx, fny, fnz):
    """Phong surface (shape factor 1/2) point, unit normal and flat point at barycentrics."""
    qx = b0 * V[0, 0] + b1 * V[1, 0] + b2 * V[2, 0]
    qy = b0 * V[0, 1] + b1 * V[1, 1] + b2 * V[2, 1]
    qz = b0 * V[0, 2] + b1 * V[1, 2] + b2 * V[2, 2]
    sx, sy, sz = qx, qy, qz
    nx = ny = nz = 0.0
    bb = (b0, b1, b2)
    for i in range(3):
        h = dot3(V[i, 0] - qx, V[i, 1] - qy, V[i, 2] - qz, N[i, 0], N[i, 1], N[i, 2])
        sx += 0.5 * bb[i] * h * N[i, 0]
        sy += 0.5 * bb[i] * h * N[i, 1]
        sz += 0.5 * bb[i] * h * N[i, 2]
        nx += bb[i] * N[i, 0]
        ny += bb[i] * N[i, 1]
        nz += bb[i] * N[i, 2]
    ln = math.sqrt(nx * nx + ny * ny + nz * nz)
    if ln > 1e-9:
        nx, ny, nz = nx / ln, ny / ln, nz / ln
    else:
        nx, ny, nz = fnx, fny, fnz
    return sx, sy, sz, nx, ny, nz, qx, qy, qz


@njit(cache=True, nogil=True)
def phong_finish(pts, V, N, bary, curvature, cos_tilt, extrapolate,
                 signed, foot, normal, curved):
    """Lift each point's chosen facet to its Phong surface and measure the signed distance.

    pts (n, 3); V, N (n, 3, 3) facet vertices and their outward normals; bary (n, 3) the flat
    closest point. Writes signed (n,), foot (n, 3), normal (n, 3), curved (n,). See
    ``engine.deviation._finish`` for the rules (tilt check, extrapolation over sampling gaps).
    """
    Nl = np.empty((3, 3))
    for i in range(pts.shape[0]):
        Vi = V[i]
        px, py, pz = pts[i, 0], pts[i, 1], pts[i, 2]
        e1x, e1y, e1z = Vi[1, 0] - Vi[0, 0], Vi[1, 1] - Vi[0, 1], Vi[1, 2] - Vi[0, 2]
        e2x, e2y, e2z = Vi[2, 0] - Vi[0, 0], Vi[2, 1] - Vi[0, 1], Vi[2, 2] - Vi[0, 2]
        fnx, fny, fnz = e1y * e2z - e1z * e2y, e1z * e2x - e1x * e2z, e1x * e2y - e1y * e2x
        fl = math.sqrt(fnx * fnx + fny * fny + fnz * fnz)
        if fl > 0:
            fnx, fny, fnz = fnx / fl, fny / fl, fnz / fl
        ag0 = dot3(N[i, 0, 0], N[i, 0, 1], N[i, 0, 2], fnx, fny, fnz)
        ag1 = dot3(N[i, 1, 0], N[i, 1, 1], N[i, 1, 2], fnx, fny, fnz)
        ag2 = dot3(N[i, 2, 0], N[i, 2, 1], N[i, 2, 2], fnx, fny, fnz)
        if ag0 + ag1 + ag2 < 0:
            fnx, fny, fnz = -fnx, -fny, -fnz
            ag0, ag1, ag2 = -ag0, -ag1, -ag2
        min_agree = min(ag0, min(ag1, ag2))
        is_curved = curvature and fl > 0 and min_agree >= cos_tilt
        flat = fl > 0 and not is_curved
        for k in range(3):
            for m in range(3):
                Nl[k, m] = N[i, k, m]
            if flat:
                Nl[k, 0], Nl[k, 1], Nl[k, 2] = fnx, fny, fnz
        edge = 0.0
        for k in range(3):
            k2 = (k + 1) % 3
            dx, dy, dz = Vi[k2, 0] - Vi[k, 0], Vi[k2, 1] - Vi[k, 1], Vi[k2, 2] - Vi[k, 2]
            edge = max(edge, math.sqrt(dx * dx + dy * dy + dz * dz))
        b0, b1, b2 = bary[i, 0], bary[i, 1], bary[i, 2]
        free = False
        for _ in range(2):
            sx, sy, sz, nx, ny, nz, qx, qy, qz = _phong(Vi, Nl, b0, b1, b2, fnx, fny, fnz)
            d = dot3(px - sx, py - sy, pz - sz, nx, ny, nz)
            # The tangent-plane foot, moved back to the flat facet, gives the next barycentrics.
            tx = px - d * nx - (sx - qx)
            ty = py - d * ny - (sy - qy)
            tz = pz - d * nz - (sz - qz)
            c0, c1, c2 = closest_bary(tx, ty, tz, Vi[0, 0], Vi[0, 1], Vi[0, 2],
                                      Vi[1, 0], Vi[1, 1], Vi[1, 2], Vi[2, 0], Vi[2, 1], Vi[2, 2])
            b0, b1, b2 = c0, c1, c2
            free = False
            if extrapolate and fl > 0:
                # Unclamped barycentrics of the target in the facet's plane.
                d00 = dot3(e1x, e1y, e1z, e1x, e1y, e1z)
                d01 = dot3(e1x, e1y, e1z, e2x, e2y, e2z)
                d11 = dot3(e2x, e2y, e2z, e2x, e2y, e2z)
                apx, apy, apz = tx - Vi[0, 0], ty - Vi[0, 1], tz - Vi[0, 2]
                d20 = dot3(apx, apy, apz, e1x, e1y, e1z)
                d21 = dot3(apx, apy, apz, e2x, e2y, e2z)
                det = d00 * d11 - d01 * d01
                if det > 1e-12 * max(d00 * d11, 1e-300):
                    ov = (d11 * d20 - d01 * d21) / det
                    ow = (d00 * d21 - d01 * d20) / det
                    ou = 1.0 - ov - ow
                    gx = ((ou - c0) * Vi[0, 0] + (ov - c1) * Vi[1, 0] + (ow - c2) * Vi[2, 0])
                    gy = ((ou - c0) * Vi[0, 1] + (ov - c1) * Vi[1, 1] + (ow - c2) * Vi[2, 1])
                    gz = ((ou - c0) * Vi[0, 2] + (ov - c1) * Vi[1, 2] + (ow - c2) * Vi[2, 2])
                    if math.sqrt(gx * gx + gy * gy + gz * gz) <= edge:
                        free = True
                        b0, b1, b2 = ou, ov, ow
        sx, sy, sz, nx, ny, nz, _, _, _ = _phong(Vi, Nl, b0, b1, b2, fnx, fny, fnz)
        d = dot3(px - sx, py - sy, pz - sz, nx, ny, nz)
        interior = free or (b0 > 1e-9 and b1 > 1e-9 and b2 > 1e-9)
        if not interior:
            e = math.sqrt(dot3(px - sx, py - sy, pz - sz, px - sx, py - sy, pz - sz))
            d = -e if d < 0 else e
        signed[i] = d
        foot[i, 0], foot[i, 1], foot[i, 2] = sx, sy, sz
        normal[i, 0], normal[i, 1], normal[i, 2] = nx, ny, nz
        curved[i] = is_curved


@njit(cache=True, nogil=True)
def _box_gap(p, box):
    """Distance from point p (3,) to the axis-aligned box (2, 3) (0 inside)."""
    s = 0.0
    for a in range(3):
        g = max(box[0, a] - p[a], p[a] - box[1, a], 0.0)
        s += g * g
    return math.sqrt(s)


@njit(cache=True, nogil=True)
def boxes_nearer(p, boxes, limit, done_start, done_face):
    """The (point, box) pairs whose box is nearer to the point than ``limit``, leaving out those
    already done.

    p (n, 3); boxes (F, 2, 3) min and max corners; limit (n,); done_face holds, for point i, the
    box numbers (1-based) done_face[done_start[i]:done_start[i + 1]]. Returns (m, 2) int64 pairs
    (point index, box number 1-based), by point then box. Twin: tests/naive.py boxes_nearer."""
    n, nb = p.shape[0], boxes.shape[0]
    count = np.zeros(n, np.int64)
    for i in range(n):
        for f in range(nb):
            if _box_gap(p[i], boxes[f]) < limit[i]:
                count[i] += 1
    out = np.empty((count.sum(), 2), np.int64)
    k = 0
    for i in range(n):
        if count[i] == 0:
            continue
        for f in range(nb):
            if _box_gap(p[i], boxes[f]) < limit[i]:
                seen = False
                for j in range(done_start[i], done_start[i + 1]):
                    if done_face[j] == f + 1:
                        seen = True
                        break
                if not seen:
                    out[k, 0] = i
                    out[k, 1] = f + 1
                    k += 1
    return out[:k]


def in_polygon(uv, segments, band):
    """Even-odd classification of 2D points against closed polylines given as a soup of
    segments, with the points within ``band`` of any segment marked apart.

    uv (m, 2); segments (E, 4): u0 v0 u1 v1 each, the union of closed loops in any order and
    direction. Returns (inside (m,) bool: an odd number of crossings of the ray towards +u;
    near (m,) bool: within ``band`` of a segment, where the caller decides otherwise)."""
    m = uv.shape[0]
    return in_polygons(uv, segments, np.zeros(m, np.int64),
                       np.full(m, segments.shape[0], np.int64), np.full(m, float(band)))


@njit(cache=True, nogil=True)
def in_polygons(uv, segments, start, stop, band):
    """:func:`in_polygon` of each point against its own polylines: point i against
    ``segments[start[i]:stop[i]]`` within ``band[i]`` (many faces' trims in one call)."""
    m = uv.shape[0]
    inside = np.zeros(m, np.bool_)
    near = np.zeros(m, np.bool_)
    for i in range(m):
        u, v = uv[i, 0], uv[i, 1]
        band2 = band[i] * band[i]
        odd = False
        for k in range(start[i], stop[i]):
            a0, a1, b0, b1 = segments[k, 0], segments[k, 1], segments[k, 2], segments[k, 3]
            if (a1 > v) != (b1 > v):
                if u < a0 + (v - a1) * (b0 - a0) / (b1 - a1):
                    odd = not odd
            if not near[i]:
                dx, dy = b0 - a0, b1 - a1
                length2 = dx * dx + dy * dy
                t = 0.0
                if length2 > 0.0:
                    t = min(1.0, max(0.0, ((u - a0) * dx + (v - a1) * dy) / length2))
                gx, gy = u - a0 - t * dx, v - a1 - t * dy
                if gx * gx + gy * gy <= band2:
                    near[i] = True
        inside[i] = odd
    return inside, near


# ------------------------------------------------------------------ nominal construction
@njit(cache=True, nogil=True)
def _nonzero_area(ax, ay, az, bx, by, bz, cx, cy, cz):
    """Numerically non-zero area of the triangle a b c: its doubled area squared above 1e-24 x
    the square of its longer edge from a, squared. Twin: tests/naive.py nonzero_area_xyz."""
    e1x, e1y, e1z = bx - ax, by - ay, bz - az
    e2x, e2y, e2z = cx - ax, cy - ay, cz - az
    nx = e1y * e2z - e1z * e2y
    ny = e1z * e2x - e1x * e2z
    nz = e1x * e2y - e1y * e2x
    scale = max(e1x * e1x + e1y * e1y + e1z * e1z, e2x * e2x + e2y * e2y + e2z * e2z)
    return nx * nx + ny * ny + nz * nz > 1e-24 * max(scale, 1e-300) ** 2


@njit(cache=True, nogil=True)
def grid_triangles(P, nu, nv):
    """The triangles (2 m, 3) of a u-v grid's points P (nv * nu, 3; u fastest), m = (nu - 1) x
    (nv - 1) cells each split along its shorter diagonal: first every cell's triangle
    v00 v10 (v11 | v01), then every cell's (v00 | v10) v11 v01; and whether each has non-zero
    area (2 m,). Twin: tests/naive.py grid_triangles."""
    m = (nv - 1) * (nu - 1)
    tris = np.empty((2 * m, 3), np.int64)
    ok = np.empty(2 * m, np.bool_)
    for j in range(nv - 1):
        for i in range(nu - 1):
            c = j * (nu - 1) + i
            v00 = j * nu + i
            v10, v01, v11 = v00 + 1, v00 + nu, v00 + nu + 1
            d1 = dot3(P[v00, 0] - P[v11, 0], P[v00, 1] - P[v11, 1], P[v00, 2] - P[v11, 2],
                      P[v00, 0] - P[v11, 0], P[v00, 1] - P[v11, 1], P[v00, 2] - P[v11, 2])
            d2 = dot3(P[v10, 0] - P[v01, 0], P[v10, 1] - P[v01, 1], P[v10, 2] - P[v01, 2],
                      P[v10, 0] - P[v01, 0], P[v10, 1] - P[v01, 1], P[v10, 2] - P[v01, 2])
            short = d1 <= d2
            third = v11 if short else v01
            first = v00 if short else v10
            tris[c, 0], tris[c, 1], tris[c, 2] = v00, v10, third
            tris[m + c, 0], tris[m + c, 1], tris[m + c, 2] = first, v11, v01
            ok[c] = _nonzero_area(P[v00, 0], P[v00, 1], P[v00, 2], P[v10, 0], P[v10, 1],
                                  P[v10, 2], P[third, 0], P[third, 1], P[third, 2])
            ok[m + c] = _nonzero_area(P[first, 0], P[first, 1], P[first, 2], P[v11, 0],
                                      P[v11, 1], P[v11, 2], P[v01, 0], P[v01, 1], P[v01, 2])
    return tris, ok


@njit(cache=True, nogil=True)
def nonzero_areas(P, tris):
    """(t,) whether each triangle of tris (t, 3) over the points P (n, 3) has a numerically
    non-zero area (the rule of grid_triangles, for meshes)."""
    out = np.empty(tris.shape[0], np.bool_)
    for t in range(tris.shape[0]):
        a, b, c = tris[t, 0], tris[t, 1], tris[t, 2]
        out[t] = _nonzero_area(P[a, 0], P[a, 1], P[a, 2], P[b, 0], P[b, 1], P[b, 2],
                               P[c, 0], P[c, 1], P[c, 2])
    return out


@njit(cache=True, nogil=True)
def longest_edges(P, tris):
    """(t,) the longest edge of each triangle of tris (t, 3) over the points P (n, 3)."""
    out = np.empty(tris.shape[0])
    for t in range(tris.shape[0]):
        best = 0.0
        for k in range(3):
            a, b = tris[t, k], tris[t, (k + 1) % 3]
            best = max(best, dot3(P[b, 0] - P[a, 0], P[b, 1] - P[a, 1], P[b, 2] - P[a, 2],
                                  P[b, 0] - P[a, 0], P[b, 1] - P[a, 1], P[b, 2] - P[a, 2]))
        out[t] = math.sqrt(best)
    return out
