"""What colleagues changed since a window last looked (usvips.app.live_changes): two handles on one survey,
as an SQLite file and on the real PostgreSQL server the suite starts. bob adds, edits, reviews and deletes
through his handle; ann's "window" (the versions she holds) is told exactly what differs, by whom —
never her own writes, which her window already holds."""

from __future__ import annotations

import pytest

from tests.store.conftest import new_database, postgres_server  # noqa: F401 - the suite's real server
from usvips.app.live_changes import ChangeBatch, ColleagueChange, clock_text, fold, read_changes, summary
from usvips.store.opening import create_project, open_project
from usvips.store.records import HistoryEntry, Vertex

FISH = [Vertex(10.0, 20.0, 8.0, 20.0), Vertex(40.0, 20.0, 38.0, 20.0)]


@pytest.fixture(params=["sqlite", "postgresql"])
def handles(request, tmp_path):
    """(ann's handle, bob's handle) on a new survey holding one object of carl's (id 1)."""
    where = str(tmp_path / "shared.usvips") if request.param == "sqlite" else \
        request.getfixturevalue("new_database")("live")
    with create_project(where) as project:
        project.annotator = "carl"
        project.add_object("length", FISH, "fish")
    ann, bob = open_project(where), open_project(where)
    ann.annotator, bob.annotator = "ann", "bob"
    yield ann, bob
    ann.close()
    bob.close()


def _versions(store) -> dict[int, str]:
    return {o.id: o.modified for o in store.objects()}


def test_a_colleagues_additions_edits_and_deletions_are_folded_per_object_with_who_and_when(handles):
    ann, bob = handles
    cursor, known = ann.last_change_id(), _versions(ann)
    assert cursor > 0 and fold(read_changes(ann, cursor), known) == []  # nothing since ann read
    new = bob.add_object("length", FISH, "cod")
    bob.update_object(1, notes="bob: remeasured")
    gone = bob.add_object("length", FISH, "bream")
    bob.delete_object(gone)  # added and deleted before ann looked: nothing to show
    batch = read_changes(ann, cursor)  # ann's own handle reads what bob committed
    assert [e.annotator for e in batch.entries] == ["bob"] * 4 and batch.last == ann.last_change_id()
    assert set(batch.versions) == {1, new}
    changes = fold(batch, known)
    assert [(c.object_id, c.what, c.who, c.changes) for c in changes] == [
        (1, "changed", "bob", ("edit",)), (new, "added", "bob", ("add",))]
    assert changes[0].at == batch.entries[1].at and changes[0].text().startswith("changed by bob at ")
    # ann's window now holds both; bob reviews one and deletes the other
    known = _versions(ann)
    cursor = batch.last
    bob.set_review(new, "accepted")
    bob.delete_object(1)
    changes = fold(read_changes(ann, cursor), known)
    assert [(c.object_id, c.what, c.who) for c in changes] == [(1, "deleted", "bob"), (new, "changed", "bob")]
    assert changes[1].changes == ("review",)


def test_the_windows_own_writes_give_nothing_even_under_a_colleagues_name(handles):
    """Two windows may run under one annotator name: what tells a window's own writes from others' is the
    version it holds, not the name."""
    ann, bob = handles
    bob.annotator = "ann"  # a second window of ann's
    cursor = ann.last_change_id()
    mine = ann.add_object("length", FISH, "mine")
    ann.update_object(1, notes="ann: first window")
    known = _versions(ann)  # ann's first window holds what it wrote
    assert fold(read_changes(ann, cursor), known) == []
    bob.update_object(mine, notes="ann: second window")  # the same name, another window
    changes = fold(read_changes(ann, cursor), known)
    assert [(c.object_id, c.what, c.who) for c in changes] == [(mine, "changed", "ann")]


def test_history_read_in_pages_is_read_whole_and_a_batch_read_again_finds_nothing_new(handles):
    ann, bob = handles
    cursor = ann.last_change_id()
    ids = bob.add_objects([("length", FISH, f"fish {k}", "", "") for k in range(5)])
    batch = read_changes(ann, cursor, page=2)
    assert [e.object_id for e in batch.entries] == ids and batch.last == ann.last_change_id()
    assert [c.object_id for c in fold(batch, _versions(ann))] == []  # already held: nothing
    assert [c.what for c in fold(batch, {1: ann.object(1).modified})] == ["added"] * 5
    assert read_changes(ann, batch.last) == ChangeBatch((), {}, batch.last)


def _entry(number: int, who: str, object_id: int, change: str) -> HistoryEntry:
    return HistoryEntry(number, f"2026-11-28T12:{number:02d}:00.000000+00:00", who, object_id, change, None, None)


def test_fold_over_many_random_histories_matches_the_stored_state():
    """Random sequences of rows and random states: an object is reported exactly when its stored version
    differs from the one held, as added, changed or deleted, with the latest row's annotator."""
    import random

    rng = random.Random(7)
    for _ in range(300):
        ids = range(1, 8)
        entries = [_entry(n + 1, rng.choice(["ann", "bob", "carl", ""]), rng.choice(ids),
                       rng.choice(["add", "edit", "review", "delete"])) for n in range(rng.randint(0, 12))]
        stored = {i: f"v{rng.randint(1, 3)}" for i in ids if rng.random() < 0.6}
        held = {i: f"v{rng.randint(1, 3)}" for i in ids if rng.random() < 0.6}
        touched = {e.object_id for e in entries}
        versions = {i: v for i, v in stored.items() if i in touched}
        changes = {c.object_id: c for c in fold(ChangeBatch(tuple(entries), versions, 0), held)}
        for object_id in touched:
            now, shown = versions.get(object_id), held.get(object_id)
            expected = None if now == shown else ("added" if shown is None else "deleted" if now is None else "changed")
            change = changes.get(object_id)
            assert (change.what if change else None) == expected
            if change:
                last = [e for e in entries if e.object_id == object_id][-1]
                assert (change.annotator, change.at) == (last.annotator, last.at)
                assert change.who == (last.annotator or "someone")
        assert set(changes) <= touched


def test_what_a_person_reads():
    changes = [ColleagueChange(3, "added", "bob", "2026-11-28T12:41:05+00:00"),
               ColleagueChange(4, "added", "bob", "x"), ColleagueChange(5, "deleted", "carl", "x"),
               ColleagueChange(7, "changed", "bob", "x", ("edit", "review"))]
    assert summary(changes) == "bob: 2 objects added, 1 changed; carl: 1 object deleted"
    assert summary([]) == ""
    assert changes[3].sentence() == "bob changed object 7 at x (edit, review)"
    assert changes[2].sentence() == "carl deleted object 5 at x"
    assert clock_text("not a time") == "not a time"
    assert len(clock_text("2026-11-28T12:41:05+00:00")) == 5  # HH:MM of this computer's clock
    assert clock_text("2026-11-28T12:41:05") == "12:41"  # no zone: as written
