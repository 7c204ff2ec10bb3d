"""The colour bar beside the views: the tolerance-banded scale of reports.figures (the
certificate's), or the plan regions' legend.
"""

from __future__ import annotations

import math

import numpy as np
from PySide6.QtCore import QEvent, QPointF, QRectF, Qt
from PySide6.QtGui import QPainter, QPen
from PySide6.QtWidgets import QToolTip, QWidget

from reports import figures

from ..model import Session
from .colours import qcolor


class Legend(QWidget):
    """The colour bar beside the views: the bands of reports.figures.bands(tol), most negative
    at the bottom, each as tall as the others, the zone's limits drawn across it and labelled
    in bold, band edges labelled where there is room; a band's tooltip gives its range and its
    number of points. While the points show their plan regions, the regions' legend instead."""

    BAR = 16
    """The bar's width, px."""

    def __init__(self, session: Session):
        super().__init__()
        self.session = session
        self.regions = None
        """The regions' legend (reports.figures.region_colours) while the view shows regions,
        else None: the deviation scale."""
        self.setMinimumWidth(104)
        self.setMinimumHeight(120)
        self.setMouseTracking(True)
        session.result_changed.connect(lambda run: self.update())

    def show_regions(self, legend) -> None:
        self.regions = legend
        self.update()

    def _paint_regions(self) -> None:
        p = QPainter(self)
        p.drawText(4, 14, "Plan region")
        h = min(26.0, (self.height() - 26) / max(len(self.regions), 1))
        for k, (name, rgb, count) in enumerate(self.regions):
            y = 22 + k * h
            p.fillRect(QRectF(4, y + 2, 18, h - 4), qcolor(rgb))
            p.drawText(QRectF(28, y, self.width() - 60, h), Qt.AlignVCenter,
                       p.fontMetrics().elidedText(name, Qt.ElideRight, self.width() - 60))
            p.drawText(QRectF(self.width() - 34, y, 32, h), Qt.AlignVCenter | Qt.AlignRight,
                       str(count))
        p.end()

    def band_boxes(self) -> list[tuple[QRectF, "figures.Band"]]:
        """Each band of the scale with its box in the widget, bottom to top (the most negative
        deviation at the bottom); empty without a result."""
        run = self.session.run
        if run is None:
            return []
        table = figures.bands(run.result.tolerance)
        top, bottom = 24.0, self.height() - 10.0
        h = (bottom - top) / len(table)
        return [(QRectF(6, bottom - (k + 1) * h, self.BAR, h), b) for k, b in enumerate(table)]

    def paintEvent(self, event):
        if self.session.run is None:
            return
        if self.regions is not None:
            self._paint_regions()
            return
        boxes = self.band_boxes()
        p = QPainter(self)
        p.drawText(QRectF(0, 0, self.width(), 18), Qt.AlignHCenter | Qt.AlignVCenter,
                   "Deviation, mm")
        for box, b in boxes:
            p.fillRect(box, qcolor(b.rgb))
        fm = p.fontMetrics()
        h = boxes[0][0].height()
        every = max(1, math.ceil(1.15 * fm.height() / h))  # label every n-th edge
        x = 6 + self.BAR
        bold = p.font()
        bold.setBold(True)
        plain = p.font()
        for k in range(1, len(boxes)):
            box, b = boxes[k]
            y = box.bottom()
            limit = b.in_tolerance != boxes[k - 1][1].in_tolerance
            if limit:
                p.setPen(QPen(Qt.black, 2))
                p.drawLine(QPointF(2, y), QPointF(x + 4, y))
            if limit or k % every == 0 and all(
                    abs(k - j) >= every for j in self._limit_edges(boxes)):
                p.setPen(Qt.black)
                p.setFont(bold if limit else plain)
                p.drawText(QRectF(x + 6, y - fm.height() / 2, self.width() - x - 6,
                                  fm.height()), Qt.AlignVCenter, f"{b.lower:+.3f}")
        p.end()

    @staticmethod
    def _limit_edges(boxes) -> list[int]:
        """The edges (index of the band above) where the zone's limits lie."""
        return [k for k in range(1, len(boxes))
                if boxes[k][1].in_tolerance != boxes[k - 1][1].in_tolerance]

    def event(self, e):
        if e.type() == QEvent.ToolTip and self.regions is None and self.session.run is not None:
            res = self.session.run.result
            table = figures.bands(res.tolerance)
            counts = np.bincount(figures.band_index(res.deviations.signed, res.tolerance),
                                 minlength=len(table))
            for k, (box, b) in enumerate(self.band_boxes()):
                if box.top() <= e.pos().y() < box.bottom():
                    QToolTip.showText(e.globalPos(),
                                      f"{figures.band_label(b)} mm: {int(counts[k])} points"
                                      + ("" if b.in_tolerance else " (out of tolerance)"), self)
                    return True
            QToolTip.hideText()
            return True
        return super().event(e)
