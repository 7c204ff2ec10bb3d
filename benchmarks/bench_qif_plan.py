"""QIF plans: reading a QIF 3.0 MBD into the plan and matching its features to the STEP
nominal's faces; prints a table.

    .venv/bin/python benchmarks/bench_qif_plan.py

"read" is engine.io.qif_plan reading the QIF (safe XML parse, units, features, datums,
characteristics, the faces of the features the plan uses); "map" is matching those faces to
the STEP model's (engine.io.qif_faces), the STEP model already read (its reading, "step", is
the nominal's load, which a run pays with or without a plan). Each is timed from a cold cache
of the QIF document (the first read in a process), median of 3. Issue 25's target: FTC-06's
plan (a 3 MB QIF) read and mapped within 3 s.

    .venv/bin/python benchmarks/bench_qif_plan.py --judge 40000

With ``--judge N``: each part's plan judged on N points spread area-uniformly on its exact faces
(0.1 µm of noise along their normals, seed 3) in a random pose (seed 5, and 6, 7 … with
``--poses K``), a whole
engine.inspect_files run: its seconds, and how many characteristics came out ACCEPT /
INCONCLUSIVE / REJECT (a perfect part: every judged one should ACCEPT, or be INCONCLUSIVE with
its reason).
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


def judged(qif: str, stp: str, n: int, pose: int = 5) -> dict:
    import tempfile

    import numpy as np

    from engine import inspect_files, warm_up
    from engine.io.step import read_step
    from step_models import random_pose
    from sweep import on_part

    warm_up()
    nominal = os.path.join(REAL, "nist_pmi_step", "ap242", stp)
    step = read_step(nominal)
    rng = np.random.default_rng(3)
    P, N, _ = on_part(step, rng, n)
    P = P + rng.normal(0.0, 1e-4, len(P))[:, None] * N
    R, t = random_pose(pose)
    with tempfile.TemporaryDirectory() as tmp:
        measured = os.path.join(tmp, "m.csv")
        np.savetxt(measured, P @ R.T + t, delimiter=",", header="x,y,z", comments="",
                   fmt="%.9f")
        t0 = time.perf_counter()
        run = inspect_files(nominal, measured, plan=os.path.join(REAL, "qif_samples", qif))
        seconds = time.perf_counter() - t0
    verdicts = [str(c.verdict) for c in run.result.plan.characteristics]
    return {"part": qif.split("__nist_")[1].split("_asme")[0].upper(), "s": seconds,
            **{v: verdicts.count(v) for v in ("ACCEPT", "INCONCLUSIVE", "REJECT")}}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--judge", type=int, metavar="N",
                        help="judge each plan on N points on its part's exact faces")
    parser.add_argument("--poses", type=int, default=1, metavar="K",
                        help="with --judge: K random poses of each part (seeds 5, 6, …)")
    parser.add_argument("--part", action="append", metavar="NAME",
                        help="only this part (CTC_01, FTC_06 …); repeatable")
    args = parser.parse_args()
    parts = [(q, s) for q, s in PARTS if not args.part
             or q.split("__nist_")[1].split("_asme")[0].upper() in args.part]
    if args.judge:
        sys.path.insert(0, os.path.join(ROOT, "tests"))
        print(f"{'part':8} {'pose':>4} {'points':>7} {'inspect s':>9} {'ACCEPT':>6} "
              f"{'INCONCL.':>8} {'REJECT':>6}")
        for qif, stp in parts:
            for pose in range(5, 5 + args.poses):
                r = judged(qif, stp, args.judge, pose)
                print(f"{r['part']:8} {pose:4d} {args.judge:7,d} {r['s']:9.2f} "
                      f"{r['ACCEPT']:6d} {r['INCONCLUSIVE']:8d} {r['REJECT']:6d}", flush=True)
        return
    print(f"{'part':8} {'QIF MB':>6} {'step s':>7} {'read s':>7} {'map s':>6} "
          f"{'read+map':>8} {'chars':>5} {'judged':>6} {'faces':>5}")
    for qif, stp in parts:
        r = case(qif, stp)
        print(f"{r['part']:8} {r['MB']:6.2f} {r['step']:7.2f} {r['read']:7.2f} {r['map']:6.2f} "
              f"{r['read'] + r['map']:8.2f} {r['n']:5d} {r['judged']:6d} {r['faces']:5d}")


if __name__ == "__main__":
    main()
