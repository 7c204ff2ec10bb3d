"""The window's 2D widgets: message bar, verdict banner, colour bar, histogram, point table,
characteristics table, tolerance form (the 2D contour view is contour_view.py's). Each takes the
session and subscribes to its events; colours and bands come from reports.figures, so the window
and the certificate show the same scale.
"""

from __future__ import annotations

import math
import os

import numpy as np
from PySide6.QtCore import (
    QAbstractTableModel,
    QEvent,
    QItemSelection,
    QItemSelectionModel,
    QModelIndex,
    QPointF,
    QRectF,
    Qt,
    Signal,
)
from PySide6.QtGui import QColor, QPainter, QPainterPath, QPen, QPixmap
from PySide6.QtWidgets import (
    QAbstractItemView,
    QCheckBox,
    QComboBox,
    QDoubleSpinBox,
    QFormLayout,
    QFrame,
    QHBoxLayout,
    QHeaderView,
    QInputDialog,
    QLabel,
    QLineEdit,
    QPushButton,
    QRadioButton,
    QTableView,
    QToolButton,
    QToolTip,
    QVBoxLayout,
    QWidget,
)

from engine.io import formats
from reports import figures
from reports.messages import VERDICT_RGB, VERDICT_WORD, alignment_text

from .model import AUTO_RULE, Session, characteristic_rows


DXF_UNITS = ("mm", "cm", "m", "in")
"""The units a DXF drawing may be read in (qa-inspect --units)."""


def qcolor(rgb) -> QColor:
    return QColor.fromRgbF(float(rgb[0]), float(rgb[1]), float(rgb[2]))


class MessageBar(QFrame):
    """The one place where errors, warnings and notes appear (the same text the command line
    prints)."""

    STYLE = {"error": ("#fde8e8", "#8a1111", "Error"), "warning": ("#fff4dc", "#7a4b00",
                                                                 "Warning"),
             "info": ("#eef3fa", "#1a3a5c", "")}

    def __init__(self, session: Session):
        super().__init__()
        self.setObjectName("messageBar")
        self.label = QLabel()
        self.label.setWordWrap(True)
        self.label.setTextInteractionFlags(Qt.TextSelectableByMouse)
        close = QToolButton(text="✕")
        close.setAutoRaise(True)
        close.clicked.connect(self.hide)
        lay = QHBoxLayout(self)
        lay.setContentsMargins(10, 6, 6, 6)
        lay.addWidget(self.label, 1)
        lay.addWidget(close)
        self.level = None
        self.hide()
        session.message.connect(self.show_message)

    def show_message(self, level: str, text: str) -> None:
        if level == "info":  # notes go to the status bar; this bar is for what needs attention
            return
        bg, fg, title = self.STYLE.get(level, self.STYLE["info"])
        self.level = level
        self.setStyleSheet(f"#messageBar {{ background: {bg}; border: 1px solid {fg}; "
                           f"border-radius: 4px; }} QLabel {{ color: {fg}; }}")
        self.label.setText(f"<b>{title}:</b> {text}" if title else text)
        self.label.setToolTip(text)
        self.text = text
        self.show()


class VerdictBanner(QFrame):
    """The verdict in large type with its reason and the statistics; when the result is stale,
    "OUT OF DATE" with what changed, and the old verdict greyed."""

    def __init__(self, session: Session):
        super().__init__()
        self.setObjectName("verdictBanner")
        self.session = session
        self.word = QLabel()
        self.word.setObjectName("verdictWord")
        self.detail = QLabel()
        self.detail.setWordWrap(True)
        self.setMinimumHeight(92)
        lay = QHBoxLayout(self)
        lay.setContentsMargins(14, 8, 14, 8)
        lay.addWidget(self.word)
        lay.addWidget(self.detail, 1)
        session.result_changed.connect(self.update_from)
        session.step_changed.connect(lambda step: self.update_from(session.run, step))
        self.update_from(None)

    def update_from(self, run, step=None) -> None:
        """verdict : the verdict shown (None when none is: no result, or a stale one);
        stale : the result shown is out of date."""
        self.stale = False
        self.trust_note = ""
        self.detail.setToolTip("")
        self.setToolTip("")
        if run is None:
            text = step.value if step is not None else "Open the nominal and the measured points"
            self.setStyleSheet("#verdictBanner { background: #e9edf2; border-radius: 4px; }")
            self.word.setText(f"<span style='font-size:15pt; color:#445'>{text}</span>")
            self.detail.setText("")
            self.verdict = None
            return
        res = run.result
        st = res.statistics
        tol = res.tolerance
        cond = res.conditioning
        trust, statements = pose_trust(res)
        stable = res.pose_sensitivity is None or res.pose_sensitivity.verdict_stable
        pose = ("pose ±" + f"{cond.pose_sigma_mm:.4f} mm" if cond is not None and
                cond.pose_sigma_mm is not None else
                "" if trust else "pose not fully constrained")
        n_excluded = int(res.outlier.sum())
        excluded = (f" · {n_excluded} excluded from alignment (gross outlier"
                    f"{'s' if n_excluded > 1 else ''})" if n_excluded else "")
        planned = getattr(res, "plan", None)
        facts = (
            plan_line(planned, run) +
            f"{st.count} points · {st.n_out} out of tolerance · zone {tol.lower:+.3f} … "
            f"{tol.upper:+.3f} mm"
            + (" (the plan's widest profile: statistics only)" if planned is not None
               and not planned.zone_in_verdict else "")
            + f"{excluded}<br>min {st.min:+.4f} · "
            f"max {st.max:+.4f} · mean {st.mean:+.4f} · std {st.std:.4f} · rms {st.rms:.4f} · "
            f"max |d| {st.max_abs:.4f} mm<br>fit {res.fit} · decision rule {res.decision_rule} · "
            f"registration rms {res.registration.rms:.4f} mm"
            + "".join(f" · {t}" for t in (pose, trust if stable else f"<b>{trust}</b>") if t))
        # The plain-word trust statements are the details behind the note (the certificate
        # states them in full); the banner keeps the verdict's own reasons.
        reasons_shown = [r for r in res.reasons if r not in statements]
        self.trust_note = trust
        details = "\n".join(s[:1].upper() + s[1:] + "." for s in statements)
        self.detail.setToolTip(details)
        self.setToolTip(details)  # anywhere on the banner
        reasons = self.session.stale_reasons if run is self.session.run else []
        if reasons:
            # No verdict is stated for a result that no longer matches the files and settings:
            # the old one stays readable, greyed, below what changed.
            self.stale = True
            self.verdict = None
            self.setStyleSheet("#verdictBanner { background: #d5d8dc; border: 2px solid #7a4b00;"
                               " border-radius: 4px; } QLabel { color: #3a3a44; }")
            self.word.setText(
                "<span style='font-size:22pt; font-weight:bold; color:#7a4b00'>OUT OF DATE"
                f"</span><br><span style='color:#8a8f96'>was "
                f"<s>{VERDICT_WORD[res.verdict]}</s></span>")
            self.detail.setText(
                f"<b>Changed since this inspection: {'; '.join(reasons)}. Press Inspect (F5) "
                f"for a result; export is disabled until then.</b><br>"
                f"<span style='color:#8a8f96'>{facts}</span>")
            return
        self.verdict = res.verdict
        colour = qcolor(VERDICT_RGB[res.verdict]).name()
        self.setStyleSheet(f"#verdictBanner {{ background: {colour}; "
                           "border-radius: 4px; } QLabel { color: white; }")
        self.word.setText(f"<span style='font-size:22pt; font-weight:bold'>"
                          f"{VERDICT_WORD[res.verdict]}</span>")
        self.detail.setText(f"{'; '.join(reasons_shown)}<br>{facts}")


def plan_line(planned, run) -> str:
    """The banner's line on ``run``'s plan (with its line break), or "" without a plan."""
    if planned is None:
        return ""
    path = run.settings.plan
    n = len(planned.characteristics)
    counts = [sum(r.verdict == v for r in planned.characteristics)
              for v in ("REJECT", "INCONCLUSIVE")]
    return (f"plan {os.path.basename(path or '')}: {n} characteristic{'s' if n != 1 else ''}"
            f" · {counts[0]} out of tolerance"
            + (f" · {counts[1]} undecided" if counts[1] else "")
            + f" · alignment {planned.method}"
            + ("" if planned.alignment is None else
               " " + "|".join(d.label for d in planned.alignment.datums)) + "<br>")


def pose_trust(res) -> tuple[str, tuple[str, ...]]:
    """(note, statements): how far the verdict depends on the pose, compactly, for the banner,
    and engine.trust's plain-word statements behind it.

    A verdict that differs at some pose the measurement allows (weak or free directions, a
    nearly-as-good runner-up: ``res.pose_sensitivity``) "depends on the pose"; one that holds
    at all of them while the pose is not fully fixed gets a short note; a runner-up or a free
    direction alone is a fact, never a reason to call a standing verdict ambiguous.
    """
    sens = res.pose_sensitivity
    statements = tuple(res.trust_statements)
    if sens is None:  # the pose cannot be trusted at all: the reasons say why
        return "", statements
    if not sens.verdict_stable:
        return "verdict depends on the pose", statements
    if statements or res.ambiguous:  # (an exact symmetry of the part is no statement)
        return "pose not fully fixed — verdict holds, see details", statements
    return "", statements


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
            return symbol_icon(r.type)
        if role == Qt.TextAlignmentRole and c in (5, 6):
            return int(Qt.AlignRight | Qt.AlignVCenter)
        if c == 7 and role == Qt.BackgroundRole:
            return qcolor(VERDICT_RGB[r.verdict])
        if c == 7 and role == Qt.ForegroundRole:
            return QColor("white")
        return None


def symbol_icon(kind: str, size: int = 16) -> QPixmap:
    """The drawing's symbol of a characteristic (ASME Y14.5 / ISO 1101), drawn: fonts lack some
    of them (⌖). profile: a closed half circle; flatness: a parallelogram; position: a circle
    with a cross; size: a circle with a slash (⌀)."""
    pm = QPixmap(size, size)
    pm.fill(Qt.transparent)
    p = QPainter(pm)
    p.setRenderHint(QPainter.Antialiasing)
    p.setPen(QPen(QColor("#222"), 1.3))
    m, w = 2.0, size - 4.0
    if kind == "profile":
        path = QPainterPath(QPointF(m, m + 0.75 * w))
        path.arcTo(QRectF(m, m + 0.25 * w, w, w), 180, -180)
        path.closeSubpath()
        p.drawPath(path)
    elif kind == "flatness":
        p.drawPolygon([QPointF(m + 0.3 * w, m + 0.25 * w), QPointF(m + w, m + 0.25 * w),
                       QPointF(m + 0.7 * w, m + 0.75 * w), QPointF(m, m + 0.75 * w)])
    elif kind in ("position", "size"):
        r = 0.3 * w if kind == "position" else 0.4 * w
        c = QPointF(m + 0.5 * w, m + 0.5 * w)
        p.drawEllipse(c, r, r)
        if kind == "position":
            p.drawLine(QPointF(m, c.y()), QPointF(m + w, c.y()))
            p.drawLine(QPointF(c.x(), m), QPointF(c.x(), m + w))
        else:
            p.drawLine(QPointF(m + 0.15 * w, m + 0.85 * w), QPointF(m + 0.85 * w, m + 0.15 * w))
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


class ToleranceForm(QWidget):
    """Symmetric or asymmetric zone (or, with a plan, the plan's), per-part presets, and the
    Inspect / Cancel buttons.

    Every edit goes to the session's settings at once, so a result computed with other settings
    is marked out of date the moment they change (not only when Inspect is pressed)."""

    inspect_clicked = Signal()
    cancel_clicked = Signal()
    preset_saved = Signal(str, float, float)

    def __init__(self, session: Session, presets: dict[str, tuple[float, float]]):
        super().__init__()
        self.session = session
        self.presets = presets
        self._loading = self._pushing = False
        self._make_fields()
        self._make_scene_fields()
        save = self._make_buttons()
        self._lay_out(save)
        for w in (self.sym, self.asym, self.by_plan):
            w.toggled.connect(self._mode)
        self.preset.activated.connect(self._apply_preset)
        for combo in (self.fit, self.rule, self.preset):
            # Long item texts must not set the panel's minimum width.
            combo.setSizeAdjustPolicy(QComboBox.AdjustToMinimumContentsLengthWithIcon)
            combo.setMinimumContentsLength(12)
        self._mode()
        self._applicable()
        session.settings_changed.connect(self.load)
        self.load()
        for spin in (self.tol, self.lower, self.upper, self.chord):
            spin.valueChanged.connect(self.push)
        for w in (self.sym, self.by_plan):
            w.toggled.connect(self.push)
        for combo in (self.fit, self.rule, self.units):
            combo.currentIndexChanged.connect(self.push)
        self.layers.editingFinished.connect(self.push)
        self.crop.editingFinished.connect(self.push)
        self.remove_plane.toggled.connect(self._applicable)
        self.remove_plane.toggled.connect(self.push)
        self.plane_distance.valueChanged.connect(self.push)
        # The plan's zone is a choice with a plan only; the airfoil chord applies to .dat
        # nominals only (see settings_fields).
        session.inputs_changed.connect(self._inputs)

    def _make_fields(self) -> None:
        """The settings controls: the zone (symmetric ±T, or lower and upper limits, mm), the
        fit, the decision rule and the airfoil chord (mm; 0 shows as "airfoil .dat only")."""
        self.sym = QRadioButton("Symmetric ±")
        self.asym = QRadioButton("Asymmetric")
        self.by_plan = QRadioButton("The plan's (statistics only)")
        self.by_plan.setToolTip("The plan's characteristics are the verdict; the zone of the "
                                "per-point statistics is its widest profile zone. A zone of "
                                "your own joins the verdict as a profile over all points.")
        self.by_plan.setVisible(False)
        self.sym.setChecked(True)
        self.tol = self._spin(0.1, 0.0001)
        self.lower = self._spin(-0.1, -1e6)
        self.upper = self._spin(0.1, -1e6)
        self.fit = QComboBox()
        self.fit.addItem("Least squares (best fit)", "lsq")
        self.fit.addItem("Minimax (fits the zone?)", "minimax")
        self.fit.setToolTip("Least squares spreads the error; minimax finds the pose with the "
                            "smallest largest excursion: can the part be placed in its zone?")
        self.rule = QComboBox()
        self.rule.addItem("Automatic (guarded when the plan states an instrument)", AUTO_RULE)
        self.rule.addItem("Simple (every point in the zone)", "simple")
        self.rule.addItem("Guarded (ISO 14253-1: each point's U)", "guarded")
        self.rule.setToolTip("Guarded (ISO 14253-1): accept only inside the zone shrunk by each "
                             "point's expanded uncertainty U, reject only outside the zone grown "
                             "by it. Automatic: guarded when the plan's [measurement] states an "
                             "instrument, as qa-inspect does without --decision-rule")
        self.chord = _optional_mm("(from the file)",
                                  "Chord length of an airfoil ordinate template (.dat)")
        self.units = QComboBox()
        self.units.addItem("(the drawing's)", None)
        for u in DXF_UNITS:
            self.units.addItem(u, u)
        self.units.setToolTip("The DXF drawing's units, when its $INSUNITS is missing or wrong")
        self.layers = QLineEdit()
        self.layers.setPlaceholderText("every layer")
        self.layers.setToolTip("The DXF layers to take, separated by commas (empty: every "
                               "layer)")

    def _make_scene_fields(self) -> None:
        """The measured scene's options (engine.scene), as the command line's --crop and
        --remove-plane [--remove-plane-distance]: the crop box typed as six numbers, the
        dominant plane's removal and its distance (mm; 0 shows as "from the data")."""
        self.crop = QLineEdit()
        self.crop.setPlaceholderText("every point")
        self.crop.setToolTip("Inspect only the measured points inside this box: XMIN YMIN ZMIN "
                             "XMAX YMAX ZMAX, mm, in the measured file's coordinates (empty: "
                             "every point)")
        self.remove_plane = QCheckBox("Remove the dominant plane (the table)")
        self.remove_plane.setToolTip("Remove the plane holding the most measured points (the "
                                     "table under the part), after the crop")
        self.plane_distance = _optional_mm(
            "(from the data)", "Points within this distance of the plane are removed; from the "
            "data: 3 robust standard deviations of the plane's points, at least their spacing")

    def _make_buttons(self) -> QPushButton:
        """The preset chooser, the Inspect and Cancel buttons, and the "Save preset…" button,
        which is returned for the layout."""
        self.preset = QComboBox()
        self.preset.setToolTip("Per-part tolerance presets")
        self._fill_presets()
        save = QPushButton("Save preset…")
        save.clicked.connect(self._save_preset)
        self.inspect_button = QPushButton("Inspect")
        self.inspect_button.setObjectName("inspectButton")
        self.inspect_button.setDefault(True)
        self.cancel_button = QPushButton("Cancel")
        self.inspect_button.clicked.connect(self.inspect_clicked)
        self.cancel_button.clicked.connect(self.cancel_clicked)
        return save

    def _lay_out(self, save: QPushButton) -> None:
        """The form (zone, limits, preset, fit, decision rule, chord: one a row) above the
        Inspect and Cancel buttons."""
        form = QFormLayout()
        row = QHBoxLayout()
        row.addWidget(self.sym)
        row.addWidget(self.tol, 1)
        form.addRow("Zone", row)
        form.addRow("", self.asym)
        # One limit a row: side by side they would set the panel's width.
        form.addRow("lower", self.lower)
        form.addRow("upper", self.upper)
        form.addRow("", self.by_plan)
        row3 = QHBoxLayout()
        row3.addWidget(self.preset, 1)
        row3.addWidget(save)
        form.addRow("Preset", row3)
        form.addRow("Fit", self.fit)
        form.addRow("Decision rule", self.rule)
        form.addRow("Airfoil chord", self.chord)
        form.addRow("DXF units", self.units)
        form.addRow("DXF layers", self.layers)
        form.addRow("Crop box", self.crop)
        form.addRow("", self.remove_plane)
        form.addRow("Plane distance", self.plane_distance)
        self.form = form
        buttons = QHBoxLayout()
        buttons.addWidget(self.inspect_button, 1)
        buttons.addWidget(self.cancel_button)
        lay = QVBoxLayout(self)
        lay.addLayout(form)
        lay.addLayout(buttons)

    @staticmethod
    def _spin(value, minimum):
        s = QDoubleSpinBox()
        s.setDecimals(4)
        s.setRange(minimum, 1e6)
        s.setSingleStep(0.01)
        s.setValue(value)
        s.setSuffix(" mm")
        return s

    def _mode(self):
        self.tol.setEnabled(self.sym.isChecked())
        for w in (self.lower, self.upper):
            w.setEnabled(self.asym.isChecked())
            self.form.setRowVisible(w, self.asym.isChecked())

    def _applicable(self) -> None:
        """Show the fields of the nominal's kind only: the chord for airfoil ordinates (.dat),
        units and layers for DXF drawings."""
        kind = formats.kind_of(self.session.nominal_path or "")
        self.form.setRowVisible(self.chord, kind == formats.AIRFOIL)
        self.form.setRowVisible(self.units, kind == formats.DXF)
        self.form.setRowVisible(self.layers, kind == formats.DXF)
        flat = kind in formats.TEMPLATE_KINDS  # a template's points lie in its plane
        self.form.setRowVisible(self.remove_plane, not flat)
        self.form.setRowVisible(self.plane_distance, not flat and self.remove_plane.isChecked())

    def _inputs(self) -> None:
        """A plan opened or closed: the plan's zone is offered with a plan only; the form shows
        the session's settings again, then sends the chord's applicability."""
        self.by_plan.setVisible(self.session.plan_path is not None)
        self._applicable()
        self.load()
        self.push()

    def plans_zone(self) -> bool:
        return self.by_plan.isChecked() and self.session.plan_path is not None

    def zone(self) -> tuple[float, float]:
        """The zone, mm: the user's, or with the plan's chosen the session's (the plan's)."""
        if self.plans_zone():
            return self.session.settings.tol_lower, self.session.settings.tol_upper
        if self.sym.isChecked():
            return -self.tol.value(), self.tol.value()
        return self.lower.value(), self.upper.value()

    def set_zone(self, lower: float, upper: float) -> None:
        symmetric = abs(lower + upper) < 1e-12
        (self.sym if symmetric else self.asym).setChecked(True)
        self.tol.setValue(upper if symmetric else self.tol.value())
        self.lower.setValue(lower)
        self.upper.setValue(upper)

    def load(self):
        """Show the session's settings (not while this form is the one changing them: the
        asymmetric zone being typed stays asymmetric)."""
        if self._pushing:
            return
        st = self.session.settings
        self._loading = True
        try:
            self.set_zone(st.tol_lower, st.tol_upper)
            if self.session.plans_zone:
                self.by_plan.setChecked(True)
            self.fit.setCurrentIndex(max(0, self.fit.findData(st.fit)))
            self.rule.setCurrentIndex(max(0, self.rule.findData(st.decision_rule)))
            self.chord.setValue(st.scale or 0.0)
            self.units.setCurrentIndex(max(0, self.units.findData(st.units)))
            self.layers.setText(", ".join(st.layers or ()))
            self.crop.setText("" if st.crop is None else " ".join(f"{v:g}" for v in st.crop))
            self.remove_plane.setChecked(st.remove_plane)
            self.plane_distance.setValue(st.plane_distance or 0.0)
        finally:
            self._loading = False
        self._applicable()

    def options(self) -> dict:
        """Fit, decision rule, airfoil chord and DXF units and layers as Settings fields."""
        layers = tuple(x.strip() for x in self.layers.text().split(",") if x.strip())
        return {"fit": self.fit.currentData(), "decision_rule": self.rule.currentData(),
                "scale": self.chord.value() or None, "units": self.units.currentData(),
                "layers": layers or None, "crop": self._crop_box(),
                "remove_plane": self.remove_plane.isChecked(),
                "plane_distance": (self.plane_distance.value() or None)
                if self.remove_plane.isChecked() else None}

    def _crop_box(self):
        """The crop box typed (six numbers, spaces or commas between them), or None when the
        field is empty; a box that is none is said in the message bar and the session's box
        stays as it was."""
        from engine.errors import SettingsError
        from engine.scene import check_box

        text = self.crop.text().replace(",", " ").split()
        if not text:
            return None
        try:
            return check_box(text)
        except SettingsError as e:
            self.session.tell("error", str(e))
            return self.session.settings.crop

    def settings_fields(self) -> dict:
        """The form as Settings fields: the zone (not checked here: the controller refuses an
        empty one at Inspect), fit, decision rule, the chord for a .dat nominal only, units
        and layers for a DXF nominal only."""
        lo, hi = self.zone()
        options = self.options()
        kind = formats.kind_of(self.session.nominal_path or "")
        if kind != formats.AIRFOIL:
            options["scale"] = None  # the chord applies to airfoil ordinates only
        if kind != formats.DXF:
            options["units"] = options["layers"] = None
        if kind in formats.TEMPLATE_KINDS:
            options["remove_plane"], options["plane_distance"] = False, None
        return {"tol_lower": float(lo), "tol_upper": float(hi),
                "zone_in_verdict": not self.plans_zone(), **options}

    def push(self, *_) -> None:
        """Send the form's values to the session's settings."""
        if self._loading:
            return
        self._pushing = True
        try:
            self.session.set_settings(**self.settings_fields())
        finally:
            self._pushing = False

    def _fill_presets(self):
        self.preset.clear()
        self.preset.addItem("(choose a preset)")
        for name, (lo, hi) in sorted(self.presets.items()):
            self.preset.addItem(f"{name}: {lo:+.3f} … {hi:+.3f} mm", name)

    def _apply_preset(self, i):
        name = self.preset.itemData(i)
        if name in self.presets:
            self.set_zone(*self.presets[name])

    def _save_preset(self):
        name, ok = QInputDialog.getText(self, "Save tolerance preset", "Part number or name:")
        if ok and name.strip():
            lo, hi = self.zone()
            self.presets[name.strip()] = (lo, hi)
            self._fill_presets()
            self.preset_saved.emit(name.strip(), lo, hi)


def _optional_mm(unset: str, tip: str) -> QDoubleSpinBox:
    """A length in mm, 0 to 1e6 to the micrometre, whose 0 shows as ``unset`` (not given)."""
    box = QDoubleSpinBox()
    box.setRange(0.0, 1e6)
    box.setDecimals(3)
    box.setSuffix(" mm")
    box.setSpecialValueText(unset)
    box.setToolTip(tip)
    return box
