"""The panes draw a survey's outlines at a level of detail: the outlines near the view stroked one by one
when there are few, else one raster of all of them (built off the GUI thread once per change); a selection
changes no outline and is always drawn highlighted; a stored, selected or removed fish is seen at once."""

import numpy as np

from tests.gui.conftest import click_pixel, truth_pixels, wait_for_pair
from usvips.gui import object_overlay
from usvips.gui.qt.bench import survey_project
from usvips.gui.qt.pane import RASTER_ALPHA, StereoPane, item_from_pixels
from usvips.locations import sample_project

COUNT = 400
MAX_PATHS = 250


def _points(item) -> np.ndarray:
    if not item.isVisible():
        return np.zeros((0, 2))
    points = item.points()
    return points[np.isfinite(points).all(axis=1)]


def _store_fish(qtbot, window, shift: float) -> None:
    left, right = truth_pixels(sample_project("rov_flatport"), "measure1", "objects")
    window.actions["tool_line"].trigger()
    for point in ("snout", "fork"):
        click_pixel(qtbot, window.panes["left"], np.add(left["fish1"][point], shift))
        click_pixel(qtbot, window.panes["right"], np.add(right["fish1"][point], shift))
    window.actions["accept"].trigger()


def _near_view(pane) -> set[int]:
    """The ids whose outline meets the view grown by the pane's margin (worked out here on their own)."""
    rect = pane.view_rect()
    dx, dy = rect.width() * pane.MARGIN, rect.height() * pane.MARGIN
    x0, x1 = rect.left() - dx - 0.5, rect.right() + dx - 0.5
    y0, y1 = rect.top() - dy - 0.5, rect.bottom() + dy - 0.5
    near = set()
    for i in pane.outlines.ids:
        xy = pane.outlines.outline(int(i), pane.outline_side)
        if xy[:, 0].min() <= x1 and xy[:, 0].max() >= x0 and xy[:, 1].min() <= y1 and xy[:, 1].max() >= y0:
            near.add(int(i))
    return near


def test_a_survey_is_drawn_as_a_raster_zoomed_out_and_as_outlines_in_view_zoomed_in(qtbot, make_window, tmp_path,
                                                                                    monkeypatch):
    monkeypatch.setattr(StereoPane, "MAX_PATHS", MAX_PATHS)
    window = make_window()
    assert window.open_path(survey_project(tmp_path / "survey", COUNT), "measure1")
    wait_for_pair(qtbot, window, "measure1")
    if window.object_list._worker is not None:
        window.object_list._worker.cancel()
    window.observation.ask.setChecked(False)
    ws, panes = window.workspace, window.panes
    overlay = window.overlay
    assert len(overlay.outlines) == COUNT
    # zoomed out: every fish is near the view, too many to stroke: the raster, and no outline stroked
    for pane in panes.values():
        qtbot.waitUntil(lambda p=pane: p.outline_form() == "raster")
        assert len(pane.object_lines()) == 0
        assert pane.raster_item.pixmap().width() == pane.image_size()[0]
        first = overlay.outlines.outline(int(overlay.outlines.ids[0]), pane.outline_side)
        alpha = pane.raster_item.pixmap().toImage().pixelColor(*np.round(first[0]).astype(int)).alpha()
        assert alpha == RASTER_ALPHA  # the raster is drawn where the outlines are
    version = overlay.outlines.version

    # zoomed in on a small part: only the outlines near the view, each stroked whole
    left = panes["left"]
    left.zoom_to(left.zoom_level() * 12, (320.0, 240.0))
    left._draw_outlines()
    near = _near_view(left)
    assert 0 < len(near) <= MAX_PATHS and left.outline_form() == "paths" and not left.raster_item.isVisible()
    drawn = left.object_lines()
    expected = item_from_pixels(overlay.outlines.lines(0, np.flatnonzero(np.isin(overlay.outlines.ids, list(near)))))
    assert np.array_equal(drawn, expected[np.isfinite(expected).all(axis=1)])

    # a selection changes no outline: drawn highlighted over them, zoomed in or out, labelled
    chosen = int(overlay.outlines.ids[5])
    ws.select([chosen])
    assert overlay.outlines.version == version
    for index, side in enumerate(("left", "right")):
        outline = item_from_pixels(overlay.outlines.outline(chosen, index))
        assert np.allclose(_points(panes[side].selected_item), outline)
        assert [label.toPlainText() for label in panes[side].labels] == [overlay.label(chosen)]
    ws.select([])
    assert len(_points(left.selected_item)) == 0 and not left.labels

    # a fish stored zoomed out is stroked over the raster at once, until the raster is built again with it
    left.fit()
    left._draw_outlines()
    qtbot.waitUntil(lambda: left.outline_form() == "raster" and left._raster_version == version)
    _store_fish(qtbot, window, 0.0)
    new = ws.cache.objects()[-1]
    assert new.id in overlay.outlines and overlay.outlines.version > version
    left.fit()  # (the picks may have moved the view)
    left._draw_outlines()
    assert left._raster_version == version  # (the raster of the set without it is still shown)
    new_picks = item_from_pixels(np.array([[v.xl, v.yl] for v in new.vertices]))
    assert np.allclose(left.object_lines(), new_picks) and left.outline_form() == "raster"
    for pane in panes.values():  # (the raster is built only when it is shown: zoomed out)
        pane.fit()
        pane._draw_outlines()
        qtbot.waitUntil(lambda p=pane: p._raster_version == overlay.outlines.version and p.outline_form() == "raster")
        assert len(pane.object_lines()) == 0  # the new fish is in the raster now
    left.zoom_to(12.0, (new.vertices[0].xl, new.vertices[0].yl))
    left._draw_outlines()
    picks = item_from_pixels(np.array([[v.xl, v.yl] for v in new.vertices]))
    assert all(np.min(np.linalg.norm(left.object_lines() - p, axis=1)) < 1e-9 for p in picks)
    # ... and a removed one goes
    ws.edits.delete_object(new.id)
    assert new.id not in overlay.outlines
    assert not any(np.min(np.linalg.norm(left.object_lines() - p, axis=1)) < 1e-9 for p in picks)


def test_every_outline_is_computed_in_slices_and_a_new_refresh_drops_the_old_slices(qtbot, make_window, tmp_path,
                                                                                     monkeypatch):
    window = make_window()
    assert window.open_path(survey_project(tmp_path / "survey", COUNT), "measure1")
    wait_for_pair(qtbot, window, "measure1")
    overlay = window.overlay
    qtbot.waitUntil(lambda: not overlay.refreshing)
    monkeypatch.setattr(object_overlay, "SLICE", 100)
    computed = []
    outline = overlay._outline
    monkeypatch.setattr(overlay, "_outline", lambda ids: (computed.append(len(ids)), outline(ids)))
    overlay.refresh()
    assert len(overlay.outlines) == 100 and overlay.refreshing  # one slice now, the window free meanwhile
    overlay.refresh()  # before the rest: the first refresh's slices are dropped
    qtbot.waitUntil(lambda: not overlay.refreshing)
    assert len(overlay.outlines) == COUNT and sum(computed) == 100 + COUNT
    assert set(overlay.outlines) == set(window.workspace.cache.ids())
