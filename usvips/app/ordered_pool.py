"""A function mapped over a stream of chunks on worker processes, the results given back in the stream's
order, with flat memory (``usvips intersect`` on both cores).

:func:`ordered_map` gives ``(item, function(state, item))`` for each item in order. The first item is
worked here, in this process; from the second on, the items go to a pool of ``workers`` processes (started
then, so a stream of one chunk never starts one), at most ``ahead`` per worker waiting or being worked at a
time: the reader stays a few chunks ahead of the writer, whatever the stream's length. ``state`` (the
calibration and options of a run) is handed to each worker once, when it starts, and kept there: a task
carries its item alone. Workers are forked where the platform can (nothing to import again), else spawned.

Errors stay those of the plain loop: an item whose work fails in a worker (an error, or a pool that broke)
is worked again here, so the error raised is the one the plain loop raises, with its own type and
message. Leaving the loop early (an error in the caller, a bad line further on) cancels what is waiting
and stops the workers.
"""

from __future__ import annotations

import multiprocessing
import os
import signal
import sys
from collections import deque
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import Future, ProcessPoolExecutor
from contextlib import contextmanager
from typing import Any, TypeVar

Item = TypeVar("Item")
Result = TypeVar("Result")

#: chunks per worker waiting or being worked at a time
AHEAD = 2

_state: Any = None  # a worker's state, set once when it starts


def available_cores() -> int:
    """The cores this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


@contextmanager
def forking_safely() -> Iterator[None]:
    """OpenCV held to one thread while worker processes are forked (the count before restored after). Its
    thread pool's threads are not copied by a fork, and a child that inherits a pool believing in them waits
    for them forever in its first parallel call (seen: a ``batch detect`` worker hung in the network's
    forward, forked from a process that had run OpenCV's DNN before). Nothing when OpenCV is not loaded."""
    cv2 = sys.modules.get("cv2")
    if cv2 is None:
        yield
        return
    before = cv2.getNumThreads()
    cv2.setNumThreads(1)
    try:
        yield
    finally:
        cv2.setNumThreads(before)


def reset_worker_signals() -> None:
    """In a forked worker: SIGTERM back to its default (the command line's handler, copied by the fork, would
    turn the pool's own termination of a worker into an interruption the worker unwinds)."""
    signal.signal(signal.SIGTERM, signal.SIG_DFL)


def _start_worker(state: Any, initializer: Callable[[], None] | None) -> None:
    global _state
    reset_worker_signals()
    _state = state
    if initializer is not None:
        initializer()


def _work(function: Callable[[Any, Item], Result], item: Item) -> Result:
    return function(_state, item)


def _context():
    methods = multiprocessing.get_all_start_methods()
    return multiprocessing.get_context("fork" if "fork" in methods else "spawn")


def ordered_map(function: Callable[[Any, Item], Result], state: Any, items: Iterable[Item], workers: int,
                ahead: int = AHEAD, initializer: Callable[[], None] | None = None
                ) -> Iterator[tuple[Item, Result]]:
    """``(item, function(state, item))`` for each of ``items``, in order (see the module docstring);
    ``function`` must be a module-level function (it is sent to the workers by name) and ``initializer``
    (if any) is run in each worker when it starts. ``workers`` ≤ 1: every item is worked here."""
    stream = iter(items)
    first = next(stream, None)
    if first is None:
        return
    yield first, function(state, first)
    if workers <= 1:
        for item in stream:
            yield item, function(state, item)
        return
    pool = ProcessPoolExecutor(max_workers=workers, mp_context=_context(), initializer=_start_worker,
                               initargs=(state, initializer))
    waiting: deque[tuple[Item, Future]] = deque()
    try:
        for item in stream:
            if waiting:
                waiting.append((item, pool.submit(_work, function, item)))
            else:  # (the first submit forks every worker)
                with forking_safely():
                    waiting.append((item, pool.submit(_work, function, item)))
            while len(waiting) >= workers * ahead:
                yield _done(function, state, *waiting.popleft())
        while waiting:
            yield _done(function, state, *waiting.popleft())
    finally:
        pool.shutdown(wait=True, cancel_futures=True)


def _done(function: Callable[[Any, Item], Result], state: Any, item: Item, future: Future
          ) -> tuple[Item, Result]:
    """The item's result from its worker, or worked again here when the worker failed with it."""
    try:
        return item, future.result()
    except Exception:  # noqa: BLE001 — worked again here: the plain loop's own error, or its result
        return item, function(state, item)
