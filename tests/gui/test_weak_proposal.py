"""A weak proposal in the window: when auto-match refuses a vertex, its best candidate on the epipolar
curve is still drawn (cyan, dashed: apart from a confident one), the hint line gives its score and why,
and Enter on the images accepts it with one key."""

import numpy as np
from PySide6 import QtCore

from tests.gui.conftest import click_pixel, open_sample, truth_pixels
from usvips.gui.qt.pane import COLOURS, item_from_pixels


def test_a_weak_proposal_is_drawn_apart_said_and_accepted_by_enter(qtbot, make_window, sample_copy):
    window = make_window()
    directory = sample_copy("tank_system1")
    open_sample(qtbot, window, directory, "water1")
    left, right = truth_pixels(directory, "water1", "targets")
    ws, pane = window.workspace, window.panes["right"]
    seen = {"weak": 0, "confident": 0}
    for number in (k for k in left if left[k] is not None and right.get(k) is not None):
        window.cancel_pick()
        click_pixel(qtbot, window.panes["left"], left[number])
        state = ws.pick_tool.state
        if state.proposal is None:
            continue
        colour = pane.proposal_item.pen().color().getRgb()[:3]
        style = pane.proposal_item.pen().style()
        drawn = pane.proposal_item.points()
        assert len(drawn) == 1  # drawn, weak or not
        if not state.weak:
            seen["confident"] += 1
            assert colour == COLOURS["proposal"] and style == QtCore.Qt.PenStyle.SolidLine
            assert not pane.proposal_weak
            continue
        seen["weak"] += 1
        assert colour == COLOURS["weak proposal"] and style == QtCore.Qt.PenStyle.DashLine and pane.proposal_weak
        hint = window.hint.text()
        assert "weak proposal (correlation" in hint and "Enter accepts" in hint
        proposal = state.proposal
        window.focus_images()
        qtbot.keyClick(window.panes["left"].graphics, QtCore.Qt.Key.Key_Return)  # one key
        if ws.pick_tool.state.pending is not None:  # a guard rail held it: Enter again keeps it, flagged
            qtbot.keyClick(window.panes["left"].graphics, QtCore.Qt.Key.Key_Return)
        assert ws.pick_tool.state.source is None
        assert np.allclose(ws.pick_tool.last_point.right, proposal)
        assert len(pane.proposal_item.points()) == 0 and not pane.proposal_weak
        if seen["confident"]:
            break
    assert seen["weak"] >= 1 and seen["confident"] >= 1, seen


def test_a_vertex_proposed_from_elsewhere_is_drawn_said_and_kept_by_enter(qtbot, make_window, sample_copy):
    """``workspace.pick_tool.propose_vertex`` (a track's proposal) in the window: the left pick and the right
    proposal drawn, the note on the hint line, Enter on the images keeps it."""
    window = make_window()
    directory = sample_copy("tank_system1")
    open_sample(qtbot, window, directory, "water1")
    left, right = truth_pixels(directory, "water1", "targets")
    number = next(k for k in left if left[k] is not None and right.get(k) is not None)
    ws = window.workspace
    ws.pick_tool.propose_vertex(left[number], right[number], "track 7, frame 40")
    drawn = window.panes["right"].proposal_item.points()
    assert np.allclose(drawn, item_from_pixels(right[number]))
    assert "track 7, frame 40" in window.hint.text() and "Enter accepts" in window.hint.text()
    window.focus_images()
    qtbot.keyClick(window.panes["left"].graphics, QtCore.Qt.Key.Key_Return)
    if ws.pick_tool.state.pending is not None:  # a guard rail held it: Enter again keeps it, flagged
        qtbot.keyClick(window.panes["left"].graphics, QtCore.Qt.Key.Key_Return)
    assert ws.pick_tool.state.source is None and np.allclose(ws.pick_tool.last_point.right, right[number])
    assert len(window.panes["right"].proposal_item.points()) == 0


def test_a_match_proposed_off_the_zoomed_other_image_is_brought_into_view(qtbot, make_window, sample_copy):
    """The right image zoomed far from the target: a click on it in the left image proposes its match
    on the right, and the right pane pans to it (keeping the zoom) so that it is seen before Enter."""
    window = make_window()
    directory = sample_copy("tank_system1")
    open_sample(qtbot, window, directory, "water1")
    left, right = truth_pixels(directory, "water1", "targets")
    ws, pane = window.workspace, window.panes["right"]
    for number in (k for k in left if left[k] is not None and right.get(k) is not None):
        window.cancel_pick()
        pane.zoom_to(6.0, (3.0, 3.0))  # the top-left corner, far from every target
        click_pixel(qtbot, window.panes["left"], left[number])
        proposal = ws.pick_tool.state.proposal
        if proposal is not None:
            break
    assert proposal is not None
    assert pane.in_view(proposal) and abs(pane.zoom_level() - 6.0) < 0.5
