"""Python's cyclic garbage collected on the GUI thread only, once the window runs work in other threads.

The automatic collector runs in whichever thread happens to allocate when a generation's threshold is
crossed. When that is a worker and the garbage holds a Qt object (a widget of a closed dialog in a
reference cycle), the object is destroyed in the worker: PySide then deadlocks — the worker, inside
``QObject``'s destructor and holding its mutex, waits for the GIL, while the GUI thread, holding the GIL,
waits for that mutex to delete the object's parent (seen in the test suite, PySide6 6.11). So, as soon as
background work starts, automatic collection is switched off and a timer on the GUI thread collects each
generation when its threshold would have been crossed — the same thresholds, only never in a worker.
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
        self.timer = QtCore.QTimer(self)
        self.timer.setInterval(INTERVAL_MS)
        self.timer.timeout.connect(self.collect_due)
        self.timer.start()
        gc.disable()

    def collect_due(self) -> int:
        """Collect the oldest generation whose count has passed its threshold (and the younger ones with it);
        the number of unreachable objects found."""
        counts = gc.get_count()
        due = -1
        for generation in range(3):
            if counts[generation] > self.thresholds[generation]:
                due = generation
            else:
                break
        return gc.collect(due) if due >= 0 else 0


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
