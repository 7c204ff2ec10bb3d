"""2D template inspection speed and accuracy; prints a table.

    .venv/bin/python benchmarks/bench_2d.py

Templates are generated: a closed profile of N entities (alternating line segments and bulged
arcs around a wavy outline, plus one circular hole), measured at M points spread along the
contours (exactly on them: the deviation column is then the engine's own error), in an
arbitrary 2D pose (points given as x y). Engine time is the
contour index, registration from the arbitrary pose and deviations; the template's DXF reading
is timed apart (the fuselage-frame sample).
"""

from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)

from engine.contour import arc, build_template, points_on, segment  # noqa: E402
from engine.inspection import Tolerance, inspect_2d  # noqa: E402
from engine.pose import apply_transform, pose_2d  # noqa: E402


def wavy_template(n_entities: int):
    k = n_entities - 1
    ang = np.linspace(0, 2 * np.pi, k, endpoint=False)
    rad = 200 + 15 * np.sin(5 * ang) + 5 * np.cos(11 * ang)
    v = np.column_stack([rad * np.cos(ang), rad * np.sin(ang)])
    prims = []
    for i in range(k):
        a, b = v[i], v[(i + 1) % k]
        if i % 2:
            theta = 0.3
            chord = b - a
            L = np.hypot(*chord)
            left = np.array([-chord[1], chord[0]]) / L
            c = (a + b) / 2 + (L / 2) / np.tan(theta / 2) * left
            prims.append(arc(c, L / (2 * np.sin(theta / 2)),
                             np.arctan2(a[1] - c[1], a[0] - c[0]), theta))
        else:
            prims.append(segment(a, b))
    hole = [arc((20.0, -10.0), 30.0, 0.0, 2 * np.pi)]
    return build_template([(prims, True), (hole, True)])


def run(n_entities: int, n_points: int) -> dict:
    rng = np.random.default_rng(2)
    t = wavy_template(n_entities)
    q = points_on(t, n_points, rng)
    meas = apply_transform(pose_2d(2.1, [350.0, -120.0]), q)
    m3 = np.column_stack([meas, np.zeros(n_points)])
    inspect_2d(t, m3[:50], 2, Tolerance.symmetric(0.05))  # load compiled code paths once
    t0 = time.perf_counter()
    res = inspect_2d(t, m3, 2, Tolerance.symmetric(0.05))
    el = time.perf_counter() - t0
    err = float(np.max(np.linalg.norm(res.registered[:, :2] - q, axis=1)))
    return {"entities": t.n_primitives, "points": n_points, "engine_s": el,
            "pose_err_um": err * 1e3, "max_dev_um": res.statistics.max_abs * 1e3,
            "verdict": res.verdict}


def main() -> int:
    rows = [run(1000, 500), run(1000, 100_000), run(100, 500)]
    print("| entities | points | engine s | pose err um | max abs dev um | verdict |")
    print("|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['entities']:,} | {r['points']:,} | {r['engine_s']:.3f} | "
              f"{r['pose_err_um']:.3f} | {r['max_dev_um']:.3f} | {r['verdict']} |")
    from engine.io.templates import read_dxf_template

    t0 = time.perf_counter()
    read_dxf_template(os.path.join(ROOT, "samples", "fuselage_frame", "template.dxf"))
    print(f"\nreading samples/fuselage_frame/template.dxf: {time.perf_counter() - t0:.3f} s")
    return 0


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    return p.parse_args(argv)  # no arguments: --help, and a stray one refused before any work


if __name__ == "__main__":
    parse_args()
    sys.exit(main())
