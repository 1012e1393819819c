"""The QA panel in the window: the survey's objects that break a rule, checked in a worker and again when
objects change; Ctrl+Shift+Q, the arrows and Enter (or a click) go to the object's pair or frame with it
selected."""

import numpy as np
from PySide6 import QtCore, QtWidgets

from tests.gui.conftest import open_sample, truth_pixels, wait_for_pair
from usvips.core.observation_record import ObservationRecord, Species

SPECIES = Species("Sparidae", "Pagrus", "auratus", "37353001", max_length_m=0.30)


def _measure(window, left, right, fish):
    ws = window.workspace
    ws.pick_tool.set_tool("line")
    for point in ("snout", "fork"):
        ws.pick_tool.pick("left", left[fish][point])
        ws.pick_tool.pick("right", right[fish][point])
        if ws.pick_tool.state.pending is not None:  # held by a guard rail: keep it
            ws.pick_tool.accept_proposal()
    ws.pick_tool.finish_object("fish", "")
    return max(ws.cache.ids())


def _checked(qtbot, window):
    qtbot.waitUntil(lambda: not window.qa.checking and window.qa.model.report is not None, timeout=20000)


def test_the_qa_panel_lists_breaches_and_goes_to_their_pair(qtbot, make_window, sample_copy):
    window = make_window()
    directory = sample_copy("tank_system1")
    open_sample(qtbot, window, directory, "measure1")
    left, right = truth_pixels(directory, "measure1", "objects")
    ws = window.workspace
    ws.project.set_species_list([SPECIES])
    fish = [_measure(window, left, right, name) for name in ("fish1", "fish2")]
    # the panel is a tab behind the object list: nothing is checked until it is shown
    assert not window.qa.shown() and window.qa.model.report is None and window.qa._worker is None
    window.docks["qa"].raise_()  # its tab brought to the front: checked then
    qtbot.waitUntil(window.qa.shown, timeout=5000)
    _checked(qtbot, window)
    assert window.qa.table_model.rowCount() == 0  # no species yet: nothing breaks a rule
    lengths = {i: ws.figures([i]).figures[0].value for i in fish}
    for object_id in fish:
        ws.edits.set_record(object_id, ObservationRecord.of(SPECIES))  # an edit: the panel checks again by itself
    _checked(qtbot, window)
    too_long = sorted(i for i in fish if lengths[i] > SPECIES.max_length_m)
    assert too_long  # the sample's fish1 is 0.46 m
    rows = window.qa.table_model.rows
    assert [r.object_id for r in rows] == too_long
    assert rows[0].cells[1] == "length > species maximum" and rows[0].cells[5] == "pair measure1"
    assert window.qa.summary.text().startswith("2 objects checked: ")
    # another pair on screen; the keyboard walks the list and Enter goes back to the object
    window.load_pair("water1")
    wait_for_pair(qtbot, window, "water1")
    ws.select([])
    view_menu = next(a.menu() for a in window.menuBar().actions() if a.text() == "&View")
    assert window.actions["qa"] in view_menu.actions() and window.actions["qa"].text() == "&QA panel"
    window.docks["objects"].raise_()  # the panel behind the object list; the key brings it and its keyboard
    window.focus_images()
    qtbot.keyClick(QtWidgets.QApplication.focusWidget(), QtCore.Qt.Key.Key_Q,
                   QtCore.Qt.KeyboardModifier.ControlModifier | QtCore.Qt.KeyboardModifier.ShiftModifier)
    assert window.qa.shown()
    qtbot.waitUntil(lambda: window.qa.view.hasFocus(), timeout=5000)
    assert window.qa.view.currentIndex().row() == 0
    with qtbot.waitSignal(window.qa.object_chosen, timeout=5000) as chosen:
        qtbot.keyClick(window.qa.view, QtCore.Qt.Key.Key_Return)
    assert chosen.args == [too_long[0]]
    wait_for_pair(qtbot, window, "measure1")
    assert ws.selection == (too_long[0],)
    vertices = ws.stored_object(too_long[0]).vertices
    middle = np.mean([(v.xl, v.yl) for v in vertices], axis=0) + 0.5  # pixels to the view's coordinates
    centre = window.panes["left"].view_rect().center()
    assert np.hypot(centre.x() - middle[0], centre.y() - middle[1]) < 2.0  # centred on the object
    assert window.object_list.selected_ids() == [too_long[0]]
    # deleting the object takes it off the list
    ws.edits.delete_object(too_long[0])
    _checked(qtbot, window)
    assert too_long[0] not in [r.object_id for r in window.qa.table_model.rows]


def test_a_click_on_a_video_object_goes_to_its_frame(qtbot, make_window, sample_copy, monkeypatch):
    window = make_window()
    directory = sample_copy("tank_system1")
    open_sample(qtbot, window, directory, "measure1")
    ws = window.workspace
    opened, requested = [], []  # the video controller hears the model's request: it opens the object's video
    monkeypatch.setattr(window.video, "open_video", lambda label: opened.append(label) and False)
    ws.object_requested.connect(requested.append)
    from usvips.store.project import Vertex
    files = [directory / "left.mp4", directory / "right.mp4"]  # never decoded: the video controller is replaced
    for file in files:
        file.write_bytes(b"not decoded here")
    ws.project.add_video("dive", [(files[0], 10, 25.0)], [(files[1], 10, 25.0)], 25.0, 10, (64, 48))
    object_id = ws.project.add_object("point", [Vertex(10.0, 20.0, 30.0, 40.0, video="dive", frame_left=7, time_s=0.23,
                                                       frame_right=9)])
    ws.reload_objects()
    window.show_qa()
    _checked(qtbot, window)
    (row,) = window.qa.table_model.rows
    assert row.object_id == object_id and row.cells[1] == "no figures" and row.cells[5] == "video 'dive', frame 7"
    qtbot.mouseClick(window.qa.view.viewport(), QtCore.Qt.MouseButton.LeftButton,
                     pos=window.qa.view.visualRect(window.qa.table_model.index(0, 1)).center())
    assert requested == [object_id] and opened == ["dive"] and ws.selection == (object_id,)
    assert ws.pair == "measure1"  # not an image pair's object: the pair shown stays
    window.qa.object_chosen.emit(10_000)  # an id no longer stored: said, nothing else
    assert requested == [object_id] and ws.selection == (object_id,)
    assert "no longer in the project" in window.statusBar().currentMessage() or \
        "no longer in the project" in window.log.toPlainText()
