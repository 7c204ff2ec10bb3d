"""The engine and Open3D's global registration side by side, in one run, on the same cases.

    .venv/bin/pip install -c constraints.txt -e '.[bench]'     # Open3D, once
    .venv/bin/python benchmarks/bench_open3d.py
    .venv/bin/python benchmarks/bench_open3d.py 60k/1.1k "60k/400 tenth"
    .venv/bin/python benchmarks/bench_open3d.py --open3d-python /path/to/venv/bin/python

Open3D is not a dependency of the product but of the optional ``bench`` extra (open3d-cpu; on
Debian it needs ``libusb-1.0-0``, which scripts/setup.sh installs). Open3D runs in the
interpreter running this script when it has Open3D, else in the one given by
``--open3d-python`` (any environment with numpy and Open3D 0.20). Each side runs in its own
process per case, the cases alternate, and each is run ``--repeat`` times (default 3; the
table gives the fastest).

Open3D's pipeline is its tutorial's, tuned to these parts: voxel down-sampling at 2% of the
nominal's diagonal, normals, FPFH features (radius 5 voxels), RANSAC over feature matches
(seeded, mutual filter, 1.5-voxel inlier distance, edge-length and distance checks, at most
100,000 iterations at 0.999 confidence), then point-to-plane ICP on the full clouds (1 voxel,
30 iterations). Its time is that pipeline, from arrays in memory to the transform; the
engine's is bench_engine's "engine s": the nominal's structures, the registration from the
arbitrary pose and every point's deviation. "pose err" is the largest distance between a
registered point and its true place, "dev err" the largest error of the deviations measured
at that pose (by the engine's point-to-surface, against the planted ones): a pose whose
deviations are more than 0.01 mm off (a fifth of these parts' +-0.05 mm zone) is WRONG.
Open3D runs twice per case: with its tutorial's RANSAC budget (100,000 iterations) and with a
hand-tuned one (1,000: ten times faster here).
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import os
import subprocess
import sys
import tempfile
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def open3d_child(npz: str, iterations: int) -> dict:
    """In the Open3D interpreter (numpy and open3d only): register the case in ``npz``, RANSAC
    running at most ``iterations`` iterations."""
    import open3d as o3d

    data = np.load(npz)
    reg = o3d.pipelines.registration
    o3d.utility.random.seed(0)
    t0 = time.perf_counter()
    src = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(data["measured"]))
    tgt = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(data["nominal"]))
    tgt.normals = o3d.utility.Vector3dVector(data["normals"])
    voxel = float(data["voxel"])
    src_d, tgt_d = src.voxel_down_sample(voxel), tgt.voxel_down_sample(voxel)
    src_d.estimate_normals(o3d.geometry.KDTreeSearchParamHybrid(radius=2 * voxel, max_nn=30))
    feature = o3d.geometry.KDTreeSearchParamHybrid(radius=5 * voxel, max_nn=100)
    f_src = reg.compute_fpfh_feature(src_d, feature)
    f_tgt = reg.compute_fpfh_feature(tgt_d, feature)
    coarse = reg.registration_ransac_based_on_feature_matching(
        src_d, tgt_d, f_src, f_tgt, True, 1.5 * voxel,
        reg.TransformationEstimationPointToPoint(False), 3,
        [reg.CorrespondenceCheckerBasedOnEdgeLength(0.9),
         reg.CorrespondenceCheckerBasedOnDistance(1.5 * voxel)],
        reg.RANSACConvergenceCriteria(iterations, 0.999))
    fine = reg.registration_icp(src, tgt, voxel, coarse.transformation,
                                reg.TransformationEstimationPointToPlane(),
                                reg.ICPConvergenceCriteria(max_iteration=30))
    seconds = time.perf_counter() - t0
    return {"seconds": seconds, "T": np.asarray(fine.transformation).tolist(),
            "version": o3d.__version__}


def run(names: list[str], open3d_python: str, repeat: int) -> int:
    sys.path.insert(0, ROOT)
    sys.path.insert(0, os.path.join(ROOT, "benchmarks"))
    from bench_engine import CASES, make_case
    from engine.deviation import point_to_surface
    from engine.nominal import Nominal

    rows = []
    for name in names:
        if name not in CASES:
            print(f"unknown case {name!r}; cases: {', '.join(CASES)}", file=sys.stderr)
            return 2
        ps, q, measured, planted, _ = make_case(name)
        diagonal = float(np.linalg.norm(ps.points.max(0) - ps.points.min(0)))
        nominal = Nominal.from_point_set(ps)
        with tempfile.TemporaryDirectory() as tmp:
            npz = os.path.join(tmp, "case.npz")
            np.savez(npz, nominal=ps.points, normals=ps.normals, measured=measured,
                     voxel=0.02 * diagonal)
            ours, theirs = [], {it: [] for it in RANSAC_ITERATIONS}
            for _ in range(repeat):
                out = subprocess.run([sys.executable, os.path.join(ROOT, "benchmarks",
                                                                   "bench_engine.py"),
                                      "--child", name], capture_output=True, text=True,
                                     check=True)
                ours.append(json.loads(out.stdout.strip().splitlines()[-1]))
                for it in RANSAC_ITERATIONS:
                    out = subprocess.run([open3d_python, os.path.abspath(__file__),
                                          "--open3d-child", npz, str(it)],
                                         capture_output=True, text=True, check=True)
                    theirs[it].append(json.loads(out.stdout.strip().splitlines()[-1]))
        best = min(ours, key=lambda r: r["engine_s"])
        row = [name, f"{len(measured):,}",
               f"{best['engine_s']:.3f}", _mark(best["pose_err_um"] / 1e3, best["dev_err_um"] / 1e3)]
        for it in RANSAC_ITERATIONS:
            fastest = min(theirs[it], key=lambda r: r["seconds"])
            T = np.asarray(fastest["T"])
            X = measured @ T[:3, :3].T + T[:3, 3]
            pose_err = float(np.max(np.linalg.norm(X - q, axis=1)))
            dev_err = float(np.nanmax(np.abs(point_to_surface(nominal, X).signed - planted)))
            row += [f"{fastest['seconds']:.3f}", _mark(pose_err, dev_err)]
            version = fastest["version"]
        rows.append(row)
    head = ["case", "measured", "engine s", "engine pose / dev err mm"]
    for it in RANSAC_ITERATIONS:
        head += [f"Open3D {it:,} s", f"Open3D {it:,} pose / dev err mm"]
    print("| " + " | ".join(head) + " |")
    print("|" + "---|" * len(head))
    for row in rows:
        print("| " + " | ".join(row) + " |")
    print(f"\nOpen3D {version} with at most {' or '.join(f'{i:,}' for i in RANSAC_ITERATIONS)} "
          f"RANSAC iterations; fastest of {repeat} runs each, alternating")
    return 0


RANSAC_ITERATIONS = (100_000, 1_000)
"""Open3D's RANSAC budgets: its tutorial's, and a hand-tuned one (10 x faster on these parts)."""


def _mark(pose_err: float, dev_err: float) -> str:
    """"pose / deviation error", WRONG when a deviation is off by more than 0.01 mm (a fifth of
    the +-0.05 mm zone): a weakly constrained patch may slide along its weak directions (pose
    error) without changing the deviations, which are what the verdict is made of."""
    return f"{pose_err:.3g} / {dev_err:.3g}" + (" WRONG" if dev_err > 0.01 else "")


DEFAULT_CASES = ["60k/1.1k", "60k/400 quarter", "60k/400 tenth", "200k/100 bracket",
                 "1M points/200k"]


def main(args: argparse.Namespace) -> int:
    if args.open3d_child is not None:
        npz, iterations = args.open3d_child
        print(json.dumps(open3d_child(npz, int(iterations))))
        return 0
    if args.open3d_python is not None:
        python = args.open3d_python
    elif importlib.util.find_spec("open3d") is not None:
        python = sys.executable
    else:
        print("Open3D is not installed here: .venv/bin/pip install -c constraints.txt "
              "-e '.[bench]', or give --open3d-python\n\n" + __doc__, file=sys.stderr)
        return 2
    return run(args.cases or DEFAULT_CASES, python, args.repeat)


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("cases", nargs="*", metavar="CASE",
                   help=f"bench_engine.py's cases to run (default: {', '.join(DEFAULT_CASES)})")
    p.add_argument("--repeat", type=int, default=3, metavar="N",
                   help="runs of each side per case; the table gives the fastest (default 3)")
    p.add_argument("--open3d-python", metavar="PYTHON",
                   help="the interpreter that runs Open3D (default: this one, if it has Open3D)")
    p.add_argument("--open3d-child", nargs=2, metavar=("NPZ", "ITERATIONS"),
                   help="register one case in this interpreter with Open3D and print the "
                        "result as JSON (how each Open3D run is started)")
    return p.parse_args(argv)


if __name__ == "__main__":
    sys.exit(main(parse_args()))
