"""Long work off the GUI thread: a QRunnable with finished / failed / progress signals and a cancel flag.

The job is a plain function ``job(progress, cancelled)`` (``progress(fraction)`` and ``cancelled()``
are callables) so that the work itself stays testable without Qt.
"""

from __future__ import annotations

import os
import sys
import threading
import traceback
from collections.abc import Callable

from PySide6 import QtCore

from usvips.core.errors import UsvipsError
from usvips.gui.qt.gui_thread_gc import collect_on_the_gui_thread


class Cancelled(Exception):
    """Raised by a job that noticed ``cancelled()``."""


class _Signals(QtCore.QObject):
    finished = QtCore.Signal(object)
    failed = QtCore.Signal(str)
    progress = QtCore.Signal(float)
    cancelled = QtCore.Signal()


class Worker(QtCore.QRunnable):
    """Runs ``job(progress, cancelled)`` in the global thread pool; results arrive as signals on the GUI
    thread. ``cancel()`` asks the job to stop; a job that stops early emits ``cancelled``."""

    def __init__(self, job: Callable[[Callable[[float], None], Callable[[], bool]], object], label: str,
                 background: bool = True) -> None:
        super().__init__()
        self.job = job
        self.label = label
        #: bulk work (the default) lowers its thread's priority below the GUI thread's (:data:`BACKGROUND_NICE`);
        #: work a user waits on to see (the video frame asked for) does not, and runs in a pool of its own
        #: whose threads no bulk work has lowered (a thread's priority cannot be raised back)
        self.background = bool(background)
        self.signals = _Signals()
        self._cancel = threading.Event()
        self.setAutoDelete(False)
        collect_on_the_gui_thread()  # no garbage (a Qt object in a cycle) is ever collected in the worker

    def cancel(self) -> None:
        self._cancel.set()

    @property
    def is_cancelled(self) -> bool:
        return self._cancel.is_set()

    def run(self) -> None:
        if self.background:
            _yield_to_the_gui()
        try:
            result = self.job(self._progress, self._cancel.is_set)
        except Cancelled:
            self._report(self.signals.cancelled)
        except UsvipsError as error:
            self._report(self.signals.failed, str(error))
        except MemoryError:
            self._report(self.signals.failed, f"{self.label}: not enough memory")
        except OSError as error:
            names = " ".join(str(n) for n in (error.filename, error.filename2) if n is not None)
            self._report(self.signals.failed, f"{self.label}: {names + ': ' if names else ''}"
                                              f"{error.strerror or error}")
        except Exception as error:  # a bug: say what and where, never crash the window
            where = traceback.extract_tb(error.__traceback__)[-1]
            self._report(self.signals.failed, f"{self.label} failed: {type(error).__name__}: {error} "
                                              f"({where.filename.rsplit('/', 1)[-1]}:{where.lineno})")
        else:
            if self._cancel.is_set():
                self._report(self.signals.cancelled)
            else:
                self._report(self.signals.finished, result)

    def _progress(self, fraction: float) -> None:
        self._report(self.signals.progress, fraction)

    @staticmethod
    def _report(signal, *args) -> None:
        """Emit a report; if its receiver's side has gone (the window closed while the work ran), drop it."""
        try:
            signal.emit(*args)
        except RuntimeError:  # "Signal source has been deleted": nobody is left to tell
            pass


#: the niceness a worker's thread takes (Linux: per thread; the threads it starts, FFmpeg's decoders among
#: them, inherit it): on two busy cores the GUI thread then gets a core first
BACKGROUND_NICE = 10


def _yield_to_the_gui() -> None:
    """Lower the calling worker thread's scheduling priority to :data:`BACKGROUND_NICE` (never raise it;
    never the main, GUI, thread — a job run there directly; where a thread's own priority cannot be set —
    not Linux — nothing changes)."""
    if (not hasattr(os, "setpriority") or not sys.platform.startswith("linux")
            or threading.current_thread() is threading.main_thread()):
        return
    try:
        thread = threading.get_native_id()
        if os.getpriority(os.PRIO_PROCESS, thread) < BACKGROUND_NICE:
            os.setpriority(os.PRIO_PROCESS, thread, BACKGROUND_NICE)
    except OSError:
        pass


#: Workers still running, kept alive here so that a window or page closing before its worker reports
#: cannot free the worker under its thread.
_RUNNING: set[Worker] = set()


def start(worker: Worker, pool: QtCore.QThreadPool | None = None) -> Worker:
    """Run ``worker`` in ``pool`` (default: the global pool), holding it until it reports."""
    _RUNNING.add(worker)
    for signal in (worker.signals.finished, worker.signals.failed, worker.signals.cancelled):
        signal.connect(lambda *_: _RUNNING.discard(worker))
    (pool or QtCore.QThreadPool.globalInstance()).start(worker)
    return worker
