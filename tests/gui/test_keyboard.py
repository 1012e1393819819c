"""Keys with real key events on the focused widget: text fields and tables keep Enter; on the images Enter
accepts, Esc cancels, Ctrl(+Shift)+arrows nudge the current pick, Page Up/Down change pairs; in the wizard's
measure page Enter accepts and never advances."""

import numpy as np
import pytest
from PySide6 import QtCore, QtWidgets

from tests.gui.conftest import click_pixel, isolated_targets, open_sample, truth_pixels, wait_for_pair
from usvips.gui.calibration_session import CalibrationSession
from usvips.gui.qt.main_window import MainWindow

Key = QtCore.Qt.Key
Modifier = QtCore.Qt.KeyboardModifier


def _focused(qtbot, widget) -> QtWidgets.QWidget:
    widget.setFocus()
    qtbot.waitUntil(lambda: QtWidgets.QApplication.focusWidget() is widget, timeout=2000)
    return widget


def _key(qtbot, key, modifier=Modifier.NoModifier) -> None:
    """A key pressed on whatever widget has the focus, as a user's key would be delivered."""
    qtbot.keyClick(QtWidgets.QApplication.focusWidget(), key, modifier)


def _first_pick_with_proposal(qtbot, window, directory, pair="water1"):
    left, right = truth_pixels(directory, pair, "targets")
    for number in isolated_targets(left, right):
        window.cancel_pick()
        click_pixel(qtbot, window.panes["left"], left[number])
        if window.workspace.pick_tool.state.proposal is not None and not window.workspace.pick_tool.state.weak:
            return number, left, right
    pytest.fail("no target got a proposal")


def test_enter_in_the_attribute_box_stores_the_text(qtbot, make_window, sample_copy):
    window = make_window()
    open_sample(qtbot, window, sample_copy("rov_flatport"), "water1")
    assert window.attribute_box.currentText() == ""  # nothing preselected
    _focused(qtbot, window.attribute_box)
    qtbot.keyClicks(window.attribute_box, "Pagrus auratus")
    _key(qtbot, Key.Key_Return)
    assert window.workspace.pick_tool.attribute == "Pagrus auratus"
    assert "Pagrus auratus" in window.workspace.project.vocabulary()
    assert "nothing to accept" not in window.log.toPlainText()
    assert QtWidgets.QApplication.focusWidget() is window.panes["left"].graphics  # back to measuring


def test_the_point_tool_stores_the_attribute_typed(qtbot, make_window, sample_copy):
    window = make_window()
    directory = sample_copy("rov_flatport")
    open_sample(qtbot, window, directory, "water1")
    window.set_tool("point")
    _focused(qtbot, window.attribute_box)
    qtbot.keyClicks(window.attribute_box, "marker")
    _key(qtbot, Key.Key_Return)
    _first_pick_with_proposal(qtbot, window, directory)
    _key(qtbot, Key.Key_Return)  # the pane has the focus after the click: Enter accepts
    (stored,) = window.workspace.project.objects()
    assert stored.kind == "point" and stored.attribute == "marker"


def test_enter_in_a_table_cell_commits_the_edit(qtbot, make_window, sample_copy):
    window = make_window()
    directory = sample_copy("rov_flatport")
    open_sample(qtbot, window, directory, "water1")
    window.set_tool("point")
    _first_pick_with_proposal(qtbot, window, directory)
    _key(qtbot, Key.Key_Return)
    table = window.object_list.table
    assert table.model().rowCount() == 1
    window.docks["objects"].raise_()
    column = window.object_list.COLUMNS.index("notes")
    table.setCurrentIndex(table.model().index(0, column))
    table.edit(table.model().index(0, column))
    qtbot.waitUntil(lambda: isinstance(QtWidgets.QApplication.focusWidget(), QtWidgets.QLineEdit), timeout=2000)
    qtbot.keyClicks(QtWidgets.QApplication.focusWidget(), "behind the rock")
    _key(qtbot, Key.Key_Return)  # the delegate commits on the next round of the event loop
    qtbot.waitUntil(lambda: window.workspace.project.objects()[0].notes == "behind the rock", timeout=2000)
    assert window.workspace.pick_tool.state.source is None  # Enter did not reach the images


def test_enter_in_the_enhancement_parameters_applies_them(qtbot, make_window, sample_copy):
    window = make_window()
    open_sample(qtbot, window, sample_copy("rov_flatport"), "water1")
    panel = window.enhancement
    panel.operation.setCurrentText("gamma")
    panel.add_button.click()
    qtbot.waitUntil(lambda: not window.busy, timeout=10000)
    field = _focused(qtbot, panel.parameters)
    field.selectAll()
    qtbot.keyClicks(field, '{"gamma": 0.5}')
    _key(qtbot, Key.Key_Return)
    assert window.workspace.enhancement.pipelines["left"].operations[-1].params == {"gamma": 0.5}


def test_enter_accepts_and_nudging_moves_the_pick_by_a_tenth_and_one_pixel(qtbot, make_window, sample_copy):
    window = make_window()
    directory = sample_copy("rov_flatport")
    open_sample(qtbot, window, directory, "water1")
    number, left, right = _first_pick_with_proposal(qtbot, window, directory)
    assert QtWidgets.QApplication.focusWidget() is window.panes["left"].graphics
    ws = window.workspace
    proposal = np.array(ws.pick_tool.state.proposal)
    _key(qtbot, Key.Key_Right, Modifier.ControlModifier)
    assert np.allclose(np.array(ws.pick_tool.state.proposal) - proposal, (0.1, 0.0), atol=1e-12)
    _key(qtbot, Key.Key_Down, Modifier.ControlModifier | Modifier.ShiftModifier)
    assert np.allclose(np.array(ws.pick_tool.state.proposal) - proposal, (0.1, 1.0), atol=1e-12)
    window.undo()
    window.undo()
    assert np.allclose(ws.pick_tool.state.proposal, proposal)
    _key(qtbot, Key.Key_Return)
    assert ws.pick_tool.state.source is None and ws.pick_tool.last_point is not None  # the vertex was completed
    assert np.allclose(ws.pick_tool.last_point.right, proposal)
    # without a proposal the first pick itself moves, and its epipolar curve with it
    ws.settings.auto_match = False
    click_pixel(qtbot, window.panes["left"], left[number])
    pick, curve = np.array(ws.pick_tool.state.left), ws.pick_tool.state.curve.copy()
    _key(qtbot, Key.Key_Up, Modifier.ControlModifier)
    assert np.allclose(np.array(ws.pick_tool.state.left) - pick, (0.0, -0.1), atol=1e-12)
    moved = ws.pick_tool.state.curve  # a new curve (its number of samples may differ too)
    assert moved.shape != curve.shape or not np.allclose(moved, curve)
    _key(qtbot, Key.Key_Escape)
    assert ws.pick_tool.state.source is None


def test_enter_with_a_refused_match_says_what_to_do_instead_of_finishing(qtbot, make_window, sample_copy):
    window = make_window()
    directory = sample_copy("rov_flatport")
    open_sample(qtbot, window, directory, "water1")
    window.set_tool("polygon")
    window.workspace.settings.auto_match = False
    left, _ = truth_pixels(directory, "water1", "targets")
    click_pixel(qtbot, window.panes["left"], next(iter(v for v in left.values() if v is not None)))
    _key(qtbot, Key.Key_Return)
    assert "click the point in the right image" in window.statusBar().currentMessage()
    assert "needs at least" not in window.log.toPlainText()


def test_page_down_and_up_step_through_the_pairs(qtbot, make_window, sample_copy):
    window = make_window()
    open_sample(qtbot, window, sample_copy("tank_system1"), "air1")
    _focused(qtbot, window.panes["left"].graphics)
    _key(qtbot, Key.Key_PageDown)
    wait_for_pair(qtbot, window, "water1")
    _focused(qtbot, window.panes["left"].graphics)
    _key(qtbot, Key.Key_PageUp)
    wait_for_pair(qtbot, window, "air1")


def test_measuring_keys_are_in_the_menus_and_the_guide():
    from usvips.gui.qt.main_window import quick_guide

    guide = quick_guide()  # a resource file shipped with the package
    for text in ("Enter", "Esc", "Ctrl+arrow", "Ctrl+Shift+arrow", "Page Down", "Attribute"):
        assert text in guide, text
    assert MainWindow.export_path("/tmp/fish.geojson", "Objects CSV (*.csv)") == "/tmp/fish.geojson"
    assert MainWindow.export_path("/tmp/fish", "GeoJSON (*.geojson)") == "/tmp/fish.geojson"


def test_enter_in_the_wizards_measure_page_accepts_and_never_advances(qtbot, sample_copy):
    from usvips.app.samples import open_or_create_from_manifest
    from usvips.gui.qt.calibration_wizard import CalibrationWizard

    directory = sample_copy("rov_flatport")
    project = open_or_create_from_manifest(directory)
    session = CalibrationSession(project, "water")
    wizard = CalibrationWizard(session)
    qtbot.addWidget(wizard)
    wizard.show()
    qtbot.waitExposed(wizard)
    wizard.setup_page.set_checked_pairs(["water1"])
    wizard.next()
    measure = wizard.measure_page
    qtbot.waitUntil(lambda: measure.panes["left"].display is not None, timeout=10000)
    left, right = truth_pixels(directory, "water1", "targets")
    number = next(k for k in isolated_targets(left, right) if k in session.measured("water1"))
    session.remove_observation("water1", number)
    measure.refresh()
    measure.target.setCurrentText(number)
    _focused(qtbot, measure.panes["left"].graphics)
    _key(qtbot, Key.Key_Return)  # nothing picked: a hint, not the next page
    assert wizard.currentPage() is measure
    click_pixel(qtbot, measure.panes["left"], left[number], zoom=4.0)
    assert QtWidgets.QApplication.focusWidget() is measure.panes["left"].graphics
    proposal = measure.workspace.pick_tool.state.proposal
    _key(qtbot, Key.Key_Return)
    assert wizard.currentPage() is measure
    if proposal is not None:  # with a calibration to draw the curve, Enter took the proposal
        assert ("water1", number) in session.observations
        assert np.allclose(session.observations[("water1", number)][2:], proposal)
    else:
        assert "click the target in the right image" in measure.message.text()
    wizard.close()
    project.close()
