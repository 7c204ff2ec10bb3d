"""The real 3D viewport and the whole workflow, in a window on an X display (Xvfb)."""

import json
import os

import numpy as np
import pytest
from PySide6.QtCore import QSettings, Qt

from qa_app.cli import main as cli_main
from qa_app.desktop.dialogs import CertificateDialog
from qa_app.desktop.model import Step
from qa_app.desktop.window import MainWindow
from reports import figures

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
BELLY = os.path.join(ROOT, "samples", "belly_fairing")


@pytest.fixture
def window(qtbot, tmp_path):
    made = []

    def make(synchronous=True):
        w = MainWindow(synchronous=synchronous,
                       settings=QSettings(str(tmp_path / "qa-app.ini"), QSettings.IniFormat))
        qtbot.addWidget(w)
        w.show()
        qtbot.waitExposed(w)
        made.append(w)
        return w

    yield make
    for w in made:
        w.close()


def inspected_belly(w, qtbot, tol=0.25):
    """The window ``w`` with the belly fairing inspected at ±tol mm, drawn."""
    w.controller.open_files([os.path.join(BELLY, "nominal.csv"),
                             os.path.join(BELLY, "measured.csv")])
    w.tolerance.set_zone(-tol, tol)
    w.act_inspect.trigger()
    qtbot.wait(100)
    return w


def _screen_of(plotter, xyz):
    r = plotter.renderer
    r.SetWorldPoint(*xyz, 1.0)
    r.WorldToDisplay()
    return r.GetDisplayPoint()[:2]


def test_viewport_shows_the_deviation_colours(window, qtbot):
    w = window()
    assert w.viewport.plotter is not None
    w.controller.open_files([os.path.join(BELLY, "nominal.csv"),
                             os.path.join(BELLY, "measured.csv")])
    # The sample's highest point lies about 0.050 mm above the surface, the next 0.040 mm: an
    # upper limit of 0.045 leaves exactly one point above the zone, whatever the last digits.
    w.tolerance.set_zone(-0.05, 0.045)
    w.act_inspect.trigger()
    d = w.session.run.result.deviations.signed
    assert (d < -0.05).sum() == 20 and (d > 0.045).sum() == 1
    qtbot.wait(100)

    def colours():
        img = w.viewport.plotter.screenshot(return_img=True).astype(int)
        r, g, b = img[..., 0], img[..., 1], img[..., 2]
        return {"green": (g > r + 40) & (g > b + 40), "blue": (b > r + 60) & (b > g + 20),
                "grey": (abs(r - g) < 8) & (abs(g - b) < 12) & (r > 90) & (r < 235),
                # the dark red of the band above the zone (the zone's own reds end at its limit)
                "above": (r > 60) & (r < 150) & (g < 0.12 * r) & (b < 0.3 * r)}

    vp = w.viewport
    assert vp.surface_box.isVisible() and vp.surface_box.isChecked() and vp.surface_coloured()
    vp.surface_box.setChecked(False)  # the grey surface, the points coloured
    qtbot.wait(100)
    c = {k: int(v.sum()) for k, v in colours().items()}
    # In-tolerance points (greens) dominate; the 20 points below the zone show blue; the nominal
    # surface shows grey between the points.
    assert c["green"] > 20 * c["blue"] > 0
    assert c["blue"] > 200
    assert c["grey"] > 2000
    # No out-of-tolerance colour where there is no such point: the dark red of the band above
    # the zone appears only at the one point above it.
    assert 0 < c["above"] < c["blue"]
    # The surface coloured by the deviations (issue 26), the points hidden: the colours are
    # the surface's own. Every part of it the points cover takes a band colour (no grey left
    # but its border), the dent below the zone a blue patch wider than its points were.
    vp.surface_box.setChecked(True)
    vp.points_box.setChecked(False)
    qtbot.wait(100)
    assert not any(a in w.viewport.plotter.renderer.actors for a in ("qa-in", "qa-out"))
    s = {k: int(v.sum()) for k, v in colours().items()}
    assert s["grey"] < 0.05 * c["grey"]
    assert s["blue"] > c["blue"] and s["green"] > c["green"]
    assert 0 < s["above"] < s["blue"]
    vp.points_box.setChecked(True)
    assert {"qa-in", "qa-out"} <= set(w.viewport.plotter.renderer.actors)


def test_pick_a_point_in_the_view(window, qtbot):
    w = inspected_belly(window(), qtbot)
    pl = w.viewport.plotter
    target = int(np.argmin(np.linalg.norm(w.viewport._shown - w.viewport._shown.mean(0),
                                          axis=1)))
    x, y = _screen_of(pl, w.viewport._shown[target])
    pl.iren._mouse_left_button_click(int(round(x)), int(round(y)))
    qtbot.wait(50)
    sel = w.session.selected
    assert sel is not None
    # The picked point is the one under the cursor (or a neighbour drawn within a few pixels).
    sx, sy = _screen_of(pl, w.viewport._shown[sel])
    assert np.hypot(sx - x, sy - y) < 8
    label = str(w.session.run.measured.labels[sel])
    assert label in w.viewport.readout.text()
    assert w.table.model().point(w.table.currentIndex().row()) == sel
    assert "qa-selection" in pl.renderer.actors


def test_standard_views_move_the_camera(window, qtbot):
    w = window()
    w.controller.open_files([os.path.join(BELLY, "nominal.csv"),
                             os.path.join(BELLY, "measured.csv")])
    w.act_inspect.trigger()
    pl = w.viewport.plotter
    seen = set()
    for name in ("Top", "Front", "Side", "Iso", "Face-on"):
        w.viewport.view_buttons[name].click()
        d = np.subtract(pl.camera.position, pl.camera.focal_point)
        seen.add(tuple(np.round(d / np.linalg.norm(d), 3)))
    assert len(seen) == 5
    assert np.allclose(np.subtract(pl.camera.position, pl.camera.focal_point)
                       / np.linalg.norm(np.subtract(pl.camera.position, pl.camera.focal_point)),
                       figures.face_on_direction(w.session.run.result.deviations.foot,
                                                 w.session.run.result.deviations.normal),
                       atol=1e-6)


def test_workflow_from_files_to_a_verified_signed_certificate(window, qtbot, tmp_path,
                                                              monkeypatch):
    """Through the window's own actions, with the engine in its worker thread."""
    monkeypatch.setenv("QA_XVFB_PASS", "s3cret")
    assert cli_main(["keygen", "--name", "Ann Inspector", "--organisation", "ACME",
                     "--out", str(tmp_path / "id"), "--pass-env", "QA_XVFB_PASS"]) == 0
    w = window(synchronous=False)
    stages = []
    w.session.progress.connect(lambda stage, f: stages.append(stage))
    w.controller.open_files([os.path.join(BELLY, "nominal.csv"),
                             os.path.join(BELLY, "measured.csv")])
    w.tolerance.set_zone(-0.25, 0.25)
    w.act_inspect.trigger()
    assert w.session.step == Step.RUNNING and w.act_cancel.isEnabled()
    qtbot.waitUntil(lambda: w.session.step == Step.INSPECTED, timeout=120_000)
    assert any("ICP iteration" in s for s in stages)
    assert w.banner.verdict == "ACCEPT"

    out = tmp_path / "certificate.pdf"
    dialog = CertificateDialog(w, {}, str(out))
    dialog.edits["part_number"].setText("BF-2231-001")
    dialog.edits["serial"].setText("SN-7")
    dialog.edits["inspector"].setText("Ann Inspector")
    dialog.p12.setText(str(tmp_path / "id" / "inspector.p12"))
    dialog.passphrase.setText("s3cret")
    w.export_certificate(dialog=dialog)
    assert dialog.passphrase.text() == ""  # handed over once, not kept
    qtbot.waitUntil(lambda: out.exists() and w.session.step == Step.INSPECTED,
                    timeout=120_000)
    assert not w.message_bar.isVisible() or w.message_bar.level != "error"
    from reports.signing import read_trust_roots, verify_pdf

    v = verify_pdf(out.read_bytes(), read_trust_roots(str(tmp_path / "id" / "ca.pem")))
    assert v.valid, v.problems
    doc = json.loads(v.attachments["results.json"])
    assert doc["verdict"] == "ACCEPT" and doc["certificate"]["serial"] == "SN-7"
    assert cli_main(["verify", str(out), "--trust", str(tmp_path / "id" / "ca.pem"),
                     "--nominal", os.path.join(BELLY, "nominal.csv"),
                     "--measured", os.path.join(BELLY, "measured.csv")]) == 0


def test_window_with_the_3d_view_fits_1366x768_and_a_new_run_clears_the_pick(window, qtbot):
    """On a real display, with the OpenGL view, the minimum size leaves room for the frame and a
    task bar on 1366×768; the picked point's readout and marker belong to one run only."""
    w = window()
    for size in (w.minimumSizeHint(), w.minimumSize()):
        assert size.width() <= 1340 and size.height() <= 700
    w.controller.open_files([os.path.join(BELLY, "nominal.csv"),
                             os.path.join(BELLY, "measured.csv")])
    w.act_inspect.trigger()
    w.session.select(5)
    label = str(w.session.run.measured.labels[5])
    assert label in w.viewport.readout.text()
    assert "qa-selection" in w.viewport.plotter.renderer.actors
    w.act_inspect.trigger()
    assert w.viewport.readout.text() == w.viewport.READOUT_HINT
    assert "qa-selection" not in w.viewport.plotter.renderer.actors


def test_the_seat_bracket_with_its_plan(window, qtbot):
    """The sample opened with its plan through the window, inspected in the worker: the
    characteristics table with its five rows and REJECT; a characteristic's points shown in
    the 3D view with the others faded; the points coloured by region instead of deviation."""
    bracket = os.path.join(ROOT, "samples", "seat_bracket")
    w = window(synchronous=False)
    w.controller.open_files([os.path.join(bracket, n) for n in ("nominal.xyz", "measured.csv",
                                                                 "plan.toml")])
    qtbot.waitUntil(lambda: w.session.plan_path is not None and not w.controller.busy,
                    timeout=60_000)
    w.act_inspect.trigger()
    qtbot.waitUntil(lambda: w.session.step == Step.INSPECTED, timeout=120_000)
    assert w.banner.verdict == "REJECT" and "REJECTED" in w.banner.word.text()
    m = w.characteristics.model_
    assert m.rowCount() == 5 and w.bottom.currentWidget() is w.characteristics
    assert [m.data(m.index(r, 7)) for r in range(5)] == ["REJECTED"] + ["ACCEPTED"] * 4
    pl = w.viewport.plotter
    n = w.session.run.measured.points.shape[0]

    def shown(name):
        actor = pl.renderer.actors.get(name)
        return 0 if actor is None else actor.mapper.dataset.n_points

    assert shown("qa-in") + shown("qa-out") == n and shown("qa-faded") == 0
    w.characteristics.view.selectRow(3)  # the hole's position: its 16 points stand out
    qtbot.wait(100)
    assert shown("qa-in") + shown("qa-out") == 16 and shown("qa-faded") == n - 16
    w.characteristics.view.selectionModel().clearCurrentIndex()
    assert w.session.characteristic is None
    qtbot.wait(100)
    assert shown("qa-faded") == 0

    def colours():
        img = pl.screenshot(return_img=True).astype(int)
        r, g, b = img[..., 0], img[..., 1], img[..., 2]
        red = (r > g + 60) & (r > b + 60)  # the deviation scale's excess
        skin = (abs(r - 0) < 30) & (abs(g - 115) < 30) & (abs(b - 178) < 30)  # the skin region
        return int(red.sum()), int(skin.sum())

    red, skin = colours()
    assert red > 300 and skin < red / 10  # (the table has the larger share of the height)
    w.viewport.regions_box.setChecked(True)
    qtbot.wait(100)
    red, skin = colours()
    assert skin > 300 and red < skin / 10


def test_flags_on_the_worst_point_of_each_cluster_and_zoom_to_a_row(window, qtbot):
    """The belly fairing at ±0.25 mm (ACCEPTED): its planted dent (−0.15 mm at (120, −40) in
    the nominal frame) gets one flag, on its deepest point, with the point's label; a table
    row double-clicked centres the 3D view on its point and comes close."""
    import json

    from reports.callouts import callout_points

    w = inspected_belly(window(), qtbot)
    run = w.session.run
    d = run.result.deviations.signed
    pl = w.viewport.plotter
    flags = w.viewport.flag_texts()
    shown = w.viewport._shown
    assert [i for i, _ in flags] == callout_points(shown, d, -0.25, 0.25, max_callouts=5)
    assert "qa-flags-labels" in pl.renderer.actors
    with open(os.path.join(BELLY, "truth.json")) as f:
        truth = json.load(f)
    assert "dent" in truth["defect"]
    foot = run.result.deviations.foot
    in_dent = np.hypot(foot[:, 0] - 120, foot[:, 1] + 40) < 2 * 18
    dent_flags = [i for i, _ in flags if in_dent[i]]
    assert dent_flags == [int(np.argmin(d))]
    assert flags[0][1] == f"{run.measured.labels[dent_flags[0]]} {d[dent_flags[0]]:+.3f}"

    # Double-click the tenth row: the view centres on its point, much closer than the whole.
    before = np.linalg.norm(np.subtract(pl.camera.position, pl.camera.focal_point))
    model = w.table.model()
    rect = w.table.visualRect(model.index(9, 1))
    # As a mouse does it: a click, then the double-click event.
    qtbot.mouseClick(w.table.viewport(), Qt.LeftButton, pos=rect.center())
    qtbot.mouseDClick(w.table.viewport(), Qt.LeftButton, pos=rect.center())
    qtbot.wait(100)
    i = model.point(9)
    assert w.session.selected == i
    assert np.allclose(pl.camera.focal_point, shown[i])
    after = np.linalg.norm(np.subtract(pl.camera.position, pl.camera.focal_point))
    assert after < 0.3 * before
    x, y = _screen_of(pl, shown[i])
    width, height = pl.window_size
    assert abs(x - width / 2) < 2 and abs(y - height / 2) < 2
