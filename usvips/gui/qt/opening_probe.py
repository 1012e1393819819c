"""What a user waits for when opening a survey in the window, timed offscreen (issue 26: a survey of 10,000
objects on a server opened in the window in ≤ 2 s). Run in its own process by ``usvips bench`` (area
``server``, :mod:`usvips.bench.server`), which cannot import the GUI::

    python -m usvips.gui.qt.opening_probe SETTINGS.ini REPEATS LOCATION [LOCATION ...]

A main window is built and shown offscreen (not timed: that is start-up, timed elsewhere); then each
location (a project file or a ``postgresql://`` URL) is opened ``REPEATS`` times in turn, each time through
``MainWindow.open_path`` as File › Open does, and timed from the call until the object list holds every
object (read by the window's worker) and shows the rows on screen with their figures (the figures of the
other rows are computed when they are drawn). Prints one JSON line: for each location the best of
its repeats, ``open_s`` (the whole wait), ``rows_s`` (until the list held its rows, figures pending),
``cpu_s`` (the CPU time of the whole wait, every thread: what a loaded shared machine does not blur),
``freeze_s`` (the longest the GUI thread went without handling events: File › Open's call or one turn of the
event loop after it — the worst freeze while the survey opens) and ``objects`` (the rows the list held).
"""

from __future__ import annotations

import json
import os
import sys
import time

os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")

#: the longest one opening may take before the probe gives up (seconds)
DEADLINE_S = 300.0


def _open_once(app, window, location: str) -> tuple[float, float, float, int, float]:
    """(seconds until the list's rows, seconds until every figure, CPU seconds of the process meanwhile (every
    thread), rows, the longest the GUI thread went without handling events meanwhile) for one opening of
    ``location``. The last is the worst freeze a user sees while the survey opens: File › Open's own call,
    or one turn of the event loop after it (the pair drawn, the figures of the rows on screen shown)."""
    listing = window.object_list
    cpu = time.process_time()
    start = time.perf_counter()
    if not window.open_path(location):
        raise SystemExit(f"the window did not open {location}")
    rows, freeze, settled = None, time.perf_counter() - start, 0

    def waiting() -> bool:  # the objects, then the figures of the rows on screen (asked for as drawn)
        return (window.workspace.cache.loading or listing._worker is not None or listing._wanted_timer.isActive()
                or any(listing.text(r, "figure") == "computing…" for r in listing.visible_rows()))

    while settled < 2:  # two turns of the event loop in a row with nothing left to wait for (the rows laid out)
        if rows is None and not window.workspace.cache.loading:
            rows = time.perf_counter() - start
        turn = time.perf_counter()
        app.processEvents()
        freeze = max(freeze, time.perf_counter() - turn)
        settled = 0 if waiting() else settled + 1
        if time.perf_counter() - start > DEADLINE_S:
            raise SystemExit(f"the figures of {location} were not computed in {DEADLINE_S:.0f} s")
        time.sleep(0.001)
    done = time.perf_counter() - start
    rows = done if rows is None else rows
    cpu = time.process_time() - cpu
    pending = [r for r in listing.visible_rows() if listing.text(r, "figure") == "computing…"]
    if pending:
        raise SystemExit(f"{len(pending)} figures of {location} on screen were never shown")
    return rows, done, cpu, listing.row_count(), freeze


def main(argv: list[str]) -> int:
    settings_path, repeats, *locations = argv
    from PySide6 import QtCore

    from usvips.gui.qt.app import application

    app = application()
    from usvips.gui.qt.main_window import MainWindow

    window = MainWindow(settings=QtCore.QSettings(settings_path, QtCore.QSettings.Format.IniFormat))
    window.show()
    app.processEvents()
    best: dict[str, dict] = {}
    for _ in range(max(1, int(repeats))):
        for location in locations:
            rows, done, cpu, count, freeze = _open_once(app, window, location)
            known = best.setdefault(location, {"open_s": done, "rows_s": rows, "cpu_s": cpu, "objects": count,
                                               "freeze_s": freeze})
            for key, value in (("open_s", done), ("rows_s", rows), ("cpu_s", cpu), ("freeze_s", freeze)):
                known[key] = min(known[key], value)
    window.workspace.close_project()
    print(json.dumps(best))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
