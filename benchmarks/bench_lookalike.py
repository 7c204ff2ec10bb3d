"""Look-alike poses: a 50 mm cube whose faces fit at 24 poses, told apart only by a small boss on
its top, sampled at random as bare points, measured in random poses; prints each case and the
right / INCONCLUSIVE / wrong counts.

    .venv/bin/python benchmarks/bench_lookalike.py                       # seeds 1-40, an R2 boss
    .venv/bin/python benchmarks/bench_lookalike.py --seeds 100 200 --radius 1.5

The cases are tests/surfaces.py's ``cube_with_small_boss``: 10,000 nominal points a face and
3,000 on the boss; 300 measured points on each of four faces and about a dozen on the boss,
1 µm of noise; a good part, so the truth is ACCEPT at the known pose. *right*: ACCEPT with
every registered point within 0.005 mm of its true place; *INCONCLUSIVE*: the product said it
could not tell; *wrong*: anything else (a REJECT of the good part, at a wrong pose or not).
"""

from __future__ import annotations

import argparse
import os
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)
sys.path.insert(0, os.path.join(ROOT, "tests"))

RIGHT_MM = 0.005


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seeds", nargs=2, type=int, default=(1, 41), metavar=("FIRST", "END"))
    ap.add_argument("--radius", type=float, default=2.0, help="the boss's radius, mm")
    ap.add_argument("--tol", type=float, default=0.025)
    args = ap.parse_args()

    import numpy as np

    from engine import warm_up
    from engine.inspection import Tolerance, inspect
    from engine.nominal import Nominal
    from engine.pose import apply_transform, make_transform
    from surfaces import cube_with_small_boss, point_set, random_rotation

    warm_up()
    counts = {"right": 0, "INCONCLUSIVE": 0, "wrong": 0}
    times = []
    print(f"{'seed':>5} {'points':>6} {'on boss':>7} {'verdict':<12} {'pose err mm':>11} "
          f"{'s':>6}  outcome")
    for seed in range(*args.seeds):
        rng = np.random.default_rng(seed)
        pts, nrm, q = cube_with_small_boss(rng, radius=args.radius)
        on_boss = int(np.sum(q[:, 2] > 50.0 + 0.05 * args.radius))
        measured = apply_transform(make_transform(random_rotation(rng),
                                                  rng.uniform(-300, 300, 3)), q)
        t0 = time.perf_counter()
        res = inspect(Nominal.from_point_set(point_set(pts, nrm)), measured,
                      Tolerance.symmetric(args.tol))
        times.append(time.perf_counter() - t0)
        T = res.registration.T_nominal_measured
        err = float(np.max(np.linalg.norm(apply_transform(T, measured) - q, axis=1)))
        outcome = ("INCONCLUSIVE" if res.verdict == "INCONCLUSIVE" else
                   "right" if res.verdict == "ACCEPT" and err <= RIGHT_MM else "wrong")
        counts[outcome] += 1
        print(f"{seed:>5} {len(q):>6} {on_boss:>7} {res.verdict:<12} {err:>11.4f} "
              f"{times[-1]:>6.2f}  {outcome}", flush=True)
    print(f"\n{sum(counts.values())} cases: {counts['right']} right, "
          f"{counts['INCONCLUSIVE']} INCONCLUSIVE, {counts['wrong']} wrong")
    print(f"inspection time per case (nominal structures included): median "
          f"{float(np.median(times)):.2f} s, max {max(times):.2f} s")


if __name__ == "__main__":
    main()
