"""Verifying a certificate from the app (File → Verify certificate…): the dialog that asks for
the certificate, the trust anchor and, optionally, the files to re-run its inspection on, as
``qa-inspect verify`` does; and the dialog that shows the outcome (reports.verify), VALID or
INVALID with every check."""

from __future__ import annotations

import os

from PySide6.QtCore import Qt
from PySide6.QtGui import QFontDatabase
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

from engine.choices import Verdict
from engine.io.formats import MEASURED_SUFFIXES, NOMINAL_SUFFIXES, PLAN_SUFFIXES
from reports.messages import VERDICT_RGB, printable
from reports.verify import (
    CertificateVerification,
    RerunFilesError,
    certified_line,
    check_files,
    signature_line,
)

from .dialogs import with_browse

RERUN = (("nominal", "Nominal", NOMINAL_SUFFIXES), ("measured", "Measured", MEASURED_SUFFIXES),
         ("plan", "Plan", PLAN_SUFFIXES))
"""The files a verification may re-run the inspection on: role, label, suffixes."""


class VerifyDialog(QDialog):
    """The certificate (PDF), the trust anchors (CA certificates, PEM or DER, separated by
    ';'; nothing else is trusted) and, optionally, the nominal, measured points and plan to
    re-run the inspection on. What the command line refuses is said here, and the dialog stays
    open."""

    def __init__(self, parent: QWidget | None, defaults: dict,
                 open_files: dict[str, str | None] | None = None):
        """defaults : the certificate and trust anchor last verified; open_files : {role: path}
        of the files open in the window, offered for the re-run."""
        super().__init__(parent)
        self.setWindowTitle("Verify certificate")
        self.setMinimumWidth(560)
        self.open_files = {k: v for k, v in (open_files or {}).items() if v}
        self.certificate = QLineEdit(defaults.get("certificate") or "")
        self.certificate.setPlaceholderText("the signed certificate (.pdf)")
        self.trust = QLineEdit(defaults.get("trust") or "")
        self.trust.setPlaceholderText("CA certificate(s) to trust (.pem), separated by ';'")
        form = QFormLayout()
        form.addRow("Certificate", with_browse(self.certificate, self._browse_certificate))
        form.addRow("Trust anchor", with_browse(self.trust, self._browse_trust))
        self.files = {}
        rerun = QGroupBox("Re-run the inspection (optional)")
        rf = QFormLayout(rerun)
        for role, label, suffixes in RERUN:
            e = QLineEdit()
            e.setObjectName(role)
            e.setPlaceholderText("optional" if role == "plan" else
                                 "the certified file, to check and re-run")
            self.files[role] = e
            rf.addRow(label, with_browse(e, lambda _=False, r=role, s=suffixes:
                                               self._browse_file(r, s)))
        self.use_open = QPushButton("Use the open files")
        self.use_open.setEnabled(bool(self.open_files))
        self.use_open.clicked.connect(self.fill_open_files)
        rf.addRow("", self.use_open)
        self.problem = QLabel()
        self.problem.setWordWrap(True)
        self.problem.setStyleSheet("QLabel { color: #8a1111; }")
        self.problem.hide()
        self.buttons = QDialogButtonBox(QDialogButtonBox.Ok | QDialogButtonBox.Cancel)
        self.verify_button = self.buttons.button(QDialogButtonBox.Ok)
        self.verify_button.setText("Verify")
        self.buttons.accepted.connect(self.accept)
        self.buttons.rejected.connect(self.reject)
        lay = QVBoxLayout(self)
        lay.addLayout(form)
        lay.addWidget(rerun)
        lay.addWidget(self.problem)
        lay.addWidget(self.buttons)

    def fill_open_files(self) -> None:
        """The files open in the window, for the re-run."""
        for role, e in self.files.items():
            e.setText(self.open_files.get(role) or "")

    def certificate_path(self) -> str:
        return os.path.expanduser(self.certificate.text().strip())

    def trust_paths(self) -> list[str]:
        return [os.path.expanduser(p.strip()) for p in self.trust.text().split(";")
                if p.strip()]

    def rerun_files(self) -> tuple[str | None, str | None, str | None]:
        """(nominal, measured, plan), None where not given."""
        return tuple(os.path.expanduser(self.files[r].text().strip()) or None
                     for r, _, _ in RERUN)

    def problems(self) -> str | None:
        """What the command line would refuse in this request (its message), or None."""
        if not self.certificate_path():
            return "give the certificate to verify (PDF)"
        if not self.trust_paths():
            return ("give the trust anchor (the CA certificate, PEM or DER): nothing else is "
                    "trusted")
        try:
            check_files(*self.rerun_files())
        except RerunFilesError as e:
            return str(e)
        return None

    def accept(self) -> None:
        problem = self.problems()
        self.problem.setText(problem or "")
        self.problem.setVisible(bool(problem))
        if not problem:
            super().accept()

    def _browse_certificate(self):
        path, _ = QFileDialog.getOpenFileName(self, "Certificate to verify",
                                              self.certificate.text(), "PDF (*.pdf)")
        if path:
            self.certificate.setText(path)

    def _browse_trust(self):
        paths, _ = QFileDialog.getOpenFileNames(
            self, "Trust anchors", os.path.dirname(self.trust_paths()[0]) if self.trust_paths()
            else "", "CA certificates (*.pem *.crt *.cer *.der);;All files (*)")
        if paths:
            self.trust.setText("; ".join(paths))

    def _browse_file(self, role: str, suffixes: tuple[str, ...]):
        path, _ = QFileDialog.getOpenFileName(
            self, f"The certified {role} file", self.files[role].text(),
            f"{role.capitalize()} ({' '.join('*' + s for s in suffixes)});;All files (*)")
        if path:
            self.files[role].setText(path)


class VerificationDialog(QDialog):
    """The outcome of a verification: VALID or INVALID in large type on the verdict colours,
    the certificate, each signature, what the certificate states, and every check with its
    outcome (✓ passed, ✗ failed) and message, in the command line's words."""

    def __init__(self, parent: QWidget | None, v: CertificateVerification):
        super().__init__(parent)
        self.setWindowTitle("Certificate verification")
        self.setMinimumSize(780, 380)
        self.valid = v.valid
        rgb = VERDICT_RGB[Verdict.ACCEPT if v.valid else Verdict.REJECT]
        colour = "#{:02x}{:02x}{:02x}".format(*(round(255 * c) for c in rgb))
        self.word = QLabel("VALID" if v.valid else "INVALID")
        self.word.setObjectName("verificationWord")
        self.word.setStyleSheet(f"QLabel {{ background: {colour}; color: white; font-size: 20pt; "
                                "font-weight: bold; padding: 6px 14px; border-radius: 4px; }")
        where = QLabel(printable(v.path))
        where.setWordWrap(True)
        where.setTextInteractionFlags(Qt.TextSelectableByMouse)
        head = QHBoxLayout()
        head.addWidget(self.word)
        head.addWidget(where, 1)
        self.details = QPlainTextEdit("\n".join(printable(line) for line in details(v)))
        self.details.setReadOnly(True)
        self.details.setLineWrapMode(QPlainTextEdit.WidgetWidth)
        self.details.setFont(QFontDatabase.systemFont(QFontDatabase.FixedFont))
        buttons = QDialogButtonBox(QDialogButtonBox.Close)
        buttons.rejected.connect(self.reject)
        lay = QVBoxLayout(self)
        lay.addLayout(head)
        lay.addWidget(self.details, 1)
        lay.addWidget(buttons)


def details(v: CertificateVerification) -> list[str]:
    """The verification below its VALID or INVALID: the signatures, what the certificate states,
    and every check, ✓ passed or ✗ failed, with its message."""
    lines = ["Signatures:"] + [f"  {signature_line(s)}" for s in v.signatures]
    if not v.signatures:
        lines.append("  none could be read")
    if v.certified is not None:
        lines += ["", "Certificate:", f"  {certified_line(v.certified)}"]
    lines += ["", "Checks:"]
    return lines + [f"  {'✓' if c.passed else '✗'} {c.message}" for c in v.checks]
