"""The main window's layout (issue 26): the 3D and 2D views with the colour bar beside them are
the central widget and take most of the window; at the left, the verdict above two tabbed docks,
the inspection's steps and its results (points, characteristics, histogram). The steps and the
results can each be hidden (View menu), moved to another side or floated, which gives the views
the whole width.

At 1366×768 the 3D view takes about 57% of the window, at 1920×1080 about 69%
(tests/test_app_layout.py measures it, at least 55%): no table, banner or tool bar row takes
height from it, and the 2D view's tab shows only for a contour template.
"""

from __future__ import annotations

from PySide6.QtCore import Qt
from PySide6.QtWidgets import (
    QDockWidget,
    QHBoxLayout,
    QMainWindow,
    QMenuBar,
    QTabWidget,
    QToolBar,
    QVBoxLayout,
    QWidget,
)

MOVABLE = (QDockWidget.DockWidgetMovable | QDockWidget.DockWidgetFloatable
           | QDockWidget.DockWidgetClosable)


class FitsItsText(QWidget):
    """Holds a widget whose height depends on its width (wrapped text, as the verdict
    banner's) where the layout around it does not ask (a dock): its minimum height follows the
    width it is given, so that no line is cut off."""

    def __init__(self, child: QWidget):
        super().__init__()
        lay = QVBoxLayout(self)
        lay.setContentsMargins(4, 4, 4, 0)
        lay.addWidget(child)

    def resizeEvent(self, event):
        super().resizeEvent(event)
        self.fit_height()

    def fit_height(self) -> None:
        h = self.layout().heightForWidth(self.width())
        if h > 0 and h != self.minimumHeight():
            self.setMinimumHeight(h)


def dock(window: QMainWindow, title: str, name: str, widget: QWidget,
         features=MOVABLE) -> QDockWidget:
    """A dock of ``window`` named ``name`` (its saved state's key) holding ``widget``."""
    d = QDockWidget(title, window)
    d.setObjectName(name)
    d.setFeatures(features)
    d.setWidget(widget)
    return d


def verdict_dock(window: QMainWindow, banner: QWidget) -> QDockWidget:
    """The verdict banner at the top of the left column, always in sight: no title bar, not
    movable nor closable."""
    d = dock(window, "Verdict", "verdictDock", FitsItsText(banner),
             QDockWidget.NoDockWidgetFeatures)
    d.setTitleBarWidget(QWidget())
    return d


def central_views(message_bar: QWidget, views: QTabWidget, legend: QWidget) -> QWidget:
    """The central widget: the message bar (shown only when a message needs attention) above
    the 3D and 2D views, with the colour bar beside them."""
    central = QWidget()
    cl = QVBoxLayout(central)
    cl.setContentsMargins(2, 4, 2, 0)
    cl.setSpacing(2)
    cl.addWidget(message_bar)
    shown = QHBoxLayout()
    shown.setSpacing(2)
    shown.addWidget(views, 1)
    # The colour bar beside the colours it explains, in the 3D and the 2D view alike.
    shown.addWidget(legend)
    cl.addLayout(shown, 1)
    return central


def tabs(*pages: tuple[QWidget, str], document_mode: bool = True) -> QTabWidget:
    t = QTabWidget()
    t.setDocumentMode(document_mode)
    for widget, title in pages:
        t.addTab(widget, title)
    return t


def arrange_left(window: QMainWindow, verdict: QDockWidget, steps: QDockWidget,
                 results: QDockWidget) -> None:
    """The verdict at the top of the left column, the steps and the results tabbed below it
    (tabs at the top), the steps in front."""
    window.setTabPosition(Qt.LeftDockWidgetArea, QTabWidget.North)
    window.addDockWidget(Qt.LeftDockWidgetArea, verdict)
    window.addDockWidget(Qt.LeftDockWidgetArea, steps)
    window.splitDockWidget(verdict, steps, Qt.Vertical)
    window.tabifyDockWidget(steps, results)
    steps.raise_()


def tool_bar_beside_menus(menu_bar: QMenuBar, title: str, actions) -> QToolBar:
    """The main tool bar with ``actions`` in the menu bar's row, at its right, rather than in
    a row of its own that would take height from the views."""
    tb = QToolBar(title)
    tb.setObjectName("mainToolBar")
    tb.setMovable(False)
    for a in actions:
        tb.addAction(a)
    menu_bar.setCornerWidget(tb, Qt.TopRightCorner)
    tb.show()
    return tb
