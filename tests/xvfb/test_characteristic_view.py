"""A characteristic shown on the part in the real 3D view (Xvfb): CTC-01 inspected with its QIF
plan; selecting position 1443 adds its faces (exactly their triangles), its datums' faces and
flags and its frame, fades the nominal and zooms to the slot; deselecting takes them away and
restores the view; the mouse resting over a face names it."""

import numpy as np
import pytest
from PySide6.QtCore import QSettings

from ctc01 import DATUMS, QIF, SLOT, STP, measured_csv, tessellation_faces
from qa_app.desktop import part_overlay
from qa_app.desktop.window import MainWindow


@pytest.fixture
def window(qtbot, tmp_path):
    w = MainWindow(synchronous=True, settings=QSettings(str(tmp_path / "qa-app.ini"),
                                                         QSettings.IniFormat))
    qtbot.addWidget(w)
    w.show()
    qtbot.waitExposed(w)
    w.controller.open_files([STP, measured_csv(tmp_path)])
    w.controller.open_plan(QIF)
    w.inspect()
    qtbot.wait(100)
    yield w
    w.close()


def n_cells(pl, name):
    actor = pl.renderer.actors.get(name)
    return None if actor is None else actor.GetMapper().GetInput().GetNumberOfCells()


def test_selecting_a_characteristic_changes_the_actors(window, qtbot):
    w = window
    pl = w.viewport.plotter
    assert pl is not None
    cam = pl.camera
    home = (cam.position, cam.focal_point)
    nominal = pl.renderer.actors["qa-nominal"]
    assert nominal.GetProperty().GetOpacity() == 1.0
    assert not any(name in pl.renderer.actors for name in part_overlay.ACTORS)
    ids = [r.characteristic.id for r in w.session.run.result.plan.characteristics]
    w.characteristics.view.selectRow(ids.index("1443"))
    qtbot.wait(100)
    tris, tri_face = tessellation_faces()
    # The highlight: exactly the slot's triangles; the datums' faces (A, B, C) tinted.
    assert n_cells(pl, "qa-char-faces") == np.isin(tri_face, SLOT).sum() > 0
    datum_faces = [f for faces in DATUMS.values() for f in faces]
    assert n_cells(pl, "qa-datum-faces") == np.isin(tri_face, datum_faces).sum()
    assert "qa-datum-flags-labels" in pl.renderer.actors and "qa-frame" in pl.renderer.actors
    assert nominal.GetProperty().GetOpacity() == part_overlay.FADED_OPACITY
    # The view is on the slot: focused on its centre, closer than the whole part.
    h = w.viewport.highlight
    assert np.allclose(cam.focal_point, h.centre)
    assert np.linalg.norm(np.subtract(cam.position, cam.focal_point)) < np.linalg.norm(
        np.subtract(*home))
    # The slot's faces are drawn outlined in orange, in front of the faded nominal.
    assert n_cells(pl, "qa-char-edges") > 0
    img = pl.screenshot(return_img=True).astype(int)
    r, g, b = img[..., 0], img[..., 1], img[..., 2]
    assert ((r > 150) & (g > 40) & (g < 130) & (b < 60)).sum() > 300
    w.characteristics.view.selectionModel().clearCurrentIndex()
    qtbot.wait(100)
    assert not any(name in pl.renderer.actors for name in part_overlay.ACTORS)
    assert nominal.GetProperty().GetOpacity() == 1.0
    assert np.allclose(cam.position, home[0]) and np.allclose(cam.focal_point, home[1])


def test_the_mouse_resting_over_a_face_names_it(window, qtbot):
    w = window
    pl = w.viewport.plotter
    faces = w.part_view.faces
    w.viewport.standard_view("Top")  # looking down on the plate's top
    qtbot.wait(100)
    # The top face (98): the centre of its largest triangle, on screen.
    V = faces.points[faces.triangles[faces.triangles_of([98])]]
    area = np.linalg.norm(np.cross(V[:, 1] - V[:, 0], V[:, 2] - V[:, 0]), axis=1)
    x, y, z = V[np.argmax(area)].mean(axis=0)
    r = pl.renderer
    r.SetWorldPoint(x, y, z, 1.0)
    r.WorldToDisplay()
    px, py = r.GetDisplayPoint()[:2]
    with qtbot.waitSignal(w.viewport.face_hovered) as said:
        assert w.viewport.hover_at(int(round(px)), int(round(py))) == \
            "face 98 · plane · (unnamed)"
    assert said.args == ["face 98 · plane · (unnamed)"]
    assert w.statusBar().currentMessage() == "face 98 · plane · (unnamed)"
    # Beside the part: no face, nothing said.
    assert w.viewport.hover_at(2, 2) == ""
    # The mouse moved there and resting: the view asks itself.
    iren = pl.iren.interactor
    iren.SetEventInformation(int(round(px)), int(round(py)))
    with qtbot.waitSignal(w.viewport.face_hovered, timeout=2000) as said:
        iren.InvokeEvent("MouseMoveEvent")
    assert said.args == ["face 98 · plane · (unnamed)"]
