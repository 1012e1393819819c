"""Edits from an out-of-date window on a shared survey (issue 34, item 1): two windows (two annotators'
workspaces) and a second process on one SQLite file and on one survey on the real PostgreSQL server the
suite starts. Every first save names the version the window read: a stale edit, record or delete is
refused by name (who changed it), nothing a colleague wrote is lost, and the refused edit is kept for
retry (on the object as it now is: only what this window changed is written) or discard."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

from tests.store.conftest import new_database, postgres_server  # noqa: F401 - the suite's real server
from usvips.core.observation_record import ObservationRecord
from usvips.gui.workspace import Workspace
from usvips.store.opening import create_project, open_project
from usvips.store.records import StaleEditError, Vertex


@pytest.fixture(params=["sqlite", "postgresql"])
def location(request, tmp_path) -> str:
    """A new survey with one stored object (id 1), as a file or on the server."""
    where = str(tmp_path / "shared.usvips") if request.param == "sqlite" else \
        request.getfixturevalue("new_database")("stale")
    with create_project(where) as project:
        project.annotator = "carl"
        project.add_object("length", [Vertex(10.0, 20.0, 8.0, 20.0), Vertex(40.0, 20.0, 38.0, 20.0)], "fish")
    return where


def _window(location: str, annotator: str) -> tuple[Workspace, list[tuple[str, str]]]:
    """A workspace (the window's model) on the survey, as ``annotator``, and what it says."""
    ws = Workspace()
    project = open_project(location)
    project.annotator = annotator
    ws.open_project(project)
    said: list[tuple[str, str]] = []
    ws.message.connect(lambda level, text: said.append((level, text)))
    return ws, said


def test_an_edit_from_an_out_of_date_window_is_refused_by_name_kept_and_retried_without_losing_the_other(location):
    ann, _ = _window(location, "ann")
    bob, said = _window(location, "bob")  # bob's window read the object before ann's edit
    try:
        ann.edits.edit_object(1, "fish", "ann's notes")
        bob.edits.edit_object(1, "cod", "")  # bob typed an attribute; his window still shows the old (empty) notes
        assert ann.project.object(1).notes == "ann's notes" and ann.project.object(1).attribute == "fish"
        ((level, text),) = [m for m in said if m[0] == "error"]
        assert "not saved" in text and "ann" in text and "\n" not in text
        assert bob.stored_object(1).notes == "ann's notes"  # the window shows the object as it now is
        assert list(bob.edits.unsaved) == [(1, "edit object 1")]
        assert bob.edits.retry_unsaved() == 1  # bob looked and saves his attribute again: ann's notes stay
        stored = bob.project.object(1)
        assert (stored.attribute, stored.notes) == ("cod", "ann's notes") and not bob.edits.unsaved
        assert [(h.annotator, h.change) for h in bob.project.history(1)] == [
            ("carl", "add"), ("ann", "edit"), ("bob", "edit")]
    finally:
        ann.close_project()
        bob.close_project()


def test_a_delete_and_a_record_from_an_out_of_date_window_are_refused_by_name_and_discarded_on_request(location):
    ann, _ = _window(location, "ann")
    bob, said = _window(location, "bob")
    try:
        ann.edits.edit_object(1, "fish", "ann: fresh edit")
        bob.edits.delete_object(1)  # from the out-of-date window: would remove ann's fresh edit
        assert ann.project.object(1).notes == "ann: fresh edit"
        assert "not saved" in said[-1][1] and "edit by ann" in said[-1][1]
        assert bob.stored_object(1).notes == "ann: fresh edit"  # re-read: bob now sees ann's edit
        assert bob.edits.discard_unsaved() == 1 and not bob.edits.unsaved
        assert bob.project.object(1).notes == "ann: fresh edit"
        bob.edits.set_record(1, ObservationRecord(genus="Pagrus", species="auratus"))  # bob's window is up to date
        with pytest.raises(StaleEditError, match="record by bob"):  # ann's is not: refused, bob's record kept
            ann.edits.set_record(1, ObservationRecord(genus="Gadus", species="morhua"))
        assert ann.project.record(1).genus == "Pagrus" and list(ann.edits.unsaved) == [
            (1, "observation record of object 1")]
        assert ann.edits.discard_unsaved() == 1 and ann.project.record(1).genus == "Pagrus"
    finally:
        ann.close_project()
        bob.close_project()


def test_an_edit_made_by_another_process_since_the_window_read_is_refused_by_name(location, tmp_path):
    ann, said = _window(location, "ann")
    try:
        script = ("import sys\nfrom usvips.store.opening import open_project\n"
                  "with open_project(sys.argv[1]) as p:\n    p.update_object(1, notes='dora: remeasured')\n")
        environment = {**os.environ, "USVIPS_ANNOTATOR": "dora"}
        subprocess.run([sys.executable, "-c", script, location], check=True, env=environment, timeout=120)
        ann.edits.edit_object(1, "snapper", "")
        assert ann.project.object(1).notes == "dora: remeasured" and ann.project.object(1).attribute == "fish"
        assert "edit by dora" in said[-1][1]
        assert ann.edits.retry_unsaved() == 1
        assert (ann.project.object(1).attribute, ann.project.object(1).notes) == ("snapper", "dora: remeasured")
    finally:
        ann.close_project()
