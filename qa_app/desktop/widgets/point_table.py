"""The point table: every measured point, the worst on top, in step with the views' selection."""

from __future__ import annotations

import numpy as np
from PySide6.QtCore import (
    QAbstractTableModel,
    QItemSelection,
    QItemSelectionModel,
    QModelIndex,
    Qt,
    Signal,
)
from PySide6.QtGui import QColor
from PySide6.QtWidgets import QAbstractItemView, QHeaderView, QTableView

from reports import figures

from ..model import Session


class PointTableModel(QAbstractTableModel):
    """Every measured point; sorting is done with numpy (200,000 rows sort at once)."""

    COLUMNS = ("#", "Label", "X (mm)", "Y (mm)", "Z (mm)", "Deviation (mm)", "Result",
               "Excluded")
    EXCLUDED = "excluded (gross outlier)"
    EXCLUDED_TIP = ("Excluded from the alignment as a gross outlier (a mis-probed point): its "
                    "deviation lies several zone widths and several robust standard deviations "
                    "from the median deviation, and its nearest measured neighbours do not "
                    "deviate alike. A dent or bump is never excluded. An excluded point is "
                    "judged like every other point; an empty cell: the point was fitted.")

    DEVIATION_TIP = ("Signed deviation, mm (+ excess material, − material missing). Sorted by "
                     "its size |deviation|: descending puts the worst point on top.")

    def __init__(self, session: Session):
        super().__init__()
        self.session = session
        self.run = None
        self.order = np.zeros(0, dtype=np.int64)
        session.result_changed.connect(self._reset)

    def _reset(self, run) -> None:
        self.beginResetModel()
        self.run = run
        self.order = np.arange(0 if run is None else run.result.deviations.signed.size)
        self.endResetModel()

    def rowCount(self, parent=QModelIndex()):
        return 0 if parent.isValid() else int(self.order.size)

    def columnCount(self, parent=QModelIndex()):
        return 0 if parent.isValid() else len(self.COLUMNS)

    def headerData(self, section, orientation, role=Qt.DisplayRole):
        if orientation == Qt.Horizontal:
            if role == Qt.DisplayRole:
                return self.COLUMNS[section]
            if role == Qt.ToolTipRole and section == 7:
                return self.EXCLUDED_TIP
            if role == Qt.ToolTipRole and section == 5:
                return self.DEVIATION_TIP
        return None

    def point(self, row: int) -> int:
        return int(self.order[row])

    def row_of(self, index: int) -> int:
        return int(np.flatnonzero(self.order == index)[0])

    def data(self, index, role=Qt.DisplayRole):
        if not index.isValid():
            return None
        i = int(self.order[index.row()])
        res = self.run.result
        c = index.column()
        if role == Qt.DisplayRole:
            if c == 0:
                return str(i + 1)
            if c == 1:
                labels = self.run.measured.labels
                return "" if labels is None else str(labels[i])
            if 2 <= c <= 4:
                return f"{res.registered[i, c - 2]:.3f}"
            if c == 5:
                return f"{res.deviations.signed[i]:+.4f}"
            if c == 6:
                return "PASS" if res.in_tolerance[i] else "FAIL"
            if c == 7:
                return self.EXCLUDED if res.outlier[i] else ""
        if role == Qt.TextAlignmentRole and 2 <= c <= 5:
            return int(Qt.AlignRight | Qt.AlignVCenter)
        if role == Qt.ForegroundRole and c == 6 and not res.in_tolerance[i]:
            return QColor("#b81c1c")
        if role == Qt.DecorationRole and c == 5:
            return QColor(*(int(v) for v in figures.band_rgb(
                res.deviations.signed[i:i + 1], res.tolerance)[0]))
        return None

    def sort(self, column, order=Qt.AscendingOrder):
        """Sort the rows by ``column``; the deviation column sorts by its size |deviation|
        (descending: the worst point on top, in 3D and 2D alike). Equal keys keep the points'
        order."""
        if self.run is None:
            return
        res = self.run.result
        n = res.deviations.signed.size
        keys = {0: np.arange(n), 2: res.registered[:, 0], 3: res.registered[:, 1],
                4: res.registered[:, 2], 5: np.abs(res.deviations.signed),
                6: res.in_tolerance.astype(int), 7: res.outlier.astype(int)}
        if column == 1:
            labels = self.run.measured.labels
            key = np.arange(n) if labels is None else np.asarray(labels, dtype=str)
        else:
            key = keys.get(column, np.arange(n))
        self.layoutAboutToBeChanged.emit()
        if order != Qt.DescendingOrder:
            self.order = np.argsort(key, kind="stable")
        elif key.dtype.kind in "iuf":
            self.order = np.argsort(-key, kind="stable")
        else:
            self.order = np.argsort(key, kind="stable")[::-1]
        self.layoutChanged.emit()


class PointTable(QTableView):
    """The point table, the worst point on top; selecting a row selects the point in the views,
    and back; double-clicking a row asks the 3D view to zoom to it (``point_activated``)."""

    point_activated = Signal(int)
    """The point (index) of a row double-clicked."""

    def __init__(self, session: Session):
        super().__init__()
        self.session = session
        self.model_ = PointTableModel(session)
        self.setModel(self.model_)
        self.setSortingEnabled(True)
        self.setSelectionBehavior(QAbstractItemView.SelectRows)
        self.setSelectionMode(QAbstractItemView.SingleSelection)
        self.setAlternatingRowColors(True)
        self.verticalHeader().setVisible(False)
        # Rows as tall as a line of text: a short screen shows a dozen points or more.
        rows = self.verticalHeader()
        rows.setMinimumSectionSize(self.fontMetrics().height() + 4)
        rows.setDefaultSectionSize(self.fontMetrics().height() + 6)
        self.horizontalHeader().setSectionResizeMode(QHeaderView.Interactive)
        self.horizontalHeader().setStretchLastSection(True)
        # Shown in a dock beside the views: the deviation and the result next to the label,
        # the coordinates after them (the model's columns keep their order).
        self.horizontalHeader().moveSection(5, 2)
        self.horizontalHeader().moveSection(6, 3)
        self.selectionModel().currentRowChanged.connect(self._row_changed)
        self.doubleClicked.connect(lambda index: self.point_activated.emit(
            self.model_.point(index.row())))
        session.selection_changed.connect(self._select)
        session.result_changed.connect(self._result)
        session.characteristic_changed.connect(lambda row: self.select_points(
            session.highlighted))
        # Sorting moves the rows: the characteristic's points are selected again where they are.
        self.model_.layoutChanged.connect(lambda *_: self.session.highlighted is not None
                                          and self.select_points(self.session.highlighted))

    def _result(self, run) -> None:
        """A new result: the worst point on top, every header readable in full."""
        if run is None:
            return
        self.sortByColumn(5, Qt.DescendingOrder)
        self.fit_columns()

    def fit_columns(self) -> None:
        """Each column as wide as its header (with the sort arrow) and its widest value."""
        header = self.horizontalHeader()
        fm = header.fontMetrics()
        samples = {0: "0000000", 1: "P00000", 2: "-0000.000", 3: "-0000.000", 4: "-0000.000",
                   5: "■ -00.0000", 6: "FAIL"}
        for c, title in enumerate(self.model_.COLUMNS[:-1]):
            need = max(fm.horizontalAdvance(title) + 3 * fm.height(),
                       self.fontMetrics().horizontalAdvance(samples.get(c, "")) + 16,
                       self.sizeHintForColumn(c))
            header.resizeSection(c, need)

    def select_points(self, indices) -> None:
        """Select the rows of the points ``indices`` ((k,) int; None: none), as contiguous
        ranges (a characteristic over all points selects every row at once)."""
        sm = self.selectionModel()
        if indices is None or not len(indices):
            sm.clearSelection()
            return
        order = self.model_.order
        rows = np.empty_like(order)
        rows[order] = np.arange(order.size)
        rows = np.sort(rows[np.asarray(indices)])
        breaks = np.flatnonzero(np.diff(rows) != 1)
        starts = np.r_[rows[0], rows[breaks + 1]]
        ends = np.r_[rows[breaks], rows[-1]]
        last = self.model_.columnCount() - 1
        selection = QItemSelection()
        for a, b in zip(starts, ends):
            selection.select(self.model_.index(int(a), 0), self.model_.index(int(b), last))
        sm.select(selection, QItemSelectionModel.ClearAndSelect | QItemSelectionModel.Rows)
        self.scrollTo(self.model_.index(int(rows[0]), 0))

    def selected_points(self) -> list[int]:
        """The points of the selected rows, in row order."""
        return [self.model_.point(i.row()) for i in self.selectionModel().selectedRows()]

    def _row_changed(self, current, previous):
        if current.isValid():
            self.session.select(self.model_.point(current.row()))

    def _select(self, index):
        if index is None:
            return
        row = self.model_.row_of(index)
        if self.currentIndex().row() != row:
            self.selectRow(row)
        self.scrollTo(self.model_.index(row, 0))
