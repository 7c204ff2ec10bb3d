"""The window (Qt's offscreen platform, no OpenGL): selecting a row of the Characteristics tab
of CTC-01 inspected with its QIF plan hands the 3D view exactly that characteristic's faces,
points, datums and frame (the view's ``show_highlight`` recorded); clearing the row hands it
None; a face hovered is named in the status bar."""

import numpy as np
import pytest
from PySide6.QtCore import QSettings

from ctc01 import DATUMS, QIF, SLOT, STP, measured_csv
from qa_app.desktop.viewport import Viewport3D
from qa_app.desktop.window import MainWindow


@pytest.fixture
def window(qtbot, tmp_path, monkeypatch):
    shown = []
    monkeypatch.setattr(Viewport3D, "show_highlight", lambda self, h: shown.append(h))
    w = MainWindow(synchronous=True, settings=QSettings(str(tmp_path / "qa-app.ini"),
                                                         QSettings.IniFormat), enable_3d=False)
    qtbot.addWidget(w)
    w.controller.open_files([STP, measured_csv(tmp_path)])
    w.controller.open_plan(QIF)
    w.inspect()
    assert w.session.run is not None
    yield w, shown
    w.close()


def test_selecting_a_row_calls_the_view_with_the_characteristics_faces(window):
    w, shown = window
    ids = [r.characteristic.id for r in w.session.run.result.plan.characteristics]
    m = w.characteristics.model_
    assert [m.data(m.index(r, 0)) for r in range(m.rowCount())] == ids
    w.characteristics.view.selectRow(ids.index("1443"))
    h = shown[-1]
    assert h is not None and h.id == "1443" and h.faces == SLOT
    assert {d.label: d.faces for d in h.datums} == DATUMS
    assert h.frame == "⌖ 0.75 | A | B | C"
    assert np.array_equal(h.points, w.session.highlighted)
    w.characteristics.view.selectRow(ids.index("1470"))  # flatness of datum A: the top
    assert shown[-1].faces == (98,) and shown[-1].datums == ()
    w.characteristics.view.selectionModel().clearCurrentIndex()
    assert w.session.characteristic is None and shown[-1] is None


def test_a_face_hovered_is_named_in_the_status_bar(window):
    w, _ = window
    w.viewport.face_hovered.emit(w.part_view.face_text(25))
    assert w.statusBar().currentMessage() == "face 25 · plane · (unnamed)"
