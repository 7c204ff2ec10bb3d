"""What judging the verdict's pose sensitivity costs (engine.pose_sensitivity); prints a table.

    .venv/bin/python benchmarks/bench_trust.py

Cases whose pose the measurement does not fix (a cylinder measured all round: translation along
and rotation about its axis are free) against one where it does (the belly-fairing surface
measured all over). "sensitivity s" is the time spent moving the part along its free and weak
directions, to the runner-up pose and over the pose-uncertainty region, and re-judging it there
(``timings_s["pose_sensitivity"]``); "engine s" the whole inspection (nominal built outside).
"""

from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)


def cylinder(n_measured: int, seed: int = 4):
    from engine.pose import apply_transform, make_transform
    from engine.nominal import Nominal
    from engine.pointset import PointSet

    a = np.linspace(0, 2 * np.pi, 720, endpoint=False)
    z = np.linspace(-100, 100, 200)
    A, Z = np.meshgrid(a, z)
    pts = np.column_stack([40 * np.cos(A.ravel()), 40 * np.sin(A.ravel()), Z.ravel()])
    nrm = np.column_stack([np.cos(A.ravel()), np.sin(A.ravel()), np.zeros(A.size)])
    nominal = Nominal.from_point_set(PointSet(pts, nrm, None, (720, 200), None, 3, "<bench>"))
    rng = np.random.default_rng(seed)
    t = rng.uniform(0, 2 * np.pi, n_measured)
    r = 40 + rng.uniform(-0.012, 0.012, n_measured)
    q = np.column_stack([r * np.cos(t), r * np.sin(t), rng.uniform(-60, 60, n_measured)])
    c, s = np.cos(0.7), np.sin(0.7)
    R = np.array([[1, 0, 0], [0, c, -s], [0, s, c]])
    return nominal, apply_transform(make_transform(R, [300.0, -20.0, 55.0]), q)


def fairing():
    from engine.nominal import Nominal
    from engine.io import load_point_set

    folder = os.path.join(ROOT, "samples", "belly_fairing")
    nominal = Nominal.from_point_set(load_point_set(os.path.join(folder, "nominal.csv")))
    return nominal, load_point_set(os.path.join(folder, "measured.csv")).points


def main() -> None:
    from engine.inspection import Tolerance, inspect

    cases = [("belly fairing sample, 1,100 pts (all fixed)", fairing, 0.25),
             ("cylinder 144k grid, 1,000 pts (2 free)", lambda: cylinder(1000), 0.05),
             ("cylinder 144k grid, 20,000 pts (2 free)", lambda: cylinder(20000), 0.05),
             ("cylinder 144k grid, 200,000 pts (2 free)", lambda: cylinder(200000), 0.05)]
    print("| case | engine s | sensitivity s | probes | verdict |\n|---|---|---|---|---|")
    for name, make, tol in cases:
        nominal, measured = make()
        t = time.perf_counter()
        res = inspect(nominal, measured, Tolerance.symmetric(tol))
        total = time.perf_counter() - t
        sens = res.pose_sensitivity
        n_probes = 0 if sens is None else len(sens.probes)
        print(f"| {name} | {total:.3f} | {res.timings_s.get('pose_sensitivity', 0.0):.3f} | "
              f"{n_probes} | {res.verdict} |")


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    return p.parse_args(argv)  # no arguments: --help, and a stray one refused before any work


if __name__ == "__main__":
    parse_args()
    main()
