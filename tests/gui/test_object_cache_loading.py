"""The object cache made ``deferred`` (issue 37 item 3): empty and loading until the objects read on a handle
of its own arrive whole; what the window wrote meanwhile is read again by id on arrival, and a read that a
full read again (``reload``) has overtaken is dropped. Qt-free."""

from __future__ import annotations

from usvips.core.measurements import QualityRules
from usvips.core.observation_record import ObservationRecord
from usvips.gui.object_cache import ObjectCache, ObjectEvents, read_stored_objects
from usvips.store.opening import create_project
from usvips.store.records import Vertex


def _vertices(x: float) -> list[Vertex]:
    return [Vertex(x, 20.0, x - 2.0, 20.0), Vertex(x + 30.0, 20.0, x + 28.0, 20.0)]


def _heard(events: ObjectEvents) -> list[str]:
    said: list[str] = []
    for name in ("added", "updated", "removed", "reset", "changed"):
        getattr(events, name).connect(lambda *_, name=name: said.append(name))
    return said


def test_writes_made_while_the_objects_are_read_are_read_again_when_they_arrive(tmp_path):
    path = tmp_path / "survey.usvips"
    with create_project(path) as project:
        kept, edited, deleted = (project.add_object("length", _vertices(10.0 * k), "cod") for k in range(1, 4))
        events = ObjectEvents()
        said = _heard(events)
        cache = ObjectCache(project, events, QualityRules, deferred=True)
        assert cache.loading and cache.ids() == [] and kept not in cache
        read = read_stored_objects(path)  # the worker's read, on its own read-only handle
        assert sorted(read.objects) == [kept, edited, deleted]
        added = project.add_object("point", [Vertex(5.0, 6.0, 4.0, 6.0)], "ling")  # written after the read
        project.update_object(edited, attribute="haddock")
        project.delete_object(deleted)
        assert cache.changed_in_store(added=(added,), updated=(edited,), removed=(deleted,)) == ()
        assert said == [] and cache.ids() == []  # kept for the arrival: nothing announced of a cache being read
        cache.arrived(read)
        assert not cache.loading and cache.ids() == [kept, edited, added]
        assert cache.get(edited).attribute == "haddock" and cache.get(added).attribute == "ling"
        assert said == ["reset", "changed"]


def test_records_and_instant_links_written_while_the_objects_are_read_are_those_of_a_full_read(tmp_path):
    """Records set, changed and removed and instants linked and unlinked while the objects are read: on arrival
    the cache holds what a cache reading the whole project afresh holds (objects, records, links)."""
    path = tmp_path / "survey.usvips"
    with create_project(path) as project:
        ids = [project.add_object("length", _vertices(10.0 * k), "cod") for k in range(1, 9)]
        project.set_record(ids[0], ObservationRecord(species="Gadus morhua"))
        project.set_record(ids[1], ObservationRecord(species="Pollachius virens"))
        project.set_record(ids[7], ObservationRecord(species="Molva molva"))
        project.add_instant(ids[2], ids[3])
        project.add_instant(ids[4], ids[5])
        cache = ObjectCache(project, ObjectEvents(), QualityRules, deferred=True)
        read = read_stored_objects(path)
        project.set_record(ids[0], ObservationRecord(species="Melanogrammus aeglefinus"))  # changed
        project.set_record(ids[1], None)  # removed
        project.set_record(ids[6], ObservationRecord(species="Brosme brosme"))  # new
        project.remove_instant(ids[5])  # unlinked
        project.add_instant(ids[2], ids[6])  # linked
        project.delete_object(ids[7])
        cache.changed_in_store(updated=(ids[0], ids[1], ids[6], ids[5], ids[4], ids[2]), removed=(ids[7],))
        cache.arrived(read)
        fresh = ObjectCache(project, ObjectEvents(), QualityRules)
        assert cache.ids() == fresh.ids() and cache.instant_links() == fresh.instant_links()
        assert {i: cache.record(i) for i in cache.ids()} == {i: fresh.record(i) for i in fresh.ids()}
        assert cache.record(ids[0]).species == "Melanogrammus aeglefinus" and cache.record(ids[1]) is None
        assert cache.instant_links() == {ids[3]: ids[2], ids[6]: ids[2]}


def test_a_read_overtaken_by_a_full_read_again_is_dropped(tmp_path):
    path = tmp_path / "survey.usvips"
    with create_project(path) as project:
        first = project.add_object("length", _vertices(10.0), "cod")
        cache = ObjectCache(project, ObjectEvents(), QualityRules, deferred=True)
        read = read_stored_objects(path)
        project.delete_object(first)
        cache.reload()  # e.g. the read failed and the window read the objects itself
        cache.arrived(read)
        assert not cache.loading and first not in cache and cache.ids() == []
        assert read_stored_objects(path, cancelled=lambda: True) is None
