"""``qa-inspect batch``: every part once, on a local Dask cluster and on a real external one (a
``dask scheduler`` and two ``dask worker`` processes, one killed mid-batch); ERROR rows;
resume; the single-part command as the truth of each part's numbers."""

import contextlib
import csv
import json
import os
import re
import socket
import subprocess
import sys
import time

import numpy as np
import pytest

from engine.pose import apply_transform, make_transform
from engine.pipeline import inspection_settings, load_nominal
from engine.tolerance import Tolerance
from qa_app import batch as qb, lot_summary
from qa_app import lot as lot_model
from qa_app.cli import main
from surfaces import (height, height_normal, random_rotation, write_grid_nominal,
                      write_labelled_points)

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BIN = os.path.dirname(sys.executable)
GOOD, BAD = "ACCEPT", "REJECT"


def _write_part(path, rng, out_of_tolerance: bool) -> None:
    """300 points on the grid surface with 2 um noise in a random pose; one point 0.2 mm out."""
    x, y = rng.uniform(-240, 240, 300), rng.uniform(-115, 115, 300)
    q = np.column_stack([x, y, height(x, y)]) + rng.normal(0, 0.002, 300)[:, None] * \
        height_normal(x, y)
    if out_of_tolerance:
        q[7] += 0.2 * height_normal(x[7], y[7])
    T = make_transform(random_rotation(rng), rng.uniform(-500, 500, 3))
    write_labelled_points(path, apply_transform(T, q))


@pytest.fixture(scope="module")
def lot(tmp_path_factory):
    """A grid nominal and a lot of parts s01..s12: s03 and s08 with a point 0.2 mm out."""
    d = tmp_path_factory.mktemp("lot")
    write_grid_nominal(d / "nominal.csv", 150, 100)
    rng = np.random.default_rng(14)
    truth = {}
    os.mkdir(d / "parts")
    for k in range(1, 13):
        serial = f"s{k:02d}"
        _write_part(d / "parts" / f"{serial}.csv", rng, k in (3, 8))
        truth[serial] = BAD if k in (3, 8) else GOOD
    return d, truth


def run(*args):
    return main([str(a) for a in args])


def _summary(out):
    with open(os.path.join(out, "summary.json")) as f:
        return json.load(f)


def _complete_parts(out):
    """The serials with a complete result; fails on any partial or temporary file."""
    files = os.listdir(os.path.join(out, "parts"))
    assert not [f for f in files if f.startswith((".tmp-", ".keep-"))], files
    serials = {f.split(".")[0] for f in files if f.endswith(".json") and not f.startswith(".")}
    for s in serials:
        assert {f"{s}.json", f"{s}.csv", f".{s}.key.json"} <= set(files), s
    assert len(files) == 3 * len(serials), files
    return serials


# ---------------------------------------------------------------------------- without a cluster
def test_exit_codes_in_order_of_precedence():
    assert lot_model.exit_code(["ACCEPT", "ACCEPT"]) == 0
    assert lot_model.exit_code(["ACCEPT", "INCONCLUSIVE", "REJECT", "ERROR"]) == 1
    assert lot_model.exit_code(["ACCEPT", "INCONCLUSIVE", "ERROR"]) == 2
    assert lot_model.exit_code(["ACCEPT", "ERROR"]) == 65
    assert lot_model.exit_code(["ERROR"]) == 65


def test_progress_line_counts_rate_and_time_left():
    # 30 of 200 done, 20 of them inspected in 8 s (10 skipped): 2.5 parts/s, 170 left: 68 s.
    line = qb.progress_line(30, 200, 20, 8.0, {"ACCEPT": 25, "REJECT": 4, "ERROR": 1}, 20)
    assert line.startswith("[###.................] 30/200 parts  2.50 parts/s  ETA 1:08")
    assert line.endswith("ACCEPT 25 REJECT 4 INCONCLUSIVE 0 ERROR 1")


def test_parts_in_measurement_order_and_usage_errors(lot, tmp_path, capsys):
    d, _ = lot
    parts = lot_model.find_parts([str(d / "parts" / "s1*.csv"), str(d / "parts" / "s02.csv"),
                           str(d / "parts" / "s0[12].csv")])
    assert [p.serial for p in parts] == ["s10", "s11", "s12", "s02", "s01"]
    os.mkdir(tmp_path / "other")
    (tmp_path / "other" / "s01.csv").write_bytes((d / "parts" / "s01.csv").read_bytes())
    for measured, words in (([d / "parts" / "s01.csv", tmp_path / "other" / "s01.csv"],
                             "two parts have the serial 's01'"),
                            ([d / "parts" / "*.xyz"], "matches no file"),
                            ([d / "parts" / "s99.csv"], "does not exist")):
        code = run("batch", d / "nominal.csv", *measured, "--tol", "0.1", "--out",
                   tmp_path / "o")
        assert code == 64 and words in capsys.readouterr().err
    # An output onto an input: with --out the lot's folder, parts/s01.csv is the measured file.
    before = (d / "parts" / "s01.csv").read_bytes()
    code = run("batch", d / "nominal.csv", d / "parts" / "s01.csv", "--tol", "0.1", "--out", d)
    assert code == 64 and "never replaces an input" in capsys.readouterr().err
    assert (d / "parts" / "s01.csv").read_bytes() == before
    assert not os.path.exists(tmp_path / "o") and not os.path.exists(d / "summary.json")


def test_one_nominal_for_many_parts_gives_the_single_run_results(lot, tmp_path):
    """load_nominal once + inspect_measured per part == run_files per part, also for a bare
    point nominal whose normals are estimated (and cached) on the first part's demand."""
    from engine.pipeline import inspect_measured, run_files
    from reports.results import points_csv, run_document

    d, _ = lot
    with open(d / "nominal.csv") as f:
        rows = np.loadtxt(f, delimiter=",", skiprows=2)
    bare = tmp_path / "bare.xyz"
    np.savetxt(bare, rows[::2, :3], fmt="%.9f")  # no normals, no grid
    settings = inspection_settings(Tolerance.symmetric(0.1))
    for nominal in (d / "nominal.csv", bare):
        loaded = load_nominal(str(nominal), settings)
        for serial in ("s03", "s01", "s02"):
            part = str(d / "parts" / f"{serial}.csv")
            shared, fresh = inspect_measured(loaded, part), run_files(str(nominal), part,
                                                                      settings)
            a, b = run_document(shared), run_document(fresh)
            a.pop("timings_s"), b.pop("timings_s")
            assert a == b
            assert points_csv(shared.result, shared.measured.points, None) == \
                points_csv(fresh.result, fresh.measured.points, None)


def test_what_spc_tracks_and_judges_follows_the_fit_and_the_plan(lot, tmp_path):
    """Without a plan: max |d| (>= 0, the zone's largest |limit| above it), mean d, and the
    points out of tolerance (a count, at most 0). After a least-squares fit mean d is
    information only, with no limits to judge it by (the fit sets it to ~0); after the minimax
    fit, which centres the extremes and not the mean, it is a value against the zone. With a
    plan: a size is a value, a form or profile value is >= 0 with its zone above it."""
    from engine.spc import Kind

    d, _ = lot
    nominal = str(d / "nominal.csv")

    def tracked(**kw):
        settings = inspection_settings(Tolerance(-0.1, 0.3), **kw)
        return [(t.id, t.kind, t.lower, t.upper)
                for t in lot_summary.tracked_characteristics(load_nominal(nominal, settings))]

    assert tracked() == [("max_abs", Kind.BOUNDED, None, 0.3), ("mean", Kind.FORCED, None, None),
                         ("n_out", Kind.COUNT, None, 0.0)]
    assert tracked(fit="minimax")[1] == ("mean", Kind.MEASURED, -0.1, 0.3)
    plan = tmp_path / "plan.toml"
    plan.write_text('[part]\nnumber = "PL-7"\n[[region]]\nname = "all"\n'
                    'box = [[-1e3, -1e3, -1e3], [1e3, 1e3, 1e3]]\n'
                    '[[characteristic]]\nid = "f"\ntype = "flatness"\nregion = "all"\n'
                    'zone = 0.4\n')
    with_plan = load_nominal(nominal, inspection_settings(None, str(plan)))
    assert [(t.id, t.kind, t.upper) for t in lot_summary.tracked_characteristics(with_plan)] == [
        ("f", Kind.BOUNDED, 0.4)]
    # The part number the SPC's title names: --part-number, else the plan's, else none.
    plain = load_nominal(nominal, inspection_settings(Tolerance(-0.1, 0.3)))
    assert lot_summary.part_number(lot_model.Batch([], "out", part_number=" SB-1 "), with_plan) == "SB-1"
    assert lot_summary.part_number(lot_model.Batch([], "out"), with_plan) == "PL-7"
    assert lot_summary.part_number(lot_model.Batch([], "out"), plain) == ""


# ---------------------------------------------------------------------------- the local cluster
def test_local_cluster_matches_inspect_errors_and_resumes(lot, tmp_path, capsys):
    d, truth = lot
    bad = tmp_path / "s05x.csv"
    bad.write_text("id,x,y,z\nP1,1,2\n")
    measured = [d / "parts" / f"s0{k}.csv" for k in (1, 2, 3)] + [bad]
    out = tmp_path / "out"
    args = ["batch", d / "nominal.csv", *measured, "--tol", "0.1", "--out", out,
            "--workers", "2", "--quiet"]
    assert run(*args) == 1  # a REJECT among ACCEPTs and an ERROR
    assert capsys.readouterr().err == ""  # --quiet, and the cluster's logs silenced
    first = _summary(out)
    rows = first["parts"]
    assert [r["serial"] for r in rows] == ["s01", "s02", "s03", "s05x"]
    assert [r["verdict"] for r in rows] == [truth["s01"], truth["s02"], truth["s03"], "ERROR"]
    assert rows[3]["message"].startswith(f"{bad}:2:")  # the file and line
    assert first["counts"] == {"ACCEPT": 2, "REJECT": 1, "INCONCLUSIVE": 0, "ERROR": 1}
    assert _complete_parts(out) == {"s01", "s02", "s03"}
    # Each part: the document and CSV of the single-part command (the truth).
    for r, path in zip(rows[:3], measured):
        truth_json, truth_csv = tmp_path / "t.json", tmp_path / "t.csv"
        assert run("inspect", os.path.abspath(d / "nominal.csv"), os.path.abspath(path),
                   "--tol", "0.1", "--json", truth_json, "--csv", truth_csv) == \
            (0 if r["verdict"] == GOOD else 1)
        want = json.loads(truth_json.read_text())
        got = json.loads((out / "parts" / f"{r['serial']}.json").read_text())
        want.pop("timings_s"), got.pop("timings_s")
        assert got == want
        assert (out / "parts" / f"{r['serial']}.csv").read_text() == truth_csv.read_text()
        assert r["max_abs"] == want["deviations"]["max_abs"]
        assert r["n_out"] == want["deviations"]["n_out"]
        assert r["values"] == {"max_abs": want["deviations"]["max_abs"],
                               "mean": want["deviations"]["mean"],
                               "n_out": want["deviations"]["n_out"]}
        assert r["sha256"] == next(i["sha256"] for i in want["inputs"]
                                   if i["role"] == "measured")
    assert [(c["id"], c["lower"], c["upper"], c["kind"]) for c in first["characteristics"]] \
        == [("max_abs", None, 0.1, "bounded"), ("mean", None, None, "forced"),
            ("n_out", None, 0.0, "count")]
    with open(out / "summary.csv") as f:
        table = list(csv.DictReader(f))
    assert [(t["serial"], t["verdict"]) for t in table] == [(r["serial"], r["verdict"])
                                                            for r in rows]
    assert float(table[2]["max_abs_mm"]) == rows[2]["max_abs"]
    capsys.readouterr()

    # Resume: the same command skips the three results, re-tries the ERROR; same summary.
    assert run(*args) == 1
    assert "3 skipped" in capsys.readouterr().out
    again = _summary(out)
    assert [r["skipped"] for r in again["parts"]] == [True, True, True, False]
    for r in again["parts"] + first["parts"]:
        r.pop("skipped")
    again["parts"][3].pop("time_s"), first["parts"][3].pop("time_s")
    assert (again.pop("skipped"), first.pop("skipped")) == (3, 0)
    assert again == first

    # Other settings: every part is inspected again; the 0.2 mm point is inside +-0.3.
    args[args.index("0.1")] = "0.3"
    assert run(*args) == 65  # ACCEPTs and an ERROR
    rows = _summary(out)["parts"]
    assert [r["skipped"] for r in rows] == [False] * 4
    assert [r["verdict"] for r in rows] == ["ACCEPT", "ACCEPT", "ACCEPT", "ERROR"]

    # A part whose file is now damaged: its ERROR row, and nothing left of its earlier result.
    changed = tmp_path / "s01.csv"
    changed.write_text((d / "parts" / "s01.csv").read_text())
    args[2] = changed  # the same serial and content: its result is kept (skipped)
    assert run(*args) == 65 and _summary(out)["parts"][0]["skipped"]
    changed.write_text("id,x,y,z\nP1,1,2,x\n")
    assert run(*args) == 65
    assert _summary(out)["parts"][0]["verdict"] == "ERROR"
    assert _complete_parts(out) == {"s02", "s03"}


def test_every_match_of_a_lot_is_in_its_summary_and_an_unreadable_one_is_an_error(
        lot, tmp_path, capsys):
    """A glob's matches that are no file to read (a dangling symbolic link, a named pipe, a
    folder) were silently left out ("1 parts: 1 ACCEPT"): each is an ERROR row saying what it
    is, found without opening it (a pipe would block the batch). A part that is the nominal
    itself is an ERROR row too (issue 22, items 2 and 3). Run in a child process: a batch that
    blocked on the pipe fails the test instead of hanging the run."""
    d, truth = lot
    parts = tmp_path / "parts"
    parts.mkdir()
    (parts / "s01.csv").write_bytes((d / "parts" / "s01.csv").read_bytes())
    (parts / "s02.csv").symlink_to(tmp_path / "gone.csv")
    os.mkfifo(parts / "s03.csv")
    (parts / "s04.csv").mkdir()
    (parts / "s05.csv").write_bytes((d / "nominal.csv").read_bytes())
    out = tmp_path / "out"
    r = subprocess.run([sys.executable, "-m", "qa_app.cli", "batch", str(d / "nominal.csv"),
                        str(parts / "*.csv"), "--tol", "0.1", "--out", str(out), "--workers",
                        "1", "--quiet"], capture_output=True, text=True, timeout=300,
                       cwd=tmp_path, env={**os.environ, "PYTHONPATH": ROOT})
    assert r.returncode == 65, r.stdout + r.stderr  # ACCEPT and ERRORs
    assert r.stdout.startswith("5 parts: 1 ACCEPT, 0 REJECT, 0 INCONCLUSIVE, 4 ERROR")
    rows = _summary(out)["parts"]
    assert [(x["serial"], x["verdict"]) for x in rows] == [
        ("s01", truth["s01"]), ("s02", "ERROR"), ("s03", "ERROR"), ("s04", "ERROR"),
        ("s05", "ERROR")]
    messages = [x["message"] for x in rows[1:]]
    assert messages[0] == f"{parts / 's02.csv'}: a symbolic link to {tmp_path / 'gone.csv'}, " \
                          "which does not exist"
    assert messages[1].startswith(f"{parts / 's03.csv'}: a named pipe (FIFO), not a file")
    assert messages[2].startswith(f"{parts / 's04.csv'}: a folder, not a file")
    assert messages[3].startswith(f"{parts / 's05.csv'}: the measured file is the nominal ")
    for serial in ("s02", "s03", "s04", "s05"):
        assert f"  ERROR {serial} ({parts / serial}.csv): " in r.stdout
    assert _complete_parts(out) == {"s01"}
    # Named directly (not by a glob), such a file is a usage error, as before.
    assert run("batch", d / "nominal.csv", parts / "s03.csv", "--tol", "0.1", "--out",
               tmp_path / "o") == 64
    assert "is a named pipe (FIFO)" in capsys.readouterr().err


@pytest.mark.parametrize("service", ["http", "closed"])
def test_a_scheduler_address_without_a_scheduler_exits_69_within_seconds(lot, tmp_path,
                                                                         service):
    """--scheduler at a port where an HTTP server listens hung for ever (Dask waits for its
    handshake's answer without end); at a closed port it took 61 s. Both: exit 69 within 15 s,
    naming the address and the reason, and nothing written."""
    import http.server
    import threading

    d, _ = lot
    server = None
    if service == "http":
        server = http.server.ThreadingHTTPServer(("127.0.0.1", 0),
                                                 http.server.SimpleHTTPRequestHandler)
        threading.Thread(target=server.serve_forever, daemon=True).start()
        port = server.server_address[1]
        reason = "did not answer as a Dask scheduler within 5 s"
    else:
        with socket.socket() as s:  # a free port, closed again: nothing listens there
            s.bind(("127.0.0.1", 0))
            port = s.getsockname()[1]
        reason = "the connection was refused"
    address = f"tcp://127.0.0.1:{port}"
    try:
        t0 = time.monotonic()
        r = subprocess.run([sys.executable, "-m", "qa_app.cli", "batch", str(d / "nominal.csv"),
                            str(d / "parts" / "s01.csv"), "--tol", "0.1", "--out",
                            str(tmp_path / "out"), "--scheduler", address],
                           capture_output=True, text=True, timeout=120, cwd=tmp_path,
                           env={**os.environ, "PYTHONPATH": ROOT})
        elapsed = time.monotonic() - t0
    finally:
        if server is not None:
            server.shutdown()
            server.server_close()
    assert r.returncode == 69, r.stderr
    assert elapsed < 15, elapsed
    assert r.stderr.startswith(f"qa-inspect: error: cannot reach the Dask scheduler {address}: ")
    assert reason in r.stderr and len(r.stderr.splitlines()) == 1, r.stderr
    assert not (tmp_path / "out").exists()


def test_resuming_a_finished_lot_starts_no_cluster(lot, tmp_path, capsys, monkeypatch):
    """Every part already done: the same command writes the same summary without starting a
    local cluster (it took about 3 s for nothing) or reaching a scheduler."""
    import distributed

    d, _ = lot
    out = tmp_path / "out"
    args = ["batch", d / "nominal.csv", d / "parts" / "s01.csv", d / "parts" / "s02.csv",
            "--tol", "0.1", "--out", out, "--workers", "1", "--quiet"]
    assert run(*args) == 0
    first = _summary(out)
    capsys.readouterr()

    def no_cluster(*a, **k):
        raise AssertionError("a finished lot started a cluster")

    monkeypatch.setattr(distributed, "LocalCluster", no_cluster)
    monkeypatch.setattr(distributed, "Client", no_cluster)
    assert run(*args) == 0
    assert "2 skipped" in capsys.readouterr().out
    again = _summary(out)
    assert [r["skipped"] for r in again["parts"]] == [True, True]
    for r in first["parts"] + again["parts"]:
        r.pop("skipped")
    assert again["parts"] == first["parts"]
    # With a scheduler that does not exist, too: nothing needs it.
    at = args.index("--workers")
    assert run(*args[:at], *args[at + 2:], "--scheduler", "tcp://127.0.0.1:9") == 0


def test_a_lot_that_passes_but_drifts_is_flagged_by_spc(lot, tmp_path):
    """Twelve parts, all ACCEPT at +-0.06 mm, with a bump that grows 4 um a part: summary.json's
    SPC of max |d| warns of the drift towards the upper limit, after as many more parts as the
    least-squares line of the summary's own values says (numpy's polyfit, the independent
    line), with Nelson's rule 3 (six or more in a row rising) among its flags; spc.pdf says so in
    words, one page for the lot and one per characteristic, titled by the part number given,
    the charts naming the parts by serial. mean d is ~0 in every part (the least-squares fit's
    doing: far below the 2 um noise and the 4 um steps) and has no index or rule. A stable
    lot's max |d| (the fixture's good parts) shows no drift."""
    d, _ = lot
    rng = np.random.default_rng(31)
    files = []
    for k in range(1, 13):
        x, y = rng.uniform(-240, 240, 300), rng.uniform(-115, 115, 300)
        x[:15], y[:15] = rng.uniform(90, 110, 15), rng.uniform(40, 60, 15)
        q = np.column_stack([x, y, height(x, y)])
        q += (rng.normal(0, 0.002, 300) + np.r_[np.full(15, 0.004 * k), np.zeros(285)])[:, None] \
            * height_normal(x, y)
        T = make_transform(random_rotation(rng), rng.uniform(-500, 500, 3))
        files.append(tmp_path / f"d{k:02d}.csv")
        write_labelled_points(files[-1], apply_transform(T, q))
    out = tmp_path / "out"
    # Dask's usual web port taken (another batch, another Dask user): the local cluster
    # starts all the same (it failed: "Port 8787 is already in use").
    with contextlib.closing(socket.socket()) as taken:
        taken.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        with contextlib.suppress(OSError):  # already taken by someone else: as good
            taken.bind(("0.0.0.0", 8787))
            taken.listen()
        assert run("batch", d / "nominal.csv", *files, "--tol", "0.06", "--out", out,
                   "--workers", "1", "--quiet", "--part-number", "FA-12") == 0
    doc = _summary(out)
    spc = {c["id"]: c for c in doc["spc"]}
    values = np.array([r["values"]["max_abs"] for r in doc["parts"]])
    slope, intercept = np.polyfit(np.arange(12), values, 1)
    drift = spc["max_abs"]["drift"]
    assert drift["warning"] and drift["limit"] == "upper"
    assert drift["slope"] == pytest.approx(slope, rel=1e-9)
    assert drift["parts_to_limit"] == int(np.ceil((0.06 - (intercept + 11 * slope)) / slope))
    assert any(v["rule"] == 3 for v in spc["max_abs"]["violations"])
    assert spc["max_abs"]["n"] == 12 and spc["max_abs"]["upper"] == 0.06
    means = np.array([r["values"]["mean"] for r in doc["parts"]])
    assert np.abs(means).max() < 1e-4 and spc["mean"]["kind"] == "forced"
    assert spc["mean"]["capability"]["cpk"]["value"] is None and spc["mean"]["violations"] == []
    assert spc["n_out"]["kind"] == "count" and spc["n_out"]["out_of_tolerance"] == 0
    text = subprocess.run(["pdftotext", "-layout", str(out / "spc.pdf"), "-"],
                          capture_output=True, text=True, check=True).stdout
    assert text.lstrip().startswith("FA-12: 12 parts") and "nominal.csv:" not in text
    chart = text.split("\f")[1]
    assert all(f"d{k:02d}" in chart for k in range(1, 13))
    assert "drift towards the upper limit" in text
    assert re.search(r"R3: \d+ points in a row rising", text)
    pages = subprocess.run(["pdfinfo", str(out / "spc.pdf")], capture_output=True, text=True,
                           check=True).stdout
    assert re.search(r"^Pages:\s+4$", pages, re.M)  # the lot, max |d|, mean d, points out
    stable = lot_summary.lot_series(lot_summary.tracked_characteristics(load_nominal(
        str(d / "nominal.csv"), inspection_settings(Tolerance.symmetric(0.06)))),
        [{"serial": "x", "values": {"max_abs": v}} for v in
         np.random.default_rng(4).normal(0.02, 0.002, 12)])
    from engine.spc import analyse
    assert not analyse(stable[0]).drift.warning


def test_a_worker_never_judges_by_a_plan_edited_since_it_read_it(lot, tmp_path):
    """A worker reads a nominal it cannot be sent (a STEP model) once and keeps it for later
    batches: after the plan file is edited, the client's new reference (the new plan's SHA-256)
    makes it read the plan again, and a reference to the old plan is refused, not judged by
    whichever plan the worker holds."""
    from engine.io import sha256_of

    d, _ = lot
    plan = tmp_path / "plan.toml"

    def write(zone):
        plan.write_text('[[region]]\nname = "all"\nbox = [[-1e3, -1e3, -1e3], [1e3, 1e3, 1e3]]'
                        f'\n[[characteristic]]\nid = "p"\ntype = "profile"\nregion = "all"\n'
                        f'zone = {zone}\n')
        return qb.NominalRef(str(d / "nominal.csv"), sha256_of(str(d / "nominal.csv")),
                             inspection_settings(None, str(plan)), sha256_of(str(plan)))

    part = str(d / "parts" / "s03.csv")  # a point 0.2 mm out
    old = write(1.0)
    assert json.loads(qb.inspect_part(old, part, "s03", None).json)["verdict"] == "ACCEPT"
    new = write(0.1)
    assert json.loads(qb.inspect_part(new, part, "s03", None).json)["verdict"] == "REJECT"
    refused = qb.inspect_part(old, part, "s03", None)
    assert refused.json is None and "plan this worker reads is not the client's" in \
        refused.error


def test_a_step_nominal_reaches_the_workers_by_path(tmp_path):
    """A STEP model cannot be pickled: the worker reads it itself (checked by its SHA-256) and
    keeps it for the next part; the parts' deviations are the planted exact ones."""
    from test_step_inspection import STEP, measured_on, write

    from engine.io.step import read_step

    part = read_step(STEP)
    rng = np.random.default_rng(5)
    planted = {}
    for serial in ("a1", "a2"):
        M, planted[serial], _ = measured_on(part, rng, n=150)
        write(tmp_path / f"{serial}.csv", M)
    out = tmp_path / "out"
    assert run("batch", STEP, tmp_path / "a1.csv", tmp_path / "a2.csv", "--tol", "0.05",
               "--out", out, "--workers", "1", "--quiet") == 0
    for serial, want in planted.items():
        with open(out / "parts" / f"{serial}.csv") as f:
            d = np.array([float(r["deviation"]) for r in csv.DictReader(f)])
        assert np.max(np.abs(d - want)) < 1e-5  # the CSV prints 6 decimals
    assert [r["verdict"] for r in _summary(out)["parts"]] == ["ACCEPT", "ACCEPT"]


GEAR = os.path.join(ROOT, "tests", "data", "dxf", "gear_z20.dxf")
"""A real gear drawing whose header says metres over numbers in mm (tests/test_units.py)."""


def _gear_lot(folder, serials):
    """Parts on the gear's contours as drawn (mm), 2 um noise, each in its own pose (x y)."""
    from engine.contour import points_on
    from engine.io.templates import read_dxf_template
    from engine.pose import apply_transform, pose_2d

    t = read_dxf_template(GEAR, units="mm").template
    rng = np.random.default_rng(31)
    for serial in serials:
        q = apply_transform(pose_2d(rng.uniform(0, 2 * np.pi), rng.uniform(-200, 200, 2)),
                            points_on(t, 300, rng))
        np.savetxt(folder / f"{serial}.csv", q + rng.normal(0, 0.002, q.shape), delimiter=",",
                   header="x,y", comments="")
    return [folder / f"{s}.csv" for s in serials]


def test_a_lot_against_a_drawing_in_the_wrong_units_passes_with_units(tmp_path, capsys):
    """``batch`` takes --units (and --layer, --scale) as ``inspect`` does: without it every part
    of the gear's lot is INCONCLUSIVE, saying which option reads the drawing right; with it
    every part is ACCEPT, and the summary and each part's document record the units."""
    parts = _gear_lot(tmp_path, ("g1", "g2"))
    common = ["--tol", "0.05", "--workers", "1", "--quiet"]
    assert run("batch", GEAR, *parts, "--out", tmp_path / "as_drawn", *common) == 2
    rows = _summary(tmp_path / "as_drawn")["parts"]
    assert [r["verdict"] for r in rows] == ["INCONCLUSIVE", "INCONCLUSIVE"]
    assert all("read it with --units mm" in r["message"] for r in rows), rows
    out = tmp_path / "in_mm"
    assert run("batch", GEAR, *parts, "--out", out, "--units", "mm", "--layer", "0",
               *common) == 0
    summary = _summary(out)
    assert [r["verdict"] for r in summary["parts"]] == ["ACCEPT", "ACCEPT"]
    assert (summary["settings"]["units"], summary["settings"]["layers"]) == ("mm", ["0"])
    doc = json.loads((out / "parts" / "g1.json").read_text())
    assert (doc["settings"]["units"], doc["settings"]["layers"]) == ("mm", ["0"])
    assert doc["template"]["units"].startswith("mm (given")


@pytest.mark.parametrize("options, code", [
    (["--scale", "100"], 64),  # a chord for a DXF drawing
    (["--units", "km"], 64),
    (["--layer", "NO_SUCH_LAYER"], 65),
])
def test_batch_refuses_template_options_as_inspect_does(tmp_path, capsys, options, code):
    parts = _gear_lot(tmp_path, ("g1",))
    assert run("inspect", GEAR, parts[0], "--tol", "0.05", *options) == code
    said = capsys.readouterr().err.splitlines()[0].replace("qa-inspect inspect", "")
    assert run("batch", GEAR, *parts, "--tol", "0.05", "--out", tmp_path / "o",
               *options) == code
    assert capsys.readouterr().err.splitlines()[0].replace("qa-inspect batch", "") == said
    assert not os.path.exists(tmp_path / "o" / "summary.json")


# ---------------------------------------------------------------------------- an external cluster
@pytest.fixture()
def cluster(tmp_path):
    """A real ``dask scheduler`` and two ``dask worker`` processes (no nanny: a killed worker
    stays dead) on localhost, importing this tree; the scheduler's address."""
    env = dict(os.environ, PYTHONPATH=ROOT + os.pathsep + os.environ.get("PYTHONPATH", ""))
    sched_file = str(tmp_path / "scheduler.json")
    common = dict(env=env, cwd=str(tmp_path), stdout=subprocess.DEVNULL,
                  stderr=subprocess.DEVNULL)
    procs = [subprocess.Popen([os.path.join(BIN, "dask"), "scheduler", "--host", "127.0.0.1",
                               "--port", "0", "--no-dashboard", "--scheduler-file",
                               sched_file], **common)]
    try:
        procs += [subprocess.Popen([os.path.join(BIN, "dask"), "worker", "--scheduler-file",
                                    sched_file, "--nthreads", "1", "--no-nanny",
                                    "--no-dashboard", "--name", f"w{k}"], **common)
                  for k in range(2)]
        from distributed import Client

        deadline = time.monotonic() + 60
        while not os.path.exists(sched_file) and time.monotonic() < deadline:
            time.sleep(0.1)
        with open(sched_file) as f:
            address = json.load(f)["address"]
        with Client(address, timeout=30) as c:
            c.wait_for_workers(2, timeout=60)
        yield address, procs[1:]
    finally:
        for p in procs:
            p.kill()  # throwaway processes: no graceful shutdown to wait for
            p.wait()


def _batch(lot, out, serials):
    d, _ = lot
    settings = inspection_settings(Tolerance.symmetric(0.1))
    loaded = load_nominal(os.path.abspath(d / "nominal.csv"), settings)
    parts = lot_model.find_parts([str(d / "parts" / f"{s}.csv") for s in serials])
    return lot_model.Batch(parts, str(out)), loaded


def test_worker_killed_mid_batch_every_part_once(lot, cluster, tmp_path):
    from distributed import Client

    address, workers = cluster
    d, truth = lot
    serials = sorted(truth)
    job, loaded = _batch(lot, tmp_path / "out", serials)
    killed = []

    def kill_one_worker(row):
        if not killed:
            workers[0].kill()  # SIGKILL: its parts in progress are lost with it
            workers[0].wait()
            killed.append(row["serial"])

    with Client(address, timeout=30) as client:
        rows = qb.run_batch(job, loaded, client, on_row=kill_one_worker)
        alive = len(client.scheduler_info()["workers"])
    assert killed and alive == 1  # the kill happened during the batch
    assert [r["serial"] for r in rows] == serials
    assert [r["verdict"] for r in rows] == [truth[s] for s in serials]
    assert _complete_parts(tmp_path / "out") == set(serials)


def test_interrupted_then_resumed(lot, cluster, tmp_path, capsys):
    from distributed import Client

    address, _ = cluster
    d, truth = lot
    serials = sorted(truth)
    out = tmp_path / "out"
    job, loaded = _batch(lot, out, serials)

    def interrupt(row):
        raise KeyboardInterrupt  # Ctrl-C as the first result arrives

    with Client(address, timeout=30) as client:
        with pytest.raises(KeyboardInterrupt):
            qb.run_batch(job, loaded, client, on_row=interrupt)
        time.sleep(0.5)
        assert not client.processing() or not any(client.processing().values())
    done = _complete_parts(out)
    assert 1 <= len(done) < len(serials)
    assert not os.path.exists(out / "summary.json")
    measured = [d / "parts" / f"{s}.csv" for s in serials]
    assert run("batch", d / "nominal.csv", *measured, "--tol", "0.1", "--out", out,
               "--scheduler", address) == 1
    assert f"{len(done)} skipped" in capsys.readouterr().out
    rows = _summary(out)["parts"]
    assert [r["serial"] for r in rows] == serials
    assert [r["verdict"] for r in rows] == [truth[s] for s in serials]
    assert {r["serial"] for r in rows if r["skipped"]} == done
