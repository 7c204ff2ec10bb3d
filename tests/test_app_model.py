"""The app's session model and controller, without Qt (synchronous controller)."""

import json
import os
import shutil
from pathlib import Path

import pytest

from qa_app.cli import main as cli_main
from qa_app.desktop.controller import Controller
from qa_app.desktop.model import Session, Step
from reports.results import run_document

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BELLY = os.path.join(ROOT, "samples", "belly_fairing")
FRAME = os.path.join(ROOT, "samples", "fuselage_frame")


def make():
    s = Session()
    messages = []
    s.message.connect(lambda level, text: messages.append((level, text)))
    return s, Controller(s, synchronous=True), messages


def test_workflow_steps_and_result():
    s, c, messages = make()
    steps = []
    s.step_changed.connect(steps.append)
    assert s.step == Step.NEED_NOMINAL and not s.can_inspect and not s.can_export
    c.open_nominal(os.path.join(BELLY, "nominal.csv"))
    assert s.step == Step.NEED_MEASURED
    c.open_measured(os.path.join(BELLY, "measured.csv"))
    assert s.step == Step.READY and s.can_inspect and not s.can_export
    progress = []
    s.progress.connect(lambda stage, f: progress.append(stage))
    assert c.set_tolerance(-0.05, 0.05)
    c.inspect()
    assert s.step == Step.INSPECTED and s.can_export
    assert s.run.result.verdict == "REJECT" and s.run.result.statistics.n_out == 20
    assert Step.RUNNING in steps
    assert any("ICP iteration" in p for p in progress)
    assert messages[-1][0] == "info" and messages[-1][1].startswith("REJECT")
    # Changing the tolerance makes the result stale: it belongs to the old settings.
    c.set_tolerance(-0.25, 0.25)
    assert s.step == Step.STALE and s.can_inspect and not s.can_export


def test_bad_input_gives_the_command_lines_message(tmp_path, capsys):
    bad = tmp_path / "measured.csv"
    bad.write_text("x,y,z\n1,2,3\n4,five,6\n")
    s, c, messages = make()
    c.open_files([os.path.join(BELLY, "nominal.csv"), str(bad)])
    c.set_tolerance(-0.1, 0.1)
    c.inspect()
    assert s.run is None and s.step == Step.READY and not c.busy
    level, text = messages[-1]
    assert level == "error"
    assert cli_main(["inspect", os.path.join(BELLY, "nominal.csv"), str(bad), "--tol", "0.1"]) \
        == 65
    assert capsys.readouterr().err.strip() == f"qa-inspect: error: {text}"
    assert f"{bad}:3:" in text


def test_the_nominal_as_its_own_measurement_is_one_error(tmp_path, capsys):
    """The app runs the command line's pipeline: the nominal given as the measured file too
    (here a byte-identical copy) is refused with the command line's words, and no result."""
    copy = tmp_path / "copy.csv"
    shutil.copyfile(os.path.join(BELLY, "nominal.csv"), copy)
    s, c, messages = make()
    c.open_files([os.path.join(BELLY, "nominal.csv"), str(copy)])
    c.set_tolerance(-0.1, 0.1)
    c.inspect()
    assert s.run is None and not c.busy
    level, text = messages[-1]
    assert level == "error" and text.startswith(f"{copy}: the measured file is the nominal ")
    assert cli_main(["inspect", os.path.join(BELLY, "nominal.csv"), str(copy), "--tol", "0.1"]) \
        == 65
    assert capsys.readouterr().err.strip() == f"qa-inspect: error: {text}"


def test_missing_and_unsupported_files_and_bad_zone(tmp_path):
    s, c, messages = make()
    c.open_nominal(str(tmp_path / "nope.csv"))
    assert s.nominal_path is None and messages[-1] == ("error", f"{tmp_path / 'nope.csv'}: "
                                                                "no such file")
    odd = tmp_path / "part.docx"
    odd.write_text("x")
    c.open_nominal(str(odd))
    assert s.nominal_path is None and "unsupported file type '.docx'" in messages[-1][1]
    assert not c.set_tolerance(0.2, -0.2)
    assert messages[-1][0] == "error" and "zone is empty" in messages[-1][1]


def test_cancel_leaves_no_result():
    s, c, messages = make()
    c.open_files([os.path.join(BELLY, "nominal.csv"), os.path.join(BELLY, "measured.csv")])
    s.progress.connect(lambda stage, f: "ICP iteration" in stage and c.cancel())
    c.inspect()
    assert s.run is None and s.step == Step.READY
    assert messages[-1] == ("warning", "cancelled; no result was written")
    # The next run is not cancelled by the old request.
    s.progress._callbacks.clear()
    c.inspect()
    assert s.run is not None


def test_template_run_and_exports(tmp_path):
    s, c, messages = make()
    c.open_files([os.path.join(FRAME, "template.dxf"), os.path.join(FRAME, "measured.csv")])
    c.set_tolerance(-0.05, 0.05)
    c.inspect()
    assert s.run.result.verdict == "ACCEPT" and s.run.template is not None
    c.export_csv(str(tmp_path / "p.csv"))
    c.export_qif(str(tmp_path / "r.qif"))
    rows = (tmp_path / "p.csv").read_text().splitlines()
    assert len(rows) == 501 and rows[0].startswith("point,label,x,y,z")
    assert b"QIFDocument" in (tmp_path / "r.qif").read_bytes()[:400]


def test_a_drawing_in_the_wrong_units_says_so_and_its_units_field_reads_it_right(tmp_path):
    """The gear drawing whose header says metres over millimetre numbers (tests/test_units.py):
    the app's note is the command line's reason, and the DXF units the reason names fix it."""
    import numpy as np

    from engine.contour import points_on
    from engine.io.templates import read_dxf_template

    gear = os.path.join(ROOT, "tests", "data", "dxf", "gear_z20.dxf")
    rng = np.random.default_rng(4)
    q = points_on(read_dxf_template(gear, units="mm").template, 300, rng) + [40.0, -25.0]
    np.savetxt(tmp_path / "gear.csv", q, delimiter=",", header="x,y", comments="")
    s, c, messages = make()
    c.open_files([gear, str(tmp_path / "gear.csv")])
    c.set_tolerance(-0.05, 0.05)
    c.inspect()
    notes = [text for level, text in messages if level == "info"]
    assert s.run.result.verdict == "INCONCLUSIVE"
    assert notes[-1].startswith("INCONCLUSIVE: the nominal is 1000 x the size of the measured "
                                "points"), notes[-1]
    assert "--units mm (the desktop app's DXF units)" in notes[-1]
    assert s.run.result.reasons[0] in notes[-1]
    s.set_settings(units="mm")
    c.inspect()
    assert s.run.result.verdict == "ACCEPT"


def test_session_round_trip_and_changed_input_warning(tmp_path):
    nominal = tmp_path / "nominal.csv"
    measured = tmp_path / "measured.csv"
    shutil.copy(os.path.join(BELLY, "nominal.csv"), nominal)
    shutil.copy(os.path.join(BELLY, "measured.csv"), measured)
    s, c, messages = make()
    c.open_files([str(nominal), str(measured)])
    c.set_tolerance(-0.1, 0.3)
    c.inspect()
    path = tmp_path / "part.qasession"
    c.save_session(str(path))
    saved = json.loads(path.read_text())
    assert saved["settings"]["tol_lower"] == -0.1 and saved["settings"]["tol_upper"] == 0.3
    assert saved["results"]["verdict"] == s.run.result.verdict

    s2, c2, messages2 = make()
    c2.open_session(str(path))
    assert s2.settings.tol_lower == -0.1 and s2.settings.tol_upper == 0.3
    assert s2.nominal_path == str(nominal) and s2.run is not None
    assert (run_document(s2.run)["deviations"]["max_abs"]
            == run_document(s.run)["deviations"]["max_abs"])

    with open(measured, "a") as f:
        f.write("P9999,0,0,0\n")
    s3, c3, messages3 = make()
    c3.open_session(str(path))
    level, text = messages3[-1]
    assert level == "warning" and "measured file" in text and "changed" in text
    assert s3.run is None and s3.measured_path == str(measured)


def test_unreadable_session_file(tmp_path):
    bad = tmp_path / "x.qasession"
    bad.write_text("{not json")
    s, c, messages = make()
    c.open_session(str(bad))
    assert messages[-1][0] == "error" and str(bad) in messages[-1][1]
    assert s.step == Step.NEED_NOMINAL


@pytest.mark.parametrize("signed", [False, True])
def test_certificate_export_matches_the_command_line(tmp_path, monkeypatch, signed):
    from reports.certificate import CertificateInfo
    from reports.signing import read_trust_roots, verify_pdf

    monkeypatch.setenv("QA_APP_TEST_PASS", "pw")
    ident = tmp_path / "id"
    if signed:
        assert cli_main(["keygen", "--name", "Ann", "--out", str(ident), "--pass-env",
                         "QA_APP_TEST_PASS"]) == 0
    s, c, messages = make()
    c.open_files([os.path.join(FRAME, "template.dxf"), os.path.join(FRAME, "measured.csv")])
    c.set_tolerance(-0.05, 0.05)
    c.inspect()
    out = tmp_path / "cert.pdf"
    done = []
    c.export_certificate(str(out), CertificateInfo(part_number="FR-1", serial="SN-1"),
                         str(ident / "inspector.p12") if signed else None,
                         b"pw" if signed else None, on_done=done.append)
    assert done == [str(out)] and out.is_file()
    if signed:
        v = verify_pdf(out.read_bytes(), read_trust_roots(str(ident / "ca.pem")))
        assert v.valid, v.problems
        doc = json.loads(v.attachments["results.json"])
        assert doc["verdict"] == "ACCEPT" and doc["certificate"]["part_number"] == "FR-1"
        # Verified again by the controller (reports.verify in its worker), re-run included.
        verified = []
        c.verify_certificate(str(out), [str(ident / "ca.pem")], s.nominal_path,
                             s.measured_path, on_done=verified.append)
        assert verified[0].valid and verified[0].checks[-1].message.startswith("re-run: ACCEPT")
        assert messages[-1] == ("info", f"Certificate VALID: {out}") and s.can_export
        c.verify_certificate(str(out), [str(ident / "ca.pem")], plan=str(out),
                             on_done=verified.append)
        assert len(verified) == 1 and messages[-1][0] == "error"
        assert "--plan re-runs the inspection with --nominal and --measured" in messages[-1][1]
    else:
        assert b"UNSIGNED DRAFT" in out.read_bytes()


def test_wrong_passphrase_is_one_error_and_no_file(tmp_path, monkeypatch):
    from reports.certificate import CertificateInfo

    monkeypatch.setenv("QA_APP_TEST_PASS", "pw")
    assert cli_main(["keygen", "--name", "Ann", "--out", str(tmp_path / "id"), "--pass-env",
                     "QA_APP_TEST_PASS"]) == 0
    s, c, messages = make()
    c.open_files([os.path.join(FRAME, "template.dxf"), os.path.join(FRAME, "measured.csv")])
    c.inspect()
    out = tmp_path / "cert.pdf"
    c.export_certificate(str(out), CertificateInfo(), str(tmp_path / "id" / "inspector.p12"),
                         b"wrong")
    assert not out.exists() and s.step == Step.INSPECTED
    assert messages[-1][0] == "error" and "inspector.p12" in messages[-1][1]


def test_sample_session_opens_and_inspects_with_its_zone():
    """`qa-app samples/belly_fairing/inspection.qasession`: files found beside it, zone ±0.25."""
    s, c, messages = make()
    c.open_files([os.path.join(BELLY, "inspection.qasession")])
    assert s.settings.tol_lower == -0.25 and s.settings.tol_upper == 0.25
    assert s.nominal_path == os.path.join(BELLY, "nominal.csv")
    assert s.run is not None and s.run.result.verdict == "ACCEPT"
    assert all(level != "warning" for level, _ in messages)


@pytest.mark.parametrize("content, expected", [
    ("[]", "not a readable session file"),
    # issue 22: deeply nested JSON was a RecursionError out of the window
    ("[" * 100_000 + "]" * 100_000, "nested too deeply"),
    ('{"format": "qa-inspect session", "inputs": [], "settings": {"tol_lower": 0.1, '
     '"tol_upper": -0.1}}', "zone is empty"),
    # issue 22 item 9: a zone of 1e308 was accepted (numpy overflowed, 300 digits shown)
    ('{"format": "qa-inspect session", "inputs": [], "settings": {"tol_lower": -1e308, '
     '"tol_upper": 1e308}}', "a limit 1e+308 mm from the nominal is beyond 1e6 mm"),
])
def test_bad_session_files_are_one_error(tmp_path, content, expected):
    bad = tmp_path / "x.qasession"
    bad.write_text(content)
    s, c, messages = make()
    c.open_session(str(bad))
    assert messages[-1][0] == "error" and expected in messages[-1][1]
    c.open_session(str(tmp_path))  # a folder
    assert messages[-1][0] == "error" and str(tmp_path) in messages[-1][1]
    assert s.step == Step.NEED_NOMINAL


def test_a_zone_wider_than_1000_parts_is_one_error_and_the_app_goes_on():
    """A zone within the form's 1e6 mm but beyond 1000 x the part's size (its nominal's
    bounding-box diagonal) is refused when the run knows the part: one message, no result, and
    the next run with a sensible zone works."""
    import numpy as np

    from engine.io import load_point_set

    pts = load_point_set(os.path.join(BELLY, "nominal.csv")).points
    diagonal = float(np.linalg.norm(pts.max(axis=0) - pts.min(axis=0)))
    s, c, messages = make()
    c.open_files([os.path.join(BELLY, "nominal.csv"), os.path.join(BELLY, "measured.csv")])
    assert 1000 * diagonal * 1.01 < 1e6
    assert c.set_tolerance(-1000 * diagonal * 1.01, 1000 * diagonal * 1.01)
    c.inspect()
    level, text = messages[-1]
    assert level == "error" and f"beyond 1000 × the part's size ({diagonal:.4g} mm" in text
    assert s.run is None
    assert c.set_tolerance(-0.25, 0.25)
    c.inspect()
    assert s.run is not None and s.run.result.verdict == "ACCEPT"


def test_a_named_pipe_as_the_session_is_one_error_and_never_opened(tmp_path):
    """Issue 22: a FIFO given as the session hung the window for ever (open() waits for a
    writer). It is refused unopened, in one message, and the window goes on."""
    import threading
    import time

    fifo = tmp_path / "s.qasession"
    os.mkfifo(fifo)

    def unblock():  # a regression would block open(); a writer after 5 s lets the test fail
        time.sleep(5.0)
        try:
            os.close(os.open(fifo, os.O_WRONLY | os.O_NONBLOCK))
        except OSError:  # no reader waiting: as it should be
            pass

    threading.Thread(target=unblock, daemon=True).start()
    s, c, messages = make()
    c.open_session(str(fifo))
    assert messages[-1][0] == "error" and str(fifo) in messages[-1][1]
    assert "not a regular file" in messages[-1][1]
    assert s.step == Step.NEED_NOMINAL


def test_saving_a_session_whose_input_vanished_is_one_error(tmp_path):
    m = tmp_path / "measured.csv"
    shutil.copy(os.path.join(BELLY, "measured.csv"), m)
    s, c, messages = make()
    c.open_files([os.path.join(BELLY, "nominal.csv"), str(m)])
    m.unlink()
    c.save_session(str(tmp_path / "s.qasession"))
    assert messages[-1] == ("error", f"{m}: no such file")


def test_no_new_inputs_while_busy():
    s, c, messages = make()
    c.open_files([os.path.join(BELLY, "nominal.csv"), os.path.join(BELLY, "measured.csv")])
    c.busy = True  # as while the worker runs
    c.open_measured(os.path.join(FRAME, "measured.csv"))
    assert s.measured_path == os.path.join(BELLY, "measured.csv")
    assert messages[-1][0] == "warning" and "running" in messages[-1][1]


def test_fit_and_decision_rule_reach_the_engine_and_the_session_file(tmp_path):
    s, c, messages = make()
    c.open_files([os.path.join(BELLY, "nominal.csv"), os.path.join(BELLY, "measured.csv")])
    c.set_tolerance(-0.12, 0.12)
    s.set_settings(fit="minimax", decision_rule="guarded")
    c.inspect()
    assert s.run.result.fit == "minimax" and s.run.result.decision_rule == "guarded"
    assert s.run.result.verdict == "ACCEPT" and run_document(s.run)["fit"] == "minimax"
    c.save_session(str(tmp_path / "s.qasession"))
    s2, c2, _ = make()
    c2.open_session(str(tmp_path / "s.qasession"))
    assert s2.settings.fit == "minimax" and s2.settings.decision_rule == "guarded"


# ---------------------------------------------------------------- a stale result is never exported
def inspected(tmp_path, tol=0.05):
    """A session inspected at ±tol on copies of the belly-fairing files (so they can be edited)."""
    nominal, measured = tmp_path / "nominal.csv", tmp_path / "measured.csv"
    shutil.copy(os.path.join(BELLY, "nominal.csv"), nominal)
    shutil.copy(os.path.join(BELLY, "measured.csv"), measured)
    s, c, messages = make()
    c.open_files([str(nominal), str(measured)])
    assert c.set_tolerance(-tol, tol)
    c.inspect()
    assert s.step == Step.INSPECTED and s.can_export and not s.stale_reasons
    return s, c, messages


def exports_refused(s, c, messages, tmp_path):
    """Every export of the session's run is refused with a warning, and writes nothing."""
    from reports.certificate import CertificateInfo

    outs = [tmp_path / "out" / n for n in ("c.pdf", "p.csv", "r.qif")]
    outs[0].parent.mkdir(exist_ok=True)
    c.export_certificate(str(outs[0]), CertificateInfo(), None, None)
    assert messages[-1][0] == "warning" and "out of date" in messages[-1][1]
    c.export_csv(str(outs[1]))
    assert messages[-1][0] == "warning" and "out of date" in messages[-1][1]
    c.export_qif(str(outs[2]))
    assert messages[-1][0] == "warning" and "out of date" in messages[-1][1]
    return not any(p.exists() for p in outs)


@pytest.mark.parametrize("change, reason", [
    (lambda s, c: c.set_tolerance(-0.1, 0.1), "zone changed from -0.05 … +0.05 mm to -0.1 … "
                                               "+0.1 mm"),
    (lambda s, c: s.set_settings(fit="minimax"), "fit changed from lsq to minimax"),
    (lambda s, c: s.set_settings(decision_rule="guarded"),
     "decision rule changed from simple to guarded"),
    (lambda s, c: c.open_nominal(os.path.join(BELLY, "nominal.csv")),
     "another nominal file is open"),
    (lambda s, c: c.open_measured(os.path.join(BELLY, "measured.csv")),
     "another measured file is open"),
])
def test_any_change_of_settings_or_files_makes_the_result_stale(tmp_path, change, reason):
    s, c, messages = inspected(tmp_path)
    verdict = s.run.result.verdict
    steps = []
    s.step_changed.connect(steps.append)
    change(s, c)
    # The old result stays to be looked at, but the session says it is out of date and why,
    # and nothing of it can be exported.
    assert s.run is not None and s.run.result.verdict == verdict
    assert steps[-1] == Step.STALE and s.step == Step.STALE
    assert s.stale_reasons == [reason]
    assert s.can_inspect and not s.can_export
    assert exports_refused(s, c, messages, tmp_path)
    # Inspect makes a current result again.
    c.inspect()
    assert s.step == Step.INSPECTED and s.can_export and not s.stale_reasons
    c.export_csv(str(tmp_path / "p.csv"))
    assert messages[-1] == ("info", f"CSV written: {tmp_path / 'p.csv'}")


def test_returning_to_the_results_own_settings_makes_it_current_again(tmp_path):
    s, c, messages = inspected(tmp_path)
    run = s.run
    c.set_tolerance(-0.1, 0.1)
    s.set_settings(fit="minimax")
    assert len(s.stale_reasons) == 2
    c.set_tolerance(-0.05, 0.05)
    assert s.stale_reasons == ["fit changed from lsq to minimax"]
    s.set_settings(fit="lsq")
    # Exactly the settings and files the result was computed with: it is that result again.
    assert s.run is run and s.step == Step.INSPECTED and s.can_export
    # Another file and back again, likewise.
    measured = s.measured_path
    c.open_measured(os.path.join(BELLY, "measured.csv"))
    assert s.stale
    c.open_measured(measured)
    assert s.step == Step.INSPECTED


def test_an_input_changed_on_disk_is_never_exported(tmp_path):
    s, c, messages = inspected(tmp_path)
    with open(s.measured_path, "a") as f:
        f.write("P9999,0,0,0\n")
    # Export compares the files with the SHA-256 the result was computed from, and refuses.
    assert exports_refused(s, c, messages, tmp_path)
    assert s.step == Step.STALE
    assert s.stale_reasons == [f"the measured file {s.measured_path} changed on disk since this "
                               "inspection"]
    assert "changed on disk" in messages[-1][1]
    # A file that vanished, likewise.
    os.unlink(s.nominal_path)
    assert not c.check_inputs()
    assert f"the nominal file {s.nominal_path} can no longer be read" in s.stale_reasons
    # The session file then keeps the files and settings but no results: they are not those
    # of the files as they are now.
    shutil.copy(os.path.join(BELLY, "nominal.csv"), s.nominal_path)
    c.save_session(str(tmp_path / "s.qasession"))
    assert json.loads((tmp_path / "s.qasession").read_text())["results"] is None


def test_a_run_started_before_a_change_finishes_stale():
    """The zone is changed while the inspection runs: its result is of the old zone."""
    s, c, messages = make()
    c.open_files([os.path.join(BELLY, "nominal.csv"), os.path.join(BELLY, "measured.csv")])
    c.set_tolerance(-0.05, 0.05)
    changed = []

    def change_once(stage, fraction):
        if not changed:
            changed.append(stage)
            s.set_settings(tol_lower=-0.25, tol_upper=0.25)

    s.progress.connect(change_once)
    c.inspect()
    assert s.run.settings.tol_upper == 0.05 and s.step == Step.STALE and not s.can_export


def keygen(tmp_path, monkeypatch, name="Ann Inspector"):
    """A demonstration signing identity of ``name``: (p12 path, passphrase)."""
    monkeypatch.setenv("QA_APP_TEST_PASS", "pw")
    assert cli_main(["keygen", "--name", name, "--out", str(tmp_path / "id"), "--pass-env",
                     "QA_APP_TEST_PASS"]) == 0
    return str(tmp_path / "id" / "inspector.p12"), b"pw"


def cli_refusal(capsys, p12, out, *args) -> str:
    """The command line's refusal of the signed frame certificate with ``args``: its message
    after the command's name (exit 64, nothing written)."""
    capsys.readouterr()
    assert cli_main(["inspect", os.path.join(FRAME, "template.dxf"),
                     os.path.join(FRAME, "measured.csv"), "--tol", "0.05", "--report", str(out),
                     "--sign", p12, "--sign-pass-env", "QA_APP_TEST_PASS", *args]) == 64
    assert not os.path.exists(out)
    first = capsys.readouterr().err.splitlines()[0]
    assert first.startswith("qa-inspect inspect: ")
    return first[len("qa-inspect inspect: "):]


def test_a_signed_certificate_names_its_signer_and_is_refused_before_rendering(
        tmp_path, monkeypatch, capsys):
    """The inspector named must be the signer, and a signed ACCEPTED certificate must name its
    part: the app refuses, in the command line's words, before any map is rendered and with
    nothing written; the certificate it signs names the signer as inspector."""
    from reports.certificate import CertificateInfo
    from reports.signing import read_trust_roots, verify_pdf

    p12, pw = keygen(tmp_path, monkeypatch)
    s, c, messages = make()
    stages = []
    s.progress.connect(lambda stage, f: stages.append(stage))
    c.open_files([os.path.join(FRAME, "template.dxf"), os.path.join(FRAME, "measured.csv")])
    c.set_tolerance(-0.05, 0.05)
    c.inspect()
    assert s.run.result.verdict == "ACCEPT"
    out = tmp_path / "out" / "cert.pdf"
    for info, args in (
            (CertificateInfo(part_number="FR-1", serial="SN-1", inspector="Carol Other"),
             ["--part-number", "FR-1", "--serial", "SN-1", "--inspector", "Carol Other"]),
            (CertificateInfo(part_number="FR-1", inspector=" ann  INSPECTOR"),
             ["--part-number", "FR-1"])):
        stages.clear()
        c.export_certificate(str(out), info, p12, pw)
        assert messages[-1] == ("error", cli_refusal(capsys, p12, out, *args))
        assert not any("render" in st for st in stages), stages
        assert not out.parent.exists() and s.step == Step.INSPECTED and not c.busy
    done = []
    c.export_certificate(str(out), CertificateInfo(part_number="FR-1", serial="SN-1",
                                                   inspector="Someone Typed"), None, None,
                         on_done=done.append)
    assert done == [str(out)] and b"UNSIGNED DRAFT" in out.read_bytes()  # a draft names anyone
    c.export_certificate(str(out), CertificateInfo(part_number="FR-1", serial="SN-1"), p12, pw,
                         on_done=done.append)
    assert done[-1] == str(out) and messages[-1][1].startswith(
        "Certificate written (signed by Ann Inspector)")
    v = verify_pdf(out.read_bytes(), read_trust_roots(str(tmp_path / "id" / "ca.pem")))
    assert v.valid, v.problems
    cert = json.loads(v.attachments["results.json"])["certificate"]
    assert cert["inspector"] == cert["signed_by"] == v.signatures[0].signer == "Ann Inspector"


@pytest.mark.parametrize("export, target", [("csv", "measured"), ("qif", "nominal"),
                                            ("session", "measured"), ("session", "nominal"),
                                            ("certificate", "identity"),
                                            ("certificate", "measured"), ("csv", "identity"),
                                            ("session", "identity")])
def test_an_export_never_replaces_an_input(tmp_path, monkeypatch, export, target):
    """Every export onto the nominal, the measured points or the signing identity (the one
    given, or for the other exports the one last used, as the window remembers it), here by
    another spelling of its path, is refused with one error and nothing is written."""
    from reports.certificate import CertificateInfo

    work = tmp_path / "job"
    work.mkdir()
    shutil.copy(os.path.join(FRAME, "template.dxf"), work / "template.dxf")
    shutil.copy(os.path.join(FRAME, "measured.csv"), work / "measured.csv")
    p12, pw = keygen(tmp_path, monkeypatch)
    paths = {"nominal": str(work / "template.dxf"), "measured": str(work / "measured.csv"),
             "identity": p12}
    before = {p: Path(p).read_bytes() for p in paths.values()}
    listing = sorted(os.listdir(work))
    s, c, messages = make()
    c.signing_identity = p12
    c.open_files([paths["nominal"], paths["measured"]])
    c.set_tolerance(-0.05, 0.05)
    c.inspect()
    assert s.run.result.verdict == "ACCEPT"
    # ./dir/../name: the same file under another spelling.
    path = os.path.join(os.path.dirname(paths[target]), "..", os.path.basename(
        os.path.dirname(paths[target])), os.path.basename(paths[target]))
    n = len(messages)
    {"csv": c.export_csv, "qif": c.export_qif, "session": c.save_session,
     "certificate": lambda p: c.export_certificate(
         p, CertificateInfo(part_number="FR-1", serial="SN-1"), p12, pw)}[export](path)
    assert len(messages) == n + 1
    level, text = messages[-1]
    role = "signing identity" if target == "identity" else target
    assert level == "error" and f"is the {role} file: an output never replaces an input" in text
    assert {p: Path(p).read_bytes() for p in paths.values()} == before
    assert sorted(os.listdir(work)) == listing and s.step == Step.INSPECTED and not c.busy


# ---------------------------------------------------------------- an inspection plan
BRACKET = os.path.join(ROOT, "samples", "seat_bracket")


def bracket_truth() -> dict:
    with open(os.path.join(BRACKET, "truth.json")) as f:
        return json.load(f)


def plans_zone_of(plan_path) -> float:
    """Half the widest profile zone of the plan, read here with tomllib (the zone of the per-point
    statistics when the plan alone states the requirement)."""
    import tomllib

    with open(plan_path, "rb") as f:
        doc = tomllib.load(f)
    return max(c["zone"] for c in doc["characteristic"] if c["type"] == "profile") / 2


def bracket_files(folder=BRACKET):
    return [os.path.join(folder, n) for n in ("nominal.xyz", "measured.csv", "plan.toml")]


def test_a_plan_run_gives_the_command_lines_characteristics_to_the_table(tmp_path):
    """Nominal, measured points and plan opened together: the run is the command line's
    ``inspect … --plan`` (same settings, same characteristics), and each characteristic's row
    holds the measured points it judged: the hole's are the sample's hole points."""
    from qa_app.desktop.model import characteristic_rows

    nominal, measured, plan = bracket_files()
    s, c, messages = make()
    c.open_files([nominal, measured, plan])
    assert s.plan_path == plan and s.plans_zone
    half = plans_zone_of(plan)
    assert (s.settings.tol_lower, s.settings.tol_upper) == (-half, half)
    assert s.step == Step.READY
    c.inspect()
    assert s.step == Step.INSPECTED and s.run.result.verdict == "REJECT"
    assert cli_main(["inspect", nominal, measured, "--plan", plan, "--json",
                     str(tmp_path / "r.json")]) == 1
    doc = json.loads((tmp_path / "r.json").read_text())
    assert s.run.settings.to_json() == doc["settings"]
    rows = characteristic_rows(s.run)
    assert [(r.id, r.verdict, r.points) for r in rows] == [
        (ch["id"], ch["verdict"], ch["n_points"]) for ch in doc["characteristics"]]
    assert [r.verdict for r in rows] == ["REJECT", "ACCEPT", "ACCEPT", "ACCEPT", "ACCEPT"]
    assert [r.value for r in rows] == [f"{ch['value']:.4f} mm" for ch in doc["characteristics"]]
    assert [(r.type, r.symbol) for r in rows] == [
        ("profile", "⌓"), ("profile", "⌓"), ("flatness", "⏥"), ("position", "⌖"), ("size", "⌀")]
    assert (rows[0].datums, rows[0].region, rows[1].datums) == ("A|B|C", "skin", "—")
    assert rows[4].requirement == "⌀8.0000 -0.0500/+0.0500 mm"
    truth = bracket_truth()
    labels = s.run.measured.labels
    highlighted = []
    s.characteristic_changed.connect(highlighted.append)
    s.select_characteristic(3)  # position of the hole
    assert highlighted == [3]
    assert sorted(labels[s.highlighted]) == truth["hole"]["labels"]
    s.select_characteristic(2)  # flatness of datum face A
    assert sorted(labels[s.highlighted]) == truth["datum_faces"]["A"]["labels"]
    s.select_characteristic(None)
    assert s.highlighted is None
    # A new run is another table: nothing stays selected.
    s.select_characteristic(0)
    c.inspect()
    assert s.characteristic is None and s.highlighted is None


def test_the_users_zone_joins_a_plans_verdict_and_clearing_the_plan_leaves_the_zone(tmp_path):
    """As on the command line: with a zone of the user's the plan gains the characteristic
    'tol' over all points; without a plan the zone alone is the verdict. Each change of the
    plan or of whose zone it is makes the result out of date, and says why."""
    from qa_app.desktop.model import characteristic_rows

    nominal, measured, plan = bracket_files()
    s, c, messages = make()
    c.open_files([nominal, measured])
    c.set_tolerance(-0.05, 0.05)
    c.inspect()
    assert s.run.result.verdict == "ACCEPT" and characteristic_rows(s.run) == []
    c.open_plan(plan)
    assert s.stale_reasons == ["another plan file is open", "zone changed from -0.05 … +0.05 "
                               "mm to the plan's"]
    c.inspect()
    assert s.run.result.verdict == "REJECT" and not s.run.settings.zone_in_verdict
    assert s.run.settings.plan == plan
    s.set_settings(tol_lower=-0.05, tol_upper=0.05, zone_in_verdict=True)
    assert s.stale_reasons == ["zone changed from the plan's to -0.05 … +0.05 mm"]
    c.inspect()
    rows = characteristic_rows(s.run)
    assert [r.id for r in rows] == ["tol", "1", "2", "3", "4", "5"]
    assert rows[0].points == s.run.measured.points.shape[0] and rows[0].verdict == "ACCEPT"
    assert s.run.result.verdict == "REJECT"  # characteristic 1 is still out
    c.clear_plan()
    assert s.plan_path is None and s.stale_reasons == ["no plan file is open"]
    c.inspect()
    assert s.run.result.verdict == "ACCEPT" and s.run.settings.plan is None
    assert characteristic_rows(s.run) == []
    assert [rec.role for rec in s.run.inputs] == ["nominal", "measured"]


def test_a_session_keeps_its_plan_beside_the_files(tmp_path):
    """The plan is an input like the others: path, path relative to the session and SHA-256;
    a session moved with its files finds the plan beside it and re-inspects to the same
    characteristics; a plan edited since is a warning, and no result."""
    import hashlib

    from qa_app.desktop.model import characteristic_rows

    job = tmp_path / "job"
    job.mkdir()
    for f in bracket_files():
        shutil.copy(f, job)
    s, c, messages = make()
    c.open_files(bracket_files(str(job)))
    c.inspect()
    path = job / "bracket.qasession"
    c.save_session(str(path))
    saved = json.loads(path.read_text())
    rec = next(i for i in saved["inputs"] if i["role"] == "plan")
    assert rec["relative_path"] == "plan.toml" and rec["path"] == str(job / "plan.toml")
    assert rec["sha256"] == hashlib.sha256((job / "plan.toml").read_bytes()).hexdigest()
    assert saved["results"]["characteristics"][0]["verdict"] == "REJECT"

    moved = tmp_path / "moved"
    shutil.move(str(job), str(moved))
    s2, c2, messages2 = make()
    c2.open_session(str(moved / "bracket.qasession"))
    assert s2.plan_path == str(moved / "plan.toml") and s2.plans_zone
    assert s2.run is not None and s2.run.settings.plan == str(moved / "plan.toml")
    assert [(r.id, r.value, r.verdict) for r in characteristic_rows(s2.run)] == [
        (r.id, r.value, r.verdict) for r in characteristic_rows(s.run)]

    with open(moved / "plan.toml", "a") as f:
        f.write("\n# edited\n")
    s3, c3, messages3 = make()
    c3.open_session(str(moved / "bracket.qasession"))
    level, text = messages3[-1]
    assert level == "warning" and f"plan file {moved / 'plan.toml'} changed" in text
    assert s3.run is None and s3.plan_path == str(moved / "plan.toml")


def test_a_bad_plan_is_the_command_lines_error_and_changes_nothing(tmp_path, capsys):
    nominal, measured, plan = bracket_files()
    bad = tmp_path / "plan.toml"
    bad.write_text(Path(plan).read_text().replace("zone = 0.01", "zone = -0.01"))
    s, c, messages = make()
    c.open_files([nominal, measured, plan])
    c.open_plan(str(bad))
    assert s.plan_path == plan and not c.busy
    level, text = messages[-1]
    assert cli_main(["inspect", nominal, measured, "--plan", str(bad)]) == 65
    assert level == "error" and capsys.readouterr().err.strip() == f"qa-inspect: error: {text}"
    assert "'zone' must be > 0" in text
    c.open_plan(nominal)
    assert messages[-1] == ("error", f"{nominal}: unsupported file type '.xyz'; supported: "
                                     ".toml .qif")


def test_a_plans_instrument_decides_in_the_app_as_on_the_command_line(tmp_path):
    """A plan whose [measurement] states an instrument: the app's default (automatic) decision
    rule is the guarded one, as `qa-inspect inspect --plan` without --decision-rule, and gives
    its verdicts; an explicit Simple afterwards marks the result out of date and then gives the
    command line's `--decision-rule simple` verdicts."""
    from engine.pipeline import inspection_settings, run_files

    text = Path(BRACKET, "plan.toml").read_text()
    plan = tmp_path / "plan.toml"
    plan.write_text(text.replace('[[region]]', '[measurement]\nuncertainty_mm = 0.02\n\n'
                                 '[[region]]', 1))
    files = [os.path.join(BRACKET, "nominal.xyz"), os.path.join(BRACKET, "measured.csv")]
    s, c, _ = make()
    c.open_files(files + [str(plan)])
    c.inspect()
    cli = run_files(*files, inspection_settings(None, str(plan))).result
    assert s.run.result.decision_rule == cli.decision_rule == "guarded"
    assert [r.verdict for r in s.run.result.plan.characteristics] == \
        [r.verdict for r in cli.plan.characteristics]
    assert s.run.result.verdict == cli.verdict
    s.set_settings(decision_rule="simple")
    assert s.step != Step.INSPECTED
    c.inspect()
    simple = run_files(*files, inspection_settings(None, str(plan), decision_rule="simple"))
    assert s.run.result.decision_rule == "simple"
    assert s.run.result.verdict == simple.result.verdict


def test_an_angle_is_shown_in_degrees_and_a_size_in_mm():
    """The Characteristics tab's values carry their unit: an angle's degrees (it showed
    "60.0002 mm"), a size's mm."""
    from types import SimpleNamespace

    import numpy as np

    from engine.gdt.plan import Characteristic
    from engine.gdt.results import CharacteristicResult
    from qa_app.desktop.model import characteristic_rows

    angle = Characteristic("1", "angle", "a", -0.5, 0.5, nominal=60.0, regions=("a", "b"))
    size = Characteristic("2", "size", "h", -0.1, 0.1, nominal=8.0)
    results = [CharacteristicResult(angle, 60.0002, "ACCEPT", "", np.arange(3)),
               CharacteristicResult(size, 8.01, "ACCEPT", "", np.arange(3))]
    run = SimpleNamespace(result=SimpleNamespace(plan=SimpleNamespace(characteristics=results)))
    assert [r.value for r in characteristic_rows(run)] == ["60.0002°", "8.0100 mm"]
