"""How often the registration finds the right pose from arbitrary poses, and how long it takes.

    .venv/bin/python benchmarks/bench_poses.py          # every family (about 3 minutes)
    .venv/bin/python benchmarks/bench_poses.py cube     # one family

A speed-up of the global search must not cost a single right pose: run this before and after.
Each family is built as in tests/test_registration.py, over many more seeds than the tests use:

* "cube+boss": a 50 mm cube whose faces fit at 24 poses and whose hemispherical boss (a quarter
  of the ~110 measured points) tells the right one (the tests' ``_cube_with_boss``), 40 seeds;
  right = every point within 0.005 mm of its true place and the part ACCEPTed at +-0.025 mm;
* "fairing full / quarter / tenth": the belly-fairing surface (60k grid points) measured all
  over (1,100 points), on a quarter (400) or a tenth (400) of it, 12 seeds each; right = within
  0.01 / 0.03 / 0.3 mm (a small patch of a smooth surface slides a little along its weak
  directions);
* "bracket 2 faces": the seat bracket (60k points) measured on two curved faces, 12 seeds;
  right = within 0.02 mm.

Prints, per family: cases, right poses, and the median and largest registration time.
"""

from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)
sys.path.insert(0, os.path.join(ROOT, "tests"))


def _error(T, measured, truth):
    from engine.pose import apply_transform
    return float(np.max(np.linalg.norm(apply_transform(T, measured) - truth, axis=1)))


def cube(seeds):
    from engine.pose import apply_transform, make_transform
    from engine.inspection import Tolerance, inspect
    from surfaces import random_rotation
    import test_registration as tr

    for seed in seeds:
        rng = np.random.default_rng(seed)
        nominal = tr._cube_with_boss(rng)
        q = tr._cube_measured(rng)
        T = make_transform(random_rotation(rng), rng.uniform(-300, 300, 3))
        measured = apply_transform(T, q)
        t0 = time.perf_counter()
        res = inspect(nominal, measured, Tolerance.symmetric(0.025))
        seconds = time.perf_counter() - t0
        err = _error(res.registration.T_nominal_measured, measured, q)
        yield seed, err < 0.005 and res.verdict == "ACCEPT", seconds, err


def fairing(coverage, seeds):
    from engine.pose import apply_transform
    from engine.nominal import Nominal
    from engine.registration import register
    from surfaces import height_grid, point_set
    import test_registration as tr

    pts, nrm, grid = height_grid(300, 200)
    nominal = Nominal.from_point_set(point_set(pts, nrm, grid))
    m, xr, yr = tr.COVERAGE[coverage]
    limit = {"full": 0.01, "quarter": 0.03, "tenth": 0.3}[coverage]
    for seed in seeds:
        rng = np.random.default_rng(1000 + seed)
        q = tr._patch(rng, m, xr, yr)
        measured = apply_transform(tr._pose(rng), q)
        t0 = time.perf_counter()
        res = register(nominal, measured)
        seconds = time.perf_counter() - t0
        err = _error(res.T_nominal_measured, measured, q)
        yield seed, bool(res.converged and err < limit), seconds, err


def bracket(seeds):
    from engine.pose import apply_transform
    from engine.registration import register
    from surfaces import bracket_two_faces
    import test_registration as tr

    rng = np.random.default_rng(21)
    nominal, q, _ = bracket_two_faces(rng, 60_000)
    for seed in seeds:
        measured = apply_transform(tr._pose(np.random.default_rng(seed)), q)
        t0 = time.perf_counter()
        res = register(nominal, measured)
        seconds = time.perf_counter() - t0
        err = _error(res.T_nominal_measured, measured, q)
        yield seed, bool(res.converged and err < 0.02), seconds, err


FAMILIES = {
    "cube+boss": lambda: cube(range(1, 41)),
    "fairing full": lambda: fairing("full", range(1, 13)),
    "fairing quarter": lambda: fairing("quarter", range(1, 13)),
    "fairing tenth": lambda: fairing("tenth", range(1, 13)),
    "bracket 2 faces": lambda: bracket(range(1, 13)),
}


def main(names: list[str]) -> int:
    """names : substrings of the families' names to run (none: every family)."""
    from engine.deviation import point_to_surface  # noqa: F401  (compiled kernels loaded first)

    wanted = [f for f in FAMILIES if not names or any(a in f for a in names)]
    print("| family | cases | right poses | wrong (seed: error mm) | median s | max s |")
    print("|---|---|---|---|---|---|")
    for name in wanted:
        rows = list(FAMILIES[name]())
        wrong = [f"{s}: {e:.3g}" for s, ok, _, e in rows if not ok]
        secs = [t for _, _, t, _ in rows]
        print(f"| {name} | {len(rows)} | {len(rows) - len(wrong)} | {', '.join(wrong) or '-'} | "
              f"{np.median(secs):.3f} | {max(secs):.3f} |", flush=True)
    return 0


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("families", nargs="*", metavar="FAMILY",
                   help=f"part of a family's name ({', '.join(FAMILIES)}); none: every family")
    return p.parse_args(argv)


if __name__ == "__main__":
    sys.exit(main(parse_args().families))
