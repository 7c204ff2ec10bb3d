"""The 2D contour view (offscreen): the tolerance envelope against hand geometry, zoom about the
cursor, pan by dragging, the whole part again, and a click still selecting a point."""

import contextlib
import os

import numpy as np
import pytest
from PySide6.QtCore import QPoint, QPointF, Qt
from PySide6.QtGui import QWheelEvent
from PySide6.QtWidgets import QApplication

from engine.contour import ContourIndex, arc, build_template, deviations_2d, segment
from qa_app.desktop.contour_view import envelope_polylines
from reports import figures
from test_app_window import window  # noqa: F401  (the window fixture)

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
FRAME = os.path.join(ROOT, "samples", "fuselage_frame")


def plate_with_a_hole():
    """A 100 × 60 mm plate (outer profile, drawn clockwise) with a hole of radius 10 mm at
    (50, 30) (drawn counter-clockwise)."""
    corners = [(0, 0), (0, 60), (100, 60), (100, 0)]
    outer = [segment(corners[i], corners[(i + 1) % 4]) for i in range(4)]
    hole = [arc((50, 30), 10, 0.0, 2 * np.pi)]
    return build_template([(outer, True), (hole, True)])


@pytest.mark.parametrize("offset", [-2.0, 3.0])
def test_the_envelope_is_the_contour_offset_toward_excess_material(offset):
    """Positive deviation is excess material: outside the plate's outline, into the hole. The
    offset outline is the plate's edges each moved ``offset`` outward, the offset hole a circle
    of radius 10 − offset; by hand, with no engine distance in the check."""
    t = plate_with_a_hole()
    outline, hole = envelope_polylines(t, offset)
    o = offset
    # Each edge's two ends, moved along that edge's outward normal, in drawing order.
    expected = [(-o, 0), (-o, 60), (0, 60 + o), (100, 60 + o), (100 + o, 60), (100 + o, 0),
                (100, -o), (0, -o)]
    assert np.allclose(outline, expected, atol=1e-12)
    r = np.hypot(hole[:, 0] - 50, hole[:, 1] - 30)
    assert np.allclose(r, 10 - o, atol=1e-9)
    # Around the whole hole, in steps of at most 3 degrees.
    turn = np.unwrap(np.arctan2(hole[:, 1] - 30, hole[:, 0] - 50))
    assert abs(turn[-1] - turn[0]) == pytest.approx(2 * np.pi)
    assert np.abs(np.diff(turn)).max() <= np.radians(3) + 1e-12


@pytest.fixture
def frame_view(window):
    w = window
    w.controller.open_files([os.path.join(FRAME, "template.dxf"),
                             os.path.join(FRAME, "measured.csv")])
    w.tolerance.set_zone(-0.02, 0.02)
    w.act_inspect.trigger()
    view = w.contour
    view.resize(800, 500)
    return w, view


def wheel(view, at: QPointF, notches: float):
    event = QWheelEvent(at, view.mapToGlobal(at), QPoint(0, 0), QPoint(0, int(120 * notches)),
                        Qt.NoButton, Qt.NoModifier, Qt.NoScrollPhase, False)
    QApplication.sendEvent(view, event)


def test_the_envelope_and_whiskers_tell_the_points_out_of_tolerance(frame_view):
    """Whisker and envelope share one magnification: a whisker's tip lies beyond its side's
    offset contour exactly when its point is out of tolerance."""
    w, view = frame_view
    res = w.session.run.result
    feet, tips, factor = view._cache[1], view._cache[2], view._cache[4]
    lower, upper = view._cache[7]
    assert 0 < res.statistics.n_out < res.statistics.count
    # Along the normal at the point's foot, the envelope lies at factor × limit.
    reach = np.einsum("ij,ij->i", tips - feet, res.deviations.normal[:, :2])
    beyond = (reach > factor * res.tolerance.upper) | (reach < factor * res.tolerance.lower)
    assert np.array_equal(beyond, ~res.in_tolerance)
    # The drawn envelope lies at those offsets: the engine's signed deviation of its points
    # is the limit × factor, but where a concave bend's other side is nearer.
    index = ContourIndex(w.session.run.template.template)
    for side, limit in ((lower, res.tolerance.lower), (upper, res.tolerance.upper)):
        d = deviations_2d(index, np.vstack(side)).signed / (factor * limit)
        assert d.max() <= 1 + 1e-9 and np.mean(np.abs(d - 1) < 1e-3) > 0.8


def test_wheel_zooms_about_the_cursor_drag_pans_and_double_click_shows_all(frame_view, qtbot):
    w, view = frame_view
    feet = view._cache[1]
    fitted = view.fitted_view()
    at = QPointF(300, 200)

    def under(px: QPointF) -> np.ndarray:  # the template point (mm) at a widget pixel
        k, ox, oy = view._view or view.fitted_view()
        lo = view._cache[5]
        return np.array([lo[0] + (px.x() - ox) / k, lo[1] - (px.y() - oy) / k])

    before = under(at)
    wheel(view, at, 2)
    assert view._view[0] == pytest.approx(fitted[0] * 1.25 ** 2)
    assert np.allclose(under(at), before, atol=1e-9)
    wheel(view, at, -1)
    assert view._view[0] == pytest.approx(fitted[0] * 1.25)
    # A drag moves the drawing with the mouse, and selects nothing.
    P = view._transform()
    x0, y0 = P(feet[10])
    qtbot.mousePress(view, Qt.LeftButton, pos=QPoint(400, 250))
    qtbot.mouseMove(view, QPoint(430, 210))
    qtbot.mouseRelease(view, Qt.LeftButton, pos=QPoint(430, 210))
    x1, y1 = view._transform()(feet[10])
    assert (x1 - x0, y1 - y0) == pytest.approx((30, -40))
    assert w.session.selected is None
    # A click on a whisker tip in the zoomed view selects its point.
    tx, ty = view._transform()(view._cache[2])
    i = int(np.argmin((tx - 400) ** 2 + (ty - 250) ** 2))
    qtbot.mouseClick(view, Qt.LeftButton, pos=QPointF(tx[i], ty[i]).toPoint())
    sel = w.session.selected
    assert sel is not None and np.hypot(tx[sel] - tx[i], ty[sel] - ty[i]) <= 1.5
    qtbot.mouseDClick(view, Qt.LeftButton, pos=QPoint(5, 5))
    assert view._view is None and view._transform()(feet[10]) == pytest.approx(
        tuple(np.array(fitted[1:]) + fitted[0] * np.array([1, -1]) * (
            feet[10] - view._cache[5])))
    assert not view.grab().toImage().isNull()


def test_the_qt_binding_keeps_none_alive_across_calls_without_a_result(qtbot):
    """PySide6 6.12.0 with Python 3.11 drops a reference to None at every call of a Qt method
    that returns nothing (10,000 calls of QWidget.setMinimumWidth crashed the process:
    "deallocating None"): any long session of the app would die. The pinned 6.11.3 loses none
    in 200,000 calls."""
    import sys

    from PySide6.QtWidgets import QWidget

    w = QWidget()
    qtbot.addWidget(w)
    with _no_collection():
        before = sys.getrefcount(None)
        for _ in range(200_000):
            w.setMinimumWidth(10)
        assert before - sys.getrefcount(None) < 100


def test_repainting_the_2d_view_does_not_wear_the_interpreter_down(frame_view):
    """A repaint makes few calls into Qt (a call a polyline or a colour, not a point): under
    PySide6 6.12.0, which dropped a reference to None at each call without a result, a call a
    point lost about 2,000 a repaint of a 500-point frame and a session died after a few
    dozen."""
    import sys

    w, view = frame_view
    view.grab()
    with _no_collection():
        before = sys.getrefcount(None)
        for _ in range(10):
            view.grab()
        assert before - sys.getrefcount(None) < 10 * 50


@contextlib.contextmanager
def _no_collection():
    """The garbage collector run first and held off: freeing other tests' garbage during the
    count would release references to None that no Qt call dropped."""
    import gc

    gc.collect()
    gc.disable()
    try:
        yield
    finally:
        gc.enable()


def test_a_bare_point_nominal_is_drawn_as_a_shaded_surface_in_the_3d_view():
    """The seat bracket's nominal is 200,000 bare points with normals: the 3D view draws the
    display mesh the certificate draws (reports.mapviews), not a grey cloud; its vertices lie
    near the nominal (99 % within half a voxel of its points, all within two: marching cubes
    rounds edges and corners) and cover it (every nominal point within a voxel of a vertex)."""
    from scipy.spatial import cKDTree

    from engine.pipeline import inspection_settings, run_files
    from engine.tolerance import Tolerance
    from qa_app.desktop.viewport import Viewport3D
    from reports.mapviews import MESH_CELLS

    bracket = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))),
                           "samples", "seat_bracket")
    run = run_files(os.path.join(bracket, "nominal.xyz"), os.path.join(bracket, "measured.csv"),
                    inspection_settings(Tolerance.symmetric(0.1)))
    assert run.nominal.triangles is None
    surf = Viewport3D.prepare(run)["surface"]
    assert surf is not None and surf.n_cells > 1000
    voxel = float(np.max(np.ptp(run.nominal.points, axis=0))) / MESH_CELLS
    gap = cKDTree(run.nominal.points).query(surf.points)[0]
    assert np.quantile(gap, 0.99) < 0.5 * voxel and gap.max() < 2 * voxel
    assert cKDTree(surf.points).query(run.nominal.points[::50])[0].max() < voxel
