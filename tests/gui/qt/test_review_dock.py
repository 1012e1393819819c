"""Review mode, the annotator and an object's history in the window: Ctrl+Shift+R gives the review panel
the keyboard; N, P, A, F, S and J/Enter walk, accept, flag, skip and go to the objects; the object list
shows each review; the annotator's name is set once, shown in the title bar and stamped on every write;
H on an object's row shows its history."""

from __future__ import annotations

import shutil
from pathlib import Path

from PySide6 import QtCore, QtWidgets

from tests.gui.conftest import open_sample, wait_for_pair
from usvips.gui.qt.annotator_dialog import SETTINGS_KEY, AnnotatorDialog
from usvips.gui.qt.review_dock import ReasonDialog
from usvips.store.records import Vertex

Key = QtCore.Qt.Key
CTRL_SHIFT = QtCore.Qt.KeyboardModifier.ControlModifier | QtCore.Qt.KeyboardModifier.ShiftModifier


def _objects_on_two_pairs(window) -> list[int]:
    """Four points stored on the sample's pairs (two on each), as the window's annotator."""
    ws = window.workspace
    ids = [ws.project.add_object("point", [Vertex(300.0 + 40 * k, 200.0, 280.0 + 40 * k, 200.0, pair=pair)], "fish")
           for k, pair in enumerate(("measure1", "water1", "measure1", "water1"))]
    ws.reload_objects()
    return ids


def _review_column(window, object_id: int) -> str:
    return window.object_list.text(window.object_list.row_of(object_id), "review")


def test_review_mode_walks_the_unreviewed_objects_by_keyboard(qtbot, make_window, sample_copy):
    window = make_window()
    assert window.set_annotator("Second Reader")
    directory = sample_copy("tank_system1")
    open_sample(qtbot, window, directory, "measure1")
    ws = window.workspace
    ids = _objects_on_two_pairs(window)
    ws.project.set_review(ids[3], "accepted")  # reviewed before: not in the queue
    window.object_list.refresh()
    assert _review_column(window, ids[3]) == "accepted" and _review_column(window, ids[0]) == "unreviewed"
    window.load_pair("water1")
    wait_for_pair(qtbot, window, "water1")
    reasons = iter(["snout hidden", None])  # the second flag is cancelled
    window.review.ask_reason = lambda object_id: next(reasons)
    view_menu = next(a.menu() for a in window.menuBar().actions() if a.text() == "&View")
    assert window.actions["review"] in view_menu.actions()
    window.focus_images()
    qtbot.keyClick(QtWidgets.QApplication.focusWidget(), Key.Key_R, CTRL_SHIFT)
    queue = window.review.list
    qtbot.waitUntil(queue.hasFocus, timeout=5000)
    # the queue: by pair label, then id (measure1's two, then water1's)
    assert window.review.model.queue == [ids[0], ids[2], ids[1]]
    assert window.review.progress.text() == "0 of 3 reviewed"
    assert window.review.survey.text() == f"(survey: 1 of {len(ws.cache.ids())} reviewed)"  # ids[3] counted too
    window.review.follow.setChecked(False)  # moving stays here; J goes there
    qtbot.keyClick(queue, Key.Key_A)  # accept the first: on to the next
    assert ws.project.review(ids[0]).state == "accepted" and ws.project.review(ids[0]).reviewer == "Second Reader"
    assert window.review.model.current == ids[2] and window.review.progress.text() == "1 of 3 reviewed"
    assert _review_column(window, ids[0]) == "accepted" and queue.row_text(0).endswith("— accepted")
    qtbot.keyClick(queue, Key.Key_F)  # flag, with the reason asked
    assert (ws.project.review(ids[2]).state, ws.project.review(ids[2]).reason) == ("flagged", "snout hidden")
    assert _review_column(window, ids[2]) == "flagged: snout hidden"
    assert queue.row_text(1).endswith("— flagged: snout hidden") and queue.currentRow() == 2
    assert window.review.model.current == ids[1]
    assert window.review.progress.text() == "2 of 3 reviewed, 1 flagged"
    qtbot.keyClick(queue, Key.Key_F)  # cancelled: nothing stored, still here
    assert ws.project.review(ids[1]).state == "unreviewed" and window.review.model.current == ids[1]
    qtbot.keyClick(queue, Key.Key_P)
    qtbot.keyClick(queue, Key.Key_P)
    assert window.review.model.current == ids[0]
    qtbot.keyClick(queue, Key.Key_N)
    assert window.review.model.current == ids[2]
    snap = window.actions["snap"].isChecked()
    qtbot.keyClick(queue, Key.Key_S)  # skip to the one unreviewed (S is not the window's Snap here)
    assert window.review.model.current == ids[1] and window.actions["snap"].isChecked() == snap
    window.review.follow.setChecked(True)
    qtbot.keyClick(queue, Key.Key_P)  # following: a move goes to the object, on its pair, selected
    wait_for_pair(qtbot, window, "measure1")
    assert ws.selection == (ids[2],)
    with qtbot.waitSignal(window.review.object_chosen, timeout=5000) as chosen:
        qtbot.keyClick(queue, Key.Key_N)
    assert chosen.args == [ids[1]]
    wait_for_pair(qtbot, window, "water1")
    assert ws.selection == (ids[1],)
    with qtbot.waitSignal(window.review.object_chosen, timeout=5000):
        qtbot.keyClick(queue, Key.Key_Return)
    qtbot.keyClick(queue, Key.Key_A)
    assert window.review.progress.text() == "3 of 3 reviewed, 1 flagged"
    qtbot.keyClick(queue, Key.Key_H)  # the current object's history
    (history,) = window.object_list.history_dialogs
    assert history.object_id == ids[1] and history.table.item(1, 3).text() == "review"
    history.close()
    # a review made elsewhere shows in the list when review mode is entered again
    ws.project.set_review(ids[0], "flagged", "seen again")
    window.show_review()
    assert _review_column(window, ids[0]) == "flagged: seen again"
    assert [e.change for e in ws.project.history(ids[1])] == ["add", "review"]
    # a new object joins the queue; a deleted one leaves it
    new = ws.project.add_object("point", [Vertex(50.0, 60.0, 40.0, 60.0, pair="water1")])
    ws.reload_objects()
    window.review.load()
    assert window.review.model.queue == [new] and _review_column(window, new) == "unreviewed"


def test_the_annotator_is_set_once_shown_in_the_title_and_stamped_on_writes(qtbot, make_window, sample_copy,
                                                                             tmp_path):
    settings = tmp_path / "annotator.ini"
    window = make_window(settings)
    assert not window.set_annotator("two\nlines")  # refused in one line, nothing changed
    assert "control character" in window.log.toPlainText() and SETTINGS_KEY not in window.settings.allKeys()
    assert window.set_annotator("  K. Jones ")
    assert window.windowTitle() == "USVIPS — K. Jones"
    directory = sample_copy("tank_system1")
    open_sample(qtbot, window, directory, "measure1")
    assert window.windowTitle().startswith("USVIPS — K. Jones — ") and "saved as you go" in window.windowTitle()
    (first, *_) = _objects_on_two_pairs(window)
    assert window.workspace.project.object(first).creator == "K. Jones"
    window.workspace.edits.edit_object(first, "cod", "edited in the window")
    assert window.workspace.project.history(first)[-1].annotator == "K. Jones"
    assert window.set_annotator("R. Smith")  # changed mid-session: the open project's next writes
    window.workspace.edits.edit_object(first, "ling", "")
    assert window.workspace.project.history(first)[-1].annotator == "R. Smith"
    window.close()
    again = make_window(settings)  # the next session starts as the name set
    assert again.annotator == "R. Smith" and "R. Smith" in again.windowTitle()
    dialog = AnnotatorDialog(again.annotator, again)
    dialog.edit.setText(" ")
    assert not dialog.ok.isEnabled() and "empty" in dialog.problem.text()
    dialog.edit.setText("A. N. Other")
    assert dialog.ok.isEnabled() and dialog.name() == "A. N. Other"
    reason = ReasonDialog(3, again)
    assert not reason.ok.isEnabled()
    qtbot.keyClicks(reason.edit, "  fin cut off ")
    assert reason.ok.isEnabled() and reason.reason() == "fin cut off"


def test_h_on_an_object_row_shows_its_history_and_provenance(qtbot, make_window, sample_copy):
    window = make_window()
    window.set_annotator("alice")
    directory = sample_copy("tank_system1")
    open_sample(qtbot, window, directory, "measure1")
    ws = window.workspace
    (first, *_) = _objects_on_two_pairs(window)
    ws.edits.edit_object(first, "cod", "")
    window.set_annotator("bob")
    ws.project.set_review(first, "flagged", "blurred")
    ws.objects_changed_in_store(updated=(first,))  # the window reads the review (else its delete is stale)
    table = window.object_list.table
    table.setCurrentIndex(table.model().index(window.object_list.row_of(first), 0))
    table.setFocus()
    qtbot.keyClick(table, Key.Key_H)
    (dialog,) = window.object_list.history_dialogs
    qtbot.waitExposed(dialog)
    rows = [[dialog.table.item(r, c).text() for c in range(dialog.table.columnCount())]
            for r in range(dialog.table.rowCount())]
    assert [(r[2], r[3]) for r in rows] == [("alice", "add"), ("alice", "edit"), ("bob", "review")]
    assert "attribute 'fish' → 'cod'" in rows[1][4] and rows[2][4] == "unreviewed → flagged (blurred)"
    summary = dialog.summary.text()
    assert "Made by alice" in summary and "Vertices picked by alice (1)" in summary
    assert "Review: flagged by bob" in summary and "blurred" in summary
    ws.edits.delete_object(first)
    dialog.refresh()  # a deleted object's history stays
    assert dialog.table.rowCount() == 4 and "no longer in the project" in dialog.summary.text()
    dialog.close()


def test_history_windows_close_when_another_project_is_opened(qtbot, make_window, sample_copy, tmp_path):
    """A history window belongs to its project: opening another closes it (it would read a closed store),
    and a history opened then reads the new project."""
    window = make_window()
    directory = sample_copy("tank_system1")
    second = Path(shutil.copytree(directory, tmp_path / "second"))
    open_sample(qtbot, window, directory, "measure1")
    (first, *_) = _objects_on_two_pairs(window)
    dialogs = [window.object_list.show_history(first) for _ in range(2)]
    for dialog in dialogs:
        qtbot.waitExposed(dialog)
    gone = []
    for dialog in dialogs:
        dialog.destroyed.connect(lambda _=None: gone.append(1))
    open_sample(qtbot, window, second, "measure1")
    assert window.object_list.history_dialogs == []
    qtbot.waitUntil(lambda: len(gone) == 2, timeout=5000)  # closed, and deleted on close
    ws = window.workspace
    (fresh, *_) = _objects_on_two_pairs(window)
    dialog = window.object_list.show_history(fresh)
    dialog.refresh()
    assert "cannot read" not in dialog.summary.text() and "Made by" in dialog.summary.text()
    assert dialog.store is ws.project and dialog.table.rowCount() == 1
    dialog.close()


def test_an_object_edited_in_the_window_is_reviewed_and_one_changed_elsewhere_is_refused_by_name(
        qtbot, make_window, sample_copy):
    from usvips.store import Project

    window = make_window()
    directory = sample_copy("tank_system1")
    open_sample(qtbot, window, directory, "measure1")
    ws = window.workspace
    ids = _objects_on_two_pairs(window)
    window.show_review()
    window.review.follow.setChecked(False)
    queue = window.review.list
    ws.edits.edit_object(ids[0], "cod", "edited here before the review")  # the window's own edit: not stale
    qtbot.keyClick(queue, Key.Key_A)
    assert ws.project.review(ids[0]).state == "accepted"
    current = window.review.model.current
    with Project.open(ws.project.path) as other:  # another annotator's program edits the next one
        other.annotator = "someone else"
        other.update_object(current, notes="changed elsewhere")
    qtbot.keyClick(queue, Key.Key_A)
    assert ws.project.review(current).state == "unreviewed" and window.review.model.current == current
    assert f"object {current} was changed by someone else" in window.log.toPlainText()
    qtbot.keyClick(queue, Key.Key_A)  # looked at again: the review is kept now
    assert ws.project.review(current).state == "accepted"


def test_an_accepted_object_edited_in_the_window_shows_unreviewed_and_undo_shows_it_accepted(
        qtbot, make_window, sample_copy):
    """An edit of an accepted object's attribute in the window: the object list's Review cell and the
    review panel say unreviewed (it joins the queue again), the history says why; Ctrl+Z: accepted again."""
    window = make_window()
    window.set_annotator("editor")
    directory = sample_copy("tank_system1")
    open_sample(qtbot, window, directory, "measure1")
    ws = window.workspace
    ids = _objects_on_two_pairs(window)
    ws.project.set_review(ids[1], "accepted")  # before the queue is read: not in it
    ws.objects_changed_in_store(updated=(ids[1],))  # the window reads the review (its edit names that version)
    window.object_list.refresh()
    window.show_review()
    assert ids[1] not in window.review.model.queue and window.review.progress.text() == "0 of 3 reviewed"
    ws.edits.edit_object(ids[1], "cod", "")
    assert _review_column(window, ids[1]) == "unreviewed" and ws.project.review(ids[1]).state == "unreviewed"
    assert window.review.model.queue[-1] == ids[1] and window.review.progress.text() == "0 of 4 reviewed"
    assert window.review.list.row_text(3).endswith("— unreviewed")
    last = ws.project.history(ids[1])[-1]
    assert (last.change, last.annotator, last.new["reason"]) == ("review", "editor", "edited after review")
    ws.undo.undo()
    assert _review_column(window, ids[1]) == "accepted" and ws.project.review(ids[1]).state == "accepted"
    assert window.review.list.row_text(3).endswith("— accepted")


def test_others_reviews_appear_on_each_move_and_when_the_window_regains_the_focus_and_a_stale_one_is_said(
        qtbot, make_window, sample_copy):
    """Another annotator reviews while the panel walks the queue: N shows their review (panel and object
    list); so does the window regaining the focus; the reader's accept of an object reviewed meanwhile is
    refused, and the panel's own notice line names the object; A again stores it; the next key clears it."""
    from usvips.store import Project

    window = make_window()
    window.set_annotator("reader")
    directory = sample_copy("tank_system1")
    open_sample(qtbot, window, directory, "measure1")
    ws = window.workspace
    _objects_on_two_pairs(window)
    window.show_review()
    window.review.follow.setChecked(False)
    queue, model = window.review.list, window.review.model
    order = list(model.queue)
    with Project.open(ws.project.path) as other:
        other.annotator = "bob"
        other.set_review(order[1], "flagged", "fin cut off")
        qtbot.keyClick(queue, Key.Key_N)
        assert window.review.current.text() == f"Object {order[1]}: flagged by bob (fin cut off)"
        assert _review_column(window, order[1]) == "flagged: fin cut off"
        assert queue.row_text(1).endswith("— flagged: fin cut off")
        other.set_review(order[1], "accepted")  # while this window is in the background
        window.activateWindow()
        QtWidgets.QApplication.sendEvent(window, QtCore.QEvent(QtCore.QEvent.Type.ActivationChange))
        qtbot.waitUntil(lambda: window.review.current.text() == f"Object {order[1]}: accepted by bob", timeout=5000)
        assert _review_column(window, order[1]) == "accepted"
        other.set_review(order[2], "accepted")
        qtbot.keyClick(queue, Key.Key_N)
        other.set_review(order[2], "flagged", "too dark")  # after it was shown here
        qtbot.keyClick(queue, Key.Key_A)
    notice = window.review.notice
    assert notice.isVisible() and notice.text().startswith("Not stored: ")
    assert f"object {order[2]} was changed by someone else" in notice.text()
    assert window.review.current.text() == f"Object {order[2]}: flagged by bob (too dark)"
    assert _review_column(window, order[2]) == "flagged: too dark"
    assert ws.project.review(order[2]).state == "flagged"
    qtbot.keyClick(queue, Key.Key_A)  # seen: stored now
    assert (ws.project.review(order[2]).state, ws.project.review(order[2]).reviewer) == ("accepted", "reader")
    assert not notice.isVisible() and _review_column(window, order[2]) == "accepted"
    window.docks["review"].hide()  # without review mode: the one object selected in the list
    ws.select([order[3]])
    with Project.open(ws.project.path) as other:
        other.annotator = "bob"
        other.set_review(order[3], "flagged", "two fish")
    QtWidgets.QApplication.sendEvent(window, QtCore.QEvent(QtCore.QEvent.Type.ActivationChange))
    assert _review_column(window, order[3]) == "flagged: two fish"
