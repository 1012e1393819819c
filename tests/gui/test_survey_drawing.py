"""Storing one more fish among hundreds: the panes and the plan view draw it on items of their own and leave
the picture of all the others as it is; the next other change (here a selection) draws everything whole
again, the new fish included."""

import numpy as np

from tests.gui.conftest import click_pixel, truth_pixels, wait_for_pair
from usvips.gui.bench import survey_project
from usvips.gui.pane import item_from_pixels
from usvips.locations import sample_project

COUNT = 400


def _points(item) -> np.ndarray:
    x, y = item.getData()
    if x is None or not item.isVisible():  # pyqtgraph hides a curve given no data (and keeps the old)
        return np.zeros((0, 2))
    points = np.column_stack([x, y])
    return points[np.isfinite(points).all(axis=1)]


def _contains(points: np.ndarray, expected: np.ndarray) -> bool:
    return all(np.min(np.linalg.norm(points - p, axis=1)) < 1e-6 for p in expected)


def _store_fish(qtbot, window) -> None:
    left, right = truth_pixels(sample_project("rov_flatport"), "measure1", "objects")
    window.actions["tool_line"].trigger()
    for point in ("snout", "fork"):
        click_pixel(qtbot, window.panes["left"], left["fish1"][point])
        click_pixel(qtbot, window.panes["right"], right["fish1"][point])
    window.actions["accept"].trigger()


def test_a_stored_fish_is_drawn_alone_until_the_next_change(qtbot, make_window, tmp_path):
    window = make_window()
    assert window.open_path(survey_project(tmp_path / "survey", COUNT), "measure1")
    wait_for_pair(qtbot, window, "measure1")
    if window.object_list._worker is not None:
        window.object_list._worker.cancel()
    window.observation.ask.setChecked(False)  # the observation form would be raised over the plan view
    window.docks["plan"].raise_()
    qtbot.waitUntil(window.plan.isVisible)
    pane, plan = window.panes["left"], window.plan
    others = {"pane": _points(pane.objects_item), "plan": _points(plan.curve.curve),
              "ellipses": _points(plan.ellipses.curve)}
    assert len(others["pane"]) == 2 * COUNT and len(_points(pane.added_item)) == 0

    _store_fish(qtbot, window)
    stored = window.workspace.objects()[-1]
    picks = item_from_pixels(np.array([[v.xl, v.yl] for v in stored.vertices]))
    xyz = np.array([v.xyz for v in stored.vertices])[:, :2]  # plan (X–Y)
    # the new outline alone on the added items; the others' pictures untouched (not even re-set)
    assert np.allclose(_points(pane.added_item), picks)
    assert np.array_equal(_points(pane.objects_item), others["pane"])
    assert np.allclose(_points(plan.added_curve.curve), xyz)
    assert len(_points(plan.added_ellipses.curve)) == 2 * 49
    assert np.array_equal(_points(plan.curve.curve), others["plan"])
    assert np.array_equal(_points(plan.ellipses.curve), others["ellipses"])
    # a second fish joins the first on the added items
    window.workspace.cancel_vertex()
    _store_fish(qtbot, window)
    assert len(_points(pane.added_item)) == 4 and len(_points(plan.added_curve.curve)) == 4

    # a selection draws everything whole again: the fish are in the pictures, the added items empty
    window.workspace.select([window.workspace.objects()[0].id])
    assert len(_points(pane.added_item)) == 0 and len(_points(pane.objects_item)) == 2 * (COUNT + 2) - 2
    assert _contains(_points(pane.objects_item), picks)
    assert len(_points(plan.added_curve.curve)) == 0
    assert _contains(_points(plan.curve.curve), xyz)
