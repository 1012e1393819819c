"""The workstation window end to end (offscreen): open a sample, pick with the mouse, see the epipolar
curve and the proposal, measure a fish, undo/redo, enhance, reopen."""

import numpy as np
import pytest
from PySide6 import QtCore

from tests.gui.conftest import click_pixel, isolated_targets, open_sample, true_length, truth_pixels, wait_for_pair
from usvips.core.matching import EpipolarCurve
from usvips.gui.qt.object_list import ObjectList
from usvips.gui.qt.pane import PIXEL_CENTRE, pixel_from_item
from usvips.store import Project

FIGURE = ObjectList.COLUMNS.index("figure")  # the object list's figure column


def _drawn_curve(pane) -> np.ndarray:
    return np.array([pixel_from_item(a, b) for a, b in pane.curve_item.points()])


def _drawn_points(item) -> np.ndarray:
    return np.array([pixel_from_item(x, y) for x, y in item.points()]).reshape(-1, 2)


def test_the_window_opens_a_sample_and_shows_both_images(qtbot, make_window, sample_copy):
    window = make_window()
    directory = sample_copy("tank_system1")
    open_sample(qtbot, window, directory, "measure1")
    for side in ("left", "right"):
        assert window.panes[side].image_size() == (window.workspace.images[side].shape[1],
                                                   window.workspace.images[side].shape[0])
    assert [window.pair_box.itemText(i) for i in range(window.pair_box.count())] == \
        ["air1", "water1", "water2", "measure1"]
    assert "rig frame" in window.log.toPlainText()


def test_a_mouse_pick_draws_the_epipolar_curve_through_the_true_conjugate(qtbot, make_window, sample_copy):
    window = make_window()
    directory = sample_copy("rov_flatport")
    open_sample(qtbot, window, directory, "water1")
    left, right = truth_pixels(directory, "water1", "targets")
    proposed = 0
    for number in isolated_targets(left, right)[:6]:
        window.cancel_pick()
        click_pixel(qtbot, window.panes["left"], left[number])
        curve = _drawn_curve(window.panes["right"])
        assert EpipolarCurve(curve, np.zeros(len(curve))).distance_to(np.array(right[number])) < 0.5
        drawn = _drawn_points(window.panes["right"].proposal_item)
        if len(drawn) == 0 or window.workspace.pick_tool.state.weak:  # refused (ambiguous, image edge): said so
            assert ("no automatic match" in window.statusBar().currentMessage()
                    or "weak proposal" in window.statusBar().currentMessage())
            continue
        proposed += 1
        assert np.linalg.norm(drawn[0] - right[number]) < 0.5
        (pick,) = _drawn_points(window.panes["left"].pick_item)
        assert np.linalg.norm(pick - left[number]) < 0.2  # the click at 8× zoom
    assert proposed >= 4


def test_measuring_a_fish_with_the_mouse_stores_it_with_its_true_length(qtbot, make_window, sample_copy):
    window = make_window()
    directory = sample_copy("tank_system1")
    open_sample(qtbot, window, directory, "measure1")
    left, right = truth_pixels(directory, "measure1", "objects")
    window.actions["tool_line"].trigger()
    assert window.workspace.pick_tool.tool == "line"
    window.attribute_box.setEditText("fish")
    for point in ("snout", "fork"):
        click_pixel(qtbot, window.panes["left"], left["fish1"][point])
        assert window.workspace.pick_tool.state.proposal is not None
        click_pixel(qtbot, window.panes["right"], right["fish1"][point])  # correct the proposal by hand
        assert "±" in window.point_label.text()
    window.actions["accept"].trigger()  # no proposal pending: Enter finishes the object
    (stored,) = window.workspace.project.objects()
    assert stored.kind == "length" and stored.attribute == "fish"
    figure = window.workspace.figures([stored.id]).figures[0]
    assert abs(figure.value - true_length(directory, "fish1")) < figure.sigma
    assert window.object_list.row_count() == 1
    assert "mm" in window.object_list.text(0, "figure")
    window.object_list.table.selectRow(0)
    assert "length" in window.calculator.output.toPlainText()
    x = window.panes["left"].selected_item.points()[:, 0]
    assert len(x) >= 2  # the selected fish is drawn highlighted
    window.actions["undo"].trigger()
    assert window.workspace.project.objects() == [] and window.object_list.row_count() == 0
    window.actions["redo"].trigger()
    assert len(window.workspace.project.objects()) == 1 and window.object_list.row_count() == 1


def test_enhancement_changes_the_display_but_not_the_coordinates(qtbot, make_window, sample_copy):
    window = make_window()
    directory = sample_copy("tank_system1")
    open_sample(qtbot, window, directory, "measure1")
    left, right = truth_pixels(directory, "measure1", "objects")
    pane = window.panes["left"]

    def measure() -> np.ndarray:
        click_pixel(qtbot, pane, left["fish2"]["snout"])
        click_pixel(qtbot, window.panes["right"], right["fish2"]["snout"])
        return window.workspace.pick_tool.last_point.xyz.copy()

    before_display = pane.display.copy()
    before = measure()
    window.enhancement.target.setCurrentText("both")
    window.enhancement.operation.setCurrentText("equalize")
    window.enhancement.add_button.click()
    qtbot.waitUntil(lambda: not window.busy and not np.array_equal(pane.display, before_display), timeout=10000)
    assert np.array_equal(window.workspace.images["left"], before_display)  # the original is untouched
    assert np.array_equal(measure(), before)
    assert window.enhancement.steps.count() == 1


def test_reopening_restores_objects_enhancement_pair_and_layout(qtbot, make_window, sample_copy, tmp_path):
    settings = tmp_path / "layout.ini"
    window = make_window(settings)
    directory = sample_copy("tank_system1")
    open_sample(qtbot, window, directory, "measure1")
    left, right = truth_pixels(directory, "measure1", "objects")
    window.set_tool("point")
    click_pixel(qtbot, window.panes["left"], left["rock1"]["centre"])
    click_pixel(qtbot, window.panes["right"], right["rock1"]["centre"])
    from usvips.core.enhance import Pipeline

    window.workspace.enhancement.set_pipelines({"right": Pipeline().then("gamma", gamma=0.7)})
    qtbot.waitUntil(lambda: not window.busy, timeout=10000)
    window.docks["plan"].hide()
    window.actions["snap"].trigger()
    assert window.workspace.settings.snap
    window.close()

    again = make_window(settings)
    assert str(directory / "project.usvips") in again.recent_projects()[0]
    assert again.open_path(again.recent_projects()[0])
    wait_for_pair(qtbot, again, "measure1")  # the pair last shown
    (stored,) = again.workspace.project.objects()
    assert stored.kind == "point"
    assert again.workspace.enhancement.pipelines["right"].operations[0].name == "gamma"
    assert again.workspace.enhancement.pipelines["left"].operations == ()
    assert not again.docks["plan"].isVisible()
    assert again.actions["snap"].isChecked() and again.workspace.settings.snap
    assert again.object_list.row_count() == 1


def test_bad_input_is_reported_not_raised(qtbot, make_window, tmp_path):
    window = make_window()
    assert not window.open_path(tmp_path / "missing.usvips")
    assert "no such project" in window.statusBar().currentMessage()
    junk = tmp_path / "junk.usvips"
    junk.write_text("not a database")
    assert not window.open_path(junk)
    assert "junk.usvips" in window.statusBar().currentMessage()
    window.accept_or_finish()
    assert "nothing to accept" in window.statusBar().currentMessage()


@pytest.mark.parametrize("tool", ["point", "polygon"])
def test_tools_are_chosen_from_actions(qtbot, make_window, tool):
    window = make_window()
    window.actions[f"tool_{tool}"].trigger()
    assert window.workspace.pick_tool.tool == tool


def test_measured_control_points_are_marked_with_their_numbers(qtbot, make_window, sample_copy):
    window = make_window()
    directory = sample_copy("tank_system1")
    open_sample(qtbot, window, directory, "water1")
    stored = window.workspace.project.control_observations("calibration-water", "water1")
    pane = window.panes["left"]
    drawn = _drawn_points(pane.control_item)
    assert len(drawn) == len(stored.ids) > 10
    assert np.allclose(np.sort(drawn, axis=0), np.sort(stored.left, axis=0))
    assert sorted(t.toPlainText() for t in pane.control_labels) == sorted(stored.ids)
    placed = np.array([[t.pos().x(), t.pos().y()] for t in pane.control_labels]) - PIXEL_CENTRE  # beside its point
    assert np.allclose(np.sort(placed, axis=0), np.sort(stored.left, axis=0))


def _store_fish(window, directory) -> None:
    """fish1 of the measurement pair, picked at its true pixels, stored as a line."""
    left, right = truth_pixels(directory, "measure1", "objects")
    window.set_tool("line")
    for point in ("snout", "fork"):
        window.workspace.pick_tool.pick("left", left["fish1"][point])
        window.workspace.pick_tool.pick("right", right["fish1"][point])
    window.finish_object()


def test_the_plan_view_shows_stored_objects_in_plan_and_profile(qtbot, make_window, sample_copy):
    window = make_window()
    directory = sample_copy("tank_system1")
    open_sample(qtbot, window, directory, "measure1")
    _store_fish(window, directory)
    (stored,) = window.workspace.project.objects()
    window.docks["plan"].raise_()  # a hidden plan view draws when its tab is brought to the front
    qtbot.waitUntil(lambda: not window.plan._dirty, timeout=3000)
    x, y = window.plan.curve.getData()
    assert np.allclose(np.column_stack([x, y])[:2], [[v.xyz[0], v.xyz[1]] for v in stored.vertices])
    window.plan.view.setCurrentText("profile (X–Z)")
    x, z = window.plan.curve.getData()
    assert np.allclose(z[:2], [v.xyz[2] for v in stored.vertices])
    # 1σ ellipses: a 1σ ellipse reaches sqrt(C_xx) either side of its centre in x
    ex, ez = window.plan.ellipses.getData()
    first = np.column_stack([ex, ez])[:49]
    centre, covariance = stored.vertices[0].xyz, stored.vertices[0].covariance
    assert first[:, 0].max() - centre[0] == pytest.approx(np.sqrt(covariance[0, 0]), rel=5e-3)
    assert first[:, 1].max() - centre[2] == pytest.approx(np.sqrt(covariance[2, 2]), rel=5e-3)
    cx, _ = window.plan.cameras.getData()
    assert len(cx) == 2 and "L" in [label.toPlainText() for label in window.plan.labels]
    assert f"{stored.id} {stored.attribute}".strip() in [label.toPlainText() for label in window.plan.labels]
    assert "frame" in window.plan.frame.text()
    window.docks["plan"].setFloating(True)  # a plan view of a fair size, as a user would open it
    window.docks["plan"].resize(700, 450)
    window.docks["plan"].show()
    qtbot.waitUntil(lambda: window.plan.plot.height() > 200, timeout=3000)
    window.plan.refresh()
    (xmin, xmax), (zmin, zmax) = window.plan.plot.getViewBox().viewRange()
    _, cz = window.plan.cameras.getData()
    xs, zs = np.concatenate([x[np.isfinite(x)], cx]), np.concatenate([z[np.isfinite(z)], cz])
    assert xmin <= xs.min() and xmax >= xs.max() and zmin <= zs.min() and zmax >= zs.max()
    # fitted to the data: the tighter axis spans at most about twice what is drawn (not −9 … 10 m)
    assert min((xmax - xmin) / np.ptp(xs), (zmax - zmin) / np.ptp(zs)) < 2.0
    window.object_list.table.selectRow(0)  # bearing and slope say which frame they are in
    assert "rig frame" in window.calculator.output.toPlainText() or "object frame" in \
        window.calculator.output.toPlainText()


def test_many_objects_get_their_figures_off_the_gui_thread(qtbot, make_window, sample_copy):
    window = make_window()
    directory = sample_copy("tank_system1")
    open_sample(qtbot, window, directory, "measure1")
    _store_fish(window, directory)
    (first,) = window.workspace.project.objects()
    for _ in range(6):  # stored behind the window's back: the list meets them all at once
        window.workspace.project.add_object("line", list(first.vertices), "copy")
    window.workspace.reload_objects()  # the model reads them all by one query
    assert window.object_list.row_count() == 7
    assert "computing" in window.object_list.text(3, "figure")
    qtbot.waitUntil(lambda: "mm" in window.object_list.text(6, "figure"), timeout=20000)
    assert window.object_list.text(6, "figure") == window.object_list.text(0, "figure")


def test_objects_are_exported_from_the_window(qtbot, make_window, sample_copy, tmp_path):
    window = make_window()
    directory = sample_copy("tank_system1")
    open_sample(qtbot, window, directory, "water1")  # a calibrated station: the object frame, on the Earth
    left, right = truth_pixels(directory, "water1", "targets")
    target = isolated_targets(left, right)[0]
    window.set_tool("point")
    window.workspace.pick_tool.pick("left", left[target])
    window.workspace.pick_tool.pick("right", right[target])
    window.export_objects(tmp_path / "objects.geojson")  # GeoJSON needs a georeference (issue 19)
    assert "no georeference" in window.statusBar().currentMessage()
    from usvips.core.deployment import Georeference
    window.workspace.project.set_georeference(Georeference(-32.0, 115.5))
    window.export_objects(tmp_path / "objects.geojson")
    assert "exported 1 objects" in window.statusBar().currentMessage()
    assert '"Point"' in (tmp_path / "objects.geojson").read_text()
    window.export_objects(tmp_path / "objects.xyz")
    assert "nothing written" in window.statusBar().currentMessage()
    assert not (tmp_path / "objects.xyz").exists()


def test_nothing_of_one_project_is_left_in_the_next(qtbot, make_window, sample_copy):
    window = make_window()
    first = sample_copy("tank_system1")
    open_sample(qtbot, window, first, "measure1")
    left, _ = truth_pixels(first, "measure1", "objects")
    window.attribute_box.setEditText("snapper")
    click_pixel(qtbot, window.panes["left"], left["fish1"]["snout"])
    window.accept_or_finish()
    assert window.point_label.text()  # a 3-D readout
    window.show_message("error", "something went wrong")
    assert "snapper" in window.workspace.pick_tool.attribute
    second = sample_copy("rov_flatport")
    assert window.open_path(second)
    wait_for_pair(qtbot, window, "air1")
    assert window.point_label.text() == "" and window.workspace.pick_tool.attribute == ""
    assert window.attribute_box.currentText() == ""
    assert "measure1" not in window.panes["left"].title.text() and "air1" in window.panes["left"].title.text()
    assert window.statusBar().styleSheet() == "" and "something went wrong" not in window.hint.text()
    assert "saved as you go" in window.windowTitle() and "rov_flatport" in window.windowTitle()


def test_save_as_copies_the_project_and_goes_on_in_the_copy(qtbot, make_window, sample_copy, tmp_path):
    window = make_window()
    directory = sample_copy("tank_system1")
    open_sample(qtbot, window, directory, "measure1")
    window.workspace.project.add_term("kept")
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    target = elsewhere / "copy.usvips"
    assert window.save_as(target)
    wait_for_pair(qtbot, window, "measure1")
    assert window.workspace.project.path == target
    assert "kept" in window.workspace.project.vocabulary()
    assert window.workspace.images["left"].shape[0] > 0  # the images are found from the new folder
    assert not window.save_as(target)  # never over an existing file
    assert "already exists" in window.hint.text()
    assert not (elsewhere / "copy.usvips.part").exists()


@pytest.mark.parametrize(("typed", "chosen", "written"), [
    ("fish.geojson", "Objects CSV (*.csv)", "fish.geojson"), ("fish", "GeoJSON (*.geojson)", "fish.geojson"),
    ("fish.em.txt", "Objects CSV (*.csv)", "fish.em.txt"), ("fish.CSV", "PLY (*.ply)", "fish.CSV")])
def test_the_export_dialog_keeps_a_typed_suffix(typed, chosen, written):
    from usvips.gui.qt.main_window import MainWindow

    assert MainWindow.export_path(typed, chosen) == written


def test_quitting_with_a_half_made_object_asks_and_can_store_it(qtbot, make_window, sample_copy):
    window = make_window()
    directory = sample_copy("tank_system1")
    open_sample(qtbot, window, directory, "measure1")
    left, right = truth_pixels(directory, "measure1", "objects")
    window.set_tool("line")
    window.attribute_box.setEditText("fish")
    click_pixel(qtbot, window.panes["left"], left["fish1"]["snout"])
    click_pixel(qtbot, window.panes["right"], right["fish1"]["snout"])
    click_pixel(qtbot, window.panes["left"], left["fish1"]["fork"])
    click_pixel(qtbot, window.panes["right"], right["fish1"]["fork"])
    assert len(window.workspace.pick_tool.digitising.vertices) == 2
    questions = []
    answers = ["stay", "save"]
    window.ask_unfinished = lambda question: questions.append(question) or answers.pop(0)
    window.close()
    assert window.isVisible() and "2 vertices" in questions[0]  # "stay": nothing lost, the window stays
    project = window.workspace.project
    window.close()
    assert not window.isVisible()
    (stored,) = Project.open(project.path).objects()
    assert stored.kind == "length" and stored.attribute == "fish"


def test_a_stored_vertex_is_re_picked_from_the_object_list_with_the_mouse(qtbot, make_window, sample_copy):
    window = make_window()
    directory = sample_copy("tank_system1")
    open_sample(qtbot, window, directory, "measure1")
    left, right = truth_pixels(directory, "measure1", "objects")
    window.set_tool("line")
    for point in ("snout", "fork"):
        click_pixel(qtbot, window.panes["left"], left["fish1"][point])
        click_pixel(qtbot, window.panes["right"], right["fish1"][point])
    window.accept_or_finish()
    figure = window.object_list.text(0, "figure")
    window.object_list.table.selectRow(0)
    window.object_list.vertex.setValue(2)
    qtbot.mouseClick(window.object_list.repick_button, QtCore.Qt.MouseButton.LeftButton)
    assert window.workspace.pick_tool.repick is not None and "re-pick vertex 2" in window.hint.text()
    wrong = [np.add(p["fork"], 0.2 * np.subtract(p["fork"], p["snout"])) for p in (left["fish1"], right["fish1"])]
    click_pixel(qtbot, window.panes["left"], wrong[0])
    click_pixel(qtbot, window.panes["right"], wrong[1])
    if window.workspace.pick_tool.state.pending is not None:
        window.accept_or_finish()
    assert window.object_list.text(0, "figure") != figure
    window.undo()
    assert window.object_list.text(0, "figure") == figure


def test_linked_navigation_brings_the_other_pane_to_the_conjugate_region(qtbot, make_window, sample_copy):
    window = make_window()
    directory = sample_copy("rov_flatport")
    open_sample(qtbot, window, directory, "water1")
    left, right = truth_pixels(directory, "water1", "targets")
    window.actions["link"].setChecked(True)
    window.apply_link()
    targets = isolated_targets(left, right)[:5]
    for number in targets:
        tool = window.workspace.pick_tool
        tool.last_point = tool.intersect(left[number], right[number])  # working depth
        window.panes["left"].zoom_to(4.0, tuple(left[number]))  # zoom and pan the left pane only
        rect = window.panes["right"].view_rect()
        centre = np.array(pixel_from_item(rect.center().x(), rect.center().y()))
        assert np.linalg.norm(centre - right[number]) < 1.0, number  # the same target, not the same pixel
        assert window.panes["right"].zoom_level() == pytest.approx(4.0, rel=1e-3)
        parallax = np.linalg.norm(np.subtract(left[number], right[number]))
        assert parallax > 20  # identical pixel coordinates would have missed it


def test_the_object_list_changes_an_objects_kind_with_the_mouse(qtbot, make_window, sample_copy):
    window = make_window()
    directory = sample_copy("tank_system1")
    open_sample(qtbot, window, directory, "measure1")
    left, right = truth_pixels(directory, "measure1", "objects")
    window.set_tool("line")
    for fish, point in [("fish1", "snout"), ("fish1", "fork"), ("fish2", "fork")]:
        click_pixel(qtbot, window.panes["left"], left[fish][point])
        click_pixel(qtbot, window.panes["right"], right[fish][point])
        if window.workspace.pick_tool.state.pending is not None:
            window.accept_or_finish()
    window.accept_or_finish()
    (stored,) = window.workspace.cache.objects()
    assert stored.kind == "arc"
    window.object_list.table.selectRow(0)
    window.object_list.kind.setCurrentText("polygon")
    qtbot.mouseClick(window.object_list.set_kind_button, QtCore.Qt.MouseButton.LeftButton)
    assert window.workspace.project.object(stored.id).kind == "polygon"
    assert "polygon" in window.object_list.text(0, "type")


def test_at_first_start_the_right_hand_panels_fit_without_scrolling_beside_the_object_list(qtbot, tmp_path):
    """A first start (no saved layout) on a 1600 × 1000 window: the right-hand column runs the window's full
    height beside the object list, the Enhancement panel shows its steps and histogram without a scroll bar
    and the object list keeps its buttons in view."""
    from PySide6 import QtCore as Core

    from usvips.gui.qt.main_window import MainWindow

    settings = Core.QSettings(str(tmp_path / "settings.ini"), Core.QSettings.Format.IniFormat)
    window = MainWindow(settings=settings)
    qtbot.addWidget(window)
    window.resize(1600, 1000)
    window.show()
    qtbot.waitExposed(window)
    qtbot.waitUntil(lambda: "enhancement" in window.panels.built(), timeout=5000)
    qtbot.wait(50)
    assert window.corner(Core.Qt.Corner.BottomRightCorner) == Core.Qt.DockWidgetArea.RightDockWidgetArea
    enhancement, objects = window.docks["enhancement"], window.docks["objects"]
    assert not enhancement.widget().verticalScrollBar().isVisible()
    assert not enhancement.widget().horizontalScrollBar().isVisible()
    assert objects.geometry().right() < enhancement.geometry().left()       # the list beside the column
    assert not objects.widget().verticalScrollBar().isVisible()
    window.close()
