"""Nearest-neighbour queries (scipy's cKDTree): how many threads a query is worth."""

from __future__ import annotations

PARALLEL_QUERIES = 20000
"""A kd-tree query of fewer points runs on one thread: starting the threads costs more than
they save (a plan's datum fits query a few dozen points, many times)."""


def query_workers(n_queries: int) -> int:
    """The ``workers`` argument of cKDTree.query for ``n_queries`` points: all cores (-1) for
    large queries, one thread below PARALLEL_QUERIES. The answer does not depend on it."""
    return -1 if n_queries >= PARALLEL_QUERIES else 1
