"""Which points a deviation map calls out: the worst point of each separate cluster of notable
points (a dent gets one callout, not five), worst cluster first. Pure functions over arrays; the
desktop app's flags use them (and a certificate's callouts may).
"""

from __future__ import annotations

import numpy as np

LINK_SPACINGS = 2.5
"""Notable points closer than this many median point spacings belong to one cluster."""
NOTABLE_SHARE = 0.5
"""Without a point outside the zone, the notable points are those at least this share of the
largest distance from the zone's centre away from it."""


def notable_points(d: np.ndarray, lower: float, upper: float) -> np.ndarray:
    """(n,) bool: the points worth a callout. With any point outside the zone [lower, upper]
    (mm), exactly those; else those whose distance from the zone's centre is at least
    NOTABLE_SHARE of the largest such distance (none when every deviation is the centre)."""
    d = np.asarray(d, dtype=float)
    out = (d < lower) | (d > upper)
    if out.any():
        return out
    off = np.abs(d - 0.5 * (lower + upper))
    top = float(off.max()) if off.size else 0.0
    return off >= NOTABLE_SHARE * top if top > 0 else np.zeros(d.shape, dtype=bool)


def worst_of_clusters(points: np.ndarray, d: np.ndarray, lower: float, upper: float,
                      n: int = 5, link: float | None = None) -> np.ndarray:
    """The points to call out on a map: the worst of each separate cluster of notable points.

    points : (m, 3) or (m, 2) float, the points where they are drawn, mm.
    d : (m,) float, their signed deviations, mm; lower, upper : the zone, mm.
    n : at most this many callouts. link : notable points nearer each other than this (mm)
        on the same side of the zone's centre form one cluster; default LINK_SPACINGS times
        the median distance from a point to its nearest neighbour.

    Returns (k,) int point indices, k <= n, the worst cluster first; "worst" is the farthest
    outside the zone (Tolerance.excess), then nearest a limit. A dent and a bump side by side
    are two clusters (their deviations have opposite signs).

    Examples
    --------
    >>> import numpy as np
    >>> x = np.arange(10.0)
    >>> pts = np.column_stack([x, np.zeros(10)])
    >>> d = np.array([0, -0.3, -0.5, -0.3, 0, 0, 0, 0.4, 0, 0])
    >>> worst_of_clusters(pts, d, -0.25, 0.25).tolist()
    [2, 7]
    """
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree

    points = np.asarray(points, dtype=float)
    d = np.asarray(d, dtype=float)
    if points.shape[0] != d.shape[0]:
        raise ValueError(f"{points.shape[0]} points but {d.shape[0]} deviations")
    idx = np.flatnonzero(notable_points(d, lower, upper))
    if idx.size == 0 or n <= 0:
        return np.zeros(0, dtype=np.int64)
    if link is None:
        gap = cKDTree(points).query(points, k=2)[0][:, 1] if points.shape[0] > 1 else [0.0]
        link = LINK_SPACINGS * float(np.median(gap))
    pairs = cKDTree(points[idx]).query_pairs(link, output_type="ndarray")
    above = d[idx] > 0.5 * (lower + upper)
    pairs = pairs[above[pairs[:, 0]] == above[pairs[:, 1]]]
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])),
                       shape=(idx.size, idx.size))
    _, cluster = connected_components(graph, directed=False)
    excess = np.maximum(d[idx] - upper, lower - d[idx])
    order = np.lexsort((idx, -excess))  # worst first; ties by point index
    _, first = np.unique(cluster[order], return_index=True)
    return idx[order[np.sort(first)][:n]].astype(np.int64)
