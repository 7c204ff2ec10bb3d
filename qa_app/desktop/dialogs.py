"""The certificate dialog: what the certificate states, the signing identity and where to write.
The passphrase is handed to the controller once and never stored.

A signed certificate names its signer as inspector: once the identity is loaded the Inspector
field shows the signing certificate's name and cannot be edited; an unsigned draft names whom
the inspector types. What the command line refuses (an inspector who is not the signer, a signed
ACCEPTED certificate without part number and serial, an output onto an input) is said in the
dialog, in the same words, and the dialog stays open."""

from __future__ import annotations

import os

from PySide6.QtCore import Qt
from PySide6.QtWidgets import (
    QDialog,
    QDialogButtonBox,
    QFileDialog,
    QFormLayout,
    QGroupBox,
    QHBoxLayout,
    QLabel,
    QLineEdit,
    QPlainTextEdit,
    QPushButton,
    QVBoxLayout,
    QWidget,
)

from reports.certificate import TRACEABILITY, CertificateInfo
from reports.messages import user_message

FIELDS = (("part_number", "Part number"), ("part_name", "Part name"), ("revision", "Revision"),
          ("serial", "Serial number"), ("order", "Order"), ("inspector", "Inspector"),
          ("organisation", "Organisation"))
TRACEABILITY_HINTS = {"calibration_date": "YYYY-MM-DD", "temperature_c": "°C, e.g. 20.5",
                      "probe": "probe and stylus", "program": "measurement program",
                      "cad_revision": "revision of the CAD model"}
"""Placeholders of the traceability fields (the certificate's section 1)."""


def with_browse(edit: QWidget, slot) -> QWidget:
    """``edit`` (a path's line edit) with a "Browse…" button beside it that calls ``slot``: a
    row of the certificate and verify dialogs' forms."""
    w = QWidget()
    h = QHBoxLayout(w)
    h.setContentsMargins(0, 0, 0, 0)
    h.addWidget(edit, 1)
    b = QPushButton("Browse…")
    b.clicked.connect(slot)
    h.addWidget(b)
    return w


class CertificateDialog(QDialog):
    SIGNER_HINT = "the signer's name, read from the signing identity"

    def __init__(self, parent: QWidget | None, defaults: dict, output: str,
                 verdict: str | None = None, inputs: dict[str, str | None] | None = None):
        """verdict : the result's verdict (engine.inspection), for the checks a signed
        certificate of it must pass; inputs : {role: path} no output may replace."""
        super().__init__(parent)
        self.setWindowTitle("Export inspection certificate")
        self.setMinimumWidth(520)
        self.verdict = verdict
        self.inputs = dict(inputs or {})
        self.identity = None  # reports.signing.Identity, once loaded
        self._loaded_for = None  # (path, passphrase) it was loaded with
        form = QFormLayout()
        self.edits = {}
        for key, label in FIELDS:
            e = QLineEdit(defaults.get(key) or "")
            e.setObjectName(key)
            form.addRow(label, e)
            self.edits[key] = e
        trace = self._traceability_box(defaults)
        self.inspector = self.edits["inspector"]
        self._draft_inspector = self.inspector.text()  # what an unsigned draft names
        self.notes = QPlainTextEdit(defaults.get("notes") or "")
        self.notes.setFixedHeight(54)
        form.addRow("Notes", self.notes)
        self.p12 = QLineEdit(defaults.get("p12") or "")
        self.p12.setPlaceholderText("PKCS#12 signing identity (.p12); empty: unsigned draft")
        form.addRow("Signing identity", with_browse(self.p12, self._browse_p12))
        self.passphrase = QLineEdit()
        self.passphrase.setEchoMode(QLineEdit.Password)
        self.passphrase.setObjectName("passphrase")
        form.addRow("Passphrase", self.passphrase)
        self.output = QLineEdit(output)
        form.addRow("Save as", with_browse(self.output, self._browse_output))
        note = QLabel("Without a signing identity the PDF is marked UNSIGNED DRAFT on every page. "
                      "The passphrase is used for this signature only and is not stored. "
                      "A signed certificate names its signer as the inspector.")
        note.setWordWrap(True)
        self.problem = QLabel()
        self.problem.setObjectName("certificateProblem")
        self.problem.setWordWrap(True)
        self.problem.setTextInteractionFlags(Qt.TextSelectableByMouse)
        self.problem.setStyleSheet("QLabel { color: #8a1111; }")
        self.problem.hide()
        self.buttons = QDialogButtonBox(QDialogButtonBox.Ok | QDialogButtonBox.Cancel)
        self.export_button = self.buttons.button(QDialogButtonBox.Ok)
        self.export_button.setText("Export")
        self.buttons.accepted.connect(self.accept)
        self.buttons.rejected.connect(self.reject)
        lay = QVBoxLayout(self)
        columns = QHBoxLayout()
        columns.addLayout(form, 1)
        columns.addWidget(trace, 1)
        lay.addLayout(columns)
        lay.addWidget(note)
        lay.addWidget(self.problem)
        lay.addWidget(self.buttons)
        self.inspector.textEdited.connect(self._inspector_edited)
        self.p12.textChanged.connect(self._identity_changed)
        self.passphrase.textChanged.connect(self._identity_changed)
        self.passphrase.returnPressed.connect(self.load_identity)
        self.passphrase.editingFinished.connect(self._load_quietly)
        self._identity_changed()

    def _traceability_box(self, defaults: dict) -> QGroupBox:
        """The traceability fields (device, serial, calibration date, probe, temperature,
        program, drawing, CAD revision) beside the part's, into ``self.edits``."""
        box = QGroupBox("Traceability")
        form = QFormLayout(box)
        for key, label in TRACEABILITY:
            value = defaults.get(key)
            e = QLineEdit("" if value is None else f"{value:g}" if isinstance(value, float)
                          else str(value))
            e.setObjectName(key)
            e.setPlaceholderText(TRACEABILITY_HINTS.get(key, ""))
            form.addRow(label, e)
            self.edits[key] = e
        return box

    # ------------------------------------------------------------------ the signer
    def _inspector_edited(self, text: str) -> None:
        if self.identity_path() is None:
            self._draft_inspector = text

    def _identity_changed(self, *_) -> None:
        """Another identity or passphrase: the signer is not known until it is loaded; while an
        identity is chosen the inspector is its signer, not a typed name."""
        if self._loaded_for != self._key():
            self.identity = None
            self._loaded_for = None
        chosen = self.identity_path() is not None
        self.inspector.setReadOnly(chosen)
        if self.identity is not None:
            self.inspector.setText(self.identity.common_name)
        else:
            self.inspector.setText("" if chosen else self._draft_inspector)
        self.inspector.setPlaceholderText(self.SIGNER_HINT if chosen else "")
        self.inspector.setToolTip(
            "A signed certificate names the person who signs it: the signing certificate's "
            "name" if chosen else "")
        self._say(None)

    def _key(self):
        return (self.identity_path(), self.passphrase.text())

    def _load_quietly(self) -> None:
        """The passphrase field left: load the identity if it can be (its problems are said
        when Export is pressed)."""
        if self.identity_path() and self.passphrase.text() and os.path.isfile(
                self.identity_path()):
            self.load_identity()

    def load_identity(self) -> bool:
        """Load the chosen identity with the passphrase typed; the inspector becomes its signer.
        False (with the problem said in the dialog) when it cannot be loaded."""
        from reports.signing import load_identity

        path = self.identity_path()
        if path is None:
            return True
        if self.identity is not None and self._loaded_for == self._key():
            return True
        try:
            identity = load_identity(path, self.passphrase.text().encode("utf-8"))
        except Exception as e:  # an unreadable identity is one message, never a crash
            self._say(user_message(e))
            return False
        self.identity, self._loaded_for = identity, self._key()
        self._identity_changed()
        return True

    def problems(self) -> str | None:
        """What the command line would refuse in this certificate (its message), or None."""
        from reports.certificate import CertificationError, certified_info
        from reports.outputs import OutputConflictError, check_outputs

        try:
            check_outputs({"certificate": self.output_path() or ""},
                          dict(self.inputs, **{"signing identity": self.identity_path()}))
        except OutputConflictError as e:
            return user_message(e)
        problem = self._traceability_problem()
        if problem:
            return problem
        if not self.load_identity():
            return self.problem.text()
        if self.verdict is not None:
            try:
                certified_info(self.info(), self.identity, self.verdict)
            except CertificationError as e:
                return user_message(e)
        return None

    def _traceability_problem(self) -> str | None:
        """A calibration date that is no date or a temperature that is no number, as the
        command line says it."""
        import datetime as dt
        import math

        date = self.edits["calibration_date"].text().strip()
        if date:
            try:
                dt.date.fromisoformat(date)
            except ValueError:
                return f"calibration date: '{date}' is not a date YYYY-MM-DD"
        t = self.edits["temperature_c"].text().strip()
        if t:
            try:
                ok = math.isfinite(float(t.replace(",", ".")))
            except ValueError:
                ok = False
            if not ok:
                return f"temperature: '{t}' is not a number (°C)"
        return None

    def _say(self, text: str | None) -> None:
        self.problem.setText(text or "")
        self.problem.setVisible(bool(text))

    def accept(self) -> None:
        """Export only what the command line would certify; otherwise say why and stay open."""
        problem = self.problems()
        if problem:
            self._say(problem)
            return
        super().accept()

    def _browse_p12(self):
        path, _ = QFileDialog.getOpenFileName(self, "Signing identity", self.p12.text(),
                                              "PKCS#12 (*.p12 *.pfx);;All files (*)")
        if path:
            self.p12.setText(path)

    def _browse_output(self):
        path, _ = QFileDialog.getSaveFileName(self, "Save certificate", self.output.text(),
                                              "PDF (*.pdf)")
        if path:
            self.output.setText(path if path.lower().endswith(".pdf") else path + ".pdf")

    def info(self) -> CertificateInfo:
        """What the certificate states (a temperature that is no number is left out:
        :meth:`problems` says so before any export)."""
        values = {k: (e.text().strip() or None) for k, e in self.edits.items()}
        t = values["temperature_c"]
        try:
            values["temperature_c"] = None if t is None else float(t.replace(",", "."))
        except ValueError:
            values["temperature_c"] = None
        if values["calibration_date"] and self._traceability_problem() is None:
            import datetime as dt

            values["calibration_date"] = dt.date.fromisoformat(
                values["calibration_date"]).isoformat()
        return CertificateInfo(**values, notes=self.notes.toPlainText().strip() or None)

    def take_passphrase(self) -> bytes | None:
        """The passphrase (None when unsigned); the field and the identity loaded with it are
        cleared (the signer's name stays)."""
        value = self.passphrase.text().encode("utf-8") if self.p12.text().strip() else None
        self.passphrase.blockSignals(True)
        self.passphrase.clear()
        self.passphrase.blockSignals(False)
        self.identity = None
        return value

    def draft_inspector(self) -> str | None:
        """The inspector typed for an unsigned draft (not a signer's name)."""
        return self._draft_inspector.strip() or None

    def identity_path(self) -> str | None:
        p = self.p12.text().strip()
        return os.path.expanduser(p) if p else None

    def output_path(self) -> str:
        return os.path.expanduser(self.output.text().strip())
