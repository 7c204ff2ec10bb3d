"""Regenerate docs/screenshots/spc.png: the SPC page of a lot that passes but drifts.

    .venv/bin/python scripts/spc_screenshot.py [OUT_DIR]

Twenty parts made from the belly-fairing sample (samples/belly_fairing): its measured points
brought into the nominal's frame (truth.json), 2 um of noise, a bump on the 12 points nearest
(150, 60) along the surface's normal (~ +z there) of 0.14 mm growing 4 um a part (every part inside
+-0.25 mm), each part in a seeded random pose, serials SN0001-SN0020. `qa-inspect batch`
inspects them on one local worker (the part number BF-0150, made up for the sample, titles
the report); the page of max |d| in spc.pdf is rendered with pdftoppm.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)


def main(out_dir: str) -> str:
    from engine.pose import apply_transform, make_transform
    from qa_app.cli import main as cli
    from samples.generate import rotation

    sample = os.path.join(ROOT, "samples", "belly_fairing")
    rows = np.genfromtxt(os.path.join(sample, "measured.csv"), delimiter=",", skip_header=2,
                         dtype=None, encoding="utf-8")
    labels = [r[0] for r in rows]
    pts = np.array([[r[1], r[2], r[3]] for r in rows], float)
    with open(os.path.join(sample, "truth.json")) as f:
        T_true = np.array(json.load(f)["T_nominal_measured"])
    pts = apply_transform(T_true, pts)  # in the nominal's frame: the fairing's normal is ~ +z
    rng = np.random.default_rng(2026)
    spot = np.argsort(np.linalg.norm(pts[:, :2] - [150.0, 60.0], axis=1))[:12]
    with tempfile.TemporaryDirectory() as tmp:
        files = []
        for k in range(1, 21):
            p = pts + rng.normal(0, 0.002, (len(pts), 1)) * [0.0, 0.0, 1.0]
            p[spot, 2] += 0.14 + 0.004 * k
            T = make_transform(rotation(rng.normal(size=3), rng.uniform(0, 360)),
                               rng.uniform(-300, 300, 3))
            path = os.path.join(tmp, f"SN{k:04d}.csv")
            with open(path, "w") as f:
                f.write("id,x,y,z\n")
                for label, q in zip(labels, apply_transform(T, p)):
                    f.write(f"{label},{q[0]:.5f},{q[1]:.5f},{q[2]:.5f}\n")
            files.append(path)
        out = os.path.join(tmp, "lot")
        cli(["batch", os.path.join(sample, "nominal.csv"), *files, "--tol", "0.25", "--out", out,
             "--workers", "1", "--quiet", "--part-number", "BF-0150"])
        os.makedirs(out_dir, exist_ok=True)
        target = os.path.join(out_dir, "spc")
        subprocess.run(["pdftoppm", "-r", "70", "-png", "-f", "2", "-l", "2", "-singlefile",
                        os.path.join(out, "spc.pdf"), target], check=True)
    return target + ".png"


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("out", nargs="?", metavar="OUT_DIR",
                   default=os.path.join(ROOT, "docs", "screenshots"),
                   help="the folder spc.png is written to (default: docs/screenshots)")
    return p.parse_args(argv)


if __name__ == "__main__":
    print(main(parse_args().out))
