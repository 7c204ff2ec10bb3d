"""The main window: files (and an inspection plan), tolerance, inspect, review, export — in that
order, with each action enabled only when it makes sense."""

from __future__ import annotations

import os
from collections.abc import Callable

from PySide6.QtCore import QEvent, QObject, QSettings, Qt, Signal, Slot
from PySide6.QtGui import QAction, QKeySequence
from PySide6.QtWidgets import (
    QFileDialog,
    QFrame,
    QFormLayout,
    QGroupBox,
    QHBoxLayout,
    QLabel,
    QMainWindow,
    QProgressBar,
    QPushButton,
    QScrollArea,
    QToolButton,
    QVBoxLayout,
    QWidget,
)

from engine.io.formats import MEASURED_SUFFIXES, NOMINAL_SUFFIXES, PLAN_SUFFIXES

from .contour_view import ContourView
from .controller import SESSION_SUFFIX, Controller
from .dialogs import CertificateDialog
from .docks import arrange_left, central_views, dock, tabs, tool_bar_beside_menus, verdict_dock
from .model import Session, Step
from .part_view import PartView
from .verify_dialog import VerificationDialog, VerifyDialog
from .viewport import Viewport3D
from .widgets import (
    CharacteristicTable,
    Histogram,
    Legend,
    MessageBar,
    PointTable,
    ToleranceForm,
    VerdictBanner,
)

NOMINAL_FILTER = (f"Nominals ({' '.join('*' + s for s in NOMINAL_SUFFIXES)});;"
                  "All files (*)")
MEASURED_FILTER = (f"Measured points ({' '.join('*' + s for s in MEASURED_SUFFIXES)});;"
                   "All files (*)")
PLAN_FILTER = f"Inspection plans ({' '.join('*' + s for s in PLAN_SUFFIXES)});;All files (*)"
MAX_RECENT = 8
DEFAULT_SIZE = (1400, 900)
"""The window's size on a screen big enough; it never exceeds the screen's available area."""


class _Invoker(QObject):
    """Queues callables from worker threads into the GUI thread."""

    call = Signal(object)

    def __init__(self):
        super().__init__()
        self.call.connect(self._run, Qt.QueuedConnection)

    @Slot(object)
    def _run(self, fn: Callable[[], None]) -> None:
        fn()


class MainWindow(QMainWindow):
    def __init__(self, session: Session | None = None, synchronous: bool = False,
                 settings: QSettings | None = None, enable_3d: bool | None = None):
        super().__init__()
        self.session = session or Session()
        self._invoker = _Invoker()
        self.controller = Controller(self.session, synchronous=synchronous,
                                     post=None if synchronous else self._invoker.call.emit,
                                     prepare=Viewport3D.prepare)
        self.qsettings = settings or QSettings("qa-inspect", "qa-app")
        # The signing identity last used: no export may replace it.
        self.controller.signing_identity = self.qsettings.value("certificate/p12") or None
        self.setWindowTitle("qa-inspect — dimensional inspection")
        self.setAcceptDrops(True)
        self.verification: VerificationDialog | None = None
        """The outcome of the last certificate verified, while it is shown."""
        s = self.session

        self.message_bar = MessageBar(s)
        self.banner = VerdictBanner(s)
        self.viewport = Viewport3D(s, enable_3d)
        self.contour = ContourView(s)
        self.legend = Legend(s)
        self.histogram = Histogram(s)
        self.table = PointTable(s)
        self.characteristics = CharacteristicTable(s)
        self.viewport.colouring_changed.connect(self.legend.show_regions)
        self.part_view = PartView(s)  # what the 3D view shows of a characteristic (no Qt)
        self.viewport.use(self.part_view)
        self.tolerance = ToleranceForm(s, self._load_presets())
        self.tolerance.inspect_clicked.connect(self.inspect)
        self.tolerance.cancel_clicked.connect(self.controller.cancel)
        self.tolerance.preset_saved.connect(self._save_presets)

        # The views in the middle (docks.py); at the left the verdict, above the steps and the
        # results in tabbed docks (each may be moved, floated or hidden: View menu).
        self.views = tabs((self.viewport, "3D view"), (self.contour, "2D contour"))
        self._result(None)  # no result yet: the 2D view's tab hidden
        self.setCentralWidget(central_views(self.message_bar, self.views, self.legend))
        self.bottom = tabs((self.table, "Points"), (self.characteristics, "Characteristics"),
                           (self.histogram, "Histogram"))
        """The results' tabs (below the views before issue 26, hence the name)."""
        self.table.point_activated.connect(self._zoom_to)
        self.verdict_dock = verdict_dock(self, self.banner)
        self.steps_dock = dock(self, "Inspection", "stepsDock", self._steps_panel())
        self.results_dock = dock(self, "Results", "resultsDock", self.bottom)
        arrange_left(self, self.verdict_dock, self.steps_dock, self.results_dock)
        self._make_actions()
        self.statusBar()
        self.viewport.face_hovered.connect(lambda t: t and self.statusBar().showMessage(t, 5000))

        self._subscribe(s)
        self._inputs()
        self._step(s.step)
        self._fit_to_screen()
        self.warm_up = None if synchronous else self.controller.warm_up()

    # ------------------------------------------------------------------ layout
    def _files_box(self) -> QGroupBox:
        """Step 1: the buttons that open the nominal, the measured points and (optionally) an
        inspection plan, each beside the name of the file open (its full path in the tooltip);
        the plan's ✕ clears it."""
        self.nominal_label = QLabel("—")
        self.measured_label = QLabel("—")
        self.plan_label = QLabel("— (optional)")
        for lab in (self.nominal_label, self.measured_label, self.plan_label):
            lab.setWordWrap(True)
        open_nom = QPushButton("Open nominal…")
        open_mea = QPushButton("Open measured…")
        self.plan_button = QPushButton("Plan…")
        self.plan_button.setToolTip("Open an inspection plan (TOML): regions, datums, alignment "
                                    "and the drawing's characteristics")
        self.clear_plan_button = QToolButton(text="✕")
        self.clear_plan_button.setToolTip("Clear the plan: judge the zone over all points")
        self.clear_plan_button.setAutoRaise(True)
        open_nom.clicked.connect(self.open_nominal)
        open_mea.clicked.connect(self.open_measured)
        self.plan_button.clicked.connect(self.open_plan)
        self.clear_plan_button.clicked.connect(self.controller.clear_plan)
        plan_row = QHBoxLayout()
        plan_row.addWidget(self.plan_label, 1)
        plan_row.addWidget(self.clear_plan_button)
        files = QGroupBox("1  Files")
        ff = QFormLayout(files)
        ff.addRow(open_nom, self.nominal_label)
        ff.addRow(open_mea, self.measured_label)
        ff.addRow(self.plan_button, plan_row)
        return files

    def _tolerance_box(self) -> QGroupBox:
        """Step 2: the tolerance form with Inspect / Cancel, and below it the run's progress
        (shown while it runs) and its stage."""
        tol_box = QGroupBox("2  Tolerance and inspection")
        QVBoxLayout(tol_box).addWidget(self.tolerance)
        self.progress_bar = QProgressBar()
        self.progress_bar.setRange(0, 1000)
        self.stage_label = QLabel("")
        self.stage_label.setWordWrap(True)
        tl = tol_box.layout()
        tl.addWidget(self.progress_bar)
        tl.addWidget(self.stage_label)
        return tol_box

    def _steps_panel(self) -> QWidget:
        """The left panel: steps 1 and 2 in a vertical scroll area, step 3 (Export) below it."""
        files = self._files_box()
        tol_box = self._tolerance_box()
        self.export_button = QPushButton("3  Export certificate…")
        self.export_button.setObjectName("exportButton")
        self.export_button.clicked.connect(self.export_certificate)
        # The steps scroll when the screen is short (1366×768); Export stays in sight below.
        steps = QWidget()
        sl = QVBoxLayout(steps)
        sl.setContentsMargins(0, 0, 0, 0)
        sl.addWidget(files)
        sl.addWidget(tol_box)
        sl.addStretch(1)
        self.steps_scroll = QScrollArea()
        self.steps_scroll.setWidget(steps)
        self.steps_scroll.setWidgetResizable(True)
        self.steps_scroll.setFrameShape(QFrame.NoFrame)
        self.steps_scroll.setHorizontalScrollBarPolicy(Qt.ScrollBarAlwaysOff)
        left = QWidget()
        ll = QVBoxLayout(left)
        ll.addWidget(self.steps_scroll, 1)
        ll.addWidget(self.export_button)
        # Wide enough for the steps and a scroll bar, so that nothing is cut off sideways.
        # No maximum: the results tabbed with the steps may be widened to show every column.
        left.setMinimumWidth(max(360, steps.minimumSizeHint().width() + 30))
        return left

    def _zoom_to(self, index: int) -> None:
        """A table row double-clicked: the 3D view zooms to its point."""
        run = self.session.run
        if run is not None and run.template is None:
            self.views.setCurrentWidget(self.viewport)
            self.viewport.zoom_to(index)

    def _subscribe(self, s: Session) -> None:
        """The window's reactions to the session: file names, enabled actions, progress, the
        view that shows a new result, and every message in the status bar. Connected once the
        widgets have subscribed, so that they update first."""
        s.inputs_changed.connect(self._inputs)
        s.step_changed.connect(self._step)
        s.progress.connect(self._progress)
        s.result_changed.connect(self._result)
        s.characteristic_changed.connect(self._characteristic)
        s.message.connect(lambda level, text: self.statusBar().showMessage(text, 8000))

    # ------------------------------------------------------------------ actions
    def _make_actions(self) -> None:
        def act(text, slot, shortcut=None, tip=None):
            a = QAction(text, self)
            a.triggered.connect(slot)
            if shortcut:
                a.setShortcut(QKeySequence(shortcut))
            a.setStatusTip(tip or text)
            return a

        self.act_open_nominal = act("Open &nominal…", self.open_nominal, "Ctrl+N",
                                    "Open the nominal: CAD points, mesh, grid or DXF template")
        self.act_open_measured = act("Open &measured…", self.open_measured, "Ctrl+M",
                                     "Open the measured points")
        self.act_open_plan = act("Open &plan…", self.open_plan, "Ctrl+P",
                                 "Open an inspection plan: regions, datums, characteristics")
        self.act_clear_plan = act("Clear plan", self.controller.clear_plan, None,
                                  "Inspect without a plan: the zone over all points")
        self.act_open_session = act("Open session…", self.open_session, "Ctrl+O")
        self.act_save_session = act("Save session…", self.save_session, "Ctrl+S")
        self.act_inspect = act("&Inspect", self.inspect, "F5", "Register and judge")
        self.act_cancel = act("Cancel", self.controller.cancel, "Esc")
        self.act_certificate = act("Export &certificate…", self.export_certificate, "Ctrl+E")
        self.act_csv = act("Export CSV…", self.export_csv)
        self.act_qif = act("Export QIF…", self.export_qif)
        self.act_verify = act("&Verify certificate…", lambda: self.verify_certificate(), None,
                              "Check a certificate's signatures against a trust anchor and, "
                              "given its files, re-run its inspection")
        self.act_quit = act("Quit", self.close, "Ctrl+Q")
        file_menu = self.menuBar().addMenu("&File")
        for a in (self.act_open_nominal, self.act_open_measured, self.act_open_plan,
                  self.act_clear_plan):
            file_menu.addAction(a)
        self.recent_menu = file_menu.addMenu("Recent files")
        file_menu.addSeparator()
        for a in (self.act_open_session, self.act_save_session):
            file_menu.addAction(a)
        file_menu.addSeparator()
        for a in (self.act_certificate, self.act_csv, self.act_qif):
            file_menu.addAction(a)
        file_menu.addSeparator()
        file_menu.addAction(self.act_verify)
        file_menu.addSeparator()
        file_menu.addAction(self.act_quit)
        run_menu = self.menuBar().addMenu("&Inspection")
        run_menu.addAction(self.act_inspect)
        run_menu.addAction(self.act_cancel)
        view_menu = self.menuBar().addMenu("&View")
        view_menu.addAction(self.steps_dock.toggleViewAction())
        view_menu.addAction(self.results_dock.toggleViewAction())
        view_menu.addSeparator()
        for name in self.viewport.view_buttons:
            view_menu.addAction(act(f"{name} view", lambda _=False, n=name: (
                self.views.setCurrentWidget(self.viewport), self.viewport.standard_view(n))))
        self.tool_bar = tool_bar_beside_menus(self.menuBar(), "Main", (
            self.act_open_nominal, self.act_open_measured, self.act_inspect, self.act_cancel,
            self.act_certificate))
        self._fill_recent()

    def _fit_to_screen(self) -> None:
        """The default size, within the screen's available area less room for the frame."""
        w, h = DEFAULT_SIZE
        screen = self.screen()
        if screen is not None:
            avail = screen.availableGeometry()
            w, h = min(w, avail.width() - 16), min(h, avail.height() - 40)
        self.resize(max(w, self.minimumSizeHint().width()),
                    max(h, self.minimumSizeHint().height()))

    def _step(self, step: Step) -> None:
        s = self.session
        busy = step == Step.RUNNING
        self.act_open_nominal.setEnabled(not busy)
        self.act_open_measured.setEnabled(not busy and s.nominal_path is not None)
        self.act_open_plan.setEnabled(not busy)
        self.plan_button.setEnabled(not busy)
        self.act_clear_plan.setEnabled(not busy and s.plan_path is not None)
        self.clear_plan_button.setEnabled(not busy and s.plan_path is not None)
        self.act_open_session.setEnabled(not busy)
        self.act_verify.setEnabled(not busy)
        self.act_save_session.setEnabled(not busy and s.nominal_path is not None)
        self.act_inspect.setEnabled(s.can_inspect)
        self.tolerance.inspect_button.setEnabled(s.can_inspect)
        self.act_cancel.setEnabled(busy)
        self.tolerance.cancel_button.setEnabled(busy)
        for a in (self.act_certificate, self.act_csv, self.act_qif):
            a.setEnabled(s.can_export)
        self.export_button.setEnabled(s.can_export)
        self.progress_bar.setVisible(busy)
        if not busy:
            self.stage_label.setText(step.value)
        if step == Step.STALE:
            self.statusBar().clearMessage()  # the last run's verdict note no longer holds

    def _progress(self, stage: str, fraction: float) -> None:
        self.progress_bar.setValue(int(1000 * fraction))
        self.stage_label.setText(stage)

    def _inputs(self) -> None:
        s = self.session
        self.nominal_label.setText(os.path.basename(s.nominal_path) if s.nominal_path else "—")
        self.nominal_label.setToolTip(s.nominal_path or "")
        self.measured_label.setText(os.path.basename(s.measured_path) if s.measured_path
                                    else "—")
        self.measured_label.setToolTip(s.measured_path or "")
        self.plan_label.setText(os.path.basename(s.plan_path) if s.plan_path
                                else "— (optional)")
        self.plan_label.setToolTip(s.plan_path or "")
        for p in (s.nominal_path, s.measured_path, s.plan_path):
            if p:
                self._remember(p)

    def _result(self, run) -> None:
        # The 2D view's tab only for a contour template: otherwise its row goes to the 3D view.
        template = run is not None and run.template is not None
        self.views.setTabVisible(self.views.indexOf(self.contour), template)
        self.views.tabBar().setVisible(template)
        if run is not None:
            self.views.setCurrentWidget(self.contour if run.template is not None
                                        else self.viewport)
            # A plan's verdict is its characteristics': they are shown first.
            self.bottom.setCurrentWidget(self.characteristics
                                         if getattr(run.result, "plan", None) is not None
                                         else self.table)
            self.results_dock.raise_()

    def _characteristic(self, row) -> None:
        """A characteristic chosen: its points are shown in the 3D view."""
        run = self.session.run
        if row is not None and run is not None and run.template is None:
            self.views.setCurrentWidget(self.viewport)

    # ------------------------------------------------------------------ workflow
    def open_nominal(self, path: str | None = None) -> None:
        path = path or QFileDialog.getOpenFileName(self, "Open nominal", self._folder(),
                                                   NOMINAL_FILTER)[0]
        if path:
            self.controller.open_nominal(path)

    def open_measured(self, path: str | None = None) -> None:
        path = path or QFileDialog.getOpenFileName(self, "Open measured points", self._folder(),
                                                   MEASURED_FILTER)[0]
        if path:
            self.controller.open_measured(path)

    def open_plan(self, path: str | None = None) -> None:
        path = path or QFileDialog.getOpenFileName(self, "Open inspection plan", self._folder(),
                                                   PLAN_FILTER)[0]
        if path:
            self.controller.open_plan(path)

    def inspect(self) -> None:
        lo, hi = self.tolerance.zone()
        if self.controller.set_tolerance(lo, hi):
            self.session.set_settings(**self.tolerance.settings_fields())
            self.controller.inspect()

    def certificate_dialog(self, path: str | None = None) -> CertificateDialog:
        """The certificate dialog for the result on screen: the remembered fields, the default
        file beside the measured points, and what its checks need (verdict, inputs)."""
        default = path or os.path.join(self._folder(), os.path.splitext(
            os.path.basename(self.session.measured_path))[0] + "_certificate.pdf")
        defaults = {k: self.qsettings.value(f"certificate/{k}") for k in (
            "inspector", "organisation", "device", "p12")}
        s = self.session
        return CertificateDialog(self, defaults, default, verdict=s.run.result.verdict,
                                 inputs={"nominal": s.nominal_path, "measured": s.measured_path})

    def export_certificate(self, path: str | None = None, dialog: CertificateDialog | None = None
                           ) -> CertificateDialog | None:
        """Ask for the certificate's fields and identity, then export. Tests pass a prepared
        ``dialog`` (accepted) to drive it without a modal loop; one made here is deleted once
        used, with the passphrase and the identity loaded with it."""
        if not self.session.can_export or not self.controller.check_inputs():
            return None
        made_here = dialog is None
        if made_here:
            dialog = self.certificate_dialog(path)
            if dialog.exec() != CertificateDialog.Accepted:
                dialog.take_passphrase()
                dialog.deleteLater()
                return None
        info = dialog.info()
        p12 = dialog.identity_path()
        # An unsigned draft's inspector is remembered; a signer's name comes with the identity.
        for k in ("inspector", "organisation", "device"):
            value = dialog.draft_inspector() if k == "inspector" else getattr(info, k)
            self.qsettings.setValue(f"certificate/{k}", value or "")
        self.qsettings.setValue("certificate/p12", p12 or "")
        # The certificate written is the one File → Verify certificate… offers next.
        self.controller.export_certificate(
            dialog.output_path(), info, p12, dialog.take_passphrase(),
            on_done=lambda p: self.qsettings.setValue("verify/certificate", p))
        if made_here:
            dialog.deleteLater()
        return dialog

    def export_csv(self, path: str | None = None) -> None:
        path = path or QFileDialog.getSaveFileName(self, "Export CSV", self._folder(),
                                                   "CSV (*.csv)")[0]
        if path:
            self.controller.export_csv(path)

    def export_qif(self, path: str | None = None) -> None:
        path = path or QFileDialog.getSaveFileName(self, "Export QIF", self._folder(),
                                                   "QIF (*.qif)")[0]
        if path:
            self.controller.export_qif(path)

    def verify_dialog(self) -> VerifyDialog:
        """The verification dialog: the certificate and trust anchor last used (the last
        certificate exported, else the last verified), the open files offered for the
        re-run."""
        defaults = {k: self.qsettings.value(f"verify/{k}") for k in ("certificate", "trust")}
        s = self.session
        return VerifyDialog(self, defaults, {"nominal": s.nominal_path,
                                             "measured": s.measured_path, "plan": s.plan_path})

    def verify_certificate(self, dialog: VerifyDialog | None = None) -> VerifyDialog | None:
        """Ask for the certificate, the trust anchor and the files to re-run it on, then
        verify it in the worker (reports.verify, as ``qa-inspect verify``); the outcome is
        shown in a VerificationDialog (``verification``). Tests pass a prepared ``dialog``
        (accepted) to drive it without a modal loop."""
        made_here = dialog is None
        if made_here:
            dialog = self.verify_dialog()
            if dialog.exec() != VerifyDialog.Accepted:
                dialog.deleteLater()
                return None
        self.qsettings.setValue("verify/certificate", dialog.certificate_path())
        self.qsettings.setValue("verify/trust", "; ".join(dialog.trust_paths()))
        self.controller.verify_certificate(dialog.certificate_path(), dialog.trust_paths(),
                                           *dialog.rerun_files(),
                                           on_done=self.show_verification)
        if made_here:
            dialog.deleteLater()
        return dialog

    def show_verification(self, v) -> VerificationDialog:
        """Show a verification's outcome (reports.verify.CertificateVerification), replacing
        the last one shown."""
        if self.verification is not None:
            self.verification.close()
            self.verification.deleteLater()
        self.verification = VerificationDialog(self, v)
        self.verification.open()
        return self.verification

    def save_session(self, path: str | None = None) -> None:
        path = path or QFileDialog.getSaveFileName(
            self, "Save session", self._folder(), f"Sessions (*{SESSION_SUFFIX})")[0]
        if path:
            if not path.endswith(SESSION_SUFFIX):
                path += SESSION_SUFFIX
            self.controller.save_session(path)

    def open_session(self, path: str | None = None) -> None:
        path = path or QFileDialog.getOpenFileName(
            self, "Open session", self._folder(), f"Sessions (*{SESSION_SUFFIX})")[0]
        if path:
            self.controller.open_session(path)

    def _folder(self) -> str:
        for p in (self.session.measured_path, self.session.nominal_path):
            if p:
                return os.path.dirname(p)
        return os.getcwd()

    # ------------------------------------------------------------------ recent files, presets
    def _remember(self, path: str) -> None:
        recent = [p for p in self._recent() if p != path]
        self.qsettings.setValue("recent", [path] + recent[:MAX_RECENT - 1])
        self._fill_recent()

    def _recent(self) -> list[str]:
        v = self.qsettings.value("recent") or []
        return [v] if isinstance(v, str) else list(v)

    def _fill_recent(self) -> None:
        self.recent_menu.clear()
        for p in self._recent():
            a = self.recent_menu.addAction(p)
            a.triggered.connect(lambda _=False, p=p: self.controller.open_files([p]))
        self.recent_menu.setEnabled(bool(self._recent()))

    def _load_presets(self) -> dict[str, tuple[float, float]]:
        out = {}
        for name in self.qsettings.value("presets/names") or []:
            v = self.qsettings.value(f"presets/{name}")
            try:
                out[name] = (float(v[0]), float(v[1]))
            except (TypeError, ValueError, IndexError):
                continue
        return out

    def _save_presets(self, name: str, lo: float, hi: float) -> None:
        names = list(self.qsettings.value("presets/names") or [])
        if name not in names:
            names.append(name)
        self.qsettings.setValue("presets/names", names)
        self.qsettings.setValue(f"presets/{name}", [lo, hi])

    # ------------------------------------------------------------------ drag and drop
    def dragEnterEvent(self, event):
        if event.mimeData().hasUrls():
            event.acceptProposedAction()

    def dropEvent(self, event):
        paths = [u.toLocalFile() for u in event.mimeData().urls() if u.isLocalFile()]
        if paths:
            self.controller.open_files(paths)
            event.acceptProposedAction()

    def changeEvent(self, event):
        # Back from another program (where an input may have been edited): is the result still
        # that of the files on disk?
        if (event.type() == QEvent.ActivationChange and self.isActiveWindow()
                and self.session.run is not None and not self.controller.busy):
            self.controller.check_inputs()
        super().changeEvent(event)

    def closeEvent(self, event):
        self.controller.cancel()
        self.controller.wait(5)
        self.viewport.close_plotter()
        super().closeEvent(event)
