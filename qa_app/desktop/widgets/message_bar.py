"""The message bar above the verdict: the one place where errors and warnings appear."""

from __future__ import annotations

import html

from PySide6.QtCore import Qt
from PySide6.QtWidgets import QFrame, QHBoxLayout, QLabel, QToolButton

from ..model import Session


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
        # Rich text for the title only: the message may quote a file name or a label, shown
        # as the characters it holds ('<b>x</b>.csv' is a name, not markup).
        shown = html.escape(text, quote=False)
        self.label.setText(f"<b>{title}:</b> {shown}" if title else f"<p>{shown}</p>")
        self.label.setToolTip(f"<p>{shown}</p>")
        self.text = text
        self.show()
