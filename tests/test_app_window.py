"""The main window's widget logic on Qt's offscreen platform (no 3D viewport here; it has its
own tests under Xvfb): actions enabled when they make sense, verdict banner, table and views in
step, errors in the message bar, drag and drop, presets, recent files."""

import os
import shutil

import numpy as np
import pytest
from PySide6.QtCore import QMimeData, QPointF, QSettings, Qt, QUrl
from PySide6.QtGui import QDropEvent

from qa_app.desktop.dialogs import CertificateDialog
from qa_app.desktop.model import Step
from qa_app.desktop.window import MainWindow

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BELLY = os.path.join(ROOT, "samples", "belly_fairing")
FRAME = os.path.join(ROOT, "samples", "fuselage_frame")


@pytest.fixture
def window(qtbot, tmp_path):
    w = MainWindow(synchronous=True, settings=QSettings(str(tmp_path / "qa-app.ini"),
                                                        QSettings.IniFormat))
    qtbot.addWidget(w)
    w.show()
    return w


def load_belly(w, tol=0.05):
    w.controller.open_files([os.path.join(BELLY, "nominal.csv"),
                             os.path.join(BELLY, "measured.csv")])
    w.tolerance.set_zone(-tol, tol)


def test_actions_follow_the_workflow(window, qtbot):
    w = window
    assert w.viewport.plotter is None  # offscreen: the notice instead of the 3D view
    assert not w.act_inspect.isEnabled() and not w.act_certificate.isEnabled()
    assert not w.act_open_measured.isEnabled()
    w.controller.open_nominal(os.path.join(BELLY, "nominal.csv"))
    assert w.act_open_measured.isEnabled() and not w.act_inspect.isEnabled()
    w.controller.open_measured(os.path.join(BELLY, "measured.csv"))
    assert w.act_inspect.isEnabled() and w.tolerance.inspect_button.isEnabled()
    assert not w.export_button.isEnabled() and not w.act_cancel.isEnabled()
    w.tolerance.set_zone(-0.05, 0.05)
    qtbot.mouseClick(w.tolerance.inspect_button, Qt.LeftButton)
    assert w.session.step == Step.INSPECTED
    assert w.export_button.isEnabled() and w.act_certificate.isEnabled()
    assert w.act_csv.isEnabled() and w.act_qif.isEnabled()


def test_banner_table_and_selection(window, qtbot):
    w = window
    load_belly(w, 0.05)
    w.act_inspect.trigger()
    run = w.session.run
    assert w.banner.verdict == "REJECT"
    assert "REJECTED" in w.banner.word.text() and "20 out of tolerance" in w.banner.detail.text()
    model = w.table.model()
    assert model.rowCount() == 1100
    # Sorted by the size of the deviation, the worst point first.
    devs = [abs(float(model.data(model.index(r, 5)))) for r in range(model.rowCount())]
    assert devs == sorted(devs, reverse=True)
    assert devs[0] == pytest.approx(run.result.statistics.max_abs, abs=1e-4)
    fails = [r for r in range(model.rowCount()) if model.data(model.index(r, 6)) == "FAIL"]
    assert len(fails) == 20
    # Row → selection → viewport readout, and selection → row.
    w.table.selectRow(fails[0])
    i = w.session.selected
    assert i == model.point(fails[0])
    label = str(run.measured.labels[i])
    assert label in w.viewport.readout.text() and "OUT OF TOLERANCE" in w.viewport.readout.text()
    w.session.select(7)
    assert model.point(w.table.currentIndex().row()) == 7


@pytest.mark.parametrize("files", [("belly_fairing", "nominal.csv"),
                                   ("fuselage_frame", "template.dxf")])
def test_the_table_puts_the_worst_point_on_top_and_numbers_from_1(window, files):
    """In 3D and 2D alike, the rows run from the largest |deviation| down, and the # column
    is the point's place in the measured file counting from 1 (as JSON and CSV count)."""
    folder, nominal = files
    w = window
    w.controller.open_files([os.path.join(ROOT, "samples", folder, nominal),
                             os.path.join(ROOT, "samples", folder, "measured.csv")])
    w.tolerance.set_zone(-0.05, 0.05)
    w.act_inspect.trigger()
    run = w.session.run
    d = run.result.deviations.signed
    model = w.table.model()
    rows = [model.point(r) for r in range(model.rowCount())]
    # The naive twin: every point by |d|, largest first.
    assert rows == sorted(range(d.size), key=lambda i: (-abs(d[i]), i))
    assert abs(float(model.data(model.index(0, 5)))) == pytest.approx(np.abs(d).max(),
                                                                       abs=1e-4)
    with open(os.path.join(ROOT, "samples", folder, "measured.csv")) as f:
        lines = [ln for ln in f if ln.strip() and not ln.startswith("#")][1:]  # header row
    for r in (0, 1, model.rowCount() - 1):
        number = int(model.data(model.index(r, 0)))
        assert lines[number - 1].split(",")[0].strip() == model.data(model.index(r, 1))
    assert w.table.horizontalHeader().sortIndicatorSection() == 5


def test_contour_view_whiskers_and_click_selects(window, qtbot):
    w = window
    w.controller.open_files([os.path.join(FRAME, "template.dxf"),
                             os.path.join(FRAME, "measured.csv")])
    w.act_inspect.trigger()
    assert w.session.run.result.verdict in ("ACCEPT", "REJECT")
    assert w.views.currentWidget() is w.contour
    w.contour.resize(800, 500)
    P = w.contour._transform()
    tx, ty = P(w.contour._cache[2])
    qtbot.mouseClick(w.contour, Qt.LeftButton, pos=QPointF(tx[42], ty[42]).toPoint())
    sel = w.session.selected
    # The nearest whisker tip to the click is 42's (or one drawn within a pixel of it).
    assert np.hypot(tx[sel] - tx[42], ty[sel] - ty[42]) <= 1.5
    img = w.contour.grab().toImage()
    assert not img.isNull()


def test_a_message_quoting_a_file_shows_its_name_as_text(window, tmp_path):
    """A file named with markup and a line break: the message bar shows the name as the
    characters it holds (no bold, no second line); the label renders no tag of the name."""
    w = window
    bad = tmp_path / "<b>big<i>\nACCEPT &amp;.csv"
    bad.write_text("x,y,z\n1,2,3\n4,five,6\n")
    w.controller.open_files([os.path.join(BELLY, "nominal.csv"), str(bad)])
    w.act_inspect.trigger()
    assert w.message_bar.level == "error"
    text = w.message_bar.text
    assert "<b>big<i>\\nACCEPT &amp;.csv" in text and "\n" not in text
    label = w.message_bar.label.text()
    assert "&lt;b&gt;big&lt;i&gt;" in label and "&amp;amp;" in label and "<b>big" not in label


def test_bad_file_shows_the_error_and_the_window_survives(window, tmp_path):
    w = window
    bad = tmp_path / "broken.csv"
    bad.write_text("x,y,z\n1,2,3\n4,five,6\n")
    w.controller.open_files([os.path.join(BELLY, "nominal.csv"), str(bad)])
    w.act_inspect.trigger()
    assert w.message_bar.isVisible() and w.message_bar.level == "error"
    assert f"{bad}:3:" in w.message_bar.text
    assert w.session.step == Step.READY and w.act_inspect.isEnabled()
    # A good file afterwards works in the same window.
    w.controller.open_measured(os.path.join(BELLY, "measured.csv"))
    w.act_inspect.trigger()
    assert w.session.run is not None


def test_drop_files_onto_the_window(window):
    w = window
    mime = QMimeData()
    mime.setUrls([QUrl.fromLocalFile(os.path.join(BELLY, "nominal.csv")),
                  QUrl.fromLocalFile(os.path.join(BELLY, "measured.csv"))])
    ev = QDropEvent(QPointF(10, 10), Qt.CopyAction, mime, Qt.LeftButton, Qt.NoModifier)
    w.dropEvent(ev)
    assert w.session.nominal_path.endswith("nominal.csv")
    assert w.session.measured_path.endswith("measured.csv")
    assert w.nominal_label.text() == "nominal.csv"


def test_presets_and_recent_files_persist(window, qtbot, tmp_path, monkeypatch):
    w = window
    w.tolerance.asym.setChecked(True)
    w.tolerance.lower.setValue(-0.1)
    w.tolerance.upper.setValue(0.3)
    from PySide6.QtWidgets import QInputDialog

    monkeypatch.setattr(QInputDialog, "getText", lambda *a, **k: ("BF-2231", True))
    w.tolerance._save_preset()
    load_belly(w)
    w2 = MainWindow(synchronous=True, settings=w.qsettings)
    qtbot.addWidget(w2)
    assert w2.tolerance.presets["BF-2231"] == (-0.1, 0.3)
    i = w2.tolerance.preset.findData("BF-2231")
    w2.tolerance.preset.activated.emit(i)
    assert w2.tolerance.zone() == (-0.1, 0.3)
    recent = [a.text() for a in w2.recent_menu.actions()]
    assert recent[:2] == [os.path.join(BELLY, "measured.csv"), os.path.join(BELLY,
                                                                          "nominal.csv")]


def test_cancel_button_stops_a_running_inspection(qtbot, tmp_path):
    import time

    w = MainWindow(synchronous=False, settings=QSettings(str(tmp_path / "s.ini"),
                                                        QSettings.IniFormat))
    qtbot.addWidget(w)
    slow = w.controller._progress

    def slowed(stage, fraction):  # a long run, so that Cancel surely lands inside it
        time.sleep(0.05)
        slow(stage, fraction)

    w.controller._progress = slowed
    load_belly(w)
    w.act_inspect.trigger()
    assert w.session.step == Step.RUNNING and w.tolerance.cancel_button.isEnabled()
    qtbot.waitUntil(lambda: "ICP" in w.stage_label.text(), timeout=30_000)
    qtbot.mouseClick(w.tolerance.cancel_button, Qt.LeftButton)
    qtbot.waitUntil(lambda: w.session.step == Step.READY, timeout=30_000)
    assert w.session.run is None
    assert w.message_bar.level == "warning" and "cancelled" in w.message_bar.text
    assert w.act_inspect.isEnabled() and not w.act_cancel.isEnabled()


def run_qa_app(qtbot, monkeypatch, tmp_path, argv):
    """``qa-app ARGV`` without its event loop: the window it opened, once it has inspected."""
    import sys
    import threading

    from PySide6.QtWidgets import QApplication

    from qa_app.desktop import app as qa_app_main

    monkeypatch.setattr(QApplication, "exec", lambda self: 0)
    monkeypatch.setattr(sys, "excepthook", sys.excepthook)
    monkeypatch.setattr(threading, "excepthook", threading.excepthook)
    monkeypatch.setattr("qa_app.desktop.window.QSettings", lambda *a: QSettings(
        str(tmp_path / "s.ini"), QSettings.IniFormat))
    assert qa_app_main.main(argv) == 0
    w = next(x for x in QApplication.topLevelWidgets() if isinstance(x, MainWindow)
             and x.isVisible() and x.session.nominal_path == argv[0])
    qtbot.addWidget(w)
    qtbot.waitUntil(lambda: w.session.step == Step.INSPECTED, timeout=60_000)
    return w


def test_qa_app_command_opens_both_files_and_inspects(qtbot, monkeypatch, tmp_path):
    w = run_qa_app(qtbot, monkeypatch, tmp_path, [os.path.join(BELLY, "nominal.csv"),
                                                  os.path.join(BELLY, "measured.csv"),
                                                  "--tol", "0.25"])
    assert w.banner.verdict == "ACCEPT"
    assert w.tolerance.zone() == (-0.25, 0.25)


# ---------------------------------------------------------------- what is on screen is what exports
def export_actions(w):
    return [w.export_button, w.act_certificate, w.act_csv, w.act_qif]


def change_zone(w):
    w.tolerance.tol.setValue(0.1)


def change_fit(w):
    w.tolerance.fit.setCurrentIndex(w.tolerance.fit.findData("minimax"))


def change_rule(w):
    w.tolerance.rule.setCurrentIndex(w.tolerance.rule.findData("guarded"))


def change_nominal(w):
    w.controller.open_nominal(os.path.join(FRAME, "template.dxf"))


def change_measured(w):
    w.controller.open_measured(os.path.join(FRAME, "measured.csv"))


@pytest.mark.parametrize("change, what", [
    (change_zone, "zone changed from -0.05 … +0.05 mm to -0.1 … +0.1 mm"),
    (change_fit, "fit changed from lsq to minimax"),
    (change_rule, "decision rule changed from simple to guarded"),
    (change_nominal, "another nominal file is open"),
    (change_measured, "another measured file is open"),
])
def test_a_change_after_inspection_marks_the_result_out_of_date(window, qtbot, tmp_path, change,
                                                                what):
    w = window
    load_belly(w, 0.05)
    w.act_inspect.trigger()
    assert w.banner.verdict == "REJECT" and "REJECTED" in w.banner.word.text()
    assert all(a.isEnabled() for a in export_actions(w))
    change(w)  # in the form or the files, without pressing Inspect
    # Export is disabled; the banner says the result is out of date and what changed, and
    # states no verdict.
    assert not any(a.isEnabled() for a in export_actions(w))
    assert "OUT OF DATE" in w.banner.word.text()
    assert what in w.banner.detail.text() and "Press Inspect" in w.banner.detail.text()
    assert w.banner.stale and w.banner.verdict is None
    out = tmp_path / "c.pdf"
    assert w.export_certificate(dialog=CertificateDialog(w, {}, str(out))) is None
    assert not out.exists()
    assert w.act_inspect.isEnabled() and w.tolerance.inspect_button.isEnabled()
    # Inspect: a result for what is on screen, exportable again.
    w.act_inspect.trigger()
    assert w.session.step == Step.INSPECTED and not w.banner.stale
    assert w.banner.verdict == w.session.run.result.verdict
    assert "OUT OF DATE" not in w.banner.word.text()
    assert all(a.isEnabled() for a in export_actions(w))
    # The session's automatic decision rule is the one the run resolved it to.
    from dataclasses import replace

    from qa_app.desktop.model import resolved_rule
    st = w.session.settings
    assert w.session.run.settings == replace(
        st, decision_rule=resolved_rule(st.decision_rule, w.session.run))


def test_an_edited_zone_stays_as_typed_and_back_to_the_results_zone_is_current(window):
    w = window
    load_belly(w, 0.05)
    w.act_inspect.trigger()
    w.tolerance.asym.setChecked(True)
    w.tolerance.lower.setValue(-0.08)
    assert not w.export_button.isEnabled() and "OUT OF DATE" in w.banner.word.text()
    assert w.tolerance.asym.isChecked()
    w.tolerance.upper.setValue(0.08)  # symmetric, typed in the asymmetric fields
    assert w.tolerance.asym.isChecked() and w.tolerance.zone() == (-0.08, 0.08)
    w.tolerance.lower.setValue(-0.05)
    w.tolerance.upper.setValue(0.05)
    # The zone the result was computed with: it is current again.
    assert w.banner.verdict == "REJECT" and "OUT OF DATE" not in w.banner.word.text()
    assert all(a.isEnabled() for a in export_actions(w))


def test_a_file_changed_on_disk_disables_export(window, tmp_path):
    w = window
    measured = tmp_path / "measured.csv"
    shutil.copy(os.path.join(BELLY, "measured.csv"), measured)
    w.controller.open_files([os.path.join(BELLY, "nominal.csv"), str(measured)])
    w.act_inspect.trigger()
    assert w.export_button.isEnabled()
    with open(measured, "a") as f:
        f.write("P9999,0,0,0\n")
    # Export looks at the files before asking for the certificate's fields.
    assert w.export_certificate(dialog=CertificateDialog(w, {}, str(tmp_path / "c.pdf"))) is None
    assert not (tmp_path / "c.pdf").exists()
    assert not any(a.isEnabled() for a in export_actions(w))
    assert "OUT OF DATE" in w.banner.word.text() and "changed on disk" in w.banner.detail.text()


def test_the_point_readout_clears_on_a_new_run(window):
    w = window
    load_belly(w, 0.05)
    w.act_inspect.trigger()
    w.table.selectRow(3)
    label = str(w.session.run.measured.labels[w.session.selected])
    assert label in w.viewport.readout.text()
    w.act_inspect.trigger()
    assert w.session.selected is None and label not in w.viewport.readout.text()
    assert w.viewport.readout.text() == w.viewport.READOUT_HINT


def test_excluded_points_are_worded_as_excluded_from_the_alignment(window, tmp_path):
    """Three points moved 10 mm off (mis-probed): excluded from the alignment as gross outliers,
    and never called just "outlier"; a fitted point's cell is empty."""
    from pathlib import Path

    lines = Path(BELLY, "measured.csv").read_text().splitlines()
    for k in (100, 500, 900):
        label, x, y, z = lines[k].split(",")
        lines[k] = f"{label},{x},{y},{float(z) + 10.0:.4f}"
    bad = tmp_path / "measured.csv"
    bad.write_text("\n".join(lines) + "\n")
    w = window
    w.controller.open_files([os.path.join(BELLY, "nominal.csv"), str(bad)])
    w.tolerance.set_zone(-0.25, 0.25)
    w.act_inspect.trigger()
    res = w.session.run.result
    n = int(res.outlier.sum())
    assert n >= 3
    assert f"{n} excluded from alignment (gross outliers)" in w.banner.detail.text()
    assert "fit outlier" not in w.banner.detail.text()
    model = w.table.model()
    assert model.headerData(7, Qt.Horizontal) == "Excluded"
    assert "gross outlier" in model.headerData(7, Qt.Horizontal, Qt.ToolTipRole)
    cells = {model.point(r): model.data(model.index(r, 7)) for r in range(model.rowCount())}
    assert {i for i, t in cells.items() if t} == set(np.flatnonzero(res.outlier))
    assert {t for t in cells.values() if t} == {"excluded (gross outlier)"}
    # Points on the nominal everywhere (its own points lifted 1 µm, every 7th: the nominal
    # itself is no measurement and is refused): nothing excluded, and the banner does not
    # mention it.
    xyz = np.loadtxt(os.path.join(BELLY, "nominal.csv"), delimiter=",", comments="#",
                     skiprows=3)[::7, :3] + [0.0, 0.0, 0.001]
    on = tmp_path / "on_nominal.csv"
    np.savetxt(on, xyz, delimiter=",", header="x,y,z", comments="", fmt="%.6f")
    w.controller.open_measured(str(on))
    w.act_inspect.trigger()
    assert not w.session.run.result.outlier.any()
    assert "excluded" not in w.banner.detail.text() and "outlier" not in w.banner.detail.text()


def test_the_main_window_fits_a_1366_by_768_screen(window):
    """Its minimum size leaves room for the window frame and a task bar on 1366×768."""
    w = window
    for size in (w.minimumSizeHint(), w.minimumSize()):
        assert size.width() <= 1340 and size.height() <= 700
    load_belly(w, 0.05)
    w.act_inspect.trigger()
    w.tolerance.tol.setValue(0.1)  # the longer, out-of-date banner
    size = w.minimumSizeHint()
    assert size.width() <= 1340 and size.height() <= 700


def inspect_frame(w, tol=0.05):
    w.controller.open_files([os.path.join(FRAME, "template.dxf"),
                             os.path.join(FRAME, "measured.csv")])
    w.tolerance.set_zone(-tol, tol)
    w.act_inspect.trigger()


def test_the_certificate_dialog_names_the_signer_and_says_what_it_refuses(window, tmp_path,
                                                                          monkeypatch):
    """With a signing identity chosen, the Inspector field is the signer's name (read-only once
    loaded); an unsigned draft's inspector is typed. A signed ACCEPTED certificate without a
    serial, or one saved onto the measured file, is refused in the dialog, which stays open;
    the certificate exported names the signer."""
    import json

    from reports.certificate import CertificateInfo, CertificationError, certified_info
    from qa_app.cli import main as cli_main
    from reports.signing import load_identity, read_trust_roots, verify_pdf

    monkeypatch.setenv("QA_APP_TEST_PASS", "pw")
    assert cli_main(["keygen", "--name", "Ann Inspector", "--out", str(tmp_path / "id"),
                     "--pass-env", "QA_APP_TEST_PASS"]) == 0
    p12 = str(tmp_path / "id" / "inspector.p12")
    w = window
    w.qsettings.setValue("certificate/inspector", "Bob Typed")
    inspect_frame(w)
    assert w.session.run.result.verdict == "ACCEPT"
    out = tmp_path / "out" / "cert.pdf"
    d = w.certificate_dialog(str(out))
    assert d.inspector.text() == "Bob Typed" and not d.inspector.isReadOnly()
    d.p12.setText(p12)
    assert d.inspector.isReadOnly() and d.inspector.text() == ""  # not known until loaded
    d.passphrase.setText("wrong")
    d.passphrase.returnPressed.emit()
    assert p12 in d.problem.text() and not d.problem.isHidden() and d.inspector.text() == ""
    d.passphrase.setText("pw")
    d.passphrase.editingFinished.emit()
    assert d.problem.isHidden()
    assert d.inspector.text() == "Ann Inspector" and d.inspector.isReadOnly()
    # No serial: the command line's refusal, in the dialog, before anything is rendered.
    d.edits["part_number"].setText("FR-1")
    d.export_button.click()
    with pytest.raises(CertificationError) as refused:
        certified_info(CertificateInfo(part_number="FR-1"), load_identity(p12, b"pw"), "ACCEPT")
    assert d.result() != CertificateDialog.Accepted
    assert d.problem.text() == str(refused.value) and not d.problem.isHidden()
    # Onto the measured points: refused as well.
    d.edits["serial"].setText("SN-1")
    d.output.setText(os.path.join(FRAME, "measured.csv"))
    d.export_button.click()
    assert d.result() != CertificateDialog.Accepted
    assert "is the measured file: an output never replaces an input" in d.problem.text()
    # Without the identity the inspector is the one typed again; with it, the signer.
    d.p12.setText("")
    assert d.inspector.text() == "Bob Typed" and not d.inspector.isReadOnly()
    d.p12.setText(p12)
    d.output.setText(str(out))
    d.export_button.click()
    assert d.result() == CertificateDialog.Accepted and d.inspector.text() == "Ann Inspector"
    assert d.info().inspector == "Ann Inspector"
    w.export_certificate(dialog=d)
    assert "signed by Ann Inspector" in w.statusBar().currentMessage()
    v = verify_pdf(out.read_bytes(), read_trust_roots(str(tmp_path / "id" / "ca.pem")))
    assert v.valid, v.problems
    cert = json.loads(v.attachments["results.json"])["certificate"]
    assert cert["inspector"] == cert["signed_by"] == "Ann Inspector"
    assert cert["serial"] == "SN-1"
    # The typed draft inspector is what is remembered, not the signer's name.
    assert w.qsettings.value("certificate/inspector") == "Bob Typed"
    # The identity used is an input: no export replaces it.
    key = (tmp_path / "id" / "inspector.p12").read_bytes()
    w.export_csv(p12)
    assert "is the signing identity file" in w.message_bar.text
    assert (tmp_path / "id" / "inspector.p12").read_bytes() == key


def test_verify_certificate_shows_valid_and_a_flipped_byte_invalid(window, tmp_path,
                                                                  monkeypatch):
    """File → Verify certificate… runs reports.verify in the controller's worker and shows the
    outcome: a signed certificate re-run on the open files is VALID; the same certificate with
    one byte flipped is INVALID. Files that do not go together are said in the dialog."""
    from qa_app.cli import main as cli_main
    from qa_app.desktop.verify_dialog import VerifyDialog

    monkeypatch.setenv("QA_APP_TEST_PASS", "pw")
    ident = tmp_path / "id"
    assert cli_main(["keygen", "--name", "Ann Inspector", "--out", str(ident), "--pass-env",
                     "QA_APP_TEST_PASS"]) == 0
    files = [os.path.join(FRAME, "template.dxf"), os.path.join(FRAME, "measured.csv")]
    pdf = tmp_path / "cert.pdf"
    assert cli_main(["inspect", *files, "--tol", "0.05", "--report", str(pdf), "--sign",
                     str(ident / "inspector.p12"), "--sign-pass-env", "QA_APP_TEST_PASS",
                     "--part-number", "FR-1", "--serial", "SN-1"]) == 0
    w = window
    w.controller.open_files(files)
    assert w.act_verify.isEnabled() and w.act_verify in w.menuBar().actions()[0].menu().actions()
    d = w.verify_dialog()
    d.certificate.setText(str(pdf))
    d.trust.setText(str(ident / "ca.pem"))
    d.files["nominal"].setText(files[0])
    d.accept()
    assert d.result() != VerifyDialog.Accepted
    assert d.problem.text() == "give both --nominal and --measured, or neither"
    d.fill_open_files()
    d.accept()
    assert d.result() == VerifyDialog.Accepted
    w.verify_certificate(dialog=d)
    shown = w.verification
    assert shown.isVisible() and shown.word.text() == "VALID"
    text = shown.details.toPlainText()
    assert "signature 'Inspector': Ann Inspector" in text and "intact, trusted" in text
    assert "✓ re-run: ACCEPT" in text and "✗" not in text
    assert w.statusBar().currentMessage() == f"Certificate VALID: {pdf}"
    # One digit of page 1's content flipped: a silent, well-formed change.
    data = bytearray(pdf.read_bytes())
    at = data.find(b"(ACCEPTED) Tj")
    at = max(i for i in range(at - 200, at) if data[i:i + 1].isdigit())
    data[at] ^= 0x01
    flipped = tmp_path / "flipped.pdf"
    flipped.write_bytes(bytes(data))
    d = w.verify_dialog()
    assert d.certificate.text() == str(pdf) and d.trust.text() == str(ident / "ca.pem")
    d.certificate.setText(str(flipped))
    d.accept()
    w.verify_certificate(dialog=d)
    assert w.verification is not shown and w.verification.word.text() == "INVALID"
    assert "✗ signature 'Inspector': the signed bytes were changed" in \
        w.verification.details.toPlainText()
    assert w.message_bar.text == f"Certificate INVALID: {flipped}"


def test_exporting_the_csv_onto_the_measured_file_is_refused(window, tmp_path):
    w = window
    measured = tmp_path / "measured.csv"
    shutil.copy(os.path.join(FRAME, "measured.csv"), measured)
    before = measured.read_bytes()
    w.controller.open_files([os.path.join(FRAME, "template.dxf"), str(measured)])
    w.tolerance.set_zone(-0.05, 0.05)
    w.act_inspect.trigger()
    w.export_csv(str(measured))
    assert measured.read_bytes() == before and os.listdir(tmp_path) == ["measured.csv"]
    assert w.message_bar.level == "error" and not w.message_bar.isHidden()
    assert "is the measured file: an output never replaces an input" in w.message_bar.text


def test_the_banner_says_whether_the_verdict_depends_on_the_pose(qtbot):
    """A runner-up pose that fits nearly as well is a fact: while the verdict is the same there
    the banner says the verdict holds (never "AMBIGUOUS"), with the plain-word statements as
    its details; when the runner-up's deviations cross a limit, the verdict depends on the
    pose."""
    from types import SimpleNamespace

    from engine.deviation import point_to_surface
    from engine.pose import apply_transform
    from engine.inspection import Tolerance, inspect
    from qa_app.desktop.model import Session
    from qa_app.desktop.widgets import VerdictBanner
    from surfaces import half_turn_symmetric_part

    banner = VerdictBanner(Session())
    qtbot.addWidget(banner)
    nominal, measured = half_turn_symmetric_part(bump=0.04)
    for tol in (0.1, 0.03):
        res = inspect(nominal, measured, Tolerance.symmetric(tol))
        assert res.ambiguous  # the runner-up moves deviations by over a tenth of the zone
        # Independently: does every point lie inside the zone at both poses?
        at_runner_up = point_to_surface(nominal, apply_transform(
            res.registration.runner_up_T, measured)).signed
        holds = all(np.all(np.abs(d) <= tol) for d in (res.deviations.signed, at_runner_up))
        assert holds == (tol == 0.1)
        banner.update_from(SimpleNamespace(result=res))
        text = banner.detail.text()
        assert "AMBIGUOUS" not in text.upper()
        if holds:
            assert "ACCEPTED" in banner.word.text()
            assert "pose not fully fixed — verdict holds, see details" in text
            assert "depends on the pose" not in text
            assert "the verdict is the same at both" in banner.detail.toolTip()
        else:
            assert "INCONCLUSIVE" in banner.word.text()
            assert "verdict depends on the pose" in text and "verdict holds" not in text
            assert "at that pose the verdict would be REJECT" in banner.detail.toolTip()


def test_a_cylinder_measured_all_round_holds_its_verdict_in_the_banner(qtbot):
    """Free directions along and about a cylinder's axis leave the deviations unchanged: the
    form verdict stands, with a short note, and the statements say what is not fixed."""
    from types import SimpleNamespace

    from engine.pose import apply_transform, make_transform
    from engine.inspection import Tolerance, inspect
    from engine.nominal import Nominal
    from qa_app.desktop.model import Session
    from qa_app.desktop.widgets import VerdictBanner
    from surfaces import point_set, random_rotation

    A, Z = np.meshgrid(np.linspace(0, 2 * np.pi, 160, endpoint=False),
                       np.linspace(-100, 100, 80))
    nrm = np.column_stack([np.cos(A.ravel()), np.sin(A.ravel()), np.zeros(A.size)])
    nominal = Nominal.from_point_set(point_set(40.0 * nrm + np.column_stack(
        [0 * A.ravel(), 0 * A.ravel(), Z.ravel()]), nrm))
    rng = np.random.default_rng(4)
    a, z = rng.uniform(0, 2 * np.pi, 300), rng.uniform(-60, 60, 300)
    r = 40 + rng.uniform(-0.012, 0.012, 300)
    q = np.column_stack([r * np.cos(a), r * np.sin(a), z])
    res = inspect(nominal, apply_transform(make_transform(random_rotation(rng), [300, -20, 55]),
                                           q), Tolerance.symmetric(0.05))
    assert res.verdict == "ACCEPT" and res.pose_sensitivity.verdict_stable
    assert res.conditioning.pose_sigma_mm is None  # free directions
    banner = VerdictBanner(Session())
    qtbot.addWidget(banner)
    banner.update_from(SimpleNamespace(result=res))
    text = banner.detail.text()
    assert "ACCEPTED" in banner.word.text() and "AMBIGUOUS" not in text.upper()
    assert "pose not fully fixed — verdict holds, see details" in text
    said = banner.detail.toolTip().lower()
    assert "position along" in said and "orientation about the axis" in said


# ---------------------------------------------------------------- an inspection plan
BRACKET = os.path.join(ROOT, "samples", "seat_bracket")


def open_bracket_with_plan(w):
    """The seat bracket's files and its plan, through the window's Plan… button (the file dialog
    answered with the plan)."""
    w.controller.open_files([os.path.join(BRACKET, "nominal.xyz"),
                             os.path.join(BRACKET, "measured.csv")])
    w.open_plan(os.path.join(BRACKET, "plan.toml"))


def test_the_plan_opens_beside_the_files_and_the_form_leaves_the_zone_to_it(window, qtbot):
    from qa_app.desktop.window import PLAN_FILTER

    w = window
    assert "*.toml" in PLAN_FILTER.split(";;")[0]
    assert not w.tolerance.by_plan.isVisible() and not w.clear_plan_button.isEnabled()
    open_bracket_with_plan(w)
    assert w.plan_label.text() == "plan.toml"
    assert w.plan_label.toolTip() == os.path.join(BRACKET, "plan.toml")
    assert w.clear_plan_button.isEnabled() and w.act_clear_plan.isEnabled()
    # The plan's zone, as the command line without --tol: the spin boxes show it, greyed.
    assert w.tolerance.by_plan.isVisible() and w.tolerance.by_plan.isChecked()
    assert not w.tolerance.lower.isEnabled() and w.session.plans_zone
    assert w.tolerance.zone() == (w.session.settings.tol_lower, w.session.settings.tol_upper)
    w.act_inspect.trigger()
    assert not w.session.run.settings.zone_in_verdict and w.banner.verdict == "REJECT"
    # A zone of the user's joins the verdict as the characteristic 'tol' over all points.
    w.tolerance.sym.setChecked(True)
    w.tolerance.tol.setValue(0.05)
    assert w.session.stale_reasons == ["zone changed from the plan's to -0.05 … +0.05 mm"]
    w.act_inspect.trigger()
    assert w.session.run.settings.zone_in_verdict
    assert w.characteristics.model_.rows[0].id == "tol"
    qtbot.mouseClick(w.clear_plan_button, Qt.LeftButton)
    assert w.session.plan_path is None and w.plan_label.text() == "— (optional)"
    assert not w.tolerance.by_plan.isVisible() and w.tolerance.sym.isChecked()
    assert w.session.stale_reasons == ["no plan file is open"]


def test_the_characteristics_table_and_a_rows_points(window, qtbot):
    """After a plan's run: its characteristics as on a first-article report, the verdict
    coloured, the banner stating the plan's verdict and why; selecting a characteristic
    selects its points in the point table (the sample's hole points for the position), and
    sorting the table keeps them selected."""
    import json

    from reports.messages import VERDICT_RGB

    w = window
    open_bracket_with_plan(w)
    w.act_inspect.trigger()
    assert w.bottom.currentWidget() is w.characteristics
    m = w.characteristics.model_
    assert m.rowCount() == 5
    cells = [[m.data(m.index(r, c)) for c in range(m.columnCount())] for r in range(5)]
    assert [row[0] for row in cells] == ["1", "2", "3", "4", "5"]
    assert [row[7] for row in cells] == ["REJECTED"] + ["ACCEPTED"] * 4
    assert cells[0][1:5] == ["profile", "skin", "A|B|C", "zone 0.0200 mm"]
    from qa_app.desktop.widgets import qcolor

    assert m.data(m.index(0, 7), Qt.BackgroundRole) == qcolor(VERDICT_RGB["REJECT"])
    assert m.data(m.index(1, 7), Qt.BackgroundRole) == qcolor(VERDICT_RGB["ACCEPT"])
    assert "84 of 100 points" in m.data(m.index(0, 0), Qt.ToolTipRole)
    assert not m.data(m.index(3, 1), Qt.DecorationRole).isNull()  # ⌖, drawn
    assert "A plane (tangent, 16 points)" in w.characteristics.alignment.text()
    assert w.banner.verdict == "REJECT" and "REJECTED" in w.banner.word.text()
    detail = w.banner.detail.text()
    assert "characteristic 1 (profile) is out of tolerance" in detail
    assert "plan plan.toml: 5 characteristics · 1 out of tolerance" in detail
    assert "statistics only" in detail

    with open(os.path.join(BRACKET, "truth.json")) as f:
        truth = json.load(f)
    labels = w.session.run.measured.labels
    w.characteristics.view.selectRow(3)  # position of the hole
    assert w.session.characteristic == 3
    picked = w.table.selected_points()
    assert sorted(labels[picked]) == truth["hole"]["labels"]
    assert "[4] position of hole1 |A|B|C" in w.viewport.readout.text()
    w.table.sortByColumn(1, Qt.DescendingOrder)
    assert sorted(labels[w.table.selected_points()]) == truth["hole"]["labels"]
    w.characteristics.view.selectRow(2)  # flatness of datum face A
    assert sorted(labels[w.table.selected_points()]) == truth["datum_faces"]["A"]["labels"]
    # A new run: no characteristic, no selection.
    w.act_inspect.trigger()
    assert w.session.characteristic is None and w.table.selected_points() == []


def test_the_legend_names_the_plans_regions(window):
    """The points coloured by region: the legend lists each region with its points (the sample's
    datum faces and hole as its truth labels them)."""
    import json

    w = window
    open_bracket_with_plan(w)
    w.act_inspect.trigger()
    assert w.viewport.regions_box.isVisibleTo(w) and w.legend.regions is None
    w.viewport.regions_box.setChecked(True)
    with open(os.path.join(BRACKET, "truth.json")) as f:
        truth = json.load(f)
    faces = truth["datum_faces"]
    counts = {name: n for name, _, n in w.legend.regions}
    assert counts["A"] == len(faces["A"]["labels"]) and counts["B"] == len(faces["B"]["labels"])
    assert counts["C"] == len(faces["C"]["labels"])
    assert counts["hole1"] == len(truth["hole"]["labels"])
    assert sum(counts.values()) == w.session.run.measured.points.shape[0]
    assert [name for name, _, _ in w.legend.regions][-1] == "(no region)"
    w.viewport.regions_box.setChecked(False)
    assert w.legend.regions is None
    # A run without a plan has no regions to show.
    w.viewport.regions_box.setChecked(True)
    w.controller.clear_plan()
    w.act_inspect.trigger()
    assert not w.viewport.regions_box.isVisibleTo(w) and w.legend.regions is None


def test_qa_app_command_with_a_plan_inspects_by_it(qtbot, monkeypatch, tmp_path):
    """``qa-app NOMINAL MEASURED --plan PLAN.toml``: the plan's verdict, as ``qa-inspect``'s."""
    w = run_qa_app(qtbot, monkeypatch, tmp_path, [os.path.join(BRACKET, "nominal.xyz"),
                                                  os.path.join(BRACKET, "measured.csv"),
                                                  "--plan", os.path.join(BRACKET, "plan.toml")])
    assert w.banner.verdict == "REJECT" and w.session.run.settings.plan is not None
    assert not w.session.run.settings.zone_in_verdict
    assert w.characteristics.model_.rowCount() == 5


def test_fields_show_only_for_the_nominals_they_apply_to(window, tmp_path):
    """The airfoil chord for .dat ordinates only, DXF units and layers for DXF drawings only,
    the lower and upper limits for an asymmetric zone only; what is typed reaches the
    settings, and nothing hidden does."""
    w = window
    form = w.tolerance
    dat = tmp_path / "wing.dat"
    dat.write_text("WING\n1.0 0.0\n0.5 0.05\n0.0 0.0\n0.5 -0.05\n1.0 0.0\n")

    def shown():
        return {name for name, field in (("chord", form.chord), ("units", form.units),
                                         ("layers", form.layers), ("lower", form.lower),
                                         ("upper", form.upper)) if field.isVisibleTo(w)}

    assert shown() == set()  # no nominal yet, a symmetric zone
    w.controller.open_nominal(os.path.join(BELLY, "nominal.csv"))
    assert shown() == set()
    form.asym.setChecked(True)
    assert shown() == {"lower", "upper"}
    form.sym.setChecked(True)
    w.controller.open_nominal(str(dat))
    assert shown() == {"chord"}
    form.chord.setValue(250.0)
    assert w.session.settings.scale == 250.0
    w.controller.open_nominal(os.path.join(FRAME, "template.dxf"))
    assert shown() == {"units", "layers"}
    assert w.session.settings.scale is None  # the chord is not the drawing's
    form.units.setCurrentIndex(form.units.findData("in"))
    form.layers.setText("PROFILE, NOTES")
    form.layers.editingFinished.emit()
    assert w.session.settings.units == "in"
    assert w.session.settings.layers == ("PROFILE", "NOTES")
    w.controller.open_nominal(os.path.join(BELLY, "nominal.csv"))
    assert shown() == set()
    assert w.session.settings.units is None and w.session.settings.layers is None


def test_the_crop_box_and_plane_removal_typed_reach_the_settings(window):
    """The crop box is six numbers typed as on the command line (a box that is none is an
    error in the message bar and changes nothing); the plane's distance shows with the plane's
    removal only, and neither applies to a 2D template."""
    w = window
    form = w.tolerance
    w.controller.open_nominal(os.path.join(BELLY, "nominal.csv"))
    form.crop.setText("-130, -60, 300 130 300 500")
    form.crop.editingFinished.emit()
    assert w.session.settings.crop == (-130.0, -60.0, 300.0, 130.0, 300.0, 500.0)
    form.crop.setText("1 2 3 0 5 6")
    form.crop.editingFinished.emit()
    assert w.message_bar.level == "error" and "x range 1 .. 0 is empty" in w.message_bar.text
    assert w.session.settings.crop == (-130.0, -60.0, 300.0, 130.0, 300.0, 500.0)
    assert not form.plane_distance.isVisibleTo(w)
    form.remove_plane.setChecked(True)
    assert form.plane_distance.isVisibleTo(w) and w.session.settings.remove_plane
    assert w.session.settings.plane_distance is None
    form.plane_distance.setValue(15.0)
    assert w.session.settings.plane_distance == 15.0
    form.crop.setText("")
    form.crop.editingFinished.emit()
    assert w.session.settings.crop is None
    w.controller.open_nominal(os.path.join(FRAME, "template.dxf"))
    assert not form.remove_plane.isVisibleTo(w) and not w.session.settings.remove_plane


def test_a_dxf_layer_chosen_in_the_form_is_the_one_inspected(window):
    """Only the profile layer taken: the run is made with it, and a layer that is not in the
    drawing is refused in the message bar."""
    w = window
    w.controller.open_files([os.path.join(FRAME, "template.dxf"),
                             os.path.join(FRAME, "measured.csv")])
    w.tolerance.set_zone(-0.05, 0.05)
    w.tolerance.layers.setText("PROFILE")
    w.tolerance.layers.editingFinished.emit()
    w.act_inspect.trigger()
    assert w.session.run.settings.layers == ("PROFILE",)
    assert w.session.run.result.verdict == "ACCEPT"
    w.tolerance.layers.setText("NO_SUCH_LAYER")
    w.tolerance.layers.editingFinished.emit()
    w.act_inspect.trigger()
    assert w.message_bar.level == "error" and "no_such_layer" in w.message_bar.text.lower()


def test_the_colour_bar_follows_the_bands_of_the_scale(window, monkeypatch):
    """The bar beside the views shows reports.figures.bands(tol), most negative at the bottom,
    whatever that table is (a finer scale shows without a change here)."""
    from reports import figures

    w = window
    load_belly(w, 0.25)
    w.act_inspect.trigger()

    def colours_shown():
        w.legend.resize(120, 420)
        img = w.legend.grab().toImage()
        out = []
        for box, _ in w.legend.band_boxes():
            c = img.pixelColor(int(box.center().x()), int(box.center().y()))
            out.append((c.red(), c.green(), c.blue()))
        return out

    def expected():
        return [tuple(int(round(255 * v)) for v in b.rgb)
                for b in figures.bands(w.session.run.result.tolerance)]

    def close(a, b):
        return len(a) == len(b) and all(max(abs(x - y) for x, y in zip(p, q)) <= 1
                                        for p, q in zip(a, b))

    assert close(colours_shown(), expected())
    boxes = w.legend.band_boxes()
    assert all(boxes[k][0].top() >= boxes[k + 1][0].bottom() - 1e-9
               for k in range(len(boxes) - 1))  # bottom to top
    real = figures.bands

    def finer(tol):  # twenty bands across the zone, two beyond each limit
        lo, hi = tol.lower, tol.upper
        edges = [-np.inf, lo - 0.1, *np.linspace(lo, hi, 21), hi + 0.1, np.inf]
        rgb = [((k * 37) % 256 / 255, (k * 91) % 256 / 255, (k * 53) % 256 / 255)
               for k in range(24)]
        return [figures.Band(edges[k], edges[k + 1], rgb[k], 2 <= k <= 21) for k in range(24)]

    monkeypatch.setattr(figures, "bands", finer)
    assert len(w.legend.band_boxes()) == 24 and close(colours_shown(), expected())
    monkeypatch.setattr(figures, "bands", real)
