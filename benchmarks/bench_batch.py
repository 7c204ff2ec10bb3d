"""Batch speed: ``qa-inspect batch`` on a lot of belly-fairing parts (60k-point grid nominal,
1,100 measured points each) on the local Dask cluster; prints a table.

    .venv/bin/python benchmarks/bench_batch.py [PARTS] [CERTIFIED_PARTS]

The lot (default 200 parts) is made from the bundled sample's measured points by seeded random
rigid motions (any rotation, translations up to 1 m) plus 2 um Gaussian noise along each axis,
in a temporary folder. Each row is one fresh ``qa-inspect batch`` process timed by wall clock
from start to exit: Python start-up, reading the nominal, starting and closing the local
cluster, every part's inspection, its outputs written atomically and the summary. Modes:
JSON/CSV results, and signed certificates (``--report --sign`` with a throwaway
``qa-inspect keygen`` identity; default CERTIFIED_PARTS = PARTS), each with 1 and 2 workers.
parts/min = parts / wall time (start-up included).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)
QA = [sys.executable, "-m", "qa_app.cli"]
NOMINAL = os.path.join(ROOT, "samples", "belly_fairing", "nominal.csv")
MEASURED = os.path.join(ROOT, "samples", "belly_fairing", "measured.csv")
TOL = "0.15"


def make_lot(folder: str, n: int, seed: int = 14) -> None:
    """n parts p0001.csv ... from the sample's measured points, each in its own random pose."""
    from engine.pose import make_transform
    from scipy.spatial.transform import Rotation

    with open(MEASURED) as f:
        lines = [ln for ln in f if ln.strip() and not ln.startswith("#")][1:]
    labels = [ln.split(",")[0] for ln in lines]
    pts = np.array([[float(v) for v in ln.split(",")[1:4]] for ln in lines])
    rng = np.random.default_rng(seed)
    for k in range(1, n + 1):
        T = make_transform(Rotation.random(random_state=rng).as_matrix(),
                           rng.uniform(-1000, 1000, 3))
        q = pts @ T[:3, :3].T + T[:3, 3] + rng.normal(0, 0.002, pts.shape)
        with open(os.path.join(folder, f"p{k:04d}.csv"), "w") as f:
            f.write("id,x,y,z\n")
            f.writelines(f"{a},{x:.6f},{y:.6f},{z:.6f}\n" for a, (x, y, z) in zip(labels, q))


def run(lot: str, out: str, workers: int, n: int, extra: list[str], env) -> dict:
    files = sorted(os.listdir(lot))[:n]
    t0 = time.perf_counter()
    r = subprocess.run(QA + ["batch", NOMINAL, *[os.path.join(lot, f) for f in files],
                             "--tol", TOL, "--out", out, "--workers", str(workers), "--quiet",
                             *extra], env=env, capture_output=True, text=True, cwd=ROOT)
    wall = time.perf_counter() - t0
    if r.returncode not in (0, 1, 2):
        raise SystemExit(f"exit {r.returncode}: {r.stderr}{r.stdout}")
    with open(os.path.join(out, "summary.json")) as f:
        summary = json.load(f)
    return {"wall": wall, "parts": len(summary["parts"]), "counts": summary["counts"]}


def main(n: int = 200, n_cert: int | None = None) -> None:
    n_cert = n if n_cert is None else n_cert
    env = dict(os.environ, PYTHONPATH=ROOT, QA_BENCH_PASS="benchmark")
    with tempfile.TemporaryDirectory() as tmp:
        lot = os.path.join(tmp, "lot")
        os.mkdir(lot)
        make_lot(lot, max(n, n_cert))
        subprocess.run(QA + ["keygen", "--name", "Bench Inspector", "--out", tmp,
                             "--pass-env", "QA_BENCH_PASS"], env=env, check=True,
                       capture_output=True)
        signed = ["--report", "--sign", os.path.join(tmp, "inspector.p12"), "--sign-pass-env",
                  "QA_BENCH_PASS", "--part-number", "BF-BENCH"]
        rows = []
        for mode, parts, extra in (("JSON/CSV", n, []), ("signed certificates", n_cert, signed)):
            for workers in (1, 2):
                out = os.path.join(tmp, f"out-{len(rows)}")
                r = run(lot, out, workers, parts, extra, env)
                rows.append((mode, workers, r))
                print(f"  {mode}, {workers} worker(s): {r['parts']} parts in {r['wall']:.1f} s",
                      file=sys.stderr, flush=True)
    print("| results | workers | parts | wall s | parts/min | speed-up 1 -> 2 | verdicts |")
    print("|---|---|---|---|---|---|---|")
    for mode, workers, r in rows:
        base = next(x for m, w, x in rows if m == mode and w == 1)
        rate = 60 * r["parts"] / r["wall"]
        up = rate / (60 * base["parts"] / base["wall"])
        counts = ", ".join(f"{v} {c}" for v, c in r["counts"].items() if c)
        print(f"| {mode} | {workers} | {r['parts']} | {r['wall']:.1f} | {rate:.0f} | "
              f"{'' if workers == 1 else f'{up:.2f}x'} | {counts} |")


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("parts", nargs="?", type=int, default=200, metavar="PARTS",
                   help="parts in the lot (default 200)")
    p.add_argument("certified", nargs="?", type=int, default=None, metavar="CERTIFIED_PARTS",
                   help="parts inspected with signed certificates (default: PARTS)")
    return p.parse_args(argv)


if __name__ == "__main__":
    args = parse_args()
    main(args.parts, args.certified)
