"""Opening a project reads its objects in the window's worker, on a read-only handle of its own (issue 37
item 3): the window shows the pair at once, the object list says it is reading, and the object list, the
overlays and the review queue show the objects once they arrive; objects read for a project closed or
replaced meanwhile are never shown. Waits are conditions bounded by a timeout, never fixed sleeps."""

from __future__ import annotations

import shutil
import threading

import numpy as np

from tests.gui.conftest import truth_pixels, wait_for_pair
from usvips.app.measure import measure_into_project
from usvips.app.samples import open_or_create_from_manifest
from usvips.gui.qt import main_window

BOUND_MS = 20000  # a bound on the waits, not a wait


def _with_fish(directory, names: list[str], attribute: str) -> list[int]:
    """The sample's fish ``names`` measured on pair measure1 (their truth pixels) and stored with
    ``attribute``; their ids."""
    left, right = truth_pixels(directory, "measure1", "objects")
    picked = [(name, "length", np.array([[*left[name][p], *right[name][p]] for p in ("snout", "fork")], float),
               attribute) for name in names]
    with open_or_create_from_manifest(directory) as project:
        _, ids = measure_into_project(project, "measure1", picked)
    return list(ids)


def _held_reads(monkeypatch) -> dict[str, threading.Event]:
    """The window's reads of the objects held until their location's event is set (unheld: not listed)."""
    read, held = main_window.read_stored_objects, {}

    def held_read(where, cancelled):
        objects = read(where, cancelled)
        release = next((event for name, event in held.items() if name in str(where)), None)
        if release is not None:
            assert release.wait(BOUND_MS / 1000)
        return objects

    monkeypatch.setattr(main_window, "read_stored_objects", held_read)
    return held


def _listed(window) -> list[tuple[int, str]]:
    listing = window.object_list
    return [(listing.object_id(r), listing.text(r, "attribute")) for r in range(listing.row_count())]


def test_the_objects_arrive_from_the_worker_in_the_list_the_overlays_and_the_review_queue(
        qtbot, make_window, sample_copy, monkeypatch):
    directory = sample_copy("tank_system1")
    ids = _with_fish(directory, ["fish1", "fish2"], "first")
    held = _held_reads(monkeypatch)
    held["tank_system1"] = release = threading.Event()
    window = make_window()
    assert window.open_path(directory, "measure1")
    ws = window.workspace
    assert ws.cache.loading and not ws.cache.ids()  # nothing half-filled: empty until the read arrives
    assert window.object_list.reading.isVisibleTo(window.object_list) and window.object_list.row_count() == 0
    qtbot.waitUntil(lambda: ws.pair == "measure1", timeout=BOUND_MS)  # the pair is shown meanwhile
    assert ws.cache.loading and not window.overlay.outlines
    window.show_review()
    assert window.review.model.queue == []
    release.set()
    wait_for_pair(qtbot, window, "measure1")
    assert not ws.cache.loading and ws.cache.ids() == ids
    assert _listed(window) == [(i, "first") for i in ids]
    assert not window.object_list.reading.isVisibleTo(window.object_list)
    qtbot.waitUntil(lambda: set(ids) <= set(window.overlay.outlines), timeout=BOUND_MS)
    assert sorted(window.review.model.queue) == ids


def test_objects_read_for_a_project_replaced_or_closed_meanwhile_are_never_shown(
        qtbot, make_window, sample_copy, tmp_path, monkeypatch):
    first = sample_copy("tank_system1")
    second = shutil.copytree(first, tmp_path / "second_survey")
    _with_fish(first, ["fish1", "fish2"], "first")
    second_ids = _with_fish(second, ["fish2"], "second")
    held = _held_reads(monkeypatch)
    held["tank_system1"] = release = threading.Event()
    window = make_window()
    ws = window.workspace
    assert window.open_path(first, "measure1")
    assert window.open_path(second, "measure1")  # the first project's read still in flight
    qtbot.waitUntil(lambda: not ws.cache.loading, timeout=BOUND_MS)
    assert _listed(window) == [(i, "second") for i in second_ids]
    release.set()
    wait_for_pair(qtbot, window, "measure1")  # the first read has come back (the window is no longer busy)
    assert _listed(window) == [(i, "second") for i in second_ids]
    assert sorted(window.overlay.outlines) == second_ids

    held["second_survey"] = again = threading.Event()
    assert window.open_path(second, "measure1")
    ws.close_project()  # closed while its read is in flight
    again.set()
    qtbot.waitUntil(lambda: not window.busy, timeout=BOUND_MS)
    assert ws.project is None and not ws.cache.ids() and window.object_list.row_count() == 0
