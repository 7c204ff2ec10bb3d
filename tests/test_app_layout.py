"""The main window's layout on Qt's offscreen platform: the 3D view dominates the window at a
laptop's 1366×768 and a desktop's 1920×1080 (issue 26), the point table, characteristics and
histogram wait in a dock, and no choice in a combo box is cut off."""

import os

import pytest
from PySide6.QtCore import QSettings
from PySide6.QtWidgets import QApplication, QComboBox, QDockWidget

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
