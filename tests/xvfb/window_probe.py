"""Run on an X display of a given size (by tests/xvfb/test_window_size.py, under its own
xvfb-run): open the window as ``qa-app`` does, inspect the belly fairing, give the window the
area a maximised window has on a laptop of that screen (less a task bar and a title bar), and
print what a user sees of it as JSON."""

import json
import os
import sys
import tempfile

from PySide6.QtCore import QSettings
from PySide6.QtWidgets import QApplication

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, ROOT)

from qa_app.desktop.window import MainWindow  # noqa: E402

TASK_BAR, TITLE_BAR, BORDER = 40, 30, 8
"""A laptop's task bar, a window's title bar and side borders, px."""


def probe() -> dict:
    app = QApplication.instance() or QApplication([])
    with tempfile.TemporaryDirectory() as tmp:
        w = MainWindow(synchronous=True,
                       settings=QSettings(os.path.join(tmp, "qa.ini"), QSettings.IniFormat))
        started = w.size()
        screen = w.screen().geometry()
        belly = os.path.join(ROOT, "samples", "belly_fairing")
        w.controller.open_files([os.path.join(belly, n) for n in ("nominal.csv",
                                                                   "measured.csv")])
        w.tolerance.set_zone(-0.25, 0.25)
        w.inspect()
        w.resize(screen.width() - 2 * BORDER, screen.height() - TASK_BAR - TITLE_BAR)
        w.show()
        for _ in range(10):
            app.processEvents()
        t = w.table
        header = t.horizontalHeader()
        fm = header.fontMetrics()
        rows_seen = t.viewport().height() // t.rowHeight(0)
        out = {
            "screen": [screen.width(), screen.height()],
            "started": [started.width(), started.height()],
            "minimum_hint": [w.minimumSizeHint().width(), w.minimumSizeHint().height()],
            "minimum": [w.minimumSize().width(), w.minimumSize().height()],
            "size": [w.width(), w.height()],
            "rows_seen": int(rows_seen),
            "table_height": t.height(),
            "views_height": w.views.height(),
            "viewport": [w.viewport.width(), w.viewport.height()],
            "render": [w.viewport.plotter.interactor.width(),
                       w.viewport.plotter.interactor.height()],
            "headers": [[m, header.sectionSize(c), fm.horizontalAdvance(m), fm.height()]
                        for c, m in enumerate(t.model().COLUMNS)],
            "table_right": t.mapTo(w, t.rect().bottomRight()).x(),
        }
        w.close()
    return out


if __name__ == "__main__":
    print(json.dumps(probe()))
