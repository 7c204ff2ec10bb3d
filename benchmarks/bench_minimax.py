"""The minimax (tolerance) fit's cost on top of the least-squares fit; prints a table.

    .venv/bin/python benchmarks/bench_minimax.py

Cases: the belly-fairing sample (60k grid, 1,100 CMM points, a planted dent) at a zone of
±0.12 mm, where the least-squares pose rejects and the minimax pose places the part, and the
fuselage-frame template (500 points). Engine time only (files read before timing; compiled
kernels loaded by a first run).
"""

from __future__ import annotations

import argparse
import os
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)


def main() -> None:
    from engine.inspection import inspect, inspect_2d
    from engine.nominal import Nominal
    from engine.tolerance import Tolerance
    from engine.io import load_point_set
    from engine.io.templates import read_dxf_template

    belly = os.path.join(ROOT, "samples", "belly_fairing")
    nominal = Nominal.from_point_set(load_point_set(os.path.join(belly, "nominal.csv")))
    measured = load_point_set(os.path.join(belly, "measured.csv")).points
    frame = os.path.join(ROOT, "samples", "fuselage_frame")
    tpl = read_dxf_template(os.path.join(frame, "template.dxf")).template
    fm = load_point_set(os.path.join(frame, "measured.csv"))
    cases = [("belly fairing 60k / 1,100 pts, ±0.12",
              lambda fit: inspect(nominal, measured, Tolerance.symmetric(0.12), fit=fit)),
             ("fuselage frame DXF / 500 pts, ±0.02",
              lambda fit: inspect_2d(tpl, fm.points, fm.dim, Tolerance.symmetric(0.02), fit=fit))]
    print("| case | lsq s | minimax s | minimax extra s | LPs | max excursion lsq → minimax "
          "| verdict lsq → minimax |")
    print("|---|---|---|---|---|---|---|")
    for name, run in cases:
        run("lsq")  # compiled kernels, caches
        t = time.perf_counter()
        a = run("lsq")
        t_l = time.perf_counter() - t
        t = time.perf_counter()
        b = run("minimax")
        t_m = time.perf_counter() - t
        mm = b.extra["minimax"]
        print(f"| {name} | {t_l:.3f} | {t_m:.3f} | {t_m - t_l:.3f} | {mm['linear_programs']} | "
              f"{mm['least_squares_excursion']:.3f} → {mm['excursion']:.3f} | "
              f"{a.verdict} → {b.verdict} |")


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    return p.parse_args(argv)  # no arguments: --help, and a stray one refused before any work


if __name__ == "__main__":
    parse_args()
    main()
