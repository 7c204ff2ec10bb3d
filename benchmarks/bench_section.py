"""Planar sections (engine.section): the time to cut the nominal and gather the band's points.

    .venv/bin/python benchmarks/bench_section.py

* NIST CTC-01 (tests/data/step): OpenCascade's section of the B-rep by three planes, each
  discretised within the tessellation's deflection, with the outward normals of its chords;
  then the section of an inspection of 2,000 points on it (curve + band);
* the belly fairing (samples/belly_fairing, a 300 x 200 grid nominal, 119,002 triangles) with
  200,000 measured points (random points of its triangles moved along the normal by
  N(0, 0.01) mm, in a random pose): the inspection, then two sections with the default band.
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


def timed(f, *a, **k):
    t = time.perf_counter()
    out = f(*a, **k)
    return out, time.perf_counter() - t


def ctc01() -> None:
    from engine.inspection import Tolerance, inspect
    from engine.io.step import read_step
    from engine.nominal import Nominal
    from engine.section import axis_plane, nominal_curve, point_plane, section_of
    from engine.step_model import ExactDistances
    from test_step_inspection import measured_on

    part, t = timed(read_step, os.path.join(ROOT, "tests", "data", "step",
                                            "nist_ctc_01_asme1_ap203.stp"))
    print(f"CTC-01: read {t:.2f} s, {part.n_faces} faces")
    nominal = Nominal.from_point_set(part.point_set)
    M, _, _ = measured_on(part, np.random.default_rng(7), n=2000)
    res, t = timed(inspect, nominal, M, Tolerance.symmetric(0.05),
                   surface=ExactDistances(part, nominal))
    print(f"  inspection of {len(M)} points: {t:.2f} s")
    for plane in (axis_plane("z", -25.0), axis_plane("x", 101.5),
                  point_plane([10.0, 5.0, -30.0], [0.2, 0.3, 1.0])):
        curve, t = timed(nominal_curve, plane, step=part)
        s, t2 = timed(section_of, res, plane, band=2.0, step=part)
        print(f"  {plane.name:45s} curve {t:.3f} s ({curve.n_vertices} vertices, "
              f"{curve.length:.1f} mm, chords within {curve.chord_mm * 1000:g} µm); "
              f"with the band {t2:.3f} s ({s.signed.size} points)")


def fairing() -> None:
    from engine.inspection import Tolerance, inspect
    from engine.io import load_point_set
    from engine.nominal import Nominal
    from engine.section import axis_plane, section_of
    from surfaces import random_rotation

    ps = load_point_set(os.path.join(ROOT, "samples", "belly_fairing", "nominal.csv"))
    nominal = Nominal.from_point_set(ps)
    rng = np.random.default_rng(5)
    tris = nominal.triangles[rng.choice(len(nominal.triangles), 200_000)]
    w = rng.dirichlet(np.ones(3), len(tris))
    P = np.einsum("ij,ijk->ik", w, nominal.points[tris])
    N = np.einsum("ij,ijk->ik", w, nominal.normals(tris))
    N /= np.linalg.norm(N, axis=1, keepdims=True)
    M = (P + rng.normal(0, 0.01, len(P))[:, None] * N) @ random_rotation(rng).T + 100.0
    res, t = timed(inspect, nominal, M, Tolerance.symmetric(0.05))
    print(f"fairing: {len(nominal.triangles)} triangles, inspection of {len(M)} points "
          f"{t:.2f} s ({res.verdict})")
    for plane in (axis_plane("x", 0.0), axis_plane("y", 40.0)):
        s, t = timed(section_of, res, plane, nominal=nominal)
        print(f"  {plane.name:12s} curve + band {t:.3f} s: {s.curve.n_vertices} vertices, "
              f"{s.curve.length:.1f} mm; {s.signed.size} points within ±{s.band:.3f} mm")


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    return p.parse_args(argv)


if __name__ == "__main__":
    parse_args()
    from engine import warm_up

    warm_up()
    ctc01()
    fairing()
