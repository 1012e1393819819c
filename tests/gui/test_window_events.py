"""The window at survey size, with the mouse and keyboard: a pick and a store touch one row of the object
list and nothing lists every object from the project; selecting and deleting go through the model."""

from PySide6 import QtCore

from tests.gui.conftest import click_pixel, truth_pixels, wait_for_pair
from usvips.gui.qt.bench import survey_project
from usvips.gui.qt.object_list import ObjectList
from usvips.locations import sample_project
from usvips.store import Project

FIGURE = ObjectList.COLUMNS.index("figure")  # the object list's figure column

COUNT = 400


def test_a_pick_and_a_store_update_one_row_among_many(qtbot, make_window, tmp_path, monkeypatch):
    path = survey_project(tmp_path / "survey", COUNT)
    window = make_window()
    assert window.open_path(path, "measure1")
    wait_for_pair(qtbot, window, "measure1")
    table, model = window.object_list.table, window.object_list.model
    assert model.rowCount() == COUNT
    if window.object_list._worker is not None:  # the many figures are computed off the GUI thread ...
        window.object_list._worker.cancel()  # ... and need not finish here (test_main_window waits for them)
    before = [model.index(row, 0).data() for row in range(COUNT)]
    resets: list = []  # no row is rebuilt: the model is never reset, rows are inserted and removed
    model.modelReset.connect(lambda: resets.append(True))

    def no_listing(self):
        raise AssertionError("the whole object table was read from the project")

    monkeypatch.setattr(Project, "objects", no_listing)
    left, right = truth_pixels(sample_project("rov_flatport"), "measure1", "objects")
    window.actions["tool_line"].trigger()
    for point in ("snout", "fork"):
        click_pixel(qtbot, window.panes["left"], left["fish1"][point])
        click_pixel(qtbot, window.panes["right"], right["fish1"][point])
    assert model.rowCount() == COUNT  # picks leave the list alone
    window.actions["accept"].trigger()  # Enter stores the fish
    assert model.rowCount() == COUNT + 1
    assert [model.index(row, 0).data() for row in range(COUNT)] == before and resets == []
    new_id = window.workspace.cache.objects()[-1].id
    assert model.index(COUNT, 0).data() == str(new_id) and "mm" in model.index(COUNT, FIGURE).data()
    # above 300 objects only the selected ones are labelled on the panes
    assert window.panes["left"].labels == []
    # select with the mouse: the model holds the selection; the calculator and the panes follow it
    table.scrollTo(model.index(COUNT, 0))
    rect = table.visualRect(model.index(COUNT, 0))
    qtbot.mouseClick(table.viewport(), QtCore.Qt.MouseButton.LeftButton, pos=rect.center())
    assert window.workspace.selection == (new_id,)
    assert str(new_id) in window.calculator.output.toPlainText()
    assert [label.toPlainText() for label in window.panes["left"].labels] == [str(new_id)]
    x = window.panes["left"].selected_item.points()[:, 0]
    assert len(x) >= 2
    # the Delete key in the list deletes it (one row goes), Ctrl+Z brings it back as one new row
    table.setFocus()
    qtbot.keyClick(table, QtCore.Qt.Key.Key_Delete)
    assert model.rowCount() == COUNT and window.workspace.selection == ()
    assert [model.index(row, 0).data() for row in range(COUNT)] == before and resets == []
    window.actions["undo"].trigger()
    assert model.rowCount() == COUNT + 1 and [model.index(row, 0).data() for row in range(COUNT)] == before
    assert resets == []
