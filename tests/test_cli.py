"""The qa-inspect command-line contract: exit codes, JSON fields, CSV rows, atomic outputs."""

import csv
import hashlib
import json
import os
import re
import shlex
import stat
import subprocess
import sys
import threading

import numpy as np
import pytest

from engine.pose import apply_transform, make_transform
from qa_app.cli import main
from surfaces import (height, height_normal, random_rotation, write_grid_nominal,
                      write_labelled_points)

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """A grid nominal with normals and two measured files (in tolerance, and one point out)."""
    d = tmp_path_factory.mktemp("cli")
    write_grid_nominal(d / "nominal.csv", 150, 100)
    rng = np.random.default_rng(0)
    x, y = rng.uniform(-240, 240, 300), rng.uniform(-115, 115, 300)
    dev = rng.normal(0, 0.002, 300)
    q = np.column_stack([x, y, height(x, y)]) + dev[:, None] * height_normal(x, y)
    T = make_transform(random_rotation(rng), [500.0, -200.0, 80.0])
    good = apply_transform(T, q)
    bad = good.copy()
    bad[7] = apply_transform(T, (q[7] + 0.2 * height_normal(x[7], y[7]))[None])[0]
    for name, arr in (("good.csv", good), ("bad.csv", bad)):
        write_labelled_points(d / name, arr)
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
    assert list(rows[0]) == ["point", "label", "x", "y", "z", "x_reg", "y_reg", "z_reg",
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
    # Numbered from 1 like the app and the CSV, with the point's label from the file.
    assert doc["deviations"]["worst"][0]["point"] == 8
    assert doc["deviations"]["worst"][0]["label"] == "P007"
    assert doc["deviations"]["worst"][0]["deviation"] == pytest.approx(0.2, abs=0.01)


def test_seed_is_taken_and_reported(files, capsys):
    """--seed N reaches the settings and the JSON's settings block (0 without it); the part
    registers the same with either."""
    d, T, dev, q = files
    docs = {}
    for seed in (None, 31):
        extra = [] if seed is None else ["--seed", seed]
        assert run("inspect", d / "nominal.csv", d / "good.csv", "--tol", "0.05", "--json", "-",
                   *extra) == 0
        docs[seed] = json.loads(capsys.readouterr().out)
    assert docs[None]["settings"]["seed"] == 0 and docs[31]["settings"]["seed"] == 31
    for doc in docs.values():
        assert doc["verdict"] == "ACCEPT"
        assert np.max(np.abs(apply_transform(np.array(doc["transform"]),
                                             apply_transform(T, q)) - q)) < 0.01


@pytest.mark.parametrize("args, text", [
    ([], "a command is required"),
    (["inspect", "a.csv", "b.csv"], "a tolerance is required"),
    (["inspect", "a.csv", "b.csv", "--tol", "0.1", "--tol-lower", "-1"], "either --tol"),
    (["inspect", "a.csv", "b.csv", "--tol-lower", "-1"], "needs both"),
    (["inspect", "a.csv", "b.csv", "--tol-lower", "1", "--tol-upper", "-1"], "zone is empty"),
    (["inspect", "a.csv", "b.csv", "--tol", "-0.1"], "must be positive"),
    (["inspect", "a.csv", "b.csv", "--tol", "abc"], "'abc' is not a number"),
    (["inspect", "a.csv", "b.csv", "--tol", "1", "--seed", "-1"], "a seed is >= 0"),
    (["inspect", "a.csv", "b.csv", "--tol", "1", "--seed", "1.5"], "'1.5' is not a whole number"),
    (["inspect", "a.csv", "--tol", "1"], "required"),
    (["bogus"], "invalid choice"),
])
def test_usage_errors_exit_64(args, text, capsys):
    assert run(*args) == 64
    assert text in capsys.readouterr().err


@pytest.mark.parametrize("args, command", [
    (["inspect"], "inspect"),
    (["batch"], "batch"),
    (["batch", "n.csv", "m.csv", "--tol", "0.1", "--tol-lower", "-1", "--out", "o"], "batch"),
    (["verify"], "verify"),
    (["verify", "c.pdf", "--trust", "ca.pem", "--nominal", "n.csv"], "verify"),
    (["keygen"], "keygen"),
    (["faces"], "faces"),
    (["plan"], "plan"),
    (["plan", "p.qif", "--toml", "o.toml"], "plan"),
    (["bogus"], None),
    ([], None),
])
def test_a_usage_error_shows_its_commands_usage(args, command, capsys):
    """Issue 22 item 10: the usage errors of batch and verify printed inspect's usage (every
    command's, inspect's first). Each shows its own; no command, or an unknown one, all."""
    assert run(*args) == 64
    err = capsys.readouterr().err
    message, shown = err.split("\nusage: ", 1)
    assert message.startswith(f"qa-inspect {command}: " if command else "qa-inspect: ")
    named = re.findall(r"^(?:usage: |\s+)qa-inspect (\S+)", "usage: " + shown, re.M)
    assert named == ([command] if command else ["inspect", "batch", "keygen", "verify",
                                                "faces", "plan", "--version"]), err


@pytest.mark.parametrize("command", ["inspect", "batch"])
@pytest.mark.parametrize("zone, limit", [
    (["--tol", "1e308"], 1e308),
    (["--tol", "1e300"], 1e300),
    (["--tol-lower", "-1", "--tol-upper", "2e6"], 2e6),
])
def test_absurd_zones_are_usage_errors_before_any_work(files, tmp_path, capsys, command, zone,
                                                       limit):
    """Issue 22 item 9: --tol 1e308 was accepted (numpy overflowed, the zone was printed with
    300 digits). A limit beyond 1e6 mm (1 km) is refused as --tol's other mistakes are (64)."""
    d, _, _, _ = files
    out = tmp_path / "out"
    args = ["--json", out / "r.json"] if command == "inspect" else ["--out", out]
    assert run(command, d / "nominal.csv", d / "good.csv", *zone, *args) == 64
    err = capsys.readouterr().err
    assert f"qa-inspect {command}: tolerance zone " in err
    assert f"a limit {limit:g} mm from the nominal is beyond 1e6 mm" in err
    assert "Traceback" not in err and len(err.split("\n")[0]) < 300
    assert not out.exists()


def test_a_zone_beyond_1000_times_the_part_is_refused(files, tmp_path, capsys):
    """Within 1e6 mm but over 1000 x the nominal's bounding-box diagonal: a zone no part has.
    The command line's zone is a usage error (64); a plan's is bad input naming the plan and
    the characteristic (65)."""
    d, _, _, _ = files
    with open(d / "nominal.csv") as f:
        pts = np.loadtxt(f, delimiter=",", skiprows=2)[:, :3]
    diagonal = float(np.linalg.norm(pts.max(axis=0) - pts.min(axis=0)))
    assert 1000 * diagonal < 1e6  # so that only the part's size refuses these zones
    over, under = 1000 * diagonal * 1.01, 1000 * diagonal * 0.99
    assert run("inspect", d / "nominal.csv", d / "good.csv", "--tol", over) == 64
    err = capsys.readouterr().err
    assert f"beyond 1000 × the part's size ({diagonal:.4g} mm" in err, err
    assert run("inspect", d / "nominal.csv", d / "good.csv", "--tol", under) == 0
    capsys.readouterr()
    plan = tmp_path / "plan.toml"
    plan.write_text('[[region]]\nname = "all"\nbox = [[-1e4, -1e4, -1e4], [1e4, 1e4, 1e4]]\n'
                    '\n[[characteristic]]\nid = "7"\ntype = "profile"\nregion = "all"\n'
                    f'zone = {2 * over!r}\n')
    assert run("inspect", d / "nominal.csv", d / "good.csv", "--plan", plan) == 65
    err = capsys.readouterr().err
    assert err.startswith(f'qa-inspect: error: {plan}: [[characteristic]] #1 (id "7"): '
                          "tolerance zone "), err
    assert "1000 × the part's size" in err
    plan.write_text(plan.read_text().replace(f"zone = {2 * over!r}", "zone = 1e300"))
    assert run("inspect", d / "nominal.csv", d / "good.csv", "--plan", plan) == 65
    err = capsys.readouterr().err
    assert f'{plan}: [[characteristic]] #1 (id "7"): tolerance zone -5e+299' in err, err
    assert "beyond 1e6 mm" in err


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


def test_the_nominal_inspected_against_itself_is_refused(files, tmp_path, capsys):
    """The nominal as its own measurement (the same file, a byte-identical copy) gave a
    (signed) ACCEPT: exit 65, the reason, no output. So do measured points that are all the
    nominal's own points to the last bit (every other row, without the normals): no
    measurement carries none of its instrument's noise."""
    import shutil

    d, _, _, _ = files
    nominal = d / "nominal.csv"
    copy = tmp_path / "copy.csv"
    shutil.copyfile(nominal, copy)
    with open(nominal) as f:
        rows = [line for line in f if line[:1].isdigit() or line[:1] == "-"]
    subset = tmp_path / "subset.csv"
    subset.write_text("x,y,z\n" + "".join(",".join(r.split(",")[:3]) + "\n"
                                          for r in rows[::2]))
    sha = hashlib.sha256(nominal.read_bytes()).hexdigest()
    for measured, words in ((nominal, f"the measured file is the nominal {nominal} (same "
                                      f"content, sha256 {sha[:16]}"),
                            (copy, f"the measured file is the nominal {nominal} (same content"),
                            (subset, f"every one of the {len(rows[::2]):,} measured points is "
                                     "one of the nominal's points")):
        out = tmp_path / "r.json"
        assert run("inspect", nominal, measured, "--tol", "0.05", "--json", out) == 65
        err = capsys.readouterr().err
        assert err.startswith(f"qa-inspect: error: {measured}: {words}"), err
        assert len(err.splitlines()) == 1 and not out.exists()
    # One point measured (a hair off the nominal) makes it a measurement again.
    subset.write_text(subset.read_text().replace(rows[0].split(",")[0] + ",",
                                                 f"{float(rows[0].split(',')[0]) + 1e-6},", 1))
    assert run("inspect", nominal, subset, "--tol", "0.05") in (0, 1, 2)
    assert "error" not in capsys.readouterr().err


def test_unwritable_output_exit_73_and_no_partial_file(files, tmp_path, capsys):
    """An output whose folder is a file: exit 73, the path and why, nothing written (issue 22
    item 10: the message was "File exists")."""
    d, _, _, _ = files
    blocker = tmp_path / "file"
    blocker.write_text("")
    assert run("inspect", d / "nominal.csv", d / "good.csv", "--tol", "1",
               "--json", blocker / "sub" / "r.json", "--csv", tmp_path / "r.csv") == 73
    target = blocker / "sub" / "r.json"
    assert capsys.readouterr().err == (f"qa-inspect: error: cannot write {target}: its folder "
                                       f"{blocker} is a file, not a folder\n")
    assert [p.name for p in tmp_path.iterdir()] == ["file"] and blocker.read_text() == ""


def test_console_script_entry_point_runs():
    """The entry point pyproject.toml declares for the command the README uses exists and speaks
    the contract (usage error → 64): run the way the installed ``qa-inspect`` wrapper runs it."""
    import tomllib

    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    with open(os.path.join(root, "pyproject.toml"), "rb") as f:
        target = tomllib.load(f)["project"]["scripts"]["qa-inspect"]
    module, func = target.split(":")
    wrapper = (f"import sys; from {module} import {func}; sys.argv[0] = 'qa-inspect'; "
               f"sys.exit({func}())")
    r = subprocess.run([sys.executable, "-c", wrapper, "inspect"], capture_output=True, text=True)
    assert r.returncode == 64 and "usage: qa-inspect inspect" in r.stderr


# ---------------------------------------------------------------------------- outputs (issue 10.6)
def _snapshot(folder):
    """{name: bytes} of every file in ``folder`` (temporary files included)."""
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir()) if p.is_file()}


@pytest.fixture
def work(files, tmp_path):
    """Copies of the nominal and the measured file in a fresh folder (inputs a run may touch)."""
    d = files[0]
    for name in ("nominal.csv", "good.csv"):
        (tmp_path / name).write_bytes((d / name).read_bytes())
    return tmp_path


@pytest.mark.parametrize("how", ["same", "dot", "symlink", "hardlink"])
@pytest.mark.parametrize("option", ["--csv", "--json", "--report"])
def test_an_output_never_replaces_an_input(work, capsys, monkeypatch, how, option):
    monkeypatch.chdir(work)
    alias = {"same": "good.csv", "dot": "./good.csv", "symlink": "link.csv",
             "hardlink": "hard.csv"}[how]
    if how == "symlink":
        os.symlink("good.csv", work / "link.csv")
    elif how == "hardlink":
        os.link(work / "good.csv", work / "hard.csv")
    before = _snapshot(work)
    assert run("inspect", "nominal.csv", "good.csv", "--tol", "0.05", option, alias) == 64
    err = capsys.readouterr().err
    assert f"{option} {alias}" in err and "MEASURED" in err and "Traceback" not in err
    assert _snapshot(work) == before


def test_an_output_never_replaces_the_nominal_or_the_signing_identity(work, capsys):
    before = _snapshot(work)
    assert run("inspect", work / "nominal.csv", work / "good.csv", "--tol", "0.05",
               "--json", work / "nominal.csv") == 64
    assert "NOMINAL" in capsys.readouterr().err
    # The identity is an input too (checked before its passphrase is asked for).
    (work / "id.p12").write_bytes(b"not read: the paths are checked first")
    before = _snapshot(work)
    assert run("inspect", work / "nominal.csv", work / "good.csv", "--tol", "0.05",
               "--report", work / "id.p12", "--sign", work / "id.p12") == 64
    err = capsys.readouterr().err
    assert "--report" in err and "--sign identity" in err
    assert _snapshot(work) == before


def test_two_outputs_on_one_file_are_a_usage_error(work, capsys):
    before = _snapshot(work)
    assert run("inspect", work / "nominal.csv", work / "good.csv", "--tol", "0.05",
               "--csv", work / "r.out", "--json", work / "sub" / ".." / "r.out") == 64
    err = capsys.readouterr().err
    assert "--csv and --json name the same file" in err
    assert _snapshot(work) == before and not (work / "sub").exists()


@pytest.mark.parametrize("option", ["--json", "--csv", "--report", "--sign"])
@pytest.mark.parametrize("empty", ["", "  "])
def test_empty_file_names_are_usage_errors(work, capsys, option, empty):
    before = _snapshot(work)
    extra = ["--report", work / "c.pdf"] if option == "--sign" else []
    assert run("inspect", work / "nominal.csv", work / "good.csv", "--tol", "0.05",
               option, empty, *extra) == 64
    assert f"{option} needs a file name" in capsys.readouterr().err
    assert _snapshot(work) == before


def test_empty_positional_and_verify_paths_are_usage_errors(work, capsys):
    assert run("inspect", "", work / "good.csv", "--tol", "0.05") == 64
    assert "NOMINAL needs a file name" in capsys.readouterr().err
    assert run("verify", work / "c.pdf", "--trust", "") == 64
    assert "--trust needs a file name" in capsys.readouterr().err
    assert run("keygen", "--name", "A", "--out", "") == 64
    assert "--out needs a file name" in capsys.readouterr().err


@pytest.mark.parametrize("existing", [False, True])
def test_all_outputs_or_none(work, capsys, existing):
    """The JSON cannot be written (its folder is a file): the CSV, written first before, is not
    written either, and a CSV that was there keeps its content."""
    (work / "blocker").write_text("")
    if existing:
        (work / "c.csv").write_text("the previous run's rows\n")
    before = _snapshot(work)
    code = run("inspect", work / "nominal.csv", work / "good.csv", "--tol", "0.05",
               "--csv", work / "c.csv", "--json", work / "blocker" / "x.json")
    cap = capsys.readouterr()
    assert code == 73
    assert f"cannot write {work / 'blocker' / 'x.json'}" in cap.err
    assert _snapshot(work) == before  # no new, changed or temporary file
    assert cap.out == ""


def test_stdout_json_only_after_every_file(work, capsys):
    (work / "blocker").write_text("")
    code = run("inspect", work / "nominal.csv", work / "good.csv", "--tol", "0.05",
               "--json", "-", "--csv", work / "blocker" / "c.csv")
    cap = capsys.readouterr()
    assert code == 73 and cap.out == ""


def test_outputs_replace_their_previous_versions(work, capsys):
    (work / "c.csv").write_text("old\n")
    (work / "r.json").write_text("{}\n")
    assert run("inspect", work / "nominal.csv", work / "good.csv", "--tol", "0.05",
               "--csv", work / "c.csv", "--json", work / "r.json") == 0
    assert json.loads((work / "r.json").read_text())["verdict"] == "ACCEPT"
    assert (work / "c.csv").read_text().startswith("point,label,")
    assert sorted(p.name for p in work.iterdir()) == ["c.csv", "good.csv", "nominal.csv",
                                                      "r.json"]


def test_csv_dash_is_stdout(work, capsys, monkeypatch):
    """``--csv -`` writes the CSV to standard output, like ``--json -`` (not a file named -)."""
    monkeypatch.chdir(work)
    assert run("inspect", "nominal.csv", "good.csv", "--tol", "0.05", "--csv", "-") == 0
    rows = list(csv.DictReader(capsys.readouterr().out.splitlines()))
    assert len(rows) == 300 and rows[7]["label"] == "P007"
    assert not os.path.lexists(work / "-")


@pytest.mark.parametrize("args, text", [
    (["--csv", "-", "--json", "-"], "both ask for standard output"),
    (["--report", "-"], "--report needs a file name"),
])
def test_dash_usage_errors(work, capsys, monkeypatch, args, text):
    monkeypatch.chdir(work)
    before = _snapshot(work)
    assert run("inspect", "nominal.csv", "good.csv", "--tol", "0.05", *args) == 64
    cap = capsys.readouterr()
    assert text in cap.err and cap.out == ""
    assert _snapshot(work) == before and not os.path.lexists(work / "-")


def test_devices_and_links_to_stdout_are_written_through(work, capfd, monkeypatch):
    """``--csv mynull`` (a null device: mknod as root, as in CI, else a link to /dev/null) and
    ``--json mystdout`` (a link to /proc/self/fd/1) are written to, never replaced by files."""
    monkeypatch.chdir(work)
    if os.geteuid() == 0:
        os.mknod("mynull", 0o666 | stat.S_IFCHR, os.makedev(1, 3))
    else:
        os.symlink("/dev/null", "mynull")
    null_kind = stat.S_IFMT(os.lstat("mynull").st_mode)
    os.symlink("/proc/self/fd/1", "mystdout")
    capfd.readouterr()
    assert run("inspect", "nominal.csv", "good.csv", "--tol", "0.05", "--csv", "mynull",
               "--json", "mystdout") == 0
    out = capfd.readouterr().out
    doc, end = json.JSONDecoder().raw_decode(out)  # the JSON, then the summary after it
    assert doc["verdict"] == "ACCEPT" and out[end:].lstrip().startswith("ACCEPT: all 300")
    assert stat.S_IFMT(os.lstat("mynull").st_mode) == null_kind
    assert stat.S_ISCHR(os.stat("mynull").st_mode)
    assert os.readlink("mystdout") == "/proc/self/fd/1"


def test_a_fifo_output_reaches_its_reader(work, capsys):
    fifo = work / "myfifo"
    os.mkfifo(fifo)
    os.link(fifo, work / ".spare")  # to release the reader should the FIFO be replaced
    got = []

    def read():
        with open(fifo, "rb") as f:
            got.append(f.read())

    reader = threading.Thread(target=read, daemon=True)
    reader.start()
    try:
        assert run("inspect", work / "nominal.csv", work / "good.csv", "--tol", "0.05",
                   "--json", fifo) == 0
        reader.join(timeout=20)
        assert not reader.is_alive() and json.loads(got[0])["verdict"] == "ACCEPT"
        assert stat.S_ISFIFO(os.lstat(fifo).st_mode)
    finally:
        if reader.is_alive():
            os.close(os.open(work / ".spare", os.O_WRONLY | os.O_NONBLOCK))


def test_an_output_never_replaces_a_signing_identity_or_trust_anchor(work, capsys,
                                                                      monkeypatch):
    """Not inputs of this run, yet never to be lost: keygen's inspector.p12 and ca.pem."""
    monkeypatch.setenv("QA_TEST_OUTPUTS_PASS", "pass phrase")
    ids = work / "id"
    assert run("keygen", "--name", "A. Inspector", "--out", ids,
               "--pass-env", "QA_TEST_OUTPUTS_PASS") == 0
    capsys.readouterr()
    before = _snapshot(ids)
    for option, target in (("--report", "inspector.p12"), ("--csv", "ca.pem"),
                           ("--json", "inspector.p12")):
        assert run("inspect", work / "nominal.csv", work / "good.csv", "--tol", "0.05",
                   option, ids / target) == 64
        err = capsys.readouterr().err
        assert f"{option} {ids / target} holds a key or certificate" in err
        assert _snapshot(ids) == before


# ---------------------------------------------------------------------------- --version (10.9)
def test_version(capsys):
    from importlib.metadata import version

    assert run("--version") == 0
    out = capsys.readouterr().out
    assert out == f"qa-inspect {version('qa-inspect')}\n"


# ---------------------------------------------------------------------------- messages (10.9)
def test_swapped_files_say_so(files, tmp_path, capsys):
    """A grid nominal with normals given as MEASURED, 100 bare measured points as NOMINAL."""
    d, _, _, _ = files
    write_grid_nominal(tmp_path / "nominal.csv", 60, 40)
    with open(d / "good.csv") as src, open(tmp_path / "measured.csv", "w") as f:
        f.writelines(src.readlines()[:101])
    code = run("inspect", tmp_path / "measured.csv", tmp_path / "nominal.csv", "--tol", "0.05",
               "--json", "-")
    doc = json.loads(capsys.readouterr().out)
    assert code == 2 and doc["verdict"] == "INCONCLUSIVE"
    hint = [r for r in doc["reasons"] if "look swapped" in r]
    assert len(hint) == 1
    assert (f"NOMINAL {tmp_path / 'measured.csv'} has 100 points" in hint[0]
            and f"MEASURED {tmp_path / 'nominal.csv'} has 2,400 points with a 60 x 40 grid and "
                "normals" in hint[0])
    # The same files the right way round: no such hint.
    assert run("inspect", tmp_path / "nominal.csv", tmp_path / "measured.csv", "--tol", "0.05",
               "--json", "-") in (0, 1, 2)
    assert not any("swapped" in r for r in json.loads(capsys.readouterr().out)["reasons"])


def test_swap_hint_spares_dense_scans():
    """Only the files' make-up says 'swapped': a dense bare scan against a coarser nominal with
    normals, or two bare clouds, are not."""
    from engine.pointset import PointSet
    from engine.pipeline import swap_hint

    rng = np.random.default_rng(3)

    def cloud(n, normals=False, grid=None, path="f.csv"):
        p = rng.normal(size=(n, 3))
        return PointSet(p, p / np.linalg.norm(p, axis=1)[:, None] if normals else None,
                        grid_shape=grid, path=path)

    coarse_cad = cloud(6_000, normals=True, path="cad.csv")
    assert swap_hint(coarse_cad, cloud(60_000, path="scan.csv")) is None  # 10x denser scan
    assert swap_hint(cloud(1_100), cloud(60_000)) is None  # two bare clouds
    assert swap_hint(cloud(1_100), cloud(9_000, normals=True)) is None  # < 10x
    hint = swap_hint(cloud(1_100, path="m.csv"), cloud(60_000, normals=True, grid=(300, 200),
                                                        path="n.csv"))
    assert hint.startswith("the files look swapped: NOMINAL m.csv has 1,100 points")
    assert "MEASURED n.csv has 60,000 points with a 300 x 200 grid and normals" in hint


FRAME = os.path.join(ROOT, "samples", "fuselage_frame")


@pytest.fixture(scope="module")
def mixed(tmp_path_factory):
    """2D point files and a non-planar 3D cloud (a sphere) for the 2D/3D mix-ups."""
    d = tmp_path_factory.mktemp("mixed")
    t = np.linspace(0, 2 * np.pi, 200, endpoint=False)
    for name in ("flat.csv", "flat2.csv"):
        np.savetxt(d / name, np.column_stack([50 * np.cos(t), 50 * np.sin(t)]),
                   delimiter=",", header="x,y", comments="")
    p = np.random.default_rng(5).normal(size=(300, 3))
    np.savetxt(d / "sphere.csv", 50 * p / np.linalg.norm(p, axis=1)[:, None], delimiter=",",
               header="x,y,z", comments="")
    return d


@pytest.mark.parametrize("nominal, measured, odd, other, says", [
    ("files:nominal.csv", "mixed:flat.csv", "measured", "nominal", "2 columns"),
    ("mixed:flat.csv", "files:good.csv", "nominal", None, "must be a contour template"),
    ("mixed:flat.csv", "mixed:flat2.csv", "nominal", None, "must be a contour template"),
    ("frame:measured.csv", "frame:template.dxf", "measured", None,
     "template cannot be the measured points"),
])
def test_mixed_2d_3d_names_the_odd_file(files, mixed, capsys, nominal, measured, odd, other,
                                        says):
    folders = {"files": files[0], "mixed": mixed, "frame": FRAME}
    paths = {}
    for role, spec in (("nominal", nominal), ("measured", measured)):
        where, name = spec.split(":")
        paths[role] = os.path.join(folders[where], name)
    assert run("inspect", paths["nominal"], paths["measured"], "--tol", "0.1") == 65
    err = capsys.readouterr().err
    assert err.startswith(f"qa-inspect: error: {paths[odd]}: ") and "Traceback" not in err
    assert says in err
    if other:
        assert f"the {other} {paths[other]}" in err


def test_a_2d_template_against_non_planar_points_names_them(mixed, capsys):
    code = run("inspect", os.path.join(FRAME, "template.dxf"), mixed / "sphere.csv",
               "--tol", "0.1", "--json", "-")
    doc = json.loads(capsys.readouterr().out)
    assert code == 2 and doc["verdict"] == "INCONCLUSIVE"
    hint = [r for r in doc["reasons"] if "not a planar contour" in r]
    assert len(hint) == 1 and str(mixed / "sphere.csv") in hint[0] and "template.dxf" in hint[0]


def test_keygen_refuses_to_overwrite_an_identity(tmp_path, monkeypatch, capsys):
    # An identity in use must survive a repeated keygen: exit 73 (cannot create), the files kept.
    monkeypatch.setenv("QA_TEST_PASS", "pw")
    args = ("keygen", "--name", "Ann", "--out", tmp_path, "--pass-env", "QA_TEST_PASS")
    assert run(*args) == 0
    before = {n: (tmp_path / n).read_bytes() for n in ("ca.pem", "inspector.p12")}
    capsys.readouterr()
    assert run(*args) == 73
    err = capsys.readouterr().err
    assert err == f"qa-inspect: error: {tmp_path / 'ca.pem'} already exists; not overwritten\n"
    assert {n: (tmp_path / n).read_bytes() for n in before} == before


def test_help_shows_examples_that_parse_and_every_exit_code(capsys):
    from qa_app.cli import build_parser

    with pytest.raises(SystemExit) as e:
        main(["--help"])
    assert e.value.code == 0
    out = capsys.readouterr().out
    examples = out.split("examples:\n", 1)[1].split("\n\n", 1)[0].replace("\\\n", " ")
    lines = [shlex.split(line) for line in examples.splitlines() if line.strip()]
    assert len(lines) >= 5
    for words in lines:  # each example is a command line the parser takes
        assert words[0] == "qa-inspect"
        build_parser().parse_args(words[1:])
    codes = dict(re.findall(r"^  (\d+) +(\S+)", out.split("exit codes:\n", 1)[1], re.M))
    assert codes == {"0": "ACCEPT:", "1": "REJECT:", "2": "INCONCLUSIVE:", "64": "usage",
                     "65": "bad", "66": "an", "69": "batch:", "70": "internal", "73": "an",
                     "130": "interrupted"}
