"""The window at survey size draws what changed, not everything: a stored fish goes on items of its own
beside the cached picture of all the others; a selection draws the selected outline over that picture (and,
in the plan view, only the labels and 1σ ellipses of the selection); a removal redraws the chunk of the
picture that held the object."""

import numpy as np

from tests.gui.conftest import click_pixel, truth_pixels, wait_for_pair
from usvips.gui import object_overlay
from usvips.gui.qt.bench import survey_project
from usvips.gui.qt.pane import item_from_pixels
from usvips.locations import sample_project

COUNT = 400


def _points(item) -> np.ndarray:
    x, y = item.getData()
    if x is None or not item.isVisible():  # pyqtgraph hides a curve given no data (and keeps the old)
        return np.zeros((0, 2))
    points = np.column_stack([x, y])
    return points[np.isfinite(points).all(axis=1)]


def _contains(points: np.ndarray, expected: np.ndarray) -> bool:
    return len(points) > 0 and all(np.min(np.linalg.norm(points - p, axis=1)) < 1e-6 for p in expected)


def _store_fish(qtbot, window, shift: float) -> None:
    left, right = truth_pixels(sample_project("rov_flatport"), "measure1", "objects")
    window.actions["tool_line"].trigger()
    for point in ("snout", "fork"):
        click_pixel(qtbot, window.panes["left"], np.add(left["fish1"][point], shift))
        click_pixel(qtbot, window.panes["right"], np.add(right["fish1"][point], shift))
    window.actions["accept"].trigger()


def test_a_stored_fish_is_drawn_alone_and_a_selection_over_the_others(qtbot, make_window, tmp_path, monkeypatch):
    monkeypatch.setattr(object_overlay, "CHUNK", 100)  # four chunks of the picture here
    window = make_window()
    assert window.open_path(survey_project(tmp_path / "survey", COUNT), "measure1")
    wait_for_pair(qtbot, window, "measure1")
    if window.object_list._worker is not None:
        window.object_list._worker.cancel()
    window.observation.ask.setChecked(False)  # the observation form would be raised over the plan view
    window.docks["plan"].raise_()  # the plan view is made and drawn when its tab first comes to the front
    qtbot.waitUntil(lambda: window.plan.isVisible() and not window.plan._dirty)
    ws, pane, plan = window.workspace, window.panes["left"], window.plan
    others = {"pane": pane.object_lines(), "plan": _points(plan.curve.curve)}
    assert len(others["pane"]) == 2 * COUNT and len(_points(pane.added_item)) == 0
    assert len(_points(plan.ellipses.curve)) == 0  # at survey size only the selection's ellipses

    _store_fish(qtbot, window, 0.0)
    first = ws.cache.objects()[-1]
    picks = item_from_pixels(np.array([[v.xl, v.yl] for v in first.vertices]))
    xyz = np.array([v.xyz for v in first.vertices])[:, :2]  # plan (X–Y)
    # the new outline alone on the added items; the others' pictures untouched (not even re-set)
    assert np.allclose(_points(pane.added_item), picks)
    assert np.array_equal(pane.object_lines(), others["pane"])
    assert np.allclose(_points(plan.added_curve.curve), xyz)
    assert np.array_equal(_points(plan.curve.curve), others["plan"])
    ws.pick_tool.cancel_vertex()
    _store_fish(qtbot, window, 3.0)  # a second fish joins the first on the added items
    assert len(_points(pane.added_item)) == 4 and len(_points(plan.added_curve.curve)) == 4

    # selecting draws the selected outline over the pictures, which stay as they are; the plan view
    # labels it and draws its 1σ ellipses (49 points a vertex)
    ws.select([first.id])
    assert np.allclose(_points(pane.selected_item), picks)
    assert np.array_equal(pane.object_lines(), others["pane"]) and len(_points(pane.added_item)) == 4
    assert [label.toPlainText() for label in pane.labels] == [str(first.id)]
    assert np.array_equal(_points(plan.curve.curve), others["plan"])
    assert len(_points(plan.ellipses.curve)) == 2 * 49
    assert str(first.id) in [label.toPlainText() for label in plan.labels]
    ws.select([])
    assert len(_points(pane.selected_item)) == 0 and len(_points(plan.ellipses.curve)) == 0

    # a removal redraws the chunk of the picture that held the object, no other (the added fish stay on
    # their items); the plan view draws whole again
    chunks = [_points(item) for item in pane.object_items]
    gone = ws.cache.objects()[0]
    ws.edits.delete_object(gone.id)
    after = [_points(item) for item in pane.object_items]
    changed = [k for k, (a, b) in enumerate(zip(chunks, after, strict=True)) if not np.array_equal(a, b)]
    assert len(pane.object_items) == 4
    assert len(changed) == 1 and len(after[changed[0]]) == len(chunks[changed[0]]) - 2
    gone_picks = item_from_pixels(np.array([[v.xl, v.yl] for v in gone.vertices]))
    assert _contains(chunks[changed[0]], gone_picks) and not _contains(pane.object_lines(), gone_picks)
    assert len(_points(pane.added_item)) == 4 and len(pane.object_lines()) == 2 * (COUNT - 1)
    assert len(_points(plan.added_curve.curve)) == 0 and _contains(_points(plan.curve.curve), xyz)
    # an edit that needs the whole picture (selecting the added fish and deleting it) draws it whole
    ws.edits.delete_object(first.id)
    assert len(_points(pane.added_item)) == 0 and len(pane.object_lines()) == 2 * (COUNT - 1 + 1)
