"""The window's 2D widgets, one module each (napari's ``qt_*`` style): message bar, verdict
banner, colour bar, histogram, point table, characteristics table, tolerance form (the 2D
contour view is contour_view.py's). Each takes the session and subscribes to its events; colours
and bands come from reports.figures, so the window and the certificate show the same scale.
"""

from .banner import VerdictBanner, plan_line, pose_trust
from .characteristic_table import CharacteristicTable, CharacteristicTableModel, symbol_icon
from .colour_bar import Legend
from .colours import qcolor
from .histogram import Histogram
from .message_bar import MessageBar
from .point_table import PointTable, PointTableModel
from .tolerance_form import DXF_UNITS, ToleranceForm

__all__ = ["DXF_UNITS", "CharacteristicTable", "CharacteristicTableModel", "Histogram", "Legend",
           "MessageBar", "PointTable", "PointTableModel", "ToleranceForm", "VerdictBanner",
           "plan_line", "pose_trust", "qcolor", "symbol_icon"]
