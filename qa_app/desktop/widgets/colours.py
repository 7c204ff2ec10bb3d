"""The Qt colour of an RGB triple in 0..1 (reports.figures' and reports.messages' colours), shared
by the widgets.
"""

from __future__ import annotations

from PySide6.QtGui import QColor


def qcolor(rgb) -> QColor:
    return QColor.fromRgbF(float(rgb[0]), float(rgb[1]), float(rgb[2]))
