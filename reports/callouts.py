"""Point callouts of the deviation maps: which points get a flag (the worst point of each
separate cluster of out-of-tolerance points, or of the largest deviations on a passing part),
and where their labels go (beside the point, with a leader line; no two labels overlap, no
leader crosses another or a label, no label covers a flagged point).

Plain functions over arrays; no reportlab, no Qt: the certificate and the app both place their
flags with :func:`place_labels`.
"""

from __future__ import annotations

import math

import numpy as np

MAX_CALLOUTS = 8
LINK_SPACINGS = 4.0
"""Two flag-worthy points belong to one cluster when they lie within this many typical point
spacings of each other (the median distance from a measured point to its nearest neighbour),
or within LINK_SHARE of the measured points' diagonal (closer than that, two flags would crowd
each other on the map anyway)."""
LINK_SHARE = 0.04
PASSING_SHARE = 0.7
"""On a part with every point in tolerance, points deviating by at least this share of the
largest |deviation| are the candidates,"""
PASSING_CALLOUTS = 4
"""and at most this many of their clusters are flagged (a passing part's map is read for its
largest departures, not its noise)."""


def callout_points(feet: np.ndarray, d: np.ndarray, lower: float, upper: float,
                   max_callouts: int = MAX_CALLOUTS) -> list[int]:
    """Indices of the points to flag, most severe first: the worst point of each separate
    cluster of out-of-tolerance points (points of one sign within LINK_SPACINGS point spacings
    or LINK_SHARE of the diagonal of each other, chained), or, when every point is in tolerance, of the points deviating by
    at least PASSING_SHARE of the largest |deviation| (at most PASSING_CALLOUTS of them).

    feet : (n, 3) the points' feet on the nominal, mm; d : (n,) signed deviations, mm; lower,
    upper : the tolerance zone, mm.
    """
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree

    d = np.asarray(d, dtype=float)
    if d.size == 0:
        return []
    excess = np.maximum(d - upper, lower - d)
    if (excess > 0).any():
        cand, severity = np.flatnonzero(excess > 0), excess
    else:
        severity = np.abs(d)
        if not severity.max() > 0:
            return []
        cand = np.flatnonzero(severity >= PASSING_SHARE * severity.max())
        max_callouts = min(max_callouts, PASSING_CALLOUTS)
    link = max(LINK_SPACINGS * point_spacing(feet),
               LINK_SHARE * float(np.linalg.norm(np.ptp(feet, axis=0))))
    pairs = cKDTree(feet[cand]).query_pairs(link, output_type="ndarray")
    pairs = pairs[np.sign(d[cand[pairs[:, 0]]]) == np.sign(d[cand[pairs[:, 1]]])]
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])),
                       shape=(len(cand), len(cand)))
    _, label = connected_components(graph, directed=False)
    worst: dict[int, int] = {}  # cluster label -> its worst point
    for k in np.argsort(-severity[cand], kind="stable"):
        worst.setdefault(int(label[k]), int(cand[k]))  # the first seen is its cluster's worst
    return list(worst.values())[:max_callouts]


def point_spacing(p: np.ndarray) -> float:
    """Median distance from a point to its nearest neighbour (the part's diagonal / 100 for
    fewer than two distinct points)."""
    from scipy.spatial import cKDTree

    if len(p) > 1:
        nn = cKDTree(p).query(p, k=2)[0][:, 1]
        nn = nn[nn > 0]
        if nn.size:
            return float(np.median(nn))
    return max(float(np.linalg.norm(np.ptp(p, axis=0))) / 100.0, 1e-9) if len(p) else 1.0


# ---------------------------------------------------------------------------- label placement
ANGLES = np.radians(np.arange(0, 360, 30) + 45)  # diagonals first: flags read best there
RADII = (0.07, 0.12, 0.18, 0.26, 0.36)
"""Leader lengths tried, as shares of the picture's smaller side."""
GAP = 2.0
"""Clearance between labels, and around the flagged points, in drawing units."""


def place_labels(anchors: np.ndarray, sizes: np.ndarray, width: float, height: float,
                 avoid: np.ndarray | None = None,
                 blocked: tuple = ()) -> list[tuple[float, float] | None]:
    """Lower-left corners of label boxes for points at ``anchors``, placed in the given order
    (most important first): each box inside the picture [0, width] x [0, height] (y up), clear
    of every placed box and every anchor, its leader (anchor to the nearest point of its box)
    crossing no other leader or box; among those, the one covering the fewest ``avoid`` points
    (e.g. other out-of-tolerance points), then the shortest leader. None for a label with no
    such place (never an overlap).

    anchors : (k, 2); sizes : (k, 2) box width and height; avoid : (m, 2) or None; blocked :
    boxes (x0, y0, x1, y1) already taken (a title, an axis triad).
    """
    anchors = np.asarray(anchors, dtype=float).reshape(-1, 2)
    sizes = np.asarray(sizes, dtype=float).reshape(-1, 2)
    avoid = np.zeros((0, 2)) if avoid is None else np.asarray(avoid, dtype=float).reshape(-1, 2)
    boxes: list[tuple[float, float, float, float]] = [tuple(b) for b in blocked]
    leaders: list[tuple[np.ndarray, np.ndarray]] = []
    out: list[tuple[float, float] | None] = []
    scale = min(width, height)
    for a, (w, h) in zip(anchors, sizes):
        best = None
        for r in RADII:
            for ang in ANGLES:
                box, foot = _candidate(a, w, h, r * scale, ang)
                if not _fits(box, foot, a, width, height, boxes, leaders, anchors):
                    continue
                cost = (_covered(box, avoid), r)
                if best is None or cost < best[0]:
                    best = (cost, box, foot)
            if best is not None and best[0][0] == 0:
                break  # the nearest ring with a free place that hides nothing
        if best is None:
            out.append(None)
            continue
        _, box, foot = best
        boxes.append(box)
        leaders.append((a, foot))
        out.append((box[0], box[1]))
    return out


def leader_end(anchor, box) -> tuple[float, float]:
    """The point of ``box`` (x0, y0, x1, y1) nearest to ``anchor``: where its leader ends."""
    return (min(max(anchor[0], box[0]), box[2]), min(max(anchor[1], box[1]), box[3]))


def _candidate(a, w, h, r, ang):
    """A box of w x h whose nearest point to ``a`` lies about r away in direction ``ang``."""
    c, s = math.cos(ang), math.sin(ang)
    cx = a[0] + r * c + 0.5 * w * (1 if c > 1e-9 else -1 if c < -1e-9 else 0)
    cy = a[1] + r * s + 0.5 * h * (1 if s > 1e-9 else -1 if s < -1e-9 else 0)
    box = (cx - w / 2, cy - h / 2, cx + w / 2, cy + h / 2)
    return box, np.array(leader_end(a, box))


def _fits(box, foot, a, width, height, boxes, leaders, anchors) -> bool:
    x0, y0, x1, y1 = box
    if x0 < 0 or y0 < 0 or x1 > width or y1 > height:
        return False
    grown = (x0 - GAP, y0 - GAP, x1 + GAP, y1 + GAP)
    if any(_boxes_meet(grown, b) for b in boxes) or _covered(grown, anchors):
        return False
    for b in boxes:
        if _segment_meets_box(a, foot, b):
            return False
    for p, q in leaders:
        if _segments_cross(a, foot, p, q) or _segment_meets_box(p, q, grown):
            return False
    return True


def _boxes_meet(a, b) -> bool:
    return a[0] < b[2] and b[0] < a[2] and a[1] < b[3] and b[1] < a[3]


def _covered(box, pts: np.ndarray) -> int:
    if not len(pts):
        return 0
    return int(np.count_nonzero((pts[:, 0] >= box[0]) & (pts[:, 0] <= box[2]) &
                                (pts[:, 1] >= box[1]) & (pts[:, 1] <= box[3])))


def _segments_cross(p1, p2, q1, q2) -> bool:
    """Whether segments p1-p2 and q1-q2 share a point (touching ends included)."""
    def orient(a, b, c):
        v = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
        return 0 if abs(v) < 1e-12 else (1 if v > 0 else -1)

    def on(a, b, c):
        return min(a[0], b[0]) - 1e-9 <= c[0] <= max(a[0], b[0]) + 1e-9 and \
            min(a[1], b[1]) - 1e-9 <= c[1] <= max(a[1], b[1]) + 1e-9

    o1, o2, o3, o4 = orient(p1, p2, q1), orient(p1, p2, q2), orient(q1, q2, p1), orient(q1, q2, p2)
    if o1 != o2 and o3 != o4:
        return True
    return any(o == 0 and on(*s) for o, s in ((o1, (p1, p2, q1)), (o2, (p1, p2, q2)),
                                             (o3, (q1, q2, p1)), (o4, (q1, q2, p2))))


def _segment_meets_box(p, q, box) -> bool:
    """Whether segment p-q enters the box (Liang-Barsky clipping)."""
    t0, t1 = 0.0, 1.0
    dx, dy = q[0] - p[0], q[1] - p[1]
    for num, den in ((p[0] - box[0], -dx), (box[2] - p[0], dx), (p[1] - box[1], -dy),
                     (box[3] - p[1], dy)):
        if abs(den) < 1e-12:
            if num < 0:
                return False
            continue
        t = num / den
        if den < 0:
            t0 = max(t0, t)
        else:
            t1 = min(t1, t)
        if t0 > t1:
            return False
    return True
