"""Stale ids never reach the object cache: after a delete in the window, an undone store and a colleague's
delete on the same survey, every view holds only the ids the store still has, and changing each setting
that recomputes the objects' figures (every quality rule) computes them for those ids alone."""

from dataclasses import fields, replace

from PySide6 import QtCore

from tests.gui.conftest import click_pixel, truth_pixels, wait_for_pair
from usvips.core.measurements import QualityRules
from usvips.gui.qt.bench import survey_project
from usvips.locations import sample_project
from usvips.store.opening import open_project

COUNT = 30


def _listed(window) -> list[int]:
    """The object ids the object list shows, row by row (its first column)."""
    model = window.object_list.table.model()
    return [int(model.index(row, 0).data()) for row in range(model.rowCount())]


def test_deleted_objects_leave_every_view_before_the_figures_are_computed_again(qtbot, make_window, tmp_path):
    path = survey_project(tmp_path / "survey", COUNT)
    window = make_window()
    assert window.open_path(path, "measure1")
    wait_for_pair(qtbot, window, "measure1")
    ws, listing = window.workspace, window.object_list
    if listing._worker is not None:  # the figures of the opened survey are still being computed: stopped,
        listing._worker.cancel()     # so that the ids they were asked for are still pending when rules change
    errors: list[str] = []
    ws.message.connect(lambda level, text: errors.append(text) if level == "error" else None)
    ids = ws.cache.ids()
    # deleted in the window: selected, then Delete in the list
    for object_id in (ids[3], ids[4]):
        ws.select([object_id])
        window.object_list.table.setFocus()
        qtbot.keyClick(window.object_list.table, QtCore.Qt.Key.Key_Delete)
    # a fish stored with the mouse, then the store undone
    left, right = truth_pixels(sample_project("rov_flatport"), "measure1", "objects")
    window.actions["tool_line"].trigger()
    for point in ("snout", "fork"):
        click_pixel(qtbot, window.panes["left"], left["fish1"][point])
        click_pixel(qtbot, window.panes["right"], right["fish1"][point])
    window.actions["accept"].trigger()
    stored = ws.cache.ids()[-1]
    assert stored not in ids and stored in _listed(window)
    window.actions["undo"].trigger()
    # a colleague deletes an object this window has edited; undoing the edit meets the delete
    ws.edits.edit_object(ids[7], "mine", "")
    with open_project(path) as colleague:
        colleague.delete_object(ids[7])
    window.actions["undo"].trigger()  # refused as stale: the window reads the object again and finds it gone
    gone = {ids[3], ids[4], ids[7], stored}
    in_store = [o.id for o in ws.project.objects()]
    assert not gone & set(in_store)
    assert ws.cache.ids() == in_store and _listed(window) == in_store
    rules = ws.rules
    for rule in fields(QualityRules):  # every setting that recomputes figures, one after the other
        value = getattr(rules, rule.name)
        rules = replace(rules, **{rule.name: {"max_sigma_m": 0.01} if isinstance(value, dict) else value / 2})
        ws.set_rules(rules)
        qtbot.waitUntil(lambda: listing._worker is None and not window.busy, timeout=30000)
        assert _listed(window) == ws.cache.ids() == in_store
    window.qa.model.refresh_now()
    assert {int(row.object_id) for row in window.qa.model.rows} <= set(in_store)
    assert all(ws.cache.known_figures(i) is not None for i in in_store)
    assert errors == []
