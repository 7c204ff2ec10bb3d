"""The main window's layout on Qt's offscreen platform: the 3D view dominates the window at a
laptop's 1366×768 and a desktop's 1920×1080 (issue 26), the point table, characteristics and
histogram wait in a dock, and no choice in a combo box is cut off."""

import os

import pytest
from PySide6.QtCore import QSettings
from PySide6.QtWidgets import (
    QApplication,
    QComboBox,
    QDockWidget,
    QStyle,
    QStyleOptionComboBox,
)

from qa_app.desktop.window import MainWindow

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BELLY = os.path.join(ROOT, "samples", "belly_fairing")
SHARE = 0.55
"""The least share of the window's area the 3D view takes."""


@pytest.fixture
def inspected(qtbot, tmp_path):
    """The window with the belly fairing inspected at ±0.05 mm (a rejected part: the banner's
    longest text), shown."""
    w = MainWindow(synchronous=True, settings=QSettings(str(tmp_path / "qa-app.ini"),
                                                        QSettings.IniFormat))
    qtbot.addWidget(w)
    w.controller.open_files([os.path.join(BELLY, "nominal.csv"),
                             os.path.join(BELLY, "measured.csv")])
    w.tolerance.set_zone(-0.05, 0.05)
    w.show()
    w.act_inspect.trigger()
    return w


def share_at(w, width, height) -> float:
    """The 3D view's area over the window's, the window given ``width`` × ``height`` (the
    offscreen platform has no real maximise)."""
    w.resize(width, height)
    for _ in range(5):
        QApplication.processEvents()
    assert (w.width(), w.height()) == (width, height)
    v = w.viewport
    assert v.isVisible() and w.views.currentWidget() is v
    return v.width() * v.height() / (w.width() * w.height())


@pytest.mark.parametrize("size", [(1366, 768), (1920, 1080)])
def test_the_3d_view_takes_most_of_the_window(inspected, size):
    share = share_at(inspected, *size)
    print(f"3D view share at {size[0]}x{size[1]}: {share:.3f}")
    assert share >= SHARE, share


def test_the_qa_app_command_opens_the_window_maximised(qtbot, monkeypatch, tmp_path):
    from test_app_window import run_qa_app

    w = run_qa_app(qtbot, monkeypatch, tmp_path, [os.path.join(BELLY, "nominal.csv"),
                                                  os.path.join(BELLY, "measured.csv"),
                                                  "--tol", "0.25"])
    assert w.isMaximized()


def test_the_results_wait_in_a_dock_that_can_be_hidden(inspected):
    """Points, characteristics and histogram in a dock tabbed with the steps (the results in
    front once inspected); the View menu hides either, and the 3D view takes the room."""
    w = inspected
    assert isinstance(w.results_dock, QDockWidget) and w.results_dock.widget() is w.bottom
    assert [w.bottom.tabText(i) for i in range(w.bottom.count())] == [
        "Points", "Characteristics", "Histogram"]
    assert w.tabifiedDockWidgets(w.steps_dock) == [w.results_dock]
    assert w.centralWidget().isAncestorOf(w.viewport)
    assert not w.centralWidget().isAncestorOf(w.table)
    # The results in front (a tabbed dock behind stays "visible", moved out of sight).
    assert not w.table.visibleRegion().isEmpty() and w.tolerance.visibleRegion().isEmpty()
    before = share_at(w, 1366, 768)
    w.results_dock.toggleViewAction().trigger()
    w.steps_dock.toggleViewAction().trigger()
    assert not w.results_dock.isVisible() and not w.steps_dock.isVisible()
    assert share_at(w, 1366, 768) > before
    w.results_dock.toggleViewAction().trigger()
    assert w.results_dock.isVisible() and w.table.isVisible()


def test_no_combo_cuts_a_choice_off(inspected, qtbot, tmp_path):
    """At 1366×768, each combo box shows its longest choice whole, closed (the field beside the
    arrow) and in its list; a preset's long name may be elided closed, never in the list."""
    w = inspected
    share_at(w, 1366, 768)
    w.steps_dock.raise_()
    combos = w.findChildren(QComboBox)
    assert set(w.tolerance.combos()) == set(combos)
    shown = [c for c in combos if c.isVisible()]  # (DXF units: for a drawing only)
    assert {w.tolerance.fit, w.tolerance.rule, w.tolerance.preset} <= set(shown)
    for combo in shown:
        fm = combo.fontMetrics()
        longest = max((combo.itemText(i) for i in range(combo.count())),
                      key=fm.horizontalAdvance)
        opt = QStyleOptionComboBox()
        combo.initStyleOption(opt)
        field = combo.style().subControlRect(QStyle.CC_ComboBox, opt,
                                             QStyle.SC_ComboBoxEditField, combo)
        assert field.width() >= fm.horizontalAdvance(longest), longest
    # A window whose settings hold a preset with a long name.
    settings = QSettings(str(tmp_path / "presets.ini"), QSettings.IniFormat)
    settings.setValue("presets/names", ["A long part number, 2026 revision C"])
    settings.setValue("presets/A long part number, 2026 revision C", [-0.1, 0.2])
    w = MainWindow(synchronous=True, settings=settings)
    qtbot.addWidget(w)
    w.resize(1366, 768)
    w.show()
    combos = w.findChildren(QComboBox)
    assert any("revision C" in w.tolerance.preset.itemText(i)
               for i in range(w.tolerance.preset.count()))
    for combo in combos:
        fm = combo.view().fontMetrics()
        longest = max((combo.itemText(i) for i in range(combo.count())),
                      key=fm.horizontalAdvance)
        combo.showPopup()
        try:
            view = combo.view()
            qtbot.waitUntil(view.isVisible)
            assert view.viewport().width() >= fm.horizontalAdvance(longest), longest
            assert view.minimumWidth() >= fm.horizontalAdvance(longest)
        finally:
            combo.hidePopup()
