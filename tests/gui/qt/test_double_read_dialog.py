"""The double-read report in the window: two annotators measure the same fish on a pair; the dialog (File
menu) computes the report in a worker, lists a misread fork as a disagreement and an unread fish as
unmatched, and a row goes to its object (A's, then B's on a second activation)."""

import shutil

from PySide6 import QtCore, QtWidgets

from tests.gui.conftest import open_sample, truth_pixels
from usvips.gui.qt import double_read_dialog


def _measure(window, left, right, fish, shift=(0.0, 0.0)):
    ws = window.workspace
    ws.pick_tool.set_tool("line")
    first, second = list(left[fish])[:2]  # snout and fork (a pipe: start and end)
    for point in (first, second):
        dx, dy = shift if point == second else (0.0, 0.0)
        ws.pick_tool.pick("left", (left[fish][point][0] + dx, left[fish][point][1] + dy))
        ws.pick_tool.pick("right", (right[fish][point][0] + dx, right[fish][point][1] + dy))
        if ws.pick_tool.state.pending is not None:  # held by a guard rail: keep it
            ws.pick_tool.accept_proposal()
    ws.pick_tool.finish_object("fish", "")
    return max(ws.cache.ids())


def test_the_dialog_reports_two_readers_and_jumps_to_their_objects(qtbot, make_window, sample_copy, tmp_path):
    window = make_window()
    directory = sample_copy("tank_system1")
    open_sample(qtbot, window, directory, "measure1")
    left, right = truth_pixels(directory, "measure1", "objects")
    ws = window.workspace
    names = sorted(left)[:2]
    assert len(names) == 2
    ws.project.annotator = "ann"
    ann = {name: _measure(window, left, right, name) for name in names}
    ws.project.annotator = "bob"
    bob = {names[0]: _measure(window, left, right, names[0], shift=(25.0, 0.0))}  # a misplaced fork
    file_menu = next(a.menu() for a in window.menuBar().actions() if a.text() == "&File")
    entry = next(a for a in file_menu.actions() if a.text() == "Dou&ble-read report…")
    entry.trigger()
    dialog = next(w for w in QtWidgets.QApplication.topLevelWidgets()
                  if isinstance(w, double_read_dialog.DoubleReadDialog) and w.isVisible())
    assert (dialog.reader_a.currentText(), dialog.reader_b.currentText()) == ("ann", "bob")
    dialog.gate.setValue(0.5)
    worker = dialog.compare()
    assert worker is not None
    qtbot.waitUntil(lambda: dialog.report is not None, timeout=20000)
    rows = {(r["row"], r["object_a"], r["object_b"]) for r in dialog.rows}
    assert ("disagreement", ann[names[0]], bob[names[0]]) in rows
    assert ("unmatched A", ann[names[1]], None) in rows
    assert dialog.table.rowCount() == len(dialog.rows) == 2
    assert "matched: 1 pair (" in dialog.summary.text()
    first = next(i for i, r in enumerate(dialog.rows) if r["row"] == "disagreement")
    ws.select([])
    dialog.go_to_row(first)
    assert ws.selection == (ann[names[0]],)
    dialog.go_to_row(first)  # again: the other reader's object
    assert ws.selection == (bob[names[0]],)
    assert dialog.save_csv(str(tmp_path / "report.csv"))
    assert (tmp_path / "report.csv").read_text().count("\n") == 3 + len(dialog.report.summary())
    dialog.close()


def test_the_report_in_a_worker_stops_when_cancelled(qtbot, make_window, sample_copy):
    window = make_window()
    directory = sample_copy("tank_system1")
    open_sample(qtbot, window, directory, "measure1")
    left, right = truth_pixels(directory, "measure1", "objects")
    ws = window.workspace
    name = sorted(left)[0]
    for reader in ("ann", "bob"):
        ws.project.annotator = reader
        _measure(window, left, right, name)
    dialog = double_read_dialog.show_double_read(window.context, window)
    qtbot.addWidget(dialog)
    original = double_read_dialog.compute

    def slow(inputs, *args):  # cancelled before it starts: the job's first check stops it
        dialog.worker.cancel()
        return original(inputs, *args)

    double_read_dialog.compute = slow
    try:
        assert dialog.compare() is not None
        qtbot.waitUntil(lambda: dialog.worker is None, timeout=20000)  # it ended: cancelled
    finally:
        double_read_dialog.compute = original
    assert dialog.report is None and dialog.summary.text() == "cancelled"


def test_the_table_sorts_by_column_and_rows_still_go_to_their_objects_and_the_tolerance_may_be_frames(
        qtbot, make_window, sample_copy):
    window = make_window()
    directory = sample_copy("tank_system1")
    open_sample(qtbot, window, directory, "measure1")
    left, right = truth_pixels(directory, "measure1", "objects")
    ws = window.workspace
    names = sorted(n for n in left if len(left[n]) == 2)  # two fish and a pipe
    assert len(names) == 3
    ws.project.annotator = "ann"
    ann = [_measure(window, left, right, name) for name in names]
    ws.project.annotator = "bob"
    bob = _measure(window, left, right, names[0], shift=(25.0, 0.0))
    dialog = double_read_dialog.show_double_read(window.context, window)
    # the tolerance in frames: one of the two units, its own default; the report says which
    assert dialog.tolerances() == (0.5, None)
    dialog.tolerance_unit.setCurrentText("frames")
    assert dialog.tolerances() == (None, 12.0) and dialog.tolerance.suffix() == " frames"
    dialog.tolerance.setValue(3)
    dialog.gate.setValue(0.5)
    dialog.compare()
    qtbot.waitUntil(lambda: dialog.report is not None, timeout=20000)
    assert "tolerance 3 frames," in dialog.summary.text() and dialog.report.tolerance_frames == 3.0
    assert [(r["row"], r["object_a"], r["object_b"]) for r in dialog.rows] == [
        ("disagreement", ann[0], bob), ("unmatched A", ann[1], None), ("unmatched A", ann[2], None)]
    column = {key: c for c, (_, key, _) in enumerate(double_read_dialog.SHOWN)}

    def shown(key):
        return [dialog.table.item(r, column[key]).text() for r in range(dialog.table.rowCount())]

    assert shown("object_a") == [str(i) for i in ann]  # the report's order until a header is clicked
    header = dialog.table.horizontalHeader()

    def click(key):  # a click on the column's header, as the user makes it
        point = QtCore.QPoint(header.sectionViewportPosition(column[key]) + 5, header.height() // 2)
        qtbot.mouseClick(header.viewport(), QtCore.Qt.MouseButton.LeftButton, pos=point)

    click("object_a")
    ascending = shown("object_a")
    assert ascending in ([str(i) for i in sorted(ann)], [str(i) for i in sorted(ann, reverse=True)])
    if ascending == [str(i) for i in sorted(ann)]:
        click("object_a")  # again: the other way
    assert shown("object_a") == [str(i) for i in sorted(ann, reverse=True)]
    ws.select([])
    dialog.go_to_row(0)  # the sorted table's first row: ann's last object
    assert ws.selection == (max(ann),)
    # numbers sort as numbers and empty cells stay last either way
    for order in (QtCore.Qt.SortOrder.AscendingOrder, QtCore.Qt.SortOrder.DescendingOrder):
        header.setSortIndicator(column["object_b"], order)
        dialog.table.sortItems(column["object_b"], order)
        assert shown("object_b") == [str(bob), "", ""]
    dialog.table.sortItems(column["value_a"], QtCore.Qt.SortOrder.AscendingOrder)
    values = [float(t) for t in shown("value_a")]
    assert values == sorted(values)
    row_of_bob = shown("object_b").index(str(bob))
    dialog.go_to_row(row_of_bob)
    dialog.go_to_row(row_of_bob)  # again: the other reader's object of the pair
    assert ws.selection == (bob,)
    dialog.close()


def test_another_project_opened_clears_the_report_and_its_readers(qtbot, make_window, sample_copy, tmp_path):
    """The dialog is not modal: a project opened while it is up must not leave the previous project's rows
    there (their object ids would go to the new project's objects of the same ids) nor its readers."""
    window = make_window()
    directory = sample_copy("tank_system1")
    open_sample(qtbot, window, directory, "measure1")
    left, right = truth_pixels(directory, "measure1", "objects")
    ws = window.workspace
    name = sorted(left)[0]
    for reader in ("ann", "bob"):
        ws.project.annotator = reader
        _measure(window, left, right, name)
    dialog = double_read_dialog.show_double_read(window.context, window)
    dialog.gate.setValue(0.5)
    dialog.compare()
    qtbot.waitUntil(lambda: dialog.report is not None, timeout=20000)
    assert dialog.rows and dialog.save_button.isEnabled()
    other = tmp_path / "other"
    shutil.copytree(directory, other, ignore=shutil.ignore_patterns("project.usvips*"))
    open_sample(qtbot, window, other, "measure1")
    ws.project.annotator = "cy"
    measured = _measure(window, left, right, name)  # an object of the new project, perhaps of the same id
    assert dialog.report is None and dialog.rows == [] and dialog.table.rowCount() == 0
    assert not dialog.save_button.isEnabled() and not dialog.save_csv(str(tmp_path / "stale.csv"))
    assert [dialog.reader_a.itemText(i) for i in range(dialog.reader_a.count())] == []
    assert not dialog.compare_button.isEnabled()
    ws.select([measured])
    dialog.go_to_row(0)  # nothing listed: nothing to go to
    assert ws.selection == (measured,)
    dialog.close()
