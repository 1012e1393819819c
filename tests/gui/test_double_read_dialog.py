"""The double-read report in the window: two annotators measure the same fish on a pair; the dialog (File
menu) computes the report in a worker, lists a misread fork as a disagreement and an unread fish as
unmatched, and a row goes to its object (A's, then B's on a second activation)."""

from PySide6 import QtWidgets

from tests.gui.conftest import open_sample, truth_pixels
from usvips.gui import double_read_dialog


def _measure(window, left, right, fish, shift=(0.0, 0.0)):
    ws = window.workspace
    ws.set_tool("line")
    for point in ("snout", "fork"):
        dx, dy = shift if point == "fork" else (0.0, 0.0)
        ws.pick("left", (left[fish][point][0] + dx, left[fish][point][1] + dy))
        ws.pick("right", (right[fish][point][0] + dx, right[fish][point][1] + dy))
        if ws.state.pending is not None:  # held by a guard rail: keep it
            ws.accept_proposal()
    ws.finish_object("fish", "")
    return max(ws.object_ids())


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
    dialog = double_read_dialog.show_double_read(window)
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
