"""The certificate dialog: what the certificate states, the signing identity and where to write.
The passphrase is handed to the controller once and never stored."""

from __future__ import annotations

import os

from PySide6.QtWidgets import (
    QDialog,
    QDialogButtonBox,
    QFileDialog,
    QFormLayout,
    QHBoxLayout,
    QLabel,
    QLineEdit,
    QPlainTextEdit,
    QPushButton,
    QVBoxLayout,
    QWidget,
)

from reports.certificate import CertificateInfo

FIELDS = (("part_number", "Part number"), ("part_name", "Part name"), ("revision", "Revision"),
          ("serial", "Serial number"), ("order", "Order"), ("inspector", "Inspector"),
          ("organisation", "Organisation"), ("device", "Measuring device"))


class CertificateDialog(QDialog):
    def __init__(self, parent: QWidget | None, defaults: dict, output: str):
        super().__init__(parent)
        self.setWindowTitle("Export inspection certificate")
        self.setMinimumWidth(520)
        form = QFormLayout()
        self.edits = {}
        for key, label in FIELDS:
            e = QLineEdit(defaults.get(key) or "")
            e.setObjectName(key)
            form.addRow(label, e)
            self.edits[key] = e
        self.notes = QPlainTextEdit(defaults.get("notes") or "")
        self.notes.setFixedHeight(54)
        form.addRow("Notes", self.notes)
        self.p12 = QLineEdit(defaults.get("p12") or "")
        self.p12.setPlaceholderText("PKCS#12 signing identity (.p12); empty: unsigned draft")
        form.addRow("Signing identity", self._with_browse(self.p12, self._browse_p12))
        self.passphrase = QLineEdit()
        self.passphrase.setEchoMode(QLineEdit.Password)
        self.passphrase.setObjectName("passphrase")
        form.addRow("Passphrase", self.passphrase)
        self.output = QLineEdit(output)
        form.addRow("Save as", self._with_browse(self.output, self._browse_output))
        note = QLabel("Without a signing identity the PDF is marked UNSIGNED DRAFT on every page. "
                      "The passphrase is used for this signature only and is not stored.")
        note.setWordWrap(True)
        buttons = QDialogButtonBox(QDialogButtonBox.Ok | QDialogButtonBox.Cancel)
        buttons.button(QDialogButtonBox.Ok).setText("Export")
        buttons.accepted.connect(self.accept)
        buttons.rejected.connect(self.reject)
        lay = QVBoxLayout(self)
        lay.addLayout(form)
        lay.addWidget(note)
        lay.addWidget(buttons)

    def _with_browse(self, edit, slot):
        w = QWidget()
        h = QHBoxLayout(w)
        h.setContentsMargins(0, 0, 0, 0)
        h.addWidget(edit, 1)
        b = QPushButton("Browse…")
        b.clicked.connect(slot)
        h.addWidget(b)
        return w

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
        values = {k: (e.text().strip() or None) for k, e in self.edits.items()}
        return CertificateInfo(**values, notes=self.notes.toPlainText().strip() or None)

    def take_passphrase(self) -> bytes | None:
        """The passphrase (None when unsigned); the field is cleared."""
        if not self.p12.text().strip():
            return None
        value = self.passphrase.text().encode("utf-8")
        self.passphrase.clear()
        return value

    def identity_path(self) -> str | None:
        p = self.p12.text().strip()
        return os.path.expanduser(p) if p else None

    def output_path(self) -> str:
        return os.path.expanduser(self.output.text().strip())
