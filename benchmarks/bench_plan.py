"""What an inspection plan adds to an inspection; prints a table.

    .venv/bin/python benchmarks/bench_plan.py

Cases, each the median of 5 runs in one warm process (the compiled kernels loaded once before):
* the belly fairing sample (60k nominal grid, 1,100 points) with 5 characteristics on regions of
  its doubly curved surface: a tangent plane datum on one corner patch, the profile of a quarter
  relative to it (its free directions best-fitted), two form profiles (least squares, minimax)
  and a flatness;
* the seat bracket sample with its own plan (samples/seat_bracket/plan.toml: datums A|B|C, two
  profiles, a flatness, a hole's position and size).
"inspect" is the registration and judging without a plan; "plan" is engine.gdt.characteristics
.inspect_plan on its result (regions, alignments, characteristics, per-point outputs at the
plan's pose).

Then the scale table (issue 22 item 6): the seat bracket with its plan's five characteristics
repeated (new ids) to 100, 1,000 and 10,000 characteristics on its five regions; "read s" is
engine.io.plan.read_plan of the file, "plan s" inspect_plan after one registration (median of
3 runs, one for 10,000), "ms each" their sum over the count.

    .venv/bin/python benchmarks/bench_plan.py scale [N ...]   # the scale table only
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)

FAIRING_PLAN = """
[[region]]
name = "corner"
box = [[-250, -125, -100], [-150, -60, 100]]
[[region]]
name = "quarter"
box = [[0, 0, -100], [250, 125, 100]]
[[region]]
name = "middle"
box = [[-100, -50, -100], [100, 50, 100]]
[[datum]]
label = "A"
region = "corner"
feature = "plane"
[alignment]
method = "datums"
reference = ["A"]
best_fit_regions = ["quarter"]
[[characteristic]]
id = "1"
type = "profile"
region = "quarter"
zone = 0.5
datums = ["A"]
[[characteristic]]
id = "2"
type = "profile"
region = "quarter"
zone = 0.5
[[characteristic]]
id = "3"
type = "profile"
region = "middle"
zone = 0.5
fit = "minimax"
[[characteristic]]
id = "4"
type = "flatness"
region = "corner"
zone = 5.0
[[characteristic]]
id = "5"
type = "profile"
region = "middle"
zone = 0.5
"""


def case(nominal_path: str, measured_path: str, plan_path: str, tol: float):
    from engine.gdt.characteristics import inspect_plan
    from engine.inspection import Tolerance, inspect
    from engine.io import load_point_set
    from engine.io.plan import read_plan
    from engine.nominal import Nominal

    nps, mps = load_point_set(nominal_path), load_point_set(measured_path)
    plan = read_plan(plan_path)
    t_inspect, t_plan = [], []
    for _ in range(5):
        nominal = Nominal.from_point_set(nps)
        t0 = time.perf_counter()
        res = inspect(nominal, mps.points, Tolerance.symmetric(tol))
        t1 = time.perf_counter()
        out = inspect_plan(res, plan, nominal, nps.labels, mps.points, mps.labels, False)
        t2 = time.perf_counter()
        t_inspect.append(t1 - t0)
        t_plan.append(t2 - t1)
    return statistics.median(t_inspect), statistics.median(t_plan), out


def many_characteristics(n: int) -> str:
    """The seat bracket's plan with its characteristics repeated to ``n`` (ids 1..n)."""
    import re

    with open(os.path.join(ROOT, "samples", "seat_bracket", "plan.toml")) as f:
        head, *chars = f.read().split("[[characteristic]]")
    return head + "".join("[[characteristic]]" + re.sub(r'id = "\d+"', f'id = "{k + 1}"',
                                                         chars[k % len(chars)])
                          for k in range(n))


def scale(sizes) -> None:
    import tempfile

    from engine.gdt.characteristics import inspect_plan
    from engine.inspection import Tolerance, inspect
    from engine.io import load_point_set
    from engine.io.plan import read_plan
    from engine.nominal import Nominal

    s = os.path.join(ROOT, "samples", "seat_bracket")
    nps, mps = load_point_set(f"{s}/nominal.xyz"), load_point_set(f"{s}/measured.csv")
    nominal = Nominal.from_point_set(nps)
    res = inspect(nominal, mps.points, Tolerance.symmetric(0.05))
    print(f"{'characteristics':>15s} {'read s':>8s} {'plan s':>8s} {'ms each':>8s}  verdict")
    with tempfile.TemporaryDirectory() as d:
        for n in sizes:
            path = os.path.join(d, f"plan{n}.toml")
            with open(path, "w") as f:
                f.write(many_characteristics(n))
            t_read, t_plan = [], []
            for _ in range(1 if n >= 10_000 else 3):
                t0 = time.perf_counter()
                plan = read_plan(path)
                t1 = time.perf_counter()
                out = inspect_plan(res, plan, nominal, nps.labels, mps.points, mps.labels,
                                   False)
                t_read.append(t1 - t0)
                t_plan.append(time.perf_counter() - t1)
            tr, tp = statistics.median(t_read), statistics.median(t_plan)
            print(f"{n:15,d} {tr:8.3f} {tp:8.3f} {1000 * (tr + tp) / n:8.2f}  {out.verdict}",
                  flush=True)


def main() -> None:
    import tempfile

    from engine import warm_up

    warm_up()
    if sys.argv[1:2] == ["scale"]:
        scale([int(n) for n in sys.argv[2:]] or [100, 1_000, 10_000])
        return
    s = os.path.join(ROOT, "samples")
    with tempfile.TemporaryDirectory() as d:
        fairing_plan = os.path.join(d, "fairing.toml")
        with open(fairing_plan, "w") as f:
            f.write(FAIRING_PLAN)
        rows = [("fairing 60k/1.1k, 5 characteristics",
                 case(f"{s}/belly_fairing/nominal.csv", f"{s}/belly_fairing/measured.csv",
                      fairing_plan, 0.25)),
                ("seat bracket 200k/176, its plan (5)",
                 case(f"{s}/seat_bracket/nominal.xyz", f"{s}/seat_bracket/measured.csv",
                      f"{s}/seat_bracket/plan.toml", 0.05))]
    print(f"{'case':40s} {'inspect s':>10s} {'plan s':>8s}  verdict / characteristics")
    for name, (ti, tp, out) in rows:
        chars = ", ".join(f"{r.characteristic.id} {r.verdict}" for r in out.plan.characteristics)
        print(f"{name:40s} {ti:10.3f} {tp:8.3f}  {out.verdict} / {chars}")
    print(f"numpy {np.__version__}, {os.cpu_count()} cores")
    print()
    scale([100, 1_000, 10_000])


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    return p.parse_args(argv)  # no arguments: --help, and a stray one refused before any work


if __name__ == "__main__":
    parse_args()
    main()
