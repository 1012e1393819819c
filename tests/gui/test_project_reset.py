"""Opening a project resets every model by construction (new instances, one ``project_changed`` event), and
every view forgets the previous project because it listens, not because a list names it: first without a
window (the models), then in the window (what is on screen)."""

import numpy as np
from PySide6 import QtWidgets

from tests.gui.conftest import click_pixel, open_sample, truth_pixels
from usvips.app.samples import open_or_create_from_manifest
from usvips.core.enhance import Pipeline
from usvips.gui.pick_tool import PickState
from usvips.gui.workspace import Workspace, load_pair_images
from usvips.store import Project


def _measure_a_point(ws, directory) -> int:
    left, right = truth_pixels(directory, "water1", "targets")
    number = next(k for k in left if left[k] is not None and right.get(k) is not None)
    ws.pick_tool.set_tool("point")
    ws.pick_tool.pick("left", left[number])
    ws.pick_tool.pick("right", right[number])
    if ws.pick_tool.state.pending is not None:  # held by a guard rail: keep it
        ws.pick_tool.accept_proposal()
    (stored,) = ws.cache.objects()
    return stored.id


def test_a_second_project_leaves_nothing_of_the_first_in_any_model(sample_copy, tmp_path):
    directory = sample_copy("tank_system1")
    first = open_or_create_from_manifest(directory)
    ws = Workspace()
    heard = []
    ws.project_changed.connect(lambda project: heard.append(project))
    ws.open_project(first)
    ws.set_pair("water1", *load_pair_images(first, "water1"))
    ws.enhancement.set_pipelines({"left": Pipeline().then("clahe", clip_limit=2.0)})
    object_id = _measure_a_point(ws, directory)
    ws.select([object_id])
    ws.figures([object_id])
    ws.pick_tool.attribute = "cod"
    ws.pick_tool.set_tool("line")
    ws.pick_tool.pick("left", (100.0, 100.0))  # a vertex being picked
    ws.video_frame = ("clip", 3, 4, 0.1)  # as if a video's frame pair were shown
    models = (ws.cache, ws.enhancement, ws.pick_tool)
    assert ws.pick_tool.last_point is not None and ws.pick_tool.state.source == "left"
    assert ws.undo.undo_label is not None

    second = Project.create(tmp_path / "second.usvips")
    ws.open_project(second)
    assert heard == [first, second]
    assert all(new is not old for new, old in zip((ws.cache, ws.enhancement, ws.pick_tool), models, strict=True))
    # the project and its selection
    assert (ws.pair, ws.images, ws.geometry, ws.video_frame, ws.selection) == (None, {}, None, None, ())
    # the object cache
    assert ws.cache.objects() == [] and ws.cache.known_figures(object_id) is None and ws.cache.calibrations == {}
    # the enhancement
    assert ws.enhancement.pipelines == {"left": Pipeline(), "right": Pipeline()} and ws.enhancement.keys == {}
    assert ws.enhancement.project is None
    # the pick tool: its state, but not the user's settings and tool
    assert ws.pick_tool.state == PickState() and ws.pick_tool.digitising.vertices == ()
    assert ws.pick_tool.last_point is None
    assert ws.pick_tool.attribute == "" and ws.pick_tool.repick is None and ws.pick_tool.tool == "line"
    # undo: nothing of the first project can be undone into the second
    assert ws.undo.undo_label is None and ws.undo.redo_label is None
    ws.close_project()
    assert heard[-1] is None and ws.project is None


def test_the_views_show_nothing_of_the_previous_project(qtbot, make_window, sample_copy, tmp_path):
    window = make_window()
    directory = sample_copy("tank_system1")
    open_sample(qtbot, window, directory, "water1")
    ws = window.workspace
    left, right = truth_pixels(directory, "water1", "targets")
    number = next(k for k in left if left[k] is not None and right.get(k) is not None)
    window.set_tool("point")
    click_pixel(qtbot, window.panes["left"], left[number])
    click_pixel(qtbot, window.panes["right"], right[number])
    if ws.pick_tool.state.pending is not None:
        ws.pick_tool.accept_proposal()
    qtbot.waitUntil(lambda: bool(ws.cache.objects()), timeout=5000)
    ws.select([ws.cache.objects()[0].id])
    window._on_hovered("left", *left[number])  # the pixel readout under the mouse
    window.attribute_box.setEditText("cod")
    histogram = window.enhancement.histogram
    qtbot.waitUntil(lambda: len(histogram.counts("original")) > 0, timeout=5000)
    before = {"point": window.point_label.text(), "pixel": window.pixel_label.text(),
              "title": window.panes["left"].title.text(), "target": window.observation.target.text(),
              "rows": window.object_list.row_count()}
    assert all(before.values()), before

    empty = tmp_path / "empty.usvips"
    Project.create(empty).close()
    assert window.open_path(empty)
    QtWidgets.QApplication.processEvents()
    assert window.point_label.text() == "" and window.pixel_label.text() == ""
    assert [window.panes[s].title.text() for s in ("left", "right")] == ["Left", "Right"]
    assert all(window.panes[s].image_size() == (0, 0) for s in ("left", "right"))
    for name in ("original", "processed"):
        assert len(window.enhancement.histogram.counts(name)) == 0
    assert window.attribute_box.currentText() == "" and window.attribute_box.count() == 0
    assert window.pair_box.count() == 0 and window.pair_box.placeholderText() == ""
    assert window.observation.target.text() == "no object" and window.observation.species.currentText() == ""
    assert window.object_list.row_count() == 0 and window.selection == []
    d = window.video.dock_widget
    assert (d.offset.value(), d.frame_label.text(), d.chooser.count()) == (0, "—", 0) and not d.isEnabled()
    assert np.all([window.panes[s].display is None for s in ("left", "right")])


def test_the_pair_box_drops_the_video_placeholder_on_screen(qtbot, make_window, sample_copy, tmp_path):
    """The pair box said "(video)" over an empty project: Qt does not repaint an empty box whose
    placeholder is cleared, so the window asks it to."""
    from PySide6 import QtCore

    window = make_window()
    assert window.open_path(sample_copy("rov_flatport"))
    assert window.video.open_video("video")
    qtbot.waitUntil(lambda: window.workspace.video_frame is not None and not window.busy, timeout=30000)
    box = window.pair_box
    assert box.placeholderText() == "(video)" and box.currentIndex() == -1
    QtWidgets.QApplication.processEvents()

    class Paints(QtCore.QObject):
        count = 0

        def eventFilter(self, watched, event):  # noqa: N802 (Qt's name)
            if event.type() == QtCore.QEvent.Type.Paint:
                Paints.count += 1
            return False

    paints = Paints()
    empty = tmp_path / "empty.usvips"
    Project.create(empty).close()
    assert window.open_path(empty)
    box.installEventFilter(paints)  # after the box was emptied (clearing it repaints): the placeholder's own
    window.refresh_pair_box()
    assert Paints.count == 0  # nothing changed: nothing to repaint
    window.workspace.pair = "video"  # as if a video's frames were shown ...
    window.refresh_pair_box()
    QtWidgets.QApplication.processEvents()
    Paints.count = 0
    window.workspace.pair = None  # ... and then none
    window.refresh_pair_box()
    QtWidgets.QApplication.processEvents()
    assert box.placeholderText() == "" and Paints.count > 0
    box.removeEventFilter(paints)
