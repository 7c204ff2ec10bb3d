"""The characteristics table: a plan's alignment in words above its characteristics, as a
first-article report lists them, each with its drawing symbol.
"""

from __future__ import annotations

from PySide6.QtCore import QAbstractTableModel, QModelIndex, QPointF, Qt
from PySide6.QtGui import QColor, QPainter, QPen, QPixmap
from PySide6.QtWidgets import (
    QAbstractItemView,
    QHeaderView,
    QLabel,
    QTableView,
    QVBoxLayout,
    QWidget,
)

from reports.messages import VERDICT_RGB, VERDICT_WORD, alignment_text
from reports.symbols import BOX, symbol_strokes

from ..model import Session, characteristic_rows
from .colours import qcolor


class CharacteristicTableModel(QAbstractTableModel):
    """The plan's characteristics as a first-article report lists them (model.characteristic_rows),
    the verdict coloured; a row's tooltip says why."""

    COLUMNS = ("ID", "Type", "Region", "Datums", "Requirement", "Value", "Points", "Verdict")
    FIELDS = ("id", "type", "region", "datums", "requirement", "value", "points", "verdict")

    def __init__(self, session: Session):
        super().__init__()
        self.rows = []
        session.result_changed.connect(self._reset)

    def _reset(self, run) -> None:
        self.beginResetModel()
        self.rows = characteristic_rows(run)
        self.endResetModel()

    def rowCount(self, parent=QModelIndex()):
        return 0 if parent.isValid() else len(self.rows)

    def columnCount(self, parent=QModelIndex()):
        return 0 if parent.isValid() else len(self.COLUMNS)

    def headerData(self, section, orientation, role=Qt.DisplayRole):
        if orientation == Qt.Horizontal and role == Qt.DisplayRole:
            return self.COLUMNS[section]
        return None

    def data(self, index, role=Qt.DisplayRole):
        if not index.isValid():
            return None
        r = self.rows[index.row()]
        c = index.column()
        if role == Qt.DisplayRole:
            value = getattr(r, self.FIELDS[c])
            return VERDICT_WORD[value] if c == 7 else str(value)
        if role == Qt.ToolTipRole:
            return f"{r.symbol} {r.type}: {r.verdict}: {r.reason}"
        if role == Qt.DecorationRole and c == 1:
            return symbol_icon(r.type, feature=r.feature)
        if role == Qt.TextAlignmentRole and c in (5, 6):
            return int(Qt.AlignRight | Qt.AlignVCenter)
        if c == 7 and role == Qt.BackgroundRole:
            return qcolor(VERDICT_RGB[r.verdict])
        if c == 7 and role == Qt.ForegroundRole:
            return QColor("white")
        return None


def symbol_icon(kind: str, size: int = 16, feature: str | None = None) -> QPixmap:
    """The drawing's symbol of a characteristic (ASME Y14.5 / ISO 1101; reports.symbols, the
    certificate's strokes), drawn: fonts lack most of them (⌖). A size's ``feature``: a
    cylinder's ⌀ (None), a sphere's S⌀, a width's none."""
    pm = QPixmap(size, size)
    pm.fill(Qt.transparent)
    p = QPainter(pm)
    p.setRenderHint(QPainter.Antialiasing)
    ink = QColor("#222")
    p.setPen(QPen(ink, 1.3))
    m, k = 2.0, (size - 4.0) / BOX

    def at(x: float, y: float) -> QPointF:  # the symbol's box is y up, the pixmap's y down
        return QPointF(m + k * x, m + k * (BOX - y))

    for stroke in symbol_strokes(kind, feature):
        if stroke[0] in ("line", "fill"):
            xy = stroke[1]
            pts = [at(xy[i], xy[i + 1]) for i in range(0, len(xy), 2)]
            if stroke[0] == "fill":
                p.setBrush(ink)
                p.drawPolygon(pts)
                p.setBrush(Qt.NoBrush)
            elif stroke[2]:
                p.drawPolygon(pts)
            else:
                p.drawPolyline(pts)
        elif stroke[0] == "circle":
            p.drawEllipse(at(stroke[1], stroke[2]), k * stroke[3], k * stroke[3])
        else:
            font = p.font()
            font.setPixelSize(max(1, int(round(k * stroke[4]))))
            p.setFont(font)
            p.drawText(at(stroke[1], stroke[2]), stroke[3])
    p.end()
    return pm


class CharacteristicTable(QWidget):
    """The plan's alignment in words above its characteristics; selecting a characteristic
    selects its points in the views (the session's ``highlighted``)."""

    def __init__(self, session: Session):
        super().__init__()
        self.session = session
        self.alignment = QLabel()
        self.alignment.setWordWrap(True)
        self.view = QTableView()
        self.model_ = CharacteristicTableModel(session)
        self.view.setModel(self.model_)
        self.view.setSelectionBehavior(QAbstractItemView.SelectRows)
        self.view.setSelectionMode(QAbstractItemView.SingleSelection)
        self.view.verticalHeader().setVisible(False)
        # Rows as tall as their text: a plan's five characteristics fit a 1366×768 screen.
        self.view.verticalHeader().setSectionResizeMode(QHeaderView.ResizeToContents)
        lay = QVBoxLayout(self)
        lay.setContentsMargins(0, 0, 0, 0)
        lay.addWidget(self.alignment)
        lay.addWidget(self.view, 1)
        self.view.selectionModel().currentRowChanged.connect(
            lambda current, previous: session.select_characteristic(
                current.row() if current.isValid() else None))
        session.characteristic_changed.connect(self._select)
        session.result_changed.connect(self._result)
        self._result(session.run)

    def _result(self, run) -> None:
        planned = None if run is None else getattr(run.result, "plan", None)
        text = None if planned is None else alignment_text(planned)
        self.alignment.setText(f"Alignment: {text}" if text else
                               "Alignment: best fit (the registration's pose)" if planned
                               else "Open an inspection plan (Plan…) to judge its "
                                    "characteristics")
        self.view.resizeColumnsToContents()

    def _select(self, row) -> None:
        if row is None:
            self.view.selectionModel().clearCurrentIndex()
            self.view.clearSelection()
        elif self.view.currentIndex().row() != row:
            self.view.selectRow(row)
