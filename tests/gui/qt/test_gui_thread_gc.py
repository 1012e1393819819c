"""Cyclic garbage is collected on the GUI thread only once work runs in other threads: a Qt object
destroyed by a collection in a worker deadlocks PySide (seen in the suite)."""

import gc
import threading
import weakref

from PySide6 import QtCore

from usvips.gui.qt.gui_thread_gc import GuiThreadCollector, collect_on_the_gui_thread
from usvips.gui.qt.worker import Worker


class _Cycle:
    """Garbage in a reference cycle that records the thread it was collected in."""

    died_in: list = []

    def __init__(self) -> None:
        self.me = self

    def __del__(self) -> None:
        _Cycle.died_in.append(threading.current_thread().name)


def test_garbage_made_in_a_worker_is_collected_on_the_gui_thread(qtbot):
    _Cycle.died_in = []
    worker = Worker(lambda progress, cancelled: [_Cycle() for _ in range(20 * gc.get_threshold()[0])][-1:] and None,
                    "making garbage")
    assert not gc.isenabled()  # the first worker switched automatic collection to the GUI thread
    pool = QtCore.QThreadPool()
    with qtbot.waitSignal(worker.signals.finished, timeout=30000):
        pool.start(worker)
    pool.waitForDone()
    qtbot.waitUntil(lambda: len(_Cycle.died_in) >= 20 * gc.get_threshold()[0], timeout=10000)
    assert set(_Cycle.died_in) == {threading.main_thread().name}


def test_the_collector_is_installed_once_and_collects_what_is_due(qtbot):
    first = collect_on_the_gui_thread()
    assert isinstance(first, GuiThreadCollector) and collect_on_the_gui_thread() is first
    gc.enable()  # switched back on by someone: the next call keeps the rule
    assert collect_on_the_gui_thread() is first and not gc.isenabled()
    gc.collect()
    assert first.collect_due() == 0  # nothing due right after a full collection
    cycle = _Cycle()
    alive = weakref.ref(cycle)
    del cycle
    kept = [[] for _ in range(2 * gc.get_threshold()[0])]  # allocations the collector counts
    qtbot.waitUntil(lambda: alive() is None, timeout=5000)
    assert len(kept) > gc.get_threshold()[0]


def test_off_the_gui_thread_nothing_is_installed():
    found = []
    thread = threading.Thread(target=lambda: found.append(collect_on_the_gui_thread()))
    thread.start()
    thread.join()
    assert found == [None]
