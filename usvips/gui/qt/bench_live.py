"""Benchmark of colleagues' changes seen live (area ``window_live``, issue 34 item 2): the time from bob's
commit to ann's object list showing it, target ≤ 2 s on either backend.

ann's window (offscreen, 1366 × 768) is open on the ROV sample's survey with a few hundred objects; bob,
through a handle of his own in the same process, adds an object, then edits one, several times. Each time
is taken, once the window has opened the survey and computed its first figures, from the moment bob's
write has returned (committed) until ann's object list shows it (the new row, the changed notes), the
window's event loop running meanwhile (the live feed's thread waits on the
store, reads the history and hands it over). ``ours_s`` is the slowest of these on the PostgreSQL survey
(``$USVIPS_BENCH_POSTGRES``, else a temporary server started with ``pgserver``), ``baseline_s`` the
slowest on the SQLite file holding the same; ``met`` when both are within the target. Without a server
the file's figure is the row's own and the baseline is null.
"""

from __future__ import annotations

import os
import tempfile
import time
import uuid
from collections.abc import Iterator
from pathlib import Path

from usvips.bench.postgres_server import bench_server

os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")

#: the longest a colleague's change may take to show (s)
TARGET_S = 2.0
#: objects in the survey at scale 1; bob's additions and edits timed per backend
OBJECTS, TRIALS = 500, 6
#: how long a change may take before the trial counts as failed (s)
GIVE_UP_S = 30.0


def _shown_times(location: str, folder: Path, trials: int) -> list[float]:
    """Seconds from each of bob's commits to ann's list showing it, on the survey at ``location``."""
    from PySide6 import QtCore

    from usvips.gui.qt.app import application
    from usvips.gui.qt.main_window import MainWindow
    from usvips.store.opening import open_project

    app = application()
    settings = QtCore.QSettings(str(folder / f"{uuid.uuid4().hex}.ini"), QtCore.QSettings.Format.IniFormat)
    window = MainWindow(settings=settings)
    window.resize(1366, 768)
    window.show()
    times: list[float] = []
    try:
        if not window.open_path(location):
            raise RuntimeError(f"the window did not open {location}")
        listing = window.object_list

        def until(shown) -> float:
            start = time.perf_counter()
            while not shown():
                if time.perf_counter() - start > GIVE_UP_S:
                    return float("inf")
                app.processEvents()
                time.sleep(0.001)
            return time.perf_counter() - start

        until(lambda: not window.busy and listing._worker is None)  # opened: the first figures computed
        with open_project(location) as bob:
            bob.annotator = "bob"
            template = bob.objects()[0]
            for k in range(trials):
                if k % 2 == 0:
                    new = bob.add_object(template.kind, list(template.vertices), "bob's fish")
                    times.append(until(lambda i=new: listing.row_of(i) is not None))
                else:
                    notes = f"bob: measured again ({k})"
                    bob.update_object(template.id, notes=notes)
                    times.append(until(lambda n=notes: listing.text(listing.row_of(template.id), "notes") == n))
    finally:
        window.workspace.close_project()
        window.close()
    return times


def live_row(scale: float = 1.0) -> dict:
    from urllib.parse import urlsplit, urlunsplit

    from usvips.gui.qt.bench import survey_project
    from usvips.store.transfer import push

    n = OBJECTS if scale >= 1 else max(50, int(OBJECTS * scale))
    trials = TRIALS if scale >= 1 else 2
    with tempfile.TemporaryDirectory(prefix="usvips-bench-live-") as folder:
        folder = Path(folder)
        survey = survey_project(folder / "survey", n)
        file_times = _shown_times(str(survey), folder, trials)
        server_times: list[float] = []
        with bench_server("usvips-bench-live-pg-") as (server_url, why_not):
            if server_url is not None:
                parts = urlsplit(server_url)
                url = urlunsplit((parts.scheme, parts.netloc, f"/bench_live_{uuid.uuid4().hex[:12]}", parts.query,
                                  ""))
                os.environ.setdefault("USVIPS_MEDIA_ROOT", str(survey.parent))
                try:
                    push(survey, url)
                    server_times = _shown_times(url, folder, trials)
                finally:
                    from usvips.store.postgres import database_command

                    database_command(url, "DROP DATABASE IF EXISTS {}")
    ours = max(server_times) if server_times else max(file_times)
    baseline = max(file_times) if server_times else None
    worst = max(server_times + file_times)
    return {"name": "a colleague's change shown: bob's commit until ann's object list shows it (slowest of "
                    f"{trials} additions and edits)", "n": n, "ours_s": round(ours, 4),
            "baseline": "the same on the SQLite file" if server_times else f"none ({why_not})",
            "baseline_s": None if baseline is None else round(baseline, 4),
            "ratio": round(ours / baseline, 2) if baseline else None, "target": None, "target_s": TARGET_S,
            "met": bool(worst <= TARGET_S), "server_s": [round(t, 4) for t in server_times],
            "file_s": [round(t, 4) for t in file_times], "load_1min": round(os.getloadavg()[0], 2)}


def benchmarks(scale: float = 1.0) -> Iterator[dict]:
    yield live_row(scale)
