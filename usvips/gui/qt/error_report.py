"""Unexpected errors in the window: an exception that escapes a Qt handler (a slot, an event) would otherwise
be printed to a terminal the user does not see, or abort the window. :func:`install_error_handler` catches it
instead: the full traceback goes to ``usvips.log`` in the user's data folder (``QStandardPaths.
AppDataLocation``) and to the window's log panel, and the window shows one sentence; the user's work stays as
it was. Windows register themselves (:func:`register_window`), so nothing here imports the window.
"""

from __future__ import annotations

import datetime
import sys
import traceback
import weakref
from pathlib import Path
from types import TracebackType

import shiboken6
from PySide6 import QtCore, QtWidgets

from usvips.core.errors import UsvipsError
from usvips.core.redaction import redact

LOG_NAME = "usvips.log"


def log_path() -> Path:
    """The log file of unexpected errors: ``usvips.log`` in the user's data folder."""
    folder = QtCore.QStandardPaths.writableLocation(QtCore.QStandardPaths.StandardLocation.AppDataLocation)
    return Path(folder or Path.home() / ".usvips") / LOG_NAME


def _append_log(text: str) -> Path | None:
    path = log_path()
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        with open(path, "a", encoding="utf-8") as stream:
            stream.write(f"--- {datetime.datetime.now().isoformat(timespec='seconds')}\n{redact(text)}\n")
        return path
    except OSError:
        return None


#: The workstation windows that are open (each registers itself); errors are shown in the first visible one.
_WINDOWS: weakref.WeakSet = weakref.WeakSet()


def register_window(window: QtWidgets.QWidget) -> None:
    """Let :func:`report_unexpected` show errors in ``window`` (it has ``show_message`` and ``log``)."""
    _WINDOWS.add(window)


def _window() -> QtWidgets.QWidget | None:
    """The first open workstation window, or None. Only registered windows are asked, never every
    top-level widget: a widget Qt is tearing down must not be touched."""
    for window in list(_WINDOWS):
        if shiboken6.isValid(window) and window.isVisible():
            return window
    return None


def report_unexpected(kind: type[BaseException], error: BaseException, trace: TracebackType | None) -> str:
    """Log an exception that escaped a Qt handler and show it as one sentence; returns that sentence.

    A :class:`UsvipsError` is an expected failure and shows as its own line; anything else is a bug,
    logged with its traceback."""
    if isinstance(error, UsvipsError):
        sentence = redact(error)
        details = sentence
    else:
        details = redact("".join(traceback.format_exception(kind, error, trace)))
        written = _append_log(details)
        where = f"; details in {written}" if written else ""
        sentence = (f"Something went wrong ({kind.__name__}: {' '.join(redact(error).split())[:200]}); your work "
                    f"is kept{where}")
    window = _window()
    if window is not None:
        try:
            window.show_message("error", sentence)
            if details != sentence and hasattr(window, "log"):
                window.log.add("trace", details.rstrip())
        except Exception:  # the window itself is broken: the log file and stderr still have it
            print(sentence, file=sys.stderr)
    else:
        print(sentence, file=sys.stderr)
    return sentence


def install_error_handler() -> None:
    """Route exceptions that escape Qt handlers to :func:`report_unexpected` (``sys.excepthook``, which
    PySide6 calls for exceptions in slots and virtual overrides)."""

    def hook(kind, error, trace):
        if issubclass(kind, KeyboardInterrupt):
            sys.__excepthook__(kind, error, trace)
            return
        report_unexpected(kind, error, trace)

    sys.excepthook = hook
