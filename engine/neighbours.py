"""Nearest-neighbour queries: a scipy cKDTree query on as many threads as it is worth
(:func:`query`), the points that coincide exactly (:func:`coincident_pairs`), and the
constant-time nearest-sample lookup of the global search's coarse level
(:class:`SampleLookup`)."""

from __future__ import annotations

import contextlib
import signal
from dataclasses import dataclass

import numpy as np

from . import icp_kernels
from .seeds import DEFAULT_SEED, rng

PARALLEL_QUERIES = 1024
"""A kd-tree query of fewer points runs on one thread: starting the threads costs more than
they save (a plan's datum fits query a few dozen points, many times). From 2,048 down to 1,024
(2026-12-07, 2 cores): the belly fairing's 1,100 points, whole inspection, 0.263-0.276 s ->
0.222-0.265 s; NIST FTC-06 (AP242) bowed 1 mm, 2,000 points (4 neighbours among 1.33 million
samples, 3.9 ms on one thread, 3.3 ms on two), 1.56-1.59 s -> 1.32-1.48 s."""


def query_workers(n_queries: int) -> int:
    """The ``workers`` argument of cKDTree.query for ``n_queries`` points: all cores (-1) for
    large queries, one thread below PARALLEL_QUERIES. The answer does not depend on it."""
    return -1 if n_queries >= PARALLEL_QUERIES else 1


def query(tree, pts: np.ndarray, k: int = 1, **options):
    """tree.query(pts, k, **options) (a scipy cKDTree) on all cores for large queries
    (:func:`query_workers`). Ctrl-C during a query on several threads is held back until the
    query ends: interrupted in its wait for them, scipy's worker threads went on reading the
    arrays the unwinding freed, and the process crashed (exit 139 after "interrupted")."""
    workers = query_workers(len(pts))
    if workers == 1:
        return tree.query(pts, k=k, workers=1, **options)
    with _interrupt_held():
        return tree.query(pts, k=k, workers=workers, **options)


@contextlib.contextmanager
def _interrupt_held():
    """SIGINT held back during the block, then handled as it would have been (in the main
    thread; elsewhere no signal reaches Python code, and nothing is held)."""
    held: list = []
    try:
        previous = signal.signal(signal.SIGINT, lambda signum, frame: held.append(frame))
    except ValueError:  # not the main thread
        yield
        return
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)
        if held:
            if callable(previous):
                previous(signal.SIGINT, held[0])
            elif previous == signal.SIG_DFL:
                signal.raise_signal(signal.SIGINT)


def coincident_pairs(points: np.ndarray, candidates: np.ndarray | None = None) -> np.ndarray:
    """(k, 2) int64 pairs (representative, copy) of the points (n, 3) with exactly the same
    coordinates, among ``candidates`` (indices; None: all): a mesh written face by face (a STEP
    tessellation, an STL) or a closed grid's seam repeats its shared vertices. The
    representative is the lowest-numbered point of its coordinates. Equal means the same bits:
    -0.0 is not 0.0 (welding those too turned a grid's pole row, written with both, into one
    that no longer registered). One sort of the coordinates' bits.

    >>> coincident_pairs(np.array([[1., 2, 3], [0, 0, 0], [1, 2, 3], [-0., 0, 0]])).tolist()
    [[0, 2]]
    """
    cand = np.arange(points.shape[0]) if candidates is None else np.asarray(candidates)
    bits = np.ascontiguousarray(points[cand]).view(np.uint64).reshape(-1, 3)
    # Equal points end up in runs (a stable sort keeps each run in index order, so its first
    # point, the representative, has the lowest).
    order = np.lexsort((bits[:, 2], bits[:, 1], bits[:, 0]))
    b = bits[order]
    new_run = np.ones(len(b), dtype=bool)
    new_run[1:] = np.any(b[1:] != b[:-1], axis=1)
    if new_run.all():
        return np.zeros((0, 2), np.int64)
    rep = cand[order[np.flatnonzero(new_run)[np.cumsum(new_run) - 1]]]
    copy = cand[order]
    return np.column_stack([rep, copy])[rep != copy].astype(np.int64)


LOOKUP_CELLS = 32768
"""Cells of a :class:`SampleLookup` grid at most: its build (a Euclidean distance transform over
the cells) then costs a few milliseconds."""
LOOKUP_NEIGHBOURS = 8
"""Neighbours per sample in a :class:`SampleLookup`'s graph (the walk's steps)."""


@dataclass(frozen=True)
class SampleLookup:
    """Constant-time nearest-sample pairing for a small, fixed set of samples (a coarse level of
    the nominal), for the compiled ICP of the global search (``icp_kernels.icp_poses``), which pairs
    some 10^5 points with a 10^3-sample level: scipy's kd-tree answers each in about 0.5 us, this
    in a few tens of nanoseconds.

    A point's cell (clamped to the grid) gives a sample near the cell's centre
    (``icp_kernels.cell_owners``, a distance transform over the grid); from there the pairing
    walks the samples' graph of ``LOOKUP_NEIGHBOURS`` nearest others (scipy's kd-tree) to a
    neighbour nearer the point while there is one. The walk ends at a sample that no graph
    neighbour beats: the nearest sample itself but for unusual layouts (a point far off the
    samples, nearly as near to two separate parts of them), where it is a near one.

    lo (3,) the grid's first corner, cell its edge (mm); owner (nx, ny, nz) int32 sample per
    cell; graph (L, LOOKUP_NEIGHBOURS) int32 each sample's nearest others."""

    lo: np.ndarray
    cell: float
    owner: np.ndarray
    graph: np.ndarray

    @classmethod
    def build(cls, pts: np.ndarray, tree, spacing: float) -> "SampleLookup":
        """The lookup of samples ``pts`` (L, 3) with their kd-tree and typical ``spacing`` (mm,
        may be 0): the grid covers their box and 4 spacings around it, in cells of half a
        spacing or, where that would exceed ``LOOKUP_CELLS`` cells, larger ones."""
        margin = 4.0 * spacing
        lo = pts.min(axis=0) - margin
        size = pts.max(axis=0) + margin - lo
        # Cells of half a spacing, larger where the box would need too many, and never below
        # 1/1024 of the box's longest side (samples all in one plane and no spacing, as with
        # points stored twice, give no volume to divide).
        cell = max(0.5 * spacing, float(np.cbrt(np.prod(size) / LOOKUP_CELLS)),
                   float(np.max(size)) / 1024.0, 1e-9)
        while np.prod(np.maximum(np.ceil(size / cell), 1.0)) > LOOKUP_CELLS:  # float: no overflow
            cell *= 1.05
        shape = np.maximum(np.ceil(size / cell).astype(np.int64), 1)
        # Each cell's owner: a sample near its centre (icp_kernels.cell_owners; scipy.ndimage's
        # distance transform did it before, but importing scipy.ndimage alone cost a cold
        # process 0.3-0.4 s, and a kd-tree query per cell 60 ms a lookup).
        owner = icp_kernels.cell_owners(np.ascontiguousarray(pts, np.float64), lo, float(cell),
                                        *(int(v) for v in shape))
        k = min(LOOKUP_NEIGHBOURS + 1, len(pts))
        _, nb = tree.query(pts, k=k)
        graph = np.ascontiguousarray(np.asarray(nb).reshape(len(pts), k)[:, 1:], np.int32)
        return cls(lo.astype(np.float64), float(cell), owner, graph)


SPREAD_SEED = 7
"""The random stream of :func:`spread_subset`'s subsets (engine.seeds)."""


def spread_subset(pts: np.ndarray, m: int, seed: int = DEFAULT_SEED) -> np.ndarray:
    """Indices of up to ``m`` points spread over ``pts``: farthest-point sampling for small ``m``,
    a seeded random subset for large ``m`` (where it spreads well enough and costs nothing);
    ``seed``: the inspection's (engine.seeds)."""
    n = pts.shape[0]
    if n <= m:
        return np.arange(n)
    if m > 128:
        return np.sort(rng(seed, SPREAD_SEED).choice(n, m, replace=False))
    pool = np.arange(n)
    if n > 8192:
        pool = np.sort(rng(seed, SPREAD_SEED).choice(n, 8192, replace=False))
    P = np.ascontiguousarray(pts[pool], np.float64)
    return np.sort(pool[icp_kernels.farthest_points(P, P.mean(0), m)])


def voxel_spread(pts: np.ndarray, voxel: float, cap: int) -> np.ndarray:
    """Indices (ascending) of one point of ``pts`` (n, 3) per occupied voxel of edge ``voxel``
    mm (the one nearest the voxel's centre), the voxel grown 1.25-fold until at most ``cap``
    remain: points spread by area over a surface, whatever its shape."""
    voxel = max(voxel, 1e-9)
    lo = pts.min(axis=0)
    while True:
        cell = np.floor((pts - lo) / voxel).astype(np.int64)
        centre = lo + (cell + 0.5) * voxel
        d = np.linalg.norm(pts - centre, axis=1)
        order = np.lexsort((d, cell[:, 2], cell[:, 1], cell[:, 0]))
        c = cell[order]
        first = order[np.r_[True, np.any(c[1:] != c[:-1], axis=1)]]
        if first.size <= cap:
            return np.sort(first)
        voxel *= 1.25
