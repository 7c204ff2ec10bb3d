"""The qa-inspect command-line contract: exit codes, JSON fields, CSV rows, atomic outputs."""

import csv
import hashlib
import json
import os
import subprocess
import sys

import numpy as np
import pytest

from engine.geometry import apply_transform, make_transform
from reports.cli import main
from surfaces import height, height_grid, height_normal, random_rotation

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """A grid nominal with normals and two measured files (in tolerance, and one point out)."""
    d = tmp_path_factory.mktemp("cli")
    pts, nrm, (nu, nv) = height_grid(150, 100)
    with open(d / "nominal.csv", "w") as f:
        f.write(f"# grid: {nu} x {nv}\nx,y,z,i,j,k\n")
        np.savetxt(f, np.hstack([pts, nrm]), fmt="%.9f", delimiter=",")
    rng = np.random.default_rng(0)
    x, y = rng.uniform(-240, 240, 300), rng.uniform(-115, 115, 300)
    dev = rng.normal(0, 0.002, 300)
    q = np.column_stack([x, y, height(x, y)]) + dev[:, None] * height_normal(x, y)
    T = make_transform(random_rotation(rng), [500.0, -200.0, 80.0])
    good = apply_transform(T, q)
    bad = good.copy()
    bad[7] = apply_transform(T, (q[7] + 0.2 * height_normal(x[7], y[7]))[None])[0]
    for name, arr in (("good.csv", good), ("bad.csv", bad)):
        with open(d / name, "w") as f:
            f.write("id,x,y,z\n")
            for i, p in enumerate(arr):
                f.write(f"P{i:03d},{p[0]:.6f},{p[1]:.6f},{p[2]:.6f}\n")
    return d, T, dev, q


def run(*args):
    return main([str(a) for a in args])


def test_accept_json_and_csv(files, capsys):
    d, T, dev, q = files
    code = run("inspect", d / "nominal.csv", d / "good.csv", "--tol", "0.05",
               "--json", d / "r.json", "--csv", d / "r.csv")
    out = capsys.readouterr().out
    assert code == 0 and out.startswith("ACCEPT") and "r.json" in out
    doc = json.loads((d / "r.json").read_text())
    assert doc["verdict"] == "ACCEPT"
    assert set(doc) >= {"verdict", "transform", "registration", "deviations", "tolerance",
                        "inputs", "software", "timings_s"}
    assert set(doc["registration"]) >= {"converged", "iterations", "rms", "hypotheses",
                                        "runner_up_score", "ambiguous", "weak_directions"}
    assert doc["registration"]["weak_directions"] == [] and not doc["registration"]["ambiguous"]
    assert set(doc["deviations"]) >= {"count", "min", "max", "mean", "std", "rms", "max_abs",
                                      "n_out", "fraction_in"}
    assert doc["tolerance"] == {"lower": -0.05, "upper": 0.05}
    assert doc["fit"] == "lsq" and doc["decision_rule"] == "simple" and "margin" not in doc
    assert set(doc["timings_s"]) == {"load", "register", "deviation", "total"}
    # transform maps measured into nominal: it undoes the pose the part was put in.
    T_nm = np.array(doc["transform"])
    assert np.allclose(T_nm[:3, :3] @ T[:3, :3], np.eye(3), atol=1e-4)
    assert np.max(np.abs(apply_transform(T_nm, apply_transform(T, q)) - q)) < 0.01
    sha = hashlib.sha256((d / "good.csv").read_bytes()).hexdigest()
    assert doc["inputs"][1] == {"role": "measured", "path": str(d / "good.csv"), "sha256": sha,
                                "n_points": 300}
    with open(d / "r.csv") as f:
        rows = list(csv.DictReader(f))
    assert list(rows[0]) == ["index", "label", "x", "y", "z", "x_reg", "y_reg", "z_reg",
                             "deviation", "in_tolerance", "excluded_from_alignment"]
    assert [r["label"] for r in rows[:2]] == ["P000", "P001"] and len(rows) == 300
    got = np.array([float(r["deviation"]) for r in rows])
    assert np.max(np.abs(got - dev)) < 2e-3
    assert all(r["in_tolerance"] == "true" for r in rows)


def test_reject_and_stdout_json(files, capsys):
    d, _, _, _ = files
    code = run("inspect", d / "nominal.csv", d / "bad.csv", "--tol", "0.05", "--json", "-")
    doc = json.loads(capsys.readouterr().out)
    assert code == 1 and doc["verdict"] == "REJECT" and doc["deviations"]["n_out"] == 1
    assert doc["deviations"]["worst"][0]["index"] == 7
    assert doc["deviations"]["worst"][0]["deviation"] == pytest.approx(0.2, abs=0.01)


@pytest.mark.parametrize("args, text", [
    ([], "a command is required"),
    (["inspect", "a.csv", "b.csv"], "a tolerance is required"),
    (["inspect", "a.csv", "b.csv", "--tol", "0.1", "--tol-lower", "-1"], "either --tol"),
    (["inspect", "a.csv", "b.csv", "--tol-lower", "-1"], "needs both"),
    (["inspect", "a.csv", "b.csv", "--tol-lower", "1", "--tol-upper", "-1"], "zone is empty"),
    (["inspect", "a.csv", "b.csv", "--tol", "-0.1"], "must be positive"),
    (["inspect", "a.csv", "b.csv", "--tol", "abc"], "'abc' is not a number"),
    (["inspect", "a.csv", "--tol", "1"], "required"),
    (["bogus"], "invalid choice"),
])
def test_usage_errors_exit_64(args, text, capsys):
    assert run(*args) == 64
    assert text in capsys.readouterr().err


def test_bad_data_exit_65_and_missing_exit_66_without_outputs(files, tmp_path, capsys):
    d, _, _, _ = files
    bad = tmp_path / "m.csv"
    bad.write_text("x,y,z\n1,2,3\n4,x1.2,6\n7,8,9\n")
    out = tmp_path / "out.json"
    assert run("inspect", d / "nominal.csv", bad, "--tol", "1", "--json", out) == 65
    err = capsys.readouterr().err
    assert f"{bad}:3: 'x1.2' is not a number" in err and "Traceback" not in err
    assert not out.exists()
    assert run("inspect", d / "nominal.csv", tmp_path / "none.csv", "--tol", "1",
               "--json", out) == 66
    assert "none.csv: no such file" in capsys.readouterr().err
    assert not out.exists()
    flat = tmp_path / "flat.csv"
    flat.write_text("0 0\n1 0\n1 1\n")
    assert run("inspect", d / "nominal.csv", flat, "--tol", "1") == 65


def test_unwritable_output_exit_73_and_no_partial_file(files, tmp_path, capsys):
    d, _, _, _ = files
    blocker = tmp_path / "file"
    blocker.write_text("")
    assert run("inspect", d / "nominal.csv", d / "good.csv", "--tol", "1",
               "--json", blocker / "r.json") == 73
    assert "cannot write" in capsys.readouterr().err
    assert [p.name for p in tmp_path.iterdir()] == ["file"]


def test_installed_console_script_runs():
    """The entry point the README uses exists and speaks the contract (usage error → 64)."""
    exe = os.path.join(os.path.dirname(sys.executable), "qa-inspect")
    r = subprocess.run([exe, "inspect"], capture_output=True, text=True)
    assert r.returncode == 64 and "usage: qa-inspect inspect" in r.stderr
