"""Python's cyclic garbage collected on the GUI thread only, once the window runs work in other threads.

The automatic collector runs in whichever thread happens to allocate when a generation's threshold is
crossed. When that is a worker and the garbage holds a Qt object (a widget of a closed dialog in a
reference cycle), the object is destroyed in the worker: PySide then deadlocks — the worker, inside
``QObject``'s destructor and holding its mutex, waits for the GIL, while the GUI thread, holding the GIL,
waits for that mutex to delete the object's parent (seen in the test suite, PySide6 6.11). So, as soon as
background work starts, automatic collection is switched off and a timer on the GUI thread collects each
generation when its threshold would have been crossed — the same thresholds, only never in a worker.

CPython's own rule for the oldest generation is kept too: a full collection runs only when the objects
promoted into it since the last full one exceed a quarter of those it held then (``long_lived_pending >
long_lived_total / 4`` in CPython's collector). Without that rule every tenth middle collection was a full
one, and with a survey of 100,000 objects open a full collection holds the GUI thread 0.1–0.45 s.
"""

from __future__ import annotations

import gc

from PySide6 import QtCore

#: how often the GUI thread looks at the collector's counts (ms); collecting is cheap when there is little
INTERVAL_MS = 250


class GuiThreadCollector(QtCore.QObject):
    """Collects on the GUI thread what the automatic collector would have (:func:`collect_on_the_gui_thread`)."""

    def __init__(self, parent: QtCore.QObject) -> None:
        super().__init__(parent)
        self.thresholds = gc.get_threshold()
        #: objects in the oldest generation after the last full collection, and promoted into it since
        self.long_lived_total, self.long_lived_pending = 0, 0
        self.timer = QtCore.QTimer(self)
        self.timer.setInterval(INTERVAL_MS)
        self.timer.timeout.connect(self.collect_due)
        self.timer.start()
        gc.disable()

    def collect_due(self) -> int:
        """Collect the oldest generation whose count has passed its threshold (and the younger ones with it),
        the oldest only under CPython's long-lived rule (see the module docstring); the number of unreachable
        objects found."""
        counts = gc.get_count()
        due = -1
        for generation in range(3):
            if counts[generation] > self.thresholds[generation]:
                due = generation
            else:
                break
        if due == 2 and self.long_lived_pending <= self.long_lived_total / 4:
            due = 1
        if due < 0:
            return 0
        if due == 2:
            found = gc.collect(2)
            self.long_lived_total, self.long_lived_pending = len(gc.get_objects(generation=2)), 0
            return found
        if due == 0:
            return gc.collect(0)
        young = len(gc.get_objects(generation=0)) + len(gc.get_objects(generation=1))
        found = gc.collect(1)
        self.long_lived_pending += max(young - found, 0)  # the survivors move into the oldest generation
        return found


def collect_on_the_gui_thread() -> GuiThreadCollector | None:
    """Switch automatic collection to the GUI thread (once per application; called from the GUI thread
    when work is first sent to another thread). None without a QApplication or off the GUI thread."""
    app = QtCore.QCoreApplication.instance()
    if app is None or QtCore.QThread.currentThread() != app.thread():
        return None
    collector = app.findChild(GuiThreadCollector)
    if collector is None:
        collector = GuiThreadCollector(app)
    elif gc.isenabled():  # someone switched it back on (a test): keep the rule
        gc.disable()
    return collector


def keep_long_lived() -> None:
    """After a large read has arrived (a survey's objects, read in a worker while automatic collection is
    off, so all still in the youngest generation): everything alive now is put out of the collector's reach
    (``gc.freeze``), so that no later collection on the GUI thread scans it — the first ones after a read
    of 100,000 objects took 0.2–0.45 s each. Reference counting frees frozen objects as always; cyclic
    garbage alive at that moment waits for :func:`release_long_lived`."""
    gc.freeze()
    collector = collect_on_the_gui_thread()
    if collector is not None:
        collector.long_lived_total, collector.long_lived_pending = 0, 0


def release_long_lived() -> None:
    """Before another survey is read: what :func:`keep_long_lived` froze goes back to the oldest generation
    (``gc.unfreeze``), counted as promoted there, so the long-lived rule collects it once in due course."""
    frozen = gc.get_freeze_count()
    gc.unfreeze()
    collector = collect_on_the_gui_thread()
    if collector is not None and frozen:
        collector.long_lived_pending += frozen
