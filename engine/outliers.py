"""Gross outliers: the only measured points a final fit may leave out of the alignment.

A point is a *gross outlier* (a mis-probed point, a chip on the part, the fixture touched) at a
pose when both hold there:

1. **Far beyond any plausible deviation of the part**: its signed deviation lies farther from the
   median deviation than the gross threshold = the largest of
   ``GROSS_ZONES`` zone widths (when the zone is known), ``ROBUST_SIGMAS`` robust standard
   deviations (1.4826 x median absolute deviation) of all the deviations, and a floor (a small
   fraction of the nominal's size, given by the caller);
2. **isolated from the others**: it belongs to no region of alike deviations. Its *companions*
   are those of its ``NEIGHBOURS`` nearest measured points (nearest along the surface: between
   the points' feet on the nominal) whose deviation lies within the threshold of its own. It is
   in a region when it has at least ``COMPANIONS`` companions and it or one of them has
   ``SUPPORT`` companions of its own (a dent or a bump: its points agree with some of their
   neighbours, even at a sharp rim, and some of them with most: its inside, or the slope around
   a deep core), or when it is one of a group of at least ``REGION`` far points linked by
   companionship (i -- j when j is among i's nearest or i among j's, and they are alike): a
   line of points one probe-row wide, a scratch or a burr, whose points have only their two
   neighbours along the line as companions. A few mis-probed points that happen to lie near
   each other among good points (2% of the points at random do, now and then: in 200,000
   points, some 150 pairs, 10 threes and one group of four side by side) are interleaved with
   good points: none of them has ``SUPPORT`` companions, and they are fewer than ``REGION``.

A final fit leaves a point out only if it is gross both at the least-squares pose over the points
it keeps and at the least-squares pose over every point, it included (:func:`fit_without_gross`).
A pose that is still wrong can make good points look gross (a turn a circle leaves free brings
them over a flat); left out, nothing would pull the pose back. Fitted with them, they pull it to
where they fit; a mis-probe millimetres off stays gross there. So a dent or bump, in tolerance
or not, is never left out, and the pose reported is the least-squares optimum over the points
kept.

Left-out points are still judged like every other point: leaving a point out of the alignment
changes the pose, never the point's own verdict.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

GROSS_ZONES = 5.0
"""A gross outlier lies farther than this many zone widths from the median deviation …"""
ROBUST_SIGMAS = 6.0
"""… and than this many robust standard deviations of all the deviations …"""
NEIGHBOURS = 8
"""… and fewer than COMPANIONS of its this many nearest measured points …"""
COMPANIONS = 2
"""… have a deviation within the threshold of its own (its companions), or when neither it nor
any of its companions has …"""
SUPPORT = 3
"""… this many companions of its own; and it belongs to no group of …"""
REGION = 5
"""… this many far points linked by companionship (a line of points: a scratch, a burr). Four
side by side occur among 2% of the points mis-probed at random (about once in 200,000 points);
five did not in 1,200,000 such points (24,000 mis-probes)."""
INCLUDED_FIT_ITERATIONS = 10
"""Gauss-Newton iterations at most of the fit over every point (gross or not) that decides
which points stay gross with them included: from the kept points' optimum, a few steps bring
the pose within far less than a gross threshold of the all-point optimum (a mis-probe 10 mm off
and a kink in the nominal can keep the last digits from settling)."""


@dataclass(frozen=True)
class GrossRule:
    """The gross-outlier rule as applied: its threshold and where the threshold came from.

    threshold_mm : |d - median d| beyond this (and as far from the neighbours' median) is gross.
    zone_width_mm : the tolerance zone's width the rule was given (None: not given).
    robust_sigma_mm : 1.4826 x median absolute deviation of all the deviations.
    floor_mm : the smallest threshold allowed.
    centre_mm : median of all the deviations.
    """

    threshold_mm: float
    zone_width_mm: float | None
    robust_sigma_mm: float
    floor_mm: float
    centre_mm: float

    def describe(self) -> str:
        """The rule in words, with its numbers (for the JSON and the certificate)."""
        parts = []
        if self.zone_width_mm is not None:
            parts.append(f"{GROSS_ZONES:g} zone widths ({GROSS_ZONES * self.zone_width_mm:.4g}"
                         " mm)")
        parts.append(f"{ROBUST_SIGMAS:g} robust standard deviations "
                     f"({ROBUST_SIGMAS * self.robust_sigma_mm:.4g} mm)")
        parts.append(f"a floor of {self.floor_mm:.4g} mm")
        return (f"a point is excluded from the alignment only as a gross outlier: its deviation "
                f"lies more than {self.threshold_mm:.4g} mm (the largest of "
                + ", ".join(parts) + ") from the median deviation "
                f"({self.centre_mm:+.4g} mm) and it belongs to no region of alike deviations: "
                f"fewer than {COMPANIONS} of its {NEIGHBOURS} nearest measured points (along "
                "the surface) deviate within that distance of it, or neither it nor any of those "
                f"has {SUPPORT} such points among its own {NEIGHBOURS} nearest, and it is not "
                f"one of {REGION} or more such far points linked to each other (a line: a "
                "scratch, a burr); both at the least-squares pose over the points kept and at "
                "the one over every point, it included (a dent or bump is never excluded); it "
                "is judged like every other point")


def robust_centre_sigma(d: np.ndarray) -> tuple[float, float]:
    """(median, 1.4826 x median absolute deviation) of deviations ``d`` (n,), mm: the centre
    and the robust standard deviation that the gross rule and the coarse fits' cut share
    (0, 0 for no deviations)."""
    d = np.asarray(d, float)
    if not d.size:
        return 0.0, 0.0
    centre = float(np.median(d))
    return centre, float(1.4826 * np.median(np.abs(d - centre)))


def gross_rule(d: np.ndarray, zone_width: float | None, floor: float) -> GrossRule:
    """The rule's threshold for signed deviations ``d`` (n,), mm.

    zone_width : the tolerance zone's width, mm (None when the zone is not known); floor : the
    smallest threshold, mm."""
    centre, sigma = robust_centre_sigma(d)
    threshold = max(ROBUST_SIGMAS * sigma, floor)
    if zone_width is not None:
        threshold = max(threshold, GROSS_ZONES * float(zone_width))
    return GrossRule(float(threshold), None if zone_width is None else float(zone_width),
                     sigma, float(floor), centre)


def gross_outliers(d: np.ndarray, points: np.ndarray, rule: GrossRule) -> np.ndarray:
    """(n,) bool: the points of ``rule`` that are gross outliers.

    d : (n,) signed deviations, mm; points : (n, 2) or (n, 3) where the measured points lie along
    the nominal: their feet on it (``Deviations.foot``, any frame: only distances between them are
    used). Not the measured coordinates themselves: where points are dense, a point 10 mm off the
    surface has other points 10 mm off (on the same side, a few millimetres away) nearer to it
    than the surface points around it, and would look like a region of them."""
    d = np.asarray(d, float)
    far = np.abs(d - rule.centre_mm) > rule.threshold_mm
    gross = np.zeros(d.size, bool)
    cand = np.flatnonzero(far)
    if cand.size == 0:
        return gross
    k = min(NEIGHBOURS, d.size - 1)
    if k < 1:
        return gross
    pts = np.asarray(points, float)
    tree = cKDTree(pts)
    alike, nb = _companions(tree, pts, d, cand, k, rule.threshold_mm)
    count = alike.sum(axis=1)
    supported = count >= SUPPORT
    # Candidates with companions but too few to be inside a region themselves: a region has
    # some point, next to them, with enough.
    weak = np.flatnonzero((count >= COMPANIONS) & ~supported)
    if weak.size:
        hop = np.unique(nb[weak][alike[weak]])
        strong = np.zeros(d.size, bool)
        strong[hop] = _companions(tree, pts, d, hop, k, rule.threshold_mm)[0].sum(axis=1) \
            >= SUPPORT
        supported[weak] = np.any(alike[weak] & strong[nb[weak]], axis=1)
    region = (count >= COMPANIONS) & supported
    # A thin region (a scratch or a burr one probe-row wide, a line of points) has too few
    # companions everywhere; it is a chain of far points each alike with the next: a group of
    # REGION or more far points linked by companionship is a region, whatever its shape.
    rest = ~region & (count > 0)
    if rest.any():
        region |= _group_size(cand, alike, nb, far, d.size) >= REGION
    gross[cand] = ~region
    return gross


def _group_size(cand: np.ndarray, alike: np.ndarray, nb: np.ndarray, far: np.ndarray,
                n: int) -> np.ndarray:
    """(m,) int: for each candidate ``cand`` (m,), the size of its group: the connected
    component, among the candidates, of the companionship graph (i -- j when j is among i's
    nearest, or i among j's, and they are alike). ``alike``, ``nb`` (m, k) from _companions;
    ``far`` (n,) the candidate mask."""
    pos = np.full(n, -1)
    pos[cand] = np.arange(cand.size)
    link = alike & far[nb]
    rows = np.repeat(np.arange(cand.size), link.sum(axis=1))
    cols = pos[nb[link]]
    graph = coo_matrix((np.ones(rows.size, np.int8), (rows, cols)),
                       shape=(cand.size, cand.size))
    _, label = connected_components(graph, directed=False)
    return np.bincount(label)[label]


def _companions(tree: cKDTree, pts: np.ndarray, d: np.ndarray, idx: np.ndarray, k: int,
                threshold: float):
    """((m, k) bool: which of the k nearest points of points ``idx`` deviate within
    ``threshold`` of them, (m, k) their indices)."""
    _, nb = tree.query(pts[idx], k=k + 1)
    # Drop the point itself (not necessarily first where another point has the same foot).
    other = nb != idx[:, None]
    nb = np.take_along_axis(nb, np.argsort(~other, axis=1, kind="stable")[:, :k], axis=1)
    return np.abs(d[nb] - d[idx][:, None]) <= threshold, nb


def fit_without_gross(fit, T: np.ndarray, n: int, probe=None):
    """The final fit under the rule's second condition: a point is left out only if it is gross
    both at the least-squares pose over the points kept and at the least-squares pose over every
    point (fitted WITH it).

    A pose that is still wrong can make good points look gross (a rotation a circle leaves free
    brings them over a flat); left out, nothing pulls the pose back, and least squares over the
    rest locks the wrong pose in. Fitted with every point, such points pull the pose to where
    they fit and stop being gross; a true mis-probe (millimetres off) stays gross there.

    fit(T, included) runs least squares from pose T (opaque here: a pose, or a pose with what
    is known at it) over every one of the n points but those gross at its pose and True in
    ``included`` ((n,) bool; None: every gross point; all False: plain least squares over every
    point) and returns (T, gross (n,) bool: the rule alone at the returned pose, result: the
    fit, whose ``inlier`` (n,) bool are the points it kept). Whichever call is chosen is the
    final fit: its result must be a real fit's, whatever ``included`` is.

    probe(T) -> (T, gross (n,) bool): the rule alone at (or near) the least-squares pose over
    every point, reached from T, and a pose to start the final fit from. Only which points it
    finds gross decides; it is never the final fit, so it may be cheaper than one (a linear step,
    at most ``INCLUDED_FIT_ITERATIONS`` iterations, converged or not). None: fit(T, all False).

    Returns (the chosen fit's triple, number of calls run, the probe counted). When the first
    fit keeps every point (the usual case) nothing else runs."""
    first = fit(T, None)
    T1, _, result = first
    kept = result.inlier
    if kept.all():
        return first, 1
    if probe is None:
        T_all, gross_all = fit(T1, np.zeros(n, bool))[:2]
    else:
        T_all, gross_all = probe(T1)
    if not np.any(~kept & ~gross_all):
        # Every point left out stays gross with it included: the first fit stands.
        return first, 2
    # Some point left out is not gross with every point included: least squares over every
    # point but those gross there (over every point when none is).
    return fit(T_all, gross_all), 3
