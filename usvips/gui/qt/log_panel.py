"""The log: every message of the session, with its level."""

from __future__ import annotations

from PySide6 import QtCore, QtWidgets

from usvips.core.redaction import redact
from usvips.gui.panel_registry import Panel, register
from usvips.gui.window_context import WindowContext


class LogPanel(QtWidgets.QPlainTextEdit):
    """Every message of the session, newest last."""

    def __init__(self, parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(parent)
        self.setReadOnly(True)
        self.setMaximumBlockCount(2000)

    def add(self, level: str, text: str) -> None:
        """One line of the log (never with a password: :func:`usvips.core.redaction.redact`)."""
        text = redact(text)
        stamp = QtCore.QTime.currentTime().toString("HH:mm:ss")
        self.appendPlainText(f"{stamp} {level:7s} {text}")


def _log(context: WindowContext) -> LogPanel:
    """The log, keeping every message the window's parts say (:mod:`usvips.gui.messages`)."""
    log = LogPanel()
    context.messages.said.connect(log.add)
    return log


#: the panel's declaration (usvips.gui.panel_registry): the window builds its dock from it
PANEL = register(Panel("log", "Log", "bottom", _log, group="records", order=70, at_start=True))  # hears every message
