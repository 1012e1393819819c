"""Colleagues' changes seen live (issue 34, item 2): ann's window is open on a survey — an SQLite file
shared on disk, and a survey on the real PostgreSQL server the suite starts — while bob adds, changes and
deletes objects through his own handle. Each appears, updates and disappears in ann's object list, the
overlays of both panes, the review queue and the QA panel without reopening, marked with bob's name; an
object ann is editing that bob changes or deletes shows the conflict in plain words and keeps her text.
Waits are conditions bounded by a timeout, never fixed sleeps."""

from __future__ import annotations

import threading

import numpy as np
import pytest
from PySide6 import QtCore, QtWidgets

from tests.gui.conftest import truth_pixels, wait_for_pair
from tests.store.conftest import new_database, postgres_server  # noqa: F401 - the suite's real server
from usvips.app.measure import measure_into_project
from usvips.app.samples import open_or_create_from_manifest
from usvips.core.observation_record import ObservationRecord, Species
from usvips.gui.qt import main_window
from usvips.store.opening import open_project
from usvips.store.transfer import push

SPECIES = Species("Sparidae", "Pagrus", "auratus", "37353001", max_length_m=0.30)  # the sample's fish1 is 0.46 m
BOUND_MS = 20000  # a bound on the waits, not a wait
_Role = QtCore.Qt.ItemDataRole


@pytest.fixture(params=["sqlite", "postgresql"])
def survey(request, sample_copy, monkeypatch):
    """(location, sample folder) of the tank sample's survey with its species list: the project file, or
    the same pushed to a new survey on the server (its images found in the sample folder)."""
    directory = sample_copy("tank_system1")
    with open_or_create_from_manifest(directory) as project:
        project.set_species_list([SPECIES])
        path = project.path
    if request.param == "sqlite":
        return str(path), directory
    url = request.getfixturevalue("new_database")("live")
    monkeypatch.setenv("USVIPS_MEDIA_ROOT", str(directory))
    push(path, url)
    return url, directory


@pytest.fixture
def bob(survey):
    """bob's own handle on the survey."""
    handle = open_project(survey[0])
    handle.annotator = "bob"
    yield handle
    handle.close()


def _ann(qtbot, make_window, location: str):
    window = make_window()
    window.set_annotator("ann")
    assert window.open_path(location, "measure1")
    wait_for_pair(qtbot, window, "measure1")
    return window


def _fish(bob, directory, name: str) -> int:
    """bob measures a fish of the sample on pair measure1 (its truth pixels) and names its species."""
    left, right = truth_pixels(directory, "measure1", "objects")
    pixels = np.array([[*left[name][p], *right[name][p]] for p in ("snout", "fork")], float)
    _, (object_id,) = measure_into_project(bob, "measure1", [(name, "length", pixels, "fish")])
    bob.set_record(object_id, ObservationRecord.of(SPECIES))
    return object_id


def _marked_by(window, object_id: int, who: str) -> bool:
    """The object list's row of ``object_id`` is tinted and says who changed it."""
    listing = window.object_list
    row = listing.row_of(object_id)
    if row is None:
        return False
    index = listing.model.index(row, listing.COLUMNS.index("notes"))
    return index.data(_Role.BackgroundRole) is not None and f"by {who} at" in (index.data(_Role.ToolTipRole) or "")


def _qa_rows(window, object_id: int) -> list[str]:
    """The QA panel's rows of ``object_id`` (their tooltips)."""
    table = window.qa.table_model
    return [table.data(table.index(r, 0), _Role.ToolTipRole) for r, row in enumerate(table.rows)
            if row.object_id == object_id]


def test_a_colleagues_new_changed_and_deleted_object_appears_updates_and_disappears_everywhere(
        qtbot, make_window, survey, bob):
    location, directory = survey
    window = _ann(qtbot, make_window, location)
    window.show_review()  # review mode: its queue
    window.docks["qa"].setFloating(True)  # the QA panel beside it, on screen
    window.docks["qa"].show()
    qtbot.waitUntil(window.qa.shown, timeout=BOUND_MS)
    overlay, queue, listing = window.overlay, window.review, window.object_list
    assert window.live.label.text() == "live"

    fish = _fish(bob, directory, "fish1")  # bob's new object: every view shows it, marked as bob's
    qtbot.waitUntil(lambda: _marked_by(window, fish, "bob"), timeout=BOUND_MS)
    assert listing.text(listing.row_of(fish), "species").startswith("Pagrus auratus")
    qtbot.waitUntil(lambda: fish in overlay.outlines, timeout=BOUND_MS)
    assert overlay.label(fish).endswith("· bob")
    assert fish in queue.model.queue
    assert "added by bob at" in queue.list.row_text(queue.model.queue.index(fish))
    qtbot.waitUntil(lambda: any("added by bob at" in tip for tip in _qa_rows(window, fish)), timeout=BOUND_MS)
    assert "live · bob added" in window.live.label.text()

    bob.update_object(fish, notes="bob: snout hidden", expected_modified=bob.object(fish).modified)  # changed
    qtbot.waitUntil(lambda: listing.row_of(fish) is not None and listing.text(listing.row_of(fish), "notes")
                    == "bob: snout hidden", timeout=BOUND_MS)
    assert _marked_by(window, fish, "bob") and "changed by bob at" in window.workspace.cache.marks[fish].text()
    assert "changed by bob at" in queue.list.row_text(queue.model.queue.index(fish))
    qtbot.waitUntil(lambda: any("changed by bob at" in tip for tip in _qa_rows(window, fish)), timeout=BOUND_MS)
    bob.set_review(fish, "flagged", "two fish overlap")  # bob's review: ann's list and queue show it
    qtbot.waitUntil(lambda: listing.text(listing.row_of(fish), "review") == "flagged: two fish overlap",
                    timeout=BOUND_MS)
    qtbot.waitUntil(lambda: queue.model.state(fish).state == "flagged", timeout=BOUND_MS)

    bob.delete_object(fish, expected_modified=bob.object(fish).modified)  # deleted: gone from every view
    qtbot.waitUntil(lambda: listing.row_of(fish) is None, timeout=BOUND_MS)
    assert fish not in overlay.outlines and fish not in queue.model.queue and fish not in window.workspace.cache
    qtbot.waitUntil(lambda: not _qa_rows(window, fish), timeout=BOUND_MS)
    assert "bob deleted object" in window.log.toPlainText()


def test_anns_own_edits_are_not_marked_as_a_colleagues(qtbot, make_window, survey, bob):
    location, directory = survey
    window = _ann(qtbot, make_window, location)
    ws = window.workspace
    fish = _fish(bob, directory, "fish2")
    qtbot.waitUntil(lambda: _marked_by(window, fish, "bob"), timeout=BOUND_MS)
    qtbot.waitUntil(lambda: fish in window.overlay.outlines, timeout=BOUND_MS)
    assert window.overlay.label(fish).endswith("· bob")
    ws.edits.edit_object(fish, "fish", "ann: checked")  # ann's own edit: no longer bob's change
    assert fish not in ws.cache.marks and not _marked_by(window, fish, "bob")
    assert not window.overlay.label(fish).endswith("· bob")  # the label drawn again without the mark
    window.show_review()
    window.review.model.go_to(fish)
    window.review.accept()  # ann's own review: stored, the window's version moves with it
    assert ws.stored_object(fish).modified == bob.object(fish).modified
    other = _fish(bob, directory, "fish1")  # read by the feed after ann's own edit and review
    qtbot.waitUntil(lambda: other in ws.cache, timeout=BOUND_MS)
    assert fish not in ws.cache.marks and other in ws.cache.marks  # ann's own writes never shown as bob's
    assert [c.who for c in window.live.recent] == ["bob", "bob"]


def test_a_change_committed_while_the_window_reads_the_survey_is_not_missed(qtbot, make_window, survey, bob,
                                                                            monkeypatch):
    """bob commits after the window's worker has read the objects and before they arrive: the feed's batch
    read meanwhile waits for them, then shows bob's fish marked as his."""
    location, directory = survey
    read, release = main_window.read_stored_objects, threading.Event()

    def held_read(where, cancelled):
        objects = read(where, cancelled)
        assert release.wait(BOUND_MS / 1000)  # the objects stay on their way until bob has committed
        return objects

    monkeypatch.setattr(main_window, "read_stored_objects", held_read)
    window = make_window()
    window.set_annotator("ann")
    assert window.open_path(location, "measure1")
    assert window.workspace.cache.loading
    fish = _fish(bob, directory, "fish2")
    qtbot.waitUntil(lambda: any(fish in b.object_ids for b in window.live._waiting), timeout=BOUND_MS)
    assert fish not in window.workspace.cache  # the batch waits: nothing folded against a cache being read
    release.set()
    wait_for_pair(qtbot, window, "measure1")
    qtbot.waitUntil(lambda: _marked_by(window, fish, "bob"), timeout=BOUND_MS)
    assert fish in window.overlay.outlines


def _edit_notes(qtbot, window, object_id: int, text: str) -> QtWidgets.QLineEdit:
    """ann opens the notes cell of ``object_id`` and types ``text`` (not yet Enter)."""
    listing = window.object_list
    window.docks["objects"].raise_()
    index = listing.model.index(listing.row_of(object_id), listing.COLUMNS.index("notes"))
    listing.table.setCurrentIndex(index)
    listing.table.edit(index)
    editor = listing.table.indexWidget(index)
    assert isinstance(editor, QtWidgets.QLineEdit)
    editor.selectAll()
    qtbot.keyClicks(editor, text)
    return editor


def test_an_object_ann_is_editing_that_bob_changes_shows_the_conflict_and_keeps_her_text(
        qtbot, make_window, survey, bob):
    location, directory = survey
    window = _ann(qtbot, make_window, location)
    ws = window.workspace
    fish = _fish(bob, directory, "fish1")
    qtbot.waitUntil(lambda: fish in ws.cache, timeout=BOUND_MS)
    editor = _edit_notes(qtbot, window, fish, "ann: tail bent")
    bob.update_object(fish, notes="bob: snout hidden")  # while ann types
    qtbot.waitUntil(lambda: "Conflict: bob changed object" in window.hint.text(), timeout=BOUND_MS)
    assert "while you are editing its notes" in window.hint.text()
    assert editor.text() == "ann: tail bent"  # her text stays in the cell
    qtbot.keyClick(editor, QtCore.Qt.Key.Key_Return)  # saved only if it does not overwrite bob's: refused
    listing = window.object_list
    qtbot.waitUntil(lambda: listing.text(listing.row_of(fish), "notes") == "bob: snout hidden", timeout=BOUND_MS)
    assert bob.object(fish).notes == "bob: snout hidden"  # bob's change is not lost
    assert list(ws.edits.unsaved) == [(fish, f"edit object {fish}")]  # ann's edit is kept …
    # said once the editor has closed (a turn of the event loop after the refused save's own line)
    qtbot.waitUntil(lambda: "“ann: tail bent”" in window.hint.text(), timeout=BOUND_MS)
    assert "Retry unsaved edits" in window.hint.text()
    assert _marked_by(window, fish, "bob")
    window.retry_unsaved_edits()  # … and saved over bob's when she says so
    assert bob.object(fish).notes == "ann: tail bent" and not ws.edits.unsaved


def test_an_object_ann_is_editing_that_bob_deletes_shows_the_conflict_and_keeps_her_text(
        qtbot, make_window, survey, bob):
    location, directory = survey
    window = _ann(qtbot, make_window, location)
    ws = window.workspace
    fish = _fish(bob, directory, "fish2")
    qtbot.waitUntil(lambda: fish in ws.cache, timeout=BOUND_MS)
    editor = _edit_notes(qtbot, window, fish, "ann: juvenile")
    bob.delete_object(fish)
    qtbot.waitUntil(lambda: "Conflict: bob deleted object" in window.hint.text(), timeout=BOUND_MS)
    assert editor.text() == "ann: juvenile" and fish in ws.cache  # not taken from under her cursor
    qtbot.keyClick(editor, QtCore.Qt.Key.Key_Return)
    qtbot.waitUntil(lambda: fish not in ws.cache, timeout=BOUND_MS)
    assert window.object_list.row_of(fish) is None
    assert list(ws.edits.unsaved) == [(fish, f"edit object {fish}")]
    assert "“ann: juvenile”" in window.hint.text() and "bob deleted the object" in window.hint.text()


def test_the_feed_stops_with_the_project_and_follows_the_next(qtbot, make_window, survey, bob, tmp_path):
    location, _ = survey
    window = _ann(qtbot, make_window, location)
    first = window.live.feed
    assert first is not None and first.thread.is_alive()
    window.workspace.close_project()
    assert window.live.feed is None and window.live.label.text() == ""
    qtbot.waitUntil(lambda: not first.thread.is_alive(), timeout=BOUND_MS)
    assert window.open_path(location, "measure1")
    assert window.live.feed is not None and window.live.feed is not first


def test_an_object_reviewed_in_review_mode_can_be_edited_next(qtbot, make_window, survey, bob):
    """A review moves the object's version: the window holds the new one, so its next edit is not refused
    as a stale one (by the user's own name)."""
    location, directory = survey
    window = _ann(qtbot, make_window, location)
    ws = window.workspace
    fish = _fish(bob, directory, "fish1")
    qtbot.waitUntil(lambda: fish in ws.cache, timeout=BOUND_MS)
    window.show_review()
    window.review.model.go_to(fish)
    window.review.accept()
    ws.edits.edit_object(fish, "fish", "ann: after review")
    assert not ws.edits.unsaved and bob.object(fish).notes == "ann: after review"


def test_a_colleagues_import_is_read_again_whole_and_marked(qtbot, make_window, survey, bob, monkeypatch):
    from usvips.gui.qt import live_updates

    monkeypatch.setattr(live_updates, "MANY", 2)  # more objects at once than this: every object read again
    location, directory = survey
    window = _ann(qtbot, make_window, location)
    resets: list[int] = []
    window.workspace.objects_reset.connect(lambda: resets.append(1))
    left, right = truth_pixels(directory, "measure1", "objects")
    pixels = np.array([[*left["fish1"][p], *right["fish1"][p]] for p in ("snout", "fork")], float)
    _, ids = measure_into_project(bob, "measure1", [(f"f{k}", "length", pixels, "fish") for k in range(3)])
    qtbot.waitUntil(lambda: all(_marked_by(window, i, "bob") for i in ids), timeout=BOUND_MS)
    assert resets and all(i in window.overlay.outlines for i in ids)


def test_an_observation_record_ann_is_typing_that_bob_changes_shows_the_conflict_and_keeps_her_entries(
        qtbot, make_window, survey, bob):
    location, directory = survey
    window = _ann(qtbot, make_window, location)
    ws, form = window.workspace, window.observation
    fish = _fish(bob, directory, "fish1")
    qtbot.waitUntil(lambda: fish in ws.cache, timeout=BOUND_MS)
    window.activateWindow()
    window.docks["observation"].raise_()
    form.begin(fish)  # the form takes the keyboard
    qtbot.waitUntil(lambda: form.isAncestorOf(QtWidgets.QApplication.focusWidget()), timeout=BOUND_MS)
    form.number.setValue(7)
    form.comment.setText("ann: a school of seven")
    bob.set_record(fish, ObservationRecord.of(SPECIES, number=2))  # while ann types
    qtbot.waitUntil(lambda: "Conflict: bob changed object" in window.hint.text(), timeout=BOUND_MS)
    assert "while you are editing its observation record" in window.hint.text() and "in the form" in window.hint.text()
    assert not form.store()  # Enter: refused rather than written over bob's record …
    assert bob.record(fish).number == 2 and form.number.value() == 7  # … her entries stay in the form
    assert list(ws.edits.unsaved) == [(fish, f"observation record of object {fish}")]
    window.focus_images()  # she leaves the form: the object is read again, bob's record shown, marked
    qtbot.waitUntil(lambda: _marked_by(window, fish, "bob"), timeout=BOUND_MS)
    assert ws.cache.record(fish).number == 2 and "is kept unsaved" in window.hint.text()


def test_a_review_made_from_the_command_line_in_another_process_appears_marked(qtbot, make_window, survey, bob):
    import os
    import subprocess
    import sys

    location, directory = survey
    window = _ann(qtbot, make_window, location)
    fish = _fish(bob, directory, "fish1")
    qtbot.waitUntil(lambda: fish in window.workspace.cache, timeout=BOUND_MS)
    subprocess.run([sys.executable, "-m", "usvips", "project", "review", location, "--flag", str(fish), "--reason",
                    "snout hidden", "--annotator", "dora"], check=True, capture_output=True, timeout=120,
                   env={**os.environ, "USVIPS_ANNOTATOR": "dora"})
    listing = window.object_list
    qtbot.waitUntil(lambda: listing.text(listing.row_of(fish), "review") == "flagged: snout hidden", timeout=BOUND_MS)
    who = bob.history(fish)[-1].annotator  # the name the store recorded for the other process
    assert _marked_by(window, fish, who) and window.workspace.cache.marks[fish].changes == ("review",)


def test_a_change_the_window_already_holds_is_not_shown_and_keeps_the_mark_it_had(qtbot, make_window, survey, bob):
    """A batch read before a later write of the window itself (its review, its undo) names an object the
    window, read again, holds as stored: nothing to show, and the colleague's mark it had stays."""
    from usvips.app.live_changes import ColleagueChange

    location, directory = survey
    window = _ann(qtbot, make_window, location)
    fish = _fish(bob, directory, "fish1")
    qtbot.waitUntil(lambda: _marked_by(window, fish, "bob"), timeout=BOUND_MS)
    shown = list(window.live.recent)
    window.live.apply([ColleagueChange(fish, "changed", "ann", "2026-11-28T12:41:00+00:00", ("review",))])
    assert window.workspace.cache.marks[fish].who == "bob" and _marked_by(window, fish, "bob")
    assert window.live.recent == shown and window.overlay.label(fish).endswith("· bob")
