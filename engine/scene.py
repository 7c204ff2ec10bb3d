"""Measured scenes that hold more than the part: a scanner or 3D camera sees the table, the
fixture and whatever else lies in its view. This module keeps the part's points (a crop box, the
dominant plane removed) and says when the measured points are far too large for the nominal.

Numbers in, numbers out: every function takes arrays in millimetres, in the measured frame (the
file's coordinates, before any registration), and reads no file. The pipeline
(engine.pipeline) applies :func:`select_points` to the measured points before the inspection,
with the settings' ``crop``, ``remove_plane`` and ``plane_distance``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from . import seeds
from .errors import SettingsError

MIN_KEPT = 6
"""Points a crop and plane removal must leave at least: six fix a rigid pose (fewer is an error,
not a verdict)."""
EXTENT_RATIO = 3.0
"""The measured points' bounding-box diagonal beyond this many times the nominal's means the
measurement holds more than the part (a scene): a warning that suggests a crop. A part measured
whole spans about its nominal's diagonal; a partial view less."""
RANSAC_ITERATIONS = 1000
"""Plane hypotheses (three points each) tried: a plane holding a fifth of the points is found
with probability 1 - (1 - 0.2^3)^1000 > 0.9996."""
RANSAC_POINTS = 20_000
"""Hypotheses are counted on a seeded subset of at most this many points (the fit and the
removal use every point)."""
SPACING_SAMPLES = 2_000
"""Points whose nearest neighbour gives the scene's typical spacing (a seeded choice)."""
PLANE_SIGMAS = 3.0
"""The default removal distance: this many robust standard deviations of the plane's points
about it ..."""
SEED = 0
"""The random stream of every random choice here (engine.seeds): the same points and seed give
the same plane, every run."""
LINK_SPACINGS = 2.0
"""Two points belong to one object when they lie within this many typical point spacings of
each other (:func:`objects`): a scanner's rows are one spacing apart on a surface, and the gap
between two objects on a table is wider than two."""


def check_box(box) -> tuple[float, float, float, float, float, float]:
    """A crop box (xmin, ymin, zmin, xmax, ymax, zmax), mm, checked: six finite numbers, each
    minimum below its maximum. Raises SettingsError otherwise."""
    try:
        values = tuple(float(v) for v in box)
    except (TypeError, ValueError):
        raise SettingsError(f"a crop box is six numbers XMIN YMIN ZMIN XMAX YMAX ZMAX (mm), "
                            f"got {box!r}") from None
    if len(values) != 6:
        raise SettingsError(f"a crop box is six numbers XMIN YMIN ZMIN XMAX YMAX ZMAX (mm), "
                            f"got {len(values)}")
    if not all(math.isfinite(v) for v in values):
        raise SettingsError(f"the crop box {_box_text(values)} holds a number that is not "
                            "finite")
    for axis, lo, hi in zip("xyz", values[:3], values[3:]):
        if not lo < hi:
            raise SettingsError(f"the crop box's {axis} range {lo:g} .. {hi:g} is empty: "
                                f"{axis.upper()}MIN must be below {axis.upper()}MAX")
    return values[0], values[1], values[2], values[3], values[4], values[5]


def check_plane_distance(distance: float | None) -> None:
    """Raise SettingsError unless ``distance`` is None (the default rule) or a positive finite
    number of mm."""
    if distance is not None and not (math.isfinite(distance) and distance > 0):
        raise SettingsError(f"the plane removal distance must be a positive number of mm, got "
                            f"{distance:g}")


def crop_mask(points: np.ndarray, box) -> np.ndarray:
    """points : (n, 3) float, mm; box : (xmin, ymin, zmin, xmax, ymax, zmax), mm, the same
    frame -> (n,) bool, True for the points inside the box, its faces included.

    >>> crop_mask(np.array([[0., 0., 0.], [2., 0., 0.]]), (-1, -1, -1, 1, 1, 1)).tolist()
    [True, False]
    """
    b = np.asarray(check_box(box))
    p = np.asarray(points, dtype=np.float64)
    return np.all((p >= b[:3]) & (p <= b[3:]), axis=1)


@dataclass(frozen=True)
class Plane:
    """The dominant plane of a point set and the points within ``distance`` of it.

    normal : (3,) unit vector; offset : mm, the plane is {x : normal . x = offset};
    distance : mm, the removal distance used; rule : how ``distance`` was chosen, in words;
    inliers : (n,) bool, the points within ``distance`` (|normal . x - offset| <= distance);
    sigma : mm, the robust standard deviation (1.4826 x MAD) of the plane's consensus points
    about it; spacing : mm, the median nearest-neighbour distance of the points.
    """

    normal: np.ndarray
    offset: float
    distance: float
    rule: str
    inliers: np.ndarray
    sigma: float
    spacing: float


def typical_spacing(points: np.ndarray, samples: int = SPACING_SAMPLES,
                    seed: int = seeds.DEFAULT_SEED) -> float:
    """points (n, 3), mm -> the median distance from a point to its nearest other point, over a
    seeded choice of at most ``samples`` points (mm; 0.0 for fewer than two points; ``seed``:
    the inspection's, engine.seeds)."""
    p = np.asarray(points, dtype=np.float64)
    if p.shape[0] < 2:
        return 0.0
    rng = seeds.rng(seed, SEED)
    q = p if p.shape[0] <= samples else p[rng.choice(p.shape[0], samples, replace=False)]
    d, _ = cKDTree(p).query(q, k=2)
    return float(np.median(d[:, 1]))


def _hypotheses(p: np.ndarray, rng: np.random.Generator, k: int):
    """k planes through random triples of ``p`` (m, 3): (normals (h, 3), offsets (h,)), the
    degenerate (collinear) triples left out."""
    tri = p[np.stack([rng.choice(p.shape[0], 3, replace=False) for _ in range(k)])]
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    length = np.linalg.norm(n, axis=1)
    scale = np.ptp(p, axis=0).max() if p.shape[0] else 1.0
    ok = length > 1e-12 * scale * scale
    n = n[ok] / length[ok, None]
    return n, np.einsum("ij,ij->i", n, tri[ok, 0])


def _best_hypothesis(p: np.ndarray, threshold: float, seed: int, iterations: int):
    """(normal (3,), offset) of the plane through three of ``p`` with the most points within
    ``threshold``; the first such among the seeded hypotheses on a tie."""
    rng = seeds.rng(seed, SEED)
    normals, offsets = _hypotheses(p, rng, iterations)
    if normals.shape[0] == 0:
        raise ValueError("the points are collinear: they hold no plane")
    counts = np.empty(normals.shape[0], np.int64)
    for s in range(0, normals.shape[0], 64):  # 64 x 20,000 distances at a time
        d = p @ normals[s:s + 64].T - offsets[s:s + 64]
        counts[s:s + 64] = np.count_nonzero(np.abs(d) <= threshold, axis=0)
    best = int(np.argmax(counts))
    return normals[best], float(offsets[best])


def _robust_scale(r: np.ndarray) -> tuple[float, float]:
    """(median, 1.4826 x median absolute deviation) of the residuals r (m,): their centre and
    robust standard deviation."""
    c = float(np.median(r))
    return c, float(1.4826 * np.median(np.abs(r - c)))


def on_a_line(q: np.ndarray) -> bool:
    """Whether the points q (m, 3) lie on one straight line (or one spot)."""
    sv = np.linalg.svd(q - q.mean(axis=0), compute_uv=False)
    return not sv[1] > 1e-9 * sv[0]


def _refit(p: np.ndarray, mask: np.ndarray, normal: np.ndarray):
    """The least-squares plane (normal, offset) of p[mask], its normal turned to ``normal``'s
    side."""
    q = p[mask]
    c = q.mean(axis=0)
    n = np.linalg.svd(q - c, full_matrices=False)[2][2]
    if n @ normal < 0:
        n = -n
    return n, float(n @ c)


def dominant_plane(points: np.ndarray, distance: float | None = None, *,
                   seed: int = seeds.DEFAULT_SEED,
                   iterations: int = RANSAC_ITERATIONS) -> Plane:
    """The plane holding the most points (the table under a part), by seeded RANSAC: planes
    through random triples, counted on a seeded subset of at most ``RANSAC_POINTS`` points,
    the best refitted by least squares over its consensus points (all points).

    points : (n, 3) float, mm, n >= 3, not all on one line.
    distance : the removal distance, mm; None chooses it from the data: with h the median
        nearest-neighbour spacing, RANSAC counts within 2h, and the distance is
        ``PLANE_SIGMAS`` robust standard deviations of the consensus points about the refitted
        plane, at least h. (A 3D camera's ToF noise of a few mm gives ~15 mm; a clean dense
        scan one spacing.)
    seed : the inspection's (engine.seeds).

    Returns a :class:`Plane`; the same points give the same plane on every run. Raises
    ValueError for fewer than 3 points or points on one line.

    >>> rng = np.random.default_rng(1)
    >>> table = np.c_[rng.uniform(0, 100, (500, 2)), np.zeros(500)]
    >>> part = rng.uniform(40, 60, (100, 3)) + [0, 0, 5]
    >>> plane = dominant_plane(np.r_[table, part])
    >>> int(plane.inliers[:500].sum()), int(plane.inliers[500:].sum())
    (500, 0)
    """
    p = np.asarray(points, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 3 or p.shape[0] < 3:
        raise ValueError("a plane needs at least 3 points (n, 3)")
    h = typical_spacing(p, seed=seed)
    rng = seeds.rng(seed, SEED)
    sub = p if p.shape[0] <= RANSAC_POINTS else p[rng.choice(p.shape[0], RANSAC_POINTS,
                                                             replace=False)]
    search = distance if distance is not None else 2.0 * h
    if not search > 0:  # every point on one spot: no spacing to speak of
        search = 1e-9 * max(float(np.ptp(p, axis=0).max()), 1.0)
    normal, offset = _best_hypothesis(sub, search, seed, iterations)
    consensus = np.abs(p @ normal - offset) <= search
    normal, offset = _refit(p, consensus, normal)
    centre, sigma = _robust_scale(p[consensus] @ normal - offset)
    # Once more on the points within 3 sigma: the consensus band also holds the lowest rows of
    # whatever stands on the plane, which tilt a least-squares fit towards them.
    core = np.abs(p @ normal - offset - centre) <= PLANE_SIGMAS * sigma
    if core.sum() >= 3 and not on_a_line(p[core]):
        normal, offset = _refit(p, core, normal)
        sigma = _robust_scale(p[consensus] @ normal - offset)[1]
    if distance is None:
        distance = max(PLANE_SIGMAS * sigma, h)
        rule = (f"{PLANE_SIGMAS:g} robust standard deviations of the plane's points about it "
                f"({PLANE_SIGMAS:g} x {sigma:.3g} mm), at least the median point spacing "
                f"({h:.3g} mm)")
    else:
        rule = "given"
    inliers = np.abs(p @ normal - offset) <= distance
    return Plane(normal, offset, float(distance), rule, inliers, sigma, h)


def objects(points: np.ndarray, link: float) -> np.ndarray:
    """points (n, 3), mm; link : mm -> (n,) int64, the object each point belongs to: the
    connected components of the points linked within ``link`` of each other, numbered from 0 by
    size, largest first (equal sizes by their first point), the same on every run.

    >>> objects(np.array([[0., 0, 0], [5, 0, 0], [1, 0, 0], [9, 0, 0]]), 1.5).tolist()
    [0, 1, 0, 2]
    """
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    p = np.asarray(points, dtype=np.float64)
    n = p.shape[0]
    pairs = cKDTree(p).query_pairs(link, output_type="ndarray")
    graph = coo_matrix((np.ones(pairs.shape[0]), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    _, label = connected_components(graph, directed=False)
    sizes = np.bincount(label)
    first = np.full(sizes.size, n)
    np.minimum.at(first, label, np.arange(n))
    rank = np.empty(sizes.size, np.int64)
    rank[np.lexsort((first, -sizes))] = np.arange(sizes.size)
    return rank[label]


@dataclass(frozen=True)
class Selection:
    """Which measured points an inspection keeps, and why the others went.

    kept : (k,) int64 ascending indices into the points as read; n_read : the points read;
    box : the crop box (None: no crop); n_outside_box : points outside it; plane : the plane
    removed from the points inside the box (None: none removed); n_on_plane : points removed
    with it; n_objects : the objects (connected components) left on the plane, 0 when not
    looked for; n_other_objects : points of those objects that are not the part
    (engine.scene_part), dropped; object_link : mm, the distance that links two points of one
    object.
    """

    kept: np.ndarray
    n_read: int
    box: tuple[float, ...] | None = None
    n_outside_box: int = 0
    plane: Plane | None = None
    n_on_plane: int = 0
    n_objects: int = 0
    n_other_objects: int = 0
    object_link: float | None = None

    @property
    def n_kept(self) -> int:
        return int(self.kept.size)


def select_points(points: np.ndarray, box=None, remove_plane: bool = False,
                  plane_distance: float | None = None, what: str = "measured points",
                  seed: int = seeds.DEFAULT_SEED) -> Selection:
    """The points an inspection keeps: those inside ``box`` (all without one), less the
    dominant plane among them when ``remove_plane`` (:func:`dominant_plane`, with
    ``plane_distance`` mm or its default rule; ``seed``: the inspection's, engine.seeds).

    points : (n, 3) float, mm. Raises SettingsError when fewer than ``MIN_KEPT`` points are
    left (``what`` names them in the message): an inspection of nothing is no verdict.
    """
    p = np.asarray(points, dtype=np.float64)
    n = p.shape[0]
    keep = np.ones(n, bool)
    if box is not None:
        box = check_box(box)
        keep = crop_mask(p, box)
        if keep.sum() < MIN_KEPT:
            raise SettingsError(_too_few(f"inside the crop box {_box_text(box)}",
                                         int(keep.sum()), n, what, p))
    plane, on_plane = None, 0
    if remove_plane:
        check_plane_distance(plane_distance)
        inside = np.flatnonzero(keep)
        try:
            plane = dominant_plane(p[inside], plane_distance, seed=seed)
        except ValueError as e:
            raise SettingsError(f"no plane to remove from the {what}: {e}") from None
        on_plane = int(plane.inliers.sum())
        keep[inside[plane.inliers]] = False
        if keep.sum() < MIN_KEPT:
            raise SettingsError(_too_few(f"off the dominant plane (within {plane.distance:.3g} "
                                         "mm of it)", int(keep.sum()), n, what, p))
    _check_spread(p[keep], what)
    return Selection(np.flatnonzero(keep), n, box, n - int(keep.sum()) - on_plane, plane,
                     on_plane)


def _check_spread(kept: np.ndarray, what: str) -> None:
    """Raise SettingsError when the kept points are one point or lie on one line (no rigid pose
    is fixed)."""
    if not np.ptp(kept, axis=0).any():
        raise SettingsError(f"the {kept.shape[0]:,} {what} kept by the crop and plane removal "
                            "are all the same point: no pose can be found from them")
    if on_a_line(kept):
        raise SettingsError(f"the {kept.shape[0]:,} {what} kept by the crop and plane removal "
                            "lie on one straight line: no pose can be found from them")


def _too_few(where: str, left: int, n: int, what: str, p: np.ndarray) -> str:
    lo, hi = p.min(axis=0), p.max(axis=0)
    return (f"only {left:,} of the {n:,} {what} lie {where}; at least {MIN_KEPT} are needed. "
            f"The points span x {lo[0]:.6g} .. {hi[0]:.6g}, y {lo[1]:.6g} .. {hi[1]:.6g}, "
            f"z {lo[2]:.6g} .. {hi[2]:.6g} mm")


def _box_text(box) -> str:
    return "[" + " ".join(f"{v:g}" for v in box) + "]"


def extent_warning(measured: np.ndarray, nominal: np.ndarray, what: str = "measured points",
                   ratio: float = EXTENT_RATIO) -> str | None:
    """A sentence when the measured points span far more than the nominal (their bounding-box
    diagonal beyond ``ratio`` times the nominal's): the measurement holds more than the part,
    which no registration can fit; else None.

    measured : (n, 3), nominal : (m, 3) float, mm, each in its own frame (only the boxes'
    sizes are compared, not where they lie); what : the measured points in words.

    >>> extent_warning(np.array([[0, 0, 0], [1000, 0, 0.]]), np.array([[0, 0, 0], [10, 0, 0.]]))[:50]
    'the measured points span 1000 × 0 × 0 mm, the nomi'
    """
    m = np.ptp(np.asarray(measured, dtype=np.float64), axis=0)
    s = np.ptp(np.asarray(nominal, dtype=np.float64), axis=0)
    m_diagonal, s_diagonal = float(np.linalg.norm(m)), float(np.linalg.norm(s))
    if not m_diagonal > ratio * s_diagonal:
        return None
    return (f"the {what} span {_dims(m)} mm, the nominal {_dims(s)} mm "
            f"({m_diagonal / max(s_diagonal, 1e-300):.3g} x its diagonal): the "
            "measurement holds more than the part (a table, a fixture, other objects); crop "
            "them to the part (--crop XMIN YMIN ZMIN XMAX YMAX ZMAX, and --remove-plane for a "
            "table under it)")


def _dims(extent: np.ndarray) -> str:
    return " × ".join(f"{v:.4g}" for v in extent)
