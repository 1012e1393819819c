"""A worker's thread yields the cores to the GUI thread: on Linux bulk work runs at BACKGROUND_NICE (the
threads it starts inherit it), the GUI thread keeps its own priority, a thread already nicer is left as it
is, and work a user waits on to see (a video frame) keeps the GUI's priority in a pool of its own."""

import os
import sys
import threading

import pytest

from usvips.gui.qt.worker import BACKGROUND_NICE, Worker, _yield_to_the_gui, start

linux = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="a thread's own priority is Linux's")


@linux
def test_a_workers_thread_runs_nicer_than_the_gui_thread(qtbot):
    gui = os.getpriority(os.PRIO_PROCESS, threading.get_native_id())
    seen = []

    def job(progress, cancelled):
        seen.append(os.getpriority(os.PRIO_PROCESS, threading.get_native_id()))
        child = threading.Thread(target=lambda: seen.append(os.getpriority(os.PRIO_PROCESS, threading.get_native_id())))
        child.start()
        child.join()
        return True

    worker = Worker(job, "a job")
    with qtbot.waitSignal(worker.signals.finished, timeout=10000):
        start(worker)
    assert seen == [max(gui, BACKGROUND_NICE)] * 2  # the worker and a thread it started
    assert os.getpriority(os.PRIO_PROCESS, threading.get_native_id()) == gui


@linux
def test_the_main_thread_is_never_made_nicer():
    before = os.getpriority(os.PRIO_PROCESS, threading.get_native_id())
    _yield_to_the_gui()  # a job run directly on the GUI thread
    assert os.getpriority(os.PRIO_PROCESS, threading.get_native_id()) == before


@linux
def test_a_thread_already_nicer_is_left_as_it_is():
    seen = []

    def run():
        os.setpriority(os.PRIO_PROCESS, threading.get_native_id(), BACKGROUND_NICE + 5)
        _yield_to_the_gui()
        seen.append(os.getpriority(os.PRIO_PROCESS, threading.get_native_id()))

    thread = threading.Thread(target=run)
    thread.start()
    thread.join()
    assert seen == [BACKGROUND_NICE + 5]


@linux
def test_work_a_user_waits_on_keeps_the_guis_priority_in_a_pool_of_its_own(qtbot):
    """A worker that is not bulk work (the video frame a user steps to) leaves its thread's priority as the
    GUI thread's; the video controls decode in a pool of their own, since a thread that ran bulk work stays
    nicer (its priority cannot be raised back)."""
    from PySide6 import QtCore

    gui = os.getpriority(os.PRIO_PROCESS, threading.get_native_id())
    seen = []

    def job(progress, cancelled):
        seen.append(os.getpriority(os.PRIO_PROCESS, threading.get_native_id()))

    pool = QtCore.QThreadPool()
    pool.setMaxThreadCount(1)
    for background in (False, True, False):
        worker = Worker(job, "decoding frame 3", background=background)
        with qtbot.waitSignal(worker.signals.finished, timeout=10000):
            start(worker, pool)
    pool.waitForDone(5000)
    nicer = max(gui, BACKGROUND_NICE)
    assert seen == [gui, nicer, nicer]  # one thread: after bulk work it stays nicer, hence the own pool

