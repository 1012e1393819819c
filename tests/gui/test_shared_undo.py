"""Undo on a shared survey: two windows (two annotators' handles) on one project. Ctrl+Z in the first of
an edit the second annotator has edited over since is refused in one line naming the object and who, and
nothing changes; the undo stack stays usable (the next Ctrl+Z takes back the step before, Redo redoes
it)."""

from __future__ import annotations

import pytest
from PySide6 import QtCore, QtWidgets

from tests.gui.conftest import open_sample, truth_pixels
from usvips.app.samples import open_or_create_from_manifest
from usvips.gui.workspace import Workspace, load_pair_images
from usvips.store import Project
from usvips.store.records import StaleEditError, Vertex

Key = QtCore.Qt.Key
CTRL = QtCore.Qt.KeyboardModifier.ControlModifier


def _press(qtbot, window, key, modifiers) -> None:
    """A key pressed in ``window`` (made the active one first: two windows are open)."""
    window.activateWindow()
    qtbot.waitUntil(window.isActiveWindow, timeout=5000)
    window.focus_images()
    qtbot.keyClick(QtWidgets.QApplication.focusWidget(), key, modifiers)


def test_ctrl_z_over_another_annotators_later_edit_is_refused_in_one_line_and_the_stack_stays_usable(
        qtbot, make_window, sample_copy, tmp_path):
    directory = sample_copy("tank_system1")
    alice, bob = make_window(tmp_path / "alice.ini"), make_window(tmp_path / "bob.ini")
    assert alice.set_annotator("alice") and bob.set_annotator("bob")
    open_sample(qtbot, alice, directory, "measure1")
    mine = alice.workspace
    ids = [mine.project.add_object("point", [Vertex(300.0 + 40 * k, 200.0, 280.0 + 40 * k, 200.0,
                                                    pair="measure1")], "fish") for k in range(2)]
    mine.reload_objects()
    mine.edits.edit_object(ids[0], "cod", "alice: first")   # two steps on alice's undo stack
    mine.edits.edit_object(ids[1], "ling", "alice: second")
    open_sample(qtbot, bob, directory, "measure1")
    bob.workspace.edits.edit_object(ids[1], "haddock", "bob: measured again")  # over alice's edit
    bobs, kept = mine.project.object_rows(ids[1]), mine.project.history()
    _press(qtbot, alice, Key.Key_Z, CTRL)
    said = alice.statusBar().currentMessage()
    assert said.startswith("cannot undo: ") and "\n" not in said
    assert f"object {ids[1]} was changed by someone else" in said and "edit by bob" in said
    assert mine.project.object_rows(ids[1]) == bobs and mine.project.history() == kept  # nothing changed
    assert mine.stored_object(ids[1]).attribute == "haddock"
    # the stack stays usable: the refused step is dropped, the one before is taken back and redone
    assert alice.workspace.undo.undo_label == f"edit object {ids[0]}"
    assert alice.actions["undo"].toolTip() == f"Undo edit object {ids[0]} (Ctrl+Z)"
    _press(qtbot, alice, Key.Key_Z, CTRL)
    assert alice.statusBar().currentMessage() == f"undone: edit object {ids[0]}"
    assert mine.project.object(ids[0]).attribute == "fish" and mine.stored_object(ids[0]).notes == ""
    alice.actions["redo"].trigger()
    assert alice.statusBar().currentMessage() == f"redone: edit object {ids[0]}"
    assert mine.project.object(ids[0]).notes == "alice: first"
    assert mine.project.object_rows(ids[1]) == bobs
    # bob's own Ctrl+Z is his to make: nobody changed the object since he left it
    _press(qtbot, bob, Key.Key_Z, CTRL)
    assert bob.statusBar().currentMessage() == f"undone: edit object {ids[1]}"
    assert mine.project.object(ids[1]).notes == "alice: second"


def test_undo_of_a_store_and_redo_of_a_delete_are_refused_over_another_annotators_edit(sample_copy):
    """The window's other steps on an object name the version they left too: undoing the store of an
    object someone else has edited since would delete their edit, redoing a delete of an object someone
    edited after the undo would too — both are refused by name, the object stays as they left it, and the
    refused step leaves the stack."""
    directory = sample_copy("tank_system1")
    project = open_or_create_from_manifest(directory)
    ws = Workspace()
    ws.open_project(project)
    try:
        ws.set_pair("measure1", *load_pair_images(project, "measure1"))
        left, right = truth_pixels(directory, "measure1", "objects")
        ws.pick_tool.set_tool("line")
        for point in ("snout", "fork"):
            ws.pick_tool.pick("left", left["fish1"][point])
            ws.pick_tool.pick("right", right["fish1"][point])
        first = ws.pick_tool.finish_object("fish")
        for point in ("snout", "fork"):
            ws.pick_tool.pick("left", left["fish1"][point])
            ws.pick_tool.pick("right", right["fish1"][point])
        second = ws.pick_tool.finish_object("fish")
        ws.edits.delete_object(first)
        ws.undo.undo()  # the delete taken back: the redo would delete it again
        with Project.open(project.path) as other:
            other.annotator = "bob"
            other.update_object(first, notes="bob: checked")
            other.update_object(second, notes="bob: checked too")
        with pytest.raises(StaleEditError, match=f"object {first} was changed by someone else.*edit by bob"):
            ws.undo.redo()
        assert ws.undo.redo_label is None and ws.project.object(first).notes == "bob: checked"
        assert ws.stored_object(first).notes == "bob: checked"  # the window shows it as it now is
        assert ws.undo.undo_label == "store length"
        with pytest.raises(StaleEditError, match=f"object {second} was changed by someone else.*edit by bob"):
            ws.undo.undo()  # the store of the second object
        assert ws.project.object(second).notes == "bob: checked too"
        # the rest of the stack stays usable: the picks' steps go back, the first store is refused too
        refused = 0
        while ws.undo.undo_label is not None:
            try:
                ws.undo.undo()
            except StaleEditError as error:
                assert f"object {first} was changed by someone else" in str(error)
                refused += 1
        assert refused == 1 and [o.notes for o in ws.project.objects()] == ["bob: checked", "bob: checked too"]
    finally:
        ws.close_project()
