"""The histogram of the deviations, bars coloured by band, the tolerance limits dashed."""

from __future__ import annotations

import math

import numpy as np
from PySide6.QtCore import QPointF, QRectF, Qt
from PySide6.QtGui import QColor, QPainter, QPen
from PySide6.QtWidgets import QWidget

from reports import figures

from ..model import Session
from .colours import qcolor


class Histogram(QWidget):
    """Histogram of the deviations, bars coloured by band, tolerance limits dashed."""

    def __init__(self, session: Session):
        super().__init__()
        self.session = session
        self.setMinimumHeight(110)
        session.result_changed.connect(lambda run: self.update())

    def paintEvent(self, event):
        run = self.session.run
        p = QPainter(self)
        p.fillRect(self.rect(), Qt.white)
        if run is None:
            p.end()
            return
        d = run.result.deviations.signed
        tol = run.result.tolerance
        s = (tol.upper - tol.lower) / 4
        x0, x1 = min(float(d.min()), tol.lower - s), max(float(d.max()), tol.upper + s)
        counts, edges = np.histogram(d, bins=48, range=(x0, x1))
        ml, mb, mt = 40, 22, 18
        pw, ph = self.width() - ml - 10, self.height() - mb - mt
        top = max(int(counts.max()), 1)

        def X(v):
            return ml + (v - x0) / (x1 - x0) * pw

        table = figures.bands(tol)
        band_of = figures.band_index(0.5 * (edges[:-1] + edges[1:]), tol)
        for k in range(len(counts)):
            if counts[k]:
                bh = max(counts[k] / top * ph, 2.0)
                p.fillRect(QRectF(X(edges[k]), mt + ph - bh, X(edges[k + 1]) - X(edges[k]) - 1,
                                  bh), qcolor(table[band_of[k]].rgb))
        p.setPen(QPen(QColor("#777"), 1))
        p.drawLine(QPointF(ml, mt + ph), QPointF(ml + pw, mt + ph))
        p.drawText(QRectF(0, mt - 6, ml - 4, 14), Qt.AlignRight, str(top))
        p.drawText(QRectF(0, mt + ph - 8, ml - 4, 14), Qt.AlignRight, "0")
        step = figures.nice_step(x1 - x0, 6)
        v = math.ceil(x0 / step) * step
        while v <= x1 + 1e-12:
            p.drawText(QRectF(X(v) - 30, mt + ph + 3, 60, 14), Qt.AlignHCenter,
                       f"{v:+.3g}" if abs(v) > 1e-12 else "0")
            v += step
        pen = QPen(Qt.black, 1.2, Qt.DashLine)
        p.setPen(pen)
        for val, name in ((tol.lower, "LTL"), (tol.upper, "UTL")):
            p.drawLine(QPointF(X(val), mt), QPointF(X(val), mt + ph))
            p.drawText(QRectF(X(val) - 50, 0, 100, 14), Qt.AlignHCenter, f"{name} {val:+.3f}")
        p.end()
