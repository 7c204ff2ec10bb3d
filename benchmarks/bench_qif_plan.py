"""QIF plans: reading a QIF 3.0 MBD into the plan and matching its features to the STEP
nominal's faces; prints a table.

    .venv/bin/python benchmarks/bench_qif_plan.py

"read" is engine.io.qif_plan reading the QIF (safe XML parse, units, features, datums,
characteristics, the faces of the features the plan uses); "map" is matching those faces to
the STEP model's (engine.io.qif_faces), the STEP model already read (its reading, "step", is
the nominal's load, which a run pays with or without a plan). Each is timed from a cold cache
of the QIF document (the first read in a process), median of 3. Issue 25's target: FTC-06's
plan (a 3 MB QIF) read and mapped within 3 s.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)
REAL = os.path.join(ROOT, "..", "shared", "realdata")
PARTS = [("NISTmodels__nist_ctc_01_asme1_ap242.qif", "nist_ctc_01_asme1_ap242-e1.stp"),
         ("NISTmodels__nist_ctc_03_asme1_ap242.qif", "nist_ctc_03_asme1_ap242-e2.stp"),
         ("NISTmodels__nist_ctc_05_asme1_ap242.qif", "nist_ctc_05_asme1_ap242-e1.stp"),
         ("NISTmodels__nist_ftc_06_asme1_ap242.qif", "nist_ftc_06_asme1_ap242-e1.stp"),
         ("NISTmodels__nist_ftc_08_asme1_ap242-1.qif", "nist_ftc_08_asme1_ap242-e1.stp")]


def case(qif: str, stp: str) -> dict:
    from engine.io import qif_plan
    from engine.io.step import read_step

    t0 = time.perf_counter()
    step = read_step(os.path.join(REAL, "nist_pmi_step", "ap242", stp))
    step_s = time.perf_counter() - t0
    path = os.path.join(REAL, "qif_samples", qif)
    reads, maps = [], []
    for _ in range(3):
        qif_plan.parse_qif.cache_clear()  # a cold read each time
        t0 = time.perf_counter()
        plan = qif_plan.read_qif_plan(path)
        t1 = time.perf_counter()
        groups = qif_plan.qif_face_groups(path, step)
        t2 = time.perf_counter()
        reads.append(t1 - t0)
        maps.append(t2 - t1)
    return {"part": qif.split("__nist_")[1].split("_asme")[0].upper(),
            "MB": os.path.getsize(path) / 1e6, "step": step_s, "read": statistics.median(reads),
            "map": statistics.median(maps), "n": plan.n_source,
            "judged": len({c.id.split(".")[0] for c in plan.characteristics}),
            "faces": len({f for v in groups.values() for f in v})}


def main() -> None:
    argparse.ArgumentParser(description=__doc__,
                            formatter_class=argparse.RawDescriptionHelpFormatter).parse_args()
    print(f"{'part':8} {'QIF MB':>6} {'step s':>7} {'read s':>7} {'map s':>6} "
          f"{'read+map':>8} {'chars':>5} {'judged':>6} {'faces':>5}")
    for qif, stp in PARTS:
        r = case(qif, stp)
        print(f"{r['part']:8} {r['MB']:6.2f} {r['step']:7.2f} {r['read']:7.2f} {r['map']:6.2f} "
              f"{r['read'] + r['map']:8.2f} {r['n']:5d} {r['judged']:6d} {r['faces']:5d}")


if __name__ == "__main__":
    main()
