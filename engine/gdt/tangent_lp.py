"""The linear program of a tangent datum simulator (engine.gdt.datums): where its small motion
puts the simulator against the datum's points, solved over the few points that bind it.

The program has two rows per point (none beyond the simulator, none farther inside than the
largest gap), but at its optimum only a handful bind: the highest points and the lowest. It is
solved by constraint generation: over a working set of rows (the highest and lowest points),
then again with every row its solution breaks added, until the solution keeps every row. The
optimum of a program over some of the rows that keeps all of them is the optimum over all of
them, so the answer is the full program's, in a few programs of a few dozen rows instead of
one of thousands (a bootstrap of a 40,000-point plan's frames solved 908 such programs: 58 s).
"""

from __future__ import annotations

import numpy as np

START_ROWS = 32
"""The working set starts with this many highest and as many lowest points (at least
4 x the unknowns)."""
KEPT = 1e-9
"""A row is broken when the solution exceeds it by more than this, in units of the largest
deviation (the solver's own feasibility tolerance is 1e-7)."""


def tangent_solve(A: np.ndarray, d: np.ndarray, size: bool, radius: float, settle: float,
                  ties: bool = True) -> np.ndarray | None:
    """[eta (r), s, g] (mm): the motion eta within +-radius along the directions whose effect
    on the deviations d (m,) is A (m, r), the simulator's offset s (a size feature's; 0 for a
    plane or line) and the largest gap g. A plane or line minimises g with no point beyond it
    (d + A eta <= 0); a size feature minimises s with d + A eta <= s. Where several motions
    reach that optimum, the one with the smallest sum of gaps is taken (unless not ``ties``:
    noisy points leave none). None when the program fails."""
    m, r = A.shape
    # In units of the largest deviation, so that the solver's feasibility tolerance (1e-7)
    # is relative to the deviations, however small they have become.
    unit = max(float(np.max(np.abs(d))), settle)
    ds = d / unit
    # Variables [eta (r), s, g]; d + A eta - s <= 0 and s - d - A eta - g <= 0.
    ones = np.ones((m, 1))
    A_ub = np.block([[A, -ones, np.zeros((m, 1))], [-A, ones, -ones]])
    b_ub = np.concatenate([-ds, ds])
    primary = np.zeros(r + 2)
    primary[r if size else r + 1] = 1.0
    bounds = [(-radius / unit, radius / unit)] * r + \
        [(None, None) if size else (0.0, 0.0), (0.0, None)]
    k = min(m, max(START_ROWS, 4 * (r + 2)))
    order = np.argsort(ds, kind="stable")
    start = np.concatenate([order[-k:], m + order[:k]])  # the highest's upper rows, lowest's gaps
    sol, rows = _generated(primary, A_ub, b_ub, bounds, start)
    if sol is None:
        return None
    if not ties:
        return sol.x * unit
    # Among the optima: the smallest sum of gaps sum(s - d - A eta).
    gaps = np.concatenate([-A.sum(axis=0), [m, 0.0]])
    tie, _ = _generated(gaps, A_ub, b_ub, bounds, rows, (primary, sol.fun + 1e-9))
    return (tie.x if tie is not None else sol.x) * unit


def _generated(c, A_ub, b_ub, bounds, rows, extra=None):
    """(solution, rows): scipy's linprog (HiGHS) of min c x over the rows ``rows`` of A_ub x <=
    b_ub (and the one row ``extra`` = (a, b): a x <= b), grown by every row the solution breaks
    (by more than KEPT) until it breaks none; (None, rows) when a program fails."""
    from scipy.optimize import linprog

    rows = np.unique(rows)
    while True:
        A, b = A_ub[rows], b_ub[rows]
        if extra is not None:
            A, b = np.vstack([A, extra[0]]), np.append(b, extra[1])
        sol = linprog(c, A_ub=A, b_ub=b, bounds=bounds, method="highs")
        if sol.status != 0:
            return None, rows
        broken = np.setdiff1d(np.flatnonzero(A_ub @ sol.x - b_ub > KEPT), rows)
        if broken.size == 0:
            return sol, rows
        rows = np.union1d(rows, broken)
