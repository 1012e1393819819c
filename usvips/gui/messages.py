"""The window's messaging service, free of Qt: what controllers, dialogs and panels say to the person at the
window (status messages, warnings, errors) and how far long work has come — handed to them instead of the
window, so that they never call a window method and are tested with plain calls.

The window (or a test) listens: ``said(level, text)`` after every message; ``work_started(label)``,
``work_progress(fraction)`` (0…1) and ``work_ended()`` (no work left) for the progress bar. Text is said
with any password redacted (:func:`usvips.core.redaction.redact`)."""

from __future__ import annotations

from usvips.core.redaction import redact
from usvips.gui.signals import Signal

#: the levels of a message, least to most urgent: the window colours warnings amber and errors red
LEVELS = ("info", "warning", "error")


class Messages:
    """Say things to the user: :meth:`say` (or :meth:`info`, :meth:`warning`, :meth:`error`); announce work."""

    def __init__(self) -> None:
        self.said = Signal()
        self.work_started = Signal()
        self.work_progress = Signal()
        self.work_ended = Signal()

    def say(self, level: str, text: str) -> None:
        """Say ``text`` at ``level`` (one of :data:`LEVELS`); a level not known is a programming error."""
        if level not in LEVELS:
            raise ValueError(f"message level {level!r} is not one of {LEVELS}")
        self.said.emit(level, redact(str(text)))

    def info(self, text: str) -> None:
        self.say("info", text)

    def warning(self, text: str) -> None:
        self.say("warning", text)

    def error(self, text: str) -> None:
        self.say("error", text)


__all__ = ["LEVELS", "Messages"]
