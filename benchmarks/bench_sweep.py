"""Registration sweep on the real NIST parts: parts x defects x random poses, inspected at
+-0.05 mm from an arbitrary pose; prints each case and the right / INCONCLUSIVE / wrong counts.

    .venv/bin/python benchmarks/bench_sweep.py                 # every NIST file, 1 pose each
    .venv/bin/python benchmarks/bench_sweep.py --poses 3       # 3 random poses per case
    .venv/bin/python benchmarks/bench_sweep.py --parts ctc_01 ftc_06 --defects none bow1.0

The cases and the truth are tests/sweep.py's: 2,000 points area-uniform on the exact B-rep
faces, 2 µm noise (``--noise``), the defect, a random pose; the truth is the least-squares pose
started from the known pose, by Gauss-Newton on OpenCascade's exact distances. *left*: the
points the fit left out of the alignment as gross outliers. *right*: the truth's verdict and
every deviation within 0.01 mm of the truth's; *INCONCLUSIVE*: the product
said it could not tell (``pose right`` says whether its pose was right all the same); *wrong*: a
confident verdict at a wrong pose or the wrong verdict. A file the reader refuses counts as
*refused*.
"""

from __future__ import annotations

import argparse
import glob
import os
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)
sys.path.insert(0, os.path.join(ROOT, "tests"))
NIST = os.path.join(ROOT, "..", "shared", "realdata", "nist_pmi_step")


def main() -> None:
    # The arguments first: --help before the engine and OpenCascade are loaded.
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--poses", type=int, default=1)
    ap.add_argument("--parts", nargs="*", default=None, help="substrings of file names")
    ap.add_argument("--defects", nargs="*", default=None,
                    help="tests/sweep.py's DEFECTS to plant (default: every one)")
    ap.add_argument("--points", type=int, default=2000)
    ap.add_argument("--tol", type=float, default=0.05)
    ap.add_argument("--noise", type=float, default=0.002,
                    help="standard deviation of the noise along the normal, mm")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()

    import numpy as np

    from engine import warm_up
    from engine.errors import QAError
    from engine.inspection import Tolerance, inspect
    from engine.io.step import read_step
    from engine.nominal import Nominal
    from engine.step_model import ExactDistances
    from sweep import DEFECTS, judge, make_case, truth

    args.defects = list(DEFECTS) if args.defects is None else args.defects

    files = sorted(glob.glob(os.path.join(NIST, "*.stp")) + glob.glob(os.path.join(NIST, "*",
                                                                                   "*.stp")))
    if args.parts:
        files = [f for f in files if any(p in os.path.basename(f) for p in args.parts)]
    warm_up()
    counts = {"right": 0, "INCONCLUSIVE": 0, "wrong": 0, "refused": 0}
    inconclusive_right_pose = 0
    times = []
    print(f"{'file':34s} {'defect':9s} {'seed':>4s} {'verdict':12s} {'truth':7s} "
          f"{'max err mm':>10s} {'s':>6s} {'left':>5s}  outcome")
    for path in files:
        name = os.path.basename(path)
        try:
            t0 = time.perf_counter()
            part = read_step(path)
            load = time.perf_counter() - t0
        except QAError as e:
            counts["refused"] += len(args.defects) * args.poses
            print(f"{name:34s} refused: {e}")
            continue
        print(f"{name:34s} read in {load:.2f} s, {part.n_faces} faces, "
              f"{part.point_set.n} tessellation points")
        for defect in args.defects:
            for k in range(args.poses):
                seed = args.seed + 1000 * k + DEFECTS.index(defect) if defect in DEFECTS \
                    else args.seed + k
                case = make_case(part, defect, seed, n=args.points, noise=args.noise)
                d_true = truth(part, case)
                t0 = time.perf_counter()
                nominal = Nominal.from_point_set(part.point_set)
                res = inspect(nominal, case["measured"], Tolerance.symmetric(args.tol),
                              surface=ExactDistances(part, nominal))
                dt = time.perf_counter() - t0
                times.append(dt)
                outcome, err = judge(res, d_true, args.tol)
                counts[outcome] += 1
                if outcome == "INCONCLUSIVE" and err <= 0.01:
                    inconclusive_right_pose += 1
                expected = "ACCEPT" if np.all(np.abs(d_true) <= args.tol) else "REJECT"
                why = "" if outcome == "right" else "  " + "; ".join(res.reasons)[:110]
                left = int(res.outlier.sum())  # points the fit left out as gross outliers
                print(f"{name:34s} {defect:9s} {seed:4d} {res.verdict:12s} {expected:7s} "
                      f"{err:10.4f} {dt:6.2f} {left:5d}  {outcome}{why}", flush=True)
    n = sum(counts.values())
    print(f"\n{n} cases: {counts['right']} right, {counts['INCONCLUSIVE']} INCONCLUSIVE "
          f"({inconclusive_right_pose} of them at the right pose), {counts['wrong']} wrong, "
          f"{counts['refused']} refused")
    if times:
        print(f"inspection time per case: median {np.median(times):.2f} s, "
              f"max {np.max(times):.2f} s")


if __name__ == "__main__":
    main()
