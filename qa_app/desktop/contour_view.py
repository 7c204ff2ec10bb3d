"""The 2D view of a contour template: the nominal contour, its tolerance envelope (the contour
offset by the zone's lower and upper limits along its normals) and every point's deviation as a
whisker, both magnified by one stated factor, so that a whisker ending outside the envelope is a
point out of tolerance. The wheel zooms about the cursor, a drag pans, a double-click shows the
whole part again, a click selects the nearest point.
"""

from __future__ import annotations

import numpy as np
from PySide6.QtCore import QLineF, QPointF, QRectF, Qt
from PySide6.QtGui import QColor, QPainter, QPen, QPolygonF
from PySide6.QtWidgets import QWidget

from engine.contour import point_to_primitives
from reports import figures

from .model import Session

ZONE_SHARE = 0.04
"""The magnification draws the larger of the largest deviation and the zone's wider limit as
about this share of the part's extent (a 1-2-5 factor)."""
ZOOM_STEP = 1.25
"""One wheel notch zooms by this factor."""
DRAG_PX = 4
"""A press that moves less than this (px) before its release is a click, not a drag."""
PICK_PX = 12
"""A click selects the nearest whisker tip within this distance (px)."""


def envelope_polylines(template, offset: float, step_deg: float = 3.0) -> list[np.ndarray]:
    """The template's contours offset by ``offset`` (mm, signed as deviations are: + toward
    excess material) along their normals: the tolerance envelope's side at that limit.

    Returns one (k, 2) polyline for each contour: each primitive (a segment by its ends, an arc
    in steps of at most ``step_deg``) moved along its own unit normal toward the contour's
    positive side (engine.contour's sign convention), in drawing order; where two primitives
    meet at an angle, a straight piece joins their offsets.
    """
    t = template
    out = []
    for c in range(t.closed.size):
        pieces = []
        for i in np.flatnonzero(t.contour == c):
            pts = figures.primitive_points(t, i, step_deg, min_points=2)
            left = point_to_primitives(pts, t, np.full(len(pts), i))[2]
            pieces.append(pts + (offset * t.side[c]) * left)
        out.append(np.vstack(pieces))
    return out


class ContourView(QWidget):
    """A 2D template with its tolerance envelope and every point's deviation as a magnified
    whisker; wheel to zoom, drag to pan, double-click for the whole part, click a point to
    select it."""

    HINT = ("Whiskers and tolerance envelope × {factor:g} (outward = excess material) · "
            "wheel: zoom · drag: pan · double-click: whole part")

    def __init__(self, session: Session):
        super().__init__()
        self.session = session
        self.setMinimumSize(300, 160)
        self._cache = None
        self._view = None
        """(scale px/mm, x0 px, y0 px) after a zoom or pan; None: the whole part fits."""
        self._press = None  # (press position, view at the press) while the button is down
        self._dragged = False
        session.result_changed.connect(self._result)
        session.selection_changed.connect(lambda i: self.update())

    def _result(self, run) -> None:
        self._cache = self._view = None
        if run is not None and run.template is not None:
            res = run.result
            template = run.template.template
            polylines = figures.template_polylines(template)
            feet = res.deviations.foot[:, :2]
            allp = np.vstack(polylines + [feet])
            d = res.deviations.signed
            tol = res.tolerance
            extent = float(np.ptp(allp, axis=0).max())
            factor = figures.whisker_factor(extent, max(float(np.abs(d).max()),
                                                        abs(tol.lower), abs(tol.upper)),
                                            share=ZONE_SHARE)
            tips = feet + factor * d[:, None] * res.deviations.normal[:, :2]
            band = [envelope_polylines(template, factor * v) for v in (tol.lower, tol.upper)]
            self._cache = (polylines, feet, tips, figures.band_rgb(d, tol), factor,
                           allp.min(axis=0) - 0.1 * extent, allp.max(axis=0) + 0.1 * extent,
                           band)
        self.update()

    def fitted_view(self) -> tuple[float, float, float]:
        """(scale px/mm, x0, y0) that shows the whole part: x_px = x0 + scale (x - xmin),
        y_px = y0 - scale (y - ymin)."""
        lo, hi = self._cache[5], self._cache[6]
        k = min((self.width() - 20) / (hi[0] - lo[0]), (self.height() - 40) / (hi[1] - lo[1]))
        return (k, (self.width() - k * (hi[0] - lo[0])) / 2,
                (self.height() - 20 + k * (hi[1] - lo[1])) / 2)

    def _transform(self):
        """The map from template coordinates (..., 2) mm to widget pixels (x, y)."""
        lo = self._cache[5]
        k, ox, oy = self._view or self.fitted_view()

        def P(xy):
            return ox + k * (xy[..., 0] - lo[0]), oy - k * (xy[..., 1] - lo[1])

        return P

    def zoom(self, factor: float, at: QPointF) -> None:
        """Zoom by ``factor`` about the widget point ``at``: what lies under it stays."""
        k, ox, oy = self._view or self.fitted_view()
        self._view = (k * factor, at.x() - factor * (at.x() - ox),
                      at.y() - factor * (at.y() - oy))
        self.update()

    def pan(self, dx: float, dy: float) -> None:
        k, ox, oy = self._view or self.fitted_view()
        self._view = (k, ox + dx, oy + dy)
        self.update()

    def whole_part(self) -> None:
        self._view = None
        self.update()

    @staticmethod
    def _polygon(x: np.ndarray, y: np.ndarray) -> QPolygonF:
        """The points (x, y) px as one polygon: drawn by one call each, not a call a point
        (PySide6 6.12 loses a reference to None in each call of a method without a result:
        the fewer the calls, the longer a session runs)."""
        return QPolygonF([QPointF(a, b) for a, b in zip(x.tolist(), y.tolist())])

    def _paint_envelope(self, p: QPainter, P) -> None:
        """The zone between the offset contours, shaded, with both offsets drawn thin."""
        lower, upper = self._cache[7]
        for lo_pl, hi_pl in zip(lower, upper):
            (lx, ly), (hx, hy) = P(lo_pl), P(hi_pl)
            p.setPen(Qt.NoPen)
            p.setBrush(QColor(120, 190, 120, 60))
            # Winding fill: where a tight bend folds the band over itself, it stays shaded.
            p.drawPolygon(self._polygon(np.r_[hx, lx[::-1]], np.r_[hy, ly[::-1]]),
                          Qt.WindingFill)
            p.setPen(QPen(QColor(60, 140, 60), 0.8, Qt.DashLine))
            p.drawPolyline(self._polygon(lx, ly))
            p.drawPolyline(self._polygon(hx, hy))
        p.setBrush(Qt.NoBrush)

    def paintEvent(self, event):
        p = QPainter(self)
        p.fillRect(self.rect(), Qt.white)
        if self._cache is None:
            p.drawText(self.rect(), Qt.AlignCenter, "The 2D view shows contour templates (DXF)")
            p.end()
            return
        p.setRenderHint(QPainter.Antialiasing)
        polylines, feet, tips, rgb, factor = self._cache[:5]
        P = self._transform()
        self._paint_envelope(p, P)
        p.setPen(QPen(QColor("#3a3a44"), 1.3))
        for pl in polylines:
            p.drawPolyline(self._polygon(*P(pl)))
        fx, fy = P(feet)
        tx, ty = P(tips)
        colours, which = np.unique(rgb, axis=0, return_inverse=True)
        for k, c in enumerate(colours.tolist()):  # the whiskers, one call per colour
            i = np.flatnonzero(which.reshape(-1) == k)
            p.setPen(QPen(QColor(*c), 1.2))
            p.drawLines([QLineF(*v) for v in np.column_stack(
                [fx[i], fy[i], tx[i], ty[i]]).tolist()])
        sel = self.session.selected
        if sel is not None:
            p.setPen(QPen(QColor("#ff00ff"), 2.5))
            p.drawEllipse(QPointF(tx[sel], ty[sel]), 6, 6)
        p.fillRect(QRectF(0, self.height() - 20, self.width(), 20), QColor(255, 255, 255, 220))
        p.setPen(Qt.black)
        p.drawText(QRectF(6, self.height() - 18, self.width() - 12, 16), Qt.AlignLeft,
                   self.HINT.format(factor=factor))
        p.end()

    # ------------------------------------------------------------------ mouse
    def wheelEvent(self, event):
        if self._cache is None:
            return
        notches = event.angleDelta().y() / 120.0
        if notches:
            self.zoom(ZOOM_STEP ** notches, event.position())
        event.accept()

    def mousePressEvent(self, event):
        if self._cache is not None and event.button() == Qt.LeftButton:
            self._press = (event.position(), self._view or self.fitted_view())
            self._dragged = False

    def mouseMoveEvent(self, event):
        if self._press is None:
            return
        start, (k, ox, oy) = self._press
        dx, dy = event.position().x() - start.x(), event.position().y() - start.y()
        if self._dragged or max(abs(dx), abs(dy)) >= DRAG_PX:
            self._dragged = True
            self._view = (k, ox + dx, oy + dy)
            self.update()

    def mouseReleaseEvent(self, event):
        if self._press is None:
            return
        self._press = None
        if not self._dragged:
            self._pick(event.position())

    def mouseDoubleClickEvent(self, event):
        self.whole_part()

    def _pick(self, pos: QPointF) -> None:
        """Select the point whose whisker tip is nearest ``pos`` (within PICK_PX)."""
        tx, ty = self._transform()(self._cache[2])
        d2 = (tx - pos.x()) ** 2 + (ty - pos.y()) ** 2
        i = int(np.argmin(d2))
        if d2[i] <= PICK_PX ** 2:
            self.session.select(i)
