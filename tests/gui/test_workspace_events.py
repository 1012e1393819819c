"""The workspace's fine-grained events, without a window: each change announces what changed, by id, and
the model answers from its cache (no listing of every object from SQLite on a pick or a click)."""

from dataclasses import replace

import pytest

from tests.gui.conftest import truth_pixels
from usvips.app.samples import open_or_create_from_manifest
from usvips.gui import object_cache
from usvips.gui.workspace import Workspace, load_pair_images
from usvips.store import Project

EVENTS = ("pair_changed", "tool_changed", "picks_changed", "objects_added", "objects_updated", "objects_removed",
          "objects_reset", "selection_changed", "rules_changed")


@pytest.fixture
def model(sample_copy, monkeypatch):
    """A workspace on rov_flatport's measure1 pair that records its events, and counts of every listing
    of all objects from the project and of every figure computation."""
    from PySide6 import QtCore

    # work an earlier test's window left in the shared pool finishes first: it would be counted here
    assert QtCore.QThreadPool.globalInstance().waitForDone(60_000)
    directory = sample_copy("rov_flatport")
    project = open_or_create_from_manifest(directory)
    ws = Workspace()
    ws.open_project(project)
    ws.set_pair("measure1", *load_pair_images(project, "measure1"))
    ws.events = []
    for name in EVENTS:
        getattr(ws, name).connect(lambda *args, n=name: ws.events.append((n, *args)))
    counts = {"listings": 0, "figures": 0}
    listing, figures = Project.objects, object_cache._figures_of

    def counted_listing(self):
        counts["listings"] += 1
        return listing(self)

    def counted_figures(*args):
        counts["figures"] += 1
        return figures(*args)

    monkeypatch.setattr(Project, "objects", counted_listing)
    monkeypatch.setattr(object_cache, "_figures_of", counted_figures)
    ws.counts = counts
    yield ws, directory
    ws.close_project()


def _store_fish(ws, directory) -> int:
    left, right = truth_pixels(directory, "measure1", "objects")
    ws.pick_tool.set_tool("line")
    for point in ("snout", "fork"):
        ws.pick_tool.pick("left", left["fish1"][point])
        ws.pick_tool.pick("right", right["fish1"][point])
    return ws.pick_tool.finish_object("fish")


def _named(ws, *names):
    return [e for e in ws.events if e[0] in names]


def test_storing_an_object_announces_its_id_and_lists_nothing(model):
    ws, directory = model
    object_id = _store_fish(ws, directory)
    assert ("tool_changed", "line") in ws.events
    object_events = _named(ws, "objects_added", "objects_updated", "objects_removed", "objects_reset")
    assert object_events == [("objects_added", (object_id,))]
    assert ws.counts["listings"] == 0  # no listing of every object from SQLite
    assert [o.id for o in ws.cache.objects()] == [object_id] and ws.stored_object(object_id).attribute == "fish"
    # its figures were computed once (for the message) and are answered from the cache after that
    assert ws.counts["figures"] == 1
    first = ws.figures([object_id])
    assert ws.figures([object_id]) is first and ws.counts["figures"] == 1
    assert "mm" in first.figures[0].unit or first.figures[0].value > 0


def test_edits_announce_the_changed_id_and_recompute_only_its_figures(model):
    ws, directory = model
    fish = _store_fish(ws, directory)
    other = _store_fish(ws, directory)
    ws.figures([fish])
    ws.figures([other])
    computed = ws.counts["figures"]
    ws.events.clear()
    ws.edits.edit_object(fish, "bream", "tail damaged")
    assert _named(ws, "objects_added", "objects_updated", "objects_removed") == [("objects_updated", (fish,))]
    assert ws.stored_object(fish).notes == "tail damaged" and ws.stored_object(other).attribute == "fish"
    ws.figures([other])
    assert ws.counts["figures"] == computed  # the untouched object keeps its figures
    ws.figures([fish])
    assert ws.counts["figures"] == computed + 1  # the edited one is computed once again
    ws.events.clear()
    ws.edits.change_kind(fish, "arc")
    ws.undo.undo()
    assert _named(ws, "objects_updated") == [("objects_updated", (fish,))] * 2
    assert ws.stored_object(fish).kind == "length"
    assert ws.counts["listings"] == 0


def test_deleting_removes_by_id_prunes_the_selection_and_undo_adds_it_back(model):
    ws, directory = model
    first, second = _store_fish(ws, directory), _store_fish(ws, directory)
    ws.events.clear()
    ws.select([first, second])
    ws.select([second, first][::-1])  # the same selection again: no event
    assert _named(ws, "selection_changed") == [("selection_changed", (first, second))]
    ws.events.clear()
    ws.edits.delete_object(first)
    assert _named(ws, "objects_removed", "selection_changed", "objects_added") == [
        ("objects_removed", (first,)), ("selection_changed", (second,))]
    assert [o.id for o in ws.cache.objects()] == [second]
    ws.events.clear()
    ws.undo.undo()
    (added,) = _named(ws, "objects_added")
    (restored,) = added[1]
    assert [o.id for o in ws.cache.objects()] == sorted([second, restored])
    cached, stored = ws.cache.objects(), ws.project.objects()  # the cache is what the project holds
    assert [(o.id, o.kind, o.attribute, [v.xyz for v in o.vertices]) for o in cached] == \
        [(o.id, o.kind, o.attribute, [v.xyz for v in o.vertices]) for o in stored]
    assert ws.counts["listings"] == 1  # ... and only that comparison listed them


def test_rules_and_selection_events(model):
    ws, directory = model
    fish = _store_fish(ws, directory)
    ws.events.clear()
    ws.select([fish, 999])  # an id not stored is left out
    assert ws.selection == (fish,)
    strict = replace(ws.rules, max_range_m=0.05)
    ws.set_rules(strict)
    ws.set_rules(strict)  # no change, no event
    assert _named(ws, "rules_changed") == [("rules_changed", strict)]
    assert any("range" in failure for failure in ws.figures([fish]).failures)
    ws.rules = replace(ws.rules, max_range_m=100.0)  # set directly: the cached verdict is not used
    assert ws.figures([fish]).failures == ()


def test_another_project_resets_everything_by_one_listing(model, sample_copy):
    ws, directory = model
    _store_fish(ws, directory)
    ws.select([ws.cache.objects()[0].id])
    ws.events.clear()
    other = open_or_create_from_manifest(sample_copy("tank_system1"))
    ws.open_project(other)
    assert ("objects_reset",) in ws.events and ("selection_changed", ()) in ws.events
    assert ws.counts["listings"] == 1 and ws.cache.objects() == [] and ws.selection == ()


def test_a_stale_worker_result_is_not_kept(model):
    ws, directory = model
    fish = _store_fish(ws, directory)
    ws.cache.forget_figures()
    job = ws.cache.figures_job([fish])
    results = job()
    ws.edits.edit_object(fish, "changed meanwhile", "")
    assert ws.cache.remember(job, results) == []  # computed from the object before its edit
    job = ws.cache.figures_job([fish])
    assert ws.cache.remember(job, job()) == [fish] and ws.cache.known_figures(fish) is not None
