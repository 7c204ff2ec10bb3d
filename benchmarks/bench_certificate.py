"""Signed-certificate speed, end to end, as an inspector runs it; prints a table.

    .venv/bin/python benchmarks/bench_certificate.py [RUNS]

Each run is a fresh ``qa-inspect inspect … --report … --sign …`` process (Python start-up,
imports, reading both files, inspection, 3D renders, PDF, QIF, signature, atomic write) on the
bundled samples, timed by wall clock; the table gives the median and the range over RUNS (default
5). A demonstration identity is made once in a temporary folder. Stage times are measured in one
extra in-process run (after the imports) to show where the time goes.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)
QA = os.path.join(os.path.dirname(sys.executable), "qa-inspect")
CASES = [
    ("belly fairing 60k grid / 1,100 pts", "samples/belly_fairing/nominal.csv",
     "samples/belly_fairing/measured.csv", "0.25"),
    ("seat bracket 200k pts / 164 pts", "samples/seat_bracket/nominal.xyz",
     "samples/seat_bracket/measured.csv", "0.05"),
    ("fuselage frame DXF / 500 pts", "samples/fuselage_frame/template.dxf",
     "samples/fuselage_frame/measured.csv", "0.05"),
]


def main(runs: int = 5) -> None:
    env = dict(os.environ, QA_BENCH_PASS="benchmark")
    with tempfile.TemporaryDirectory() as tmp:
        subprocess.run([QA, "keygen", "--name", "Bench Inspector", "--organisation", "Bench",
                        "--out", tmp, "--pass-env", "QA_BENCH_PASS"], env=env, check=True,
                       cwd=ROOT, capture_output=True)
        rows = []
        for name, nominal, measured, tol in CASES:
            times = []
            for _ in range(runs):
                pdf = os.path.join(tmp, "cert.pdf")
                t = time.perf_counter()
                r = subprocess.run([QA, "inspect", nominal, measured, "--tol", tol, "--report",
                                    pdf, "--sign", os.path.join(tmp, "inspector.p12"),
                                    "--sign-pass-env", "QA_BENCH_PASS", "--part-number",
                                    "BENCH-1", "--serial", "SN-BENCH"], env=env, cwd=ROOT,
                                   capture_output=True, text=True)
                times.append(time.perf_counter() - t)
                if r.returncode not in (0, 1, 2):
                    raise SystemExit(f"{name}: exit {r.returncode}: {r.stderr}")
            size = os.path.getsize(pdf)
            rows.append((name, statistics.median(times), min(times), max(times), size))
        print(f"| case | median s | min s | max s | PDF kB |\n|---|---|---|---|---|")
        for name, med, lo, hi, size in rows:
            print(f"| {name} | {med:.2f} | {lo:.2f} | {hi:.2f} | {size / 1024:.0f} |")
        print()
        stages(os.path.join(tmp, "inspector.p12"))


def stages(p12: str) -> None:
    from engine.pipeline import run_files
    from engine.settings import InspectionSettings
    from reports import certificate, figures, signing

    identity = signing.load_identity(p12, b"benchmark")
    identity.signer
    run = run_files(*CASES[0][1:3], InspectionSettings(-0.25, 0.25))
    res = run.result
    t = time.perf_counter()
    views = figures.render_3d(run.nominal.points, run.nominal.triangles, res.deviations.foot,
                              res.deviations.normal, res.deviations.signed, res.tolerance, [])
    t_render = time.perf_counter() - t
    t = time.perf_counter()
    pdf, slots = certificate.build_pdf(run, certificate.CertificateInfo(), "QA-BENCH",
                                       __import__("datetime").datetime.now(), identity, [],
                                       views)
    t_layout = time.perf_counter() - t
    t = time.perf_counter()
    signing.finish_pdf(pdf, [], slots, identity, reason="benchmark")
    t_sign = time.perf_counter() - t
    print("in-process stages, belly fairing (imports done, key loaded once):")
    print(f"| 3D renders (2 views, first in process) | layout (reportlab) | sign (pyHanko) |\n"
          f"|---|---|---|\n| {t_render:.3f} s | {t_layout:.3f} s | {t_sign:.3f} s |")


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("runs", nargs="?", type=int, default=5, metavar="RUNS",
                   help="runs of each case (default 5; the table gives their median)")
    return p.parse_args(argv)


if __name__ == "__main__":
    main(parse_args().runs)
