"""The tolerance form: the zone (or the plan's), presets, fit, decision rule, the template's and the
measured scene's options, and the Inspect / Cancel buttons.
"""

from __future__ import annotations

from PySide6.QtCore import Signal
from PySide6.QtWidgets import (
    QCheckBox,
    QComboBox,
    QDoubleSpinBox,
    QFormLayout,
    QHBoxLayout,
    QInputDialog,
    QLineEdit,
    QPushButton,
    QRadioButton,
    QVBoxLayout,
    QWidget,
)

from engine.choices import DecisionRule, Fit
from engine.io import formats

from ..model import AUTO_RULE, Session


DXF_UNITS = ("mm", "cm", "m", "in")
"""The units a DXF drawing may be read in (qa-inspect --units)."""


def fit_popup(combo: QComboBox) -> None:
    """The combo's list at least as wide as its longest item with the item's margins, so that
    no choice (a preset's long name) is cut off there, however narrow the closed combo is: its
    width follows the panel's, which long texts must not widen."""
    view = combo.view()
    fm = view.fontMetrics()
    longest = max((fm.horizontalAdvance(combo.itemText(i)) for i in range(combo.count())),
                  default=0)
    need = max(longest + 3 * fm.height(), view.sizeHintForColumn(0) + fm.height())
    if combo.count() > combo.maxVisibleItems():
        need += view.verticalScrollBar().sizeHint().width()
    view.setMinimumWidth(need)


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
            # Long item texts must not set the panel's minimum width; the list shows them whole.
            combo.setSizeAdjustPolicy(QComboBox.AdjustToMinimumContentsLengthWithIcon)
            combo.setMinimumContentsLength(12)
        for combo in self.combos():
            fit_popup(combo)
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
        self.fit.addItem("Least squares (best fit)", Fit.LSQ)
        self.fit.addItem("Minimax (fits the zone?)", Fit.MINIMAX)
        self.fit.setToolTip("Least squares spreads the error; minimax finds the pose with the "
                            "smallest largest excursion: can the part be placed in its zone?")
        self.rule = QComboBox()
        # Each choice short enough to show whole in the closed combo at the left dock's
        # width (tests/test_app_layout.py); the tool tip says the rest.
        self.rule.addItem("Automatic (guarded if the plan has U)", AUTO_RULE)
        self.rule.addItem("Simple (every point in the zone)", DecisionRule.SIMPLE)
        self.rule.addItem("Guarded (ISO 14253-1: each point's U)", DecisionRule.GUARDED)
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
        # Across both columns: beside a label it would set the panel's (and the left dock's)
        # width.
        form.addRow(self.remove_plane)
        form.addRow("Plane distance", self.plane_distance)
        self.form = form
        buttons = QHBoxLayout()
        buttons.addWidget(self.inspect_button, 1)
        buttons.addWidget(self.cancel_button)
        lay = QVBoxLayout(self)
        lay.addLayout(form)
        lay.addLayout(buttons)

    def combos(self) -> tuple[QComboBox, ...]:
        return (self.fit, self.rule, self.units, self.preset)

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
        fit_popup(self.preset)

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
