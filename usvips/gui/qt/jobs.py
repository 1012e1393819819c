"""Long work of the window's controllers off the GUI thread: one pool, the workers running, their progress
and failures announced through the messaging service (:mod:`usvips.gui.messages`) — so that a controller
is handed this and the messages, never the window."""

from __future__ import annotations

from collections.abc import Callable

from PySide6 import QtCore

from usvips.core.errors import UsvipsError
from usvips.gui.messages import Messages
from usvips.gui.qt.worker import Worker


class Jobs:
    """Runs ``job(progress, cancelled)`` functions in ``pool`` (:class:`usvips.gui.qt.worker.Worker`); a failure
    is said as an error, a cancel as an info line (unless the caller handles it), the progress is announced
    as ``messages.work_progress``; ``messages.work_ended`` when none is left."""

    def __init__(self, pool: QtCore.QThreadPool, messages: Messages) -> None:
        self.pool = pool
        self.messages = messages
        self.workers: set[Worker] = set()

    @property
    def busy(self) -> bool:
        return bool(self.workers)

    def run(self, job, label: str, on_done: Callable[[object], None],
            on_cancelled: Callable[[], None] | None = None,
            on_failed: Callable[[str], None] | None = None) -> Worker:
        """Run ``job`` in a worker; ``on_done(result)`` when it finishes (a :class:`UsvipsError` it raises
        is said as an error), ``on_cancelled()`` (default: a message saying so) when it stops early,
        ``on_failed(message)`` after the message saying why it failed."""
        worker = Worker(job, label)
        self.workers.add(worker)

        def done(result) -> None:
            self._ended(worker)
            try:
                on_done(result)
            except UsvipsError as error:
                self.messages.error(str(error))

        def failed(message: str) -> None:
            self._ended(worker)
            self.messages.error(message)
            if on_failed is not None:
                on_failed(message)

        def cancelled() -> None:
            self._ended(worker)
            if on_cancelled is not None:
                on_cancelled()
            else:
                self.messages.info(f"{label}: cancelled")

        worker.signals.finished.connect(done)
        worker.signals.failed.connect(failed)
        worker.signals.cancelled.connect(cancelled)
        worker.signals.progress.connect(self.messages.work_progress.emit)
        self.messages.work_started.emit(label)
        self.pool.start(worker)
        return worker

    def _ended(self, worker: Worker) -> None:
        self.workers.discard(worker)
        if not self.workers:
            self.messages.work_ended.emit()

    def cancel_all(self) -> None:
        """Ask every running worker to stop."""
        for worker in list(self.workers):
            worker.cancel()


__all__ = ["Jobs"]
