"""Waiting for colleagues' changes: a :class:`ChangeWatch` wakes a background thread as soon as another
connection may have committed a change to the project, so that it reads the new history rows
(:meth:`usvips.store.interface.ProjectStore.changes_since`) — no polling of the rows themselves.

A watch owns its own connection (never the store handle's, which belongs to the thread that opened it),
so it is made to be used from one background thread: ``watch = store.watch()``, then in that thread
``while running: if watch.wait(1.0): read store.changes_since(seen)`` (through a handle of that thread),
and ``watch.close()`` when done (closing twice is no error).

``wait`` may wake without a change to the objects (another write, a checkpoint, a reconnection after the
server went away — changes may have been missed then): the reader compares
:meth:`~usvips.store.interface.ProjectStore.last_change_id` with what it has seen. It never misses a
commit made after the watch was made.

The SQLite file's watch is here (:class:`FileChangeWatch`: SQLite's ``PRAGMA data_version``, which moves
when another connection commits); a server's is in its backend module (LISTEN/NOTIFY).
"""

from __future__ import annotations

import sqlite3
import threading
from abc import ABC, abstractmethod
from pathlib import Path

from usvips.store.records import ProjectError

#: how often (s) the SQLite file's change counter is read while waiting
FILE_POLL_S = 0.2


class ChangeWatch(ABC):
    """A waiter for changes committed by other connections to one project (see the module docstring)."""

    @abstractmethod
    def wait(self, timeout_s: float) -> bool:
        """True as soon as another connection may have committed a change since the last call (or since the
        watch was made), False when ``timeout_s`` seconds passed without one (or the watch is closed)."""

    @abstractmethod
    def close(self) -> None:
        """Release the watch's connection; a later :meth:`wait` returns False at once. Idempotent."""

    def __enter__(self) -> ChangeWatch:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


class FileChangeWatch(ChangeWatch):
    """The watch of an SQLite project file: a second, read-only connection reading ``PRAGMA data_version``
    every :data:`FILE_POLL_S` s (the number moves whenever another connection — another window, another
    process, this program's own writing handle — commits to the file)."""

    def __init__(self, path: Path, poll_s: float = FILE_POLL_S):
        self.path, self.poll_s = Path(path), poll_s
        self._closed = threading.Event()
        self._lock = threading.Lock()
        try:
            self._db: sqlite3.Connection | None = sqlite3.connect(
                f"file:{self.path}?mode=ro", uri=True, timeout=2.0, isolation_level=None, check_same_thread=False)
            self._db.execute("PRAGMA query_only = ON")
            self._seen = self._version()
        except sqlite3.Error as error:
            raise ProjectError(f"{self.path}: cannot watch the project for changes: {error}") from None

    def _version(self) -> int:
        with self._lock:
            if self._db is None:
                return -1
            return int(self._db.execute("PRAGMA data_version").fetchone()[0])

    def wait(self, timeout_s: float) -> bool:
        remaining = max(0.0, float(timeout_s))
        while not self._closed.is_set():
            try:
                now = self._version()
            except sqlite3.Error:
                now = self._seen  # locked for a moment, or the file went away: try again on the next tick
            if self._closed.is_set():
                return False
            if now != self._seen:
                self._seen = now
                return True
            if remaining <= 0:
                return False
            step = min(self.poll_s, remaining)
            self._closed.wait(step)
            remaining -= step
        return False

    def close(self) -> None:
        self._closed.set()
        with self._lock:
            if self._db is not None:
                self._db.close()
                self._db = None
