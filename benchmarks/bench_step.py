"""STEP nominals: reading, and inspection with exact B-rep deviations; prints a table.

    .venv/bin/python benchmarks/bench_step.py            # the three NIST parts, 2,000 points
    .venv/bin/python benchmarks/bench_step.py --large    # and CTC-01 with 200,000 points

"load" is OpenCascade's import (first file only), reading, healing and tessellating the model;
"engine" is building the nominal's structures on the tessellation, registration from a random
pose, the least-squares finish on the exact deviations and judging (what `qa-inspect inspect`
does after loading). Measured points lie on the model's faces (random points of its
tessellation's triangles carried onto the B-rep), moved along the exact normal by N(0, 0.01) mm;
"max error" compares the deviations found with those planted (their rigid-motion share removed,
which any least-squares fit takes out).
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
NIST = os.path.join(ROOT, "..", "shared", "realdata", "nist_pmi_step")
FILES = ["nist_ctc_01_asme1_ap203.stp", "nist_ctc_05_asme1_ap203.stp",
         "nist_ftc_06_asme1_rd.stp"]


def case(path: str, n: int) -> dict:
    from engine.inspection import Tolerance, inspect
    from engine.nominal import Nominal
    from engine.io.step import read_step
    from engine.step_model import ExactDistances
    from test_step_inspection import measured_on

    t0 = time.perf_counter()
    part = read_step(path)
    t1 = time.perf_counter()
    M, planted, _ = measured_on(part, np.random.default_rng(7), n=n)
    t2 = time.perf_counter()
    nominal = Nominal.from_point_set(part.point_set)
    res = inspect(nominal, M, Tolerance.symmetric(0.05), surface=ExactDistances(part, nominal))
    t3 = time.perf_counter()
    return {"faces": part.n_faces, "tess": part.point_set.n, "load": t1 - t0,
            "engine": t3 - t2, "points": len(M), "verdict": res.verdict,
            "err": float(np.max(np.abs(res.deviations.signed - planted)))}


def main(large: bool = False) -> None:
    from engine import warm_up

    warm_up()
    rows = [(f, case(os.path.join(NIST, f), 2000)) for f in FILES]
    if large:
        rows.append((FILES[0], case(os.path.join(NIST, FILES[0]), 200_000)))
    print(f"{'file':32s} {'faces':>5s} {'tess pts':>8s} {'load s':>7s} {'points':>7s} "
          f"{'engine s':>8s} {'max error mm':>12s}  verdict")
    for f, r in rows:
        print(f"{f:32s} {r['faces']:5d} {r['tess']:8d} {r['load']:7.2f} {r['points']:7d} "
              f"{r['engine']:8.2f} {r['err']:12.2e}  {r['verdict']}")


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--large", action="store_true",
                   help="and CTC-01 with 200,000 points")
    return p.parse_args(argv)


if __name__ == "__main__":
    main(parse_args().large)
