"""An object asked for by one view is shown by the others through the model (``Workspace.request_object``):
the object list's Zoom to and double-click, a QA row, an instant — never one view reaching into another."""

import numpy as np
from PySide6 import QtCore, QtWidgets

from tests.gui.conftest import open_sample, truth_pixels, wait_for_pair
from usvips.store.project import Vertex


def _centred_on(window, object_id) -> float:
    vertices = window.workspace.stored_object(object_id).vertices
    middle = np.mean([(v.xl, v.yl) for v in vertices], axis=0) + 0.5  # pixels to the view's coordinates
    centre = window.panes["left"].view_rect().center()
    return float(np.hypot(centre.x() - middle[0], centre.y() - middle[1]))


def test_zoom_to_an_object_of_another_pair_shows_that_pair_centred_on_it(qtbot, make_window, sample_copy,
                                                                          monkeypatch):
    window = make_window()
    directory = sample_copy("tank_system1")
    open_sample(qtbot, window, directory, "measure1")
    ws = window.workspace
    left, right = truth_pixels(directory, "measure1", "objects")
    snout, fork = (left["fish1"][p] for p in ("snout", "fork")), (right["fish1"][p] for p in ("snout", "fork"))
    vertices = [Vertex(*pl, *pr, pair="measure1") for pl, pr in zip(snout, fork, strict=True)]
    object_id = ws.project.add_object("line", vertices, "fish")
    ws.reload_objects()
    window.load_pair("water1")
    wait_for_pair(qtbot, window, "water1")
    window.panes["left"].zoom_to(8.0, (5.0, 5.0))  # far from the fish
    window.docks["objects"].raise_()
    table = window.object_list.table  # the user selects its row (selectRow would follow the keyboard's
    flags = QtCore.QItemSelectionModel.SelectionFlag  # modifiers, which earlier tests' key clicks may leave set)
    table.selectionModel().select(table.model().index(window.object_list.row_of(object_id), 0),
                                  flags.ClearAndSelect | flags.Rows)
    assert ws.selection == (object_id,)
    zoom = next(b for b in window.object_list.findChildren(QtWidgets.QPushButton) if b.text() == "Zoom to")
    qtbot.mouseClick(zoom, QtCore.Qt.MouseButton.LeftButton)
    wait_for_pair(qtbot, window, "measure1")  # not "measured on another pair": its pair is read and shown
    qtbot.waitUntil(lambda: _centred_on(window, object_id) < 2.0, timeout=5000)
    assert ws.selection == (object_id,) and window.object_list.selected_ids() == [object_id]
    log = window.log.toPlainText()
    assert "measured on another pair" not in log
    # on the pair shown: centred again, nothing read
    window.panes["left"].zoom_to(8.0, (5.0, 5.0))
    assert _centred_on(window, object_id) > 2.0
    loads = []
    monkeypatch.setattr(window, "load_pair", loads.append)
    qtbot.mouseClick(zoom, QtCore.Qt.MouseButton.LeftButton)
    assert _centred_on(window, object_id) < 2.0 and loads == []


def test_an_object_measured_on_a_video_is_shown_on_its_frame_centred_from_an_image_pair(qtbot, make_window,
                                                                                       sample_copy):
    """Its vertices name the video as their pair: the window read it as an image pair and said "pair 'video'
    has no images" while the video controller showed the frame."""
    import json

    window = make_window()
    directory = sample_copy("rov_flatport")
    assert window.open_path(directory, "video")
    ws = window.workspace
    qtbot.waitUntil(lambda: ws.video_frame is not None and not window.busy, timeout=20000)
    window.video.request(12)
    qtbot.waitUntil(lambda: ws.video_frame is not None and ws.video_frame[1] == 12 and not window.busy, timeout=20000)
    truth = json.loads((directory / "truth.json").read_text())["video"]
    left, right = truth["left"][12]["pixels"], truth["right"][15]["pixels"]
    ws.pick_tool.set_tool("line")
    for point in ("snout", "fork"):
        ws.pick_tool.pick("left", left[point])
        ws.pick_tool.pick("right", right[point])
        if ws.pick_tool.state.pending is not None:
            ws.pick_tool.accept_proposal()
    object_id = ws.pick_tool.finish_object("fish2")
    assert ws.place_of(object_id) == ("video", 12)
    window.load_pair("measure1")
    qtbot.waitUntil(lambda: ws.pair == "measure1" and not window.busy, timeout=10000)
    window.panes["left"].zoom_to(8.0, (5.0, 5.0))
    window.log.clear()
    assert ws.request_object(object_id)
    qtbot.waitUntil(lambda: ws.place() == ("video", 12) and not window.busy, timeout=20000)
    qtbot.waitUntil(lambda: _centred_on(window, object_id) < 2.0, timeout=5000)
    assert "error" not in window.log.toPlainText() and "has no images" not in window.log.toPlainText()
    assert ws.selection == (object_id,)
    # while an object is being digitised on this frame, one on another frame is not gone to
    window.video.request(14)
    qtbot.waitUntil(lambda: ws.place() == ("video", 14) and not window.busy, timeout=20000)
    ws.pick_tool.pick("left", left["snout"])
    ws.pick_tool.pick("right", right["snout"])
    if ws.pick_tool.state.pending is not None:
        ws.pick_tool.accept_proposal()
    assert ws.pick_tool.digitising.vertices and not ws.request_object(object_id)
    assert "video 'video', frame 12" in window.hint.text() and ws.place() == ("video", 14)
