"""Cyclic garbage is collected on the GUI thread only once work runs in other threads: a Qt object
destroyed by a collection in a worker deadlocks PySide (seen in the suite)."""

import gc
import threading
import weakref

from PySide6 import QtCore, QtWidgets

from usvips.gui.qt import app, main_window
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


def test_the_oldest_generation_is_collected_by_cpythons_long_lived_rule(qtbot):
    """A full collection scans every object: with a large heap kept (a survey's objects) it must run only
    when the heap has grown by a quarter since the last one, as CPython's own collector does — not every
    tenth middle collection (a 0.6 s freeze while scrolling 100,000 objects)."""
    collector = collect_on_the_gui_thread()
    full: list[int] = []

    def count(phase, info):
        if phase == "start" and info["generation"] == 2:
            full.append(1)

    def churn(rounds: int, keep: list | None = None) -> None:
        """Allocations and short-lived cycles, each round enough to make a middle collection due."""
        for _ in range(rounds):
            made = [_Cycle() for _ in range(gc.get_threshold()[0] + 1)]
            if keep is not None:
                keep.extend([k] for k in range(gc.get_threshold()[0] + 1))
            del made
            while collector.collect_due():
                pass

    # long-lived, tracked by the collector: more than a quarter of whatever this process holds, so that a full
    # collection is due whatever the collector saw before this test
    size = len(gc.get_objects()) // 2 + 50_000
    heap = [[k] for k in range(size)]
    gc.callbacks.append(count)
    try:
        cycle = (gc.get_threshold()[1] + 1) * (gc.get_threshold()[2] + 1)  # rounds from one full one to the next
        for _ in range(3 * cycle):
            churn(1)
            if full:
                break
        assert len(full) == 1  # the first one: the heap was never scanned
        total = len(gc.get_objects(generation=2))
        assert total >= len(heap)
        churn(5 * cycle)  # garbage only: the heap does not grow, no full collection is due
        assert len(full) == 1
        grown: list = []
        while len(grown) < 2 * total and len(full) == 1:  # the heap grows: one more, once by a quarter
            churn(1, keep=grown)
        assert len(full) == 2 and len(grown) >= total / 4
    finally:
        gc.callbacks.remove(count)
    assert len(heap) == size


def test_the_start_freezes_what_it_made_before_the_event_loop(qtbot, monkeypatch):
    # the window's start makes objects that live as long as the program: they are out of the GUI thread
    # collector's reach (gc.freeze, through keep_long_lived) before its first tick, which the event loop runs
    seen = []

    class Window:  # what app.run asks of the main window
        def show(self) -> None:
            seen.append("shown")

        def open_path(self, project, pair) -> None:
            seen.append(("opened", project, pair))

    monkeypatch.setattr(main_window, "MainWindow", Window)
    monkeypatch.setattr(app, "keep_long_lived", lambda: seen.append("frozen"))
    monkeypatch.setattr(QtWidgets.QApplication, "exec", lambda self: seen.append("event loop") or 0)
    assert app.run("survey.usvips", "air1") == 0
    assert seen == ["shown", ("opened", "survey.usvips", "air1"), "frozen", "event loop"]
