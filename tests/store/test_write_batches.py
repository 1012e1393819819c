"""Writes sent in batches (issue 34: storing a fish on a server in few round trips): a survey's writes go to
the backend as batches — on a server in one round trip, and writes nobody reads back held until the next
statement or the commit — yet a write the database refuses still fails its whole transaction, on every
backend: nothing of it is stored, no history row, and the next write stores as before."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from tests.store.test_storage_contract import impl, store, where  # noqa: F401 - the contract's backends
from usvips.core.observation_record import ObservationRecord
from usvips.store import ProjectError
from usvips.store.records import Vertex


def _fish(rng) -> list[Vertex]:
    return [Vertex(*map(float, rng.uniform(0, 2000, 4)), tuple(map(float, rng.normal(size=3))), np.eye(3) * 1e-6)
            for _ in range(2)]


def test_a_refused_write_inside_a_transaction_leaves_nothing_of_it(store):  # noqa: F811
    rng = np.random.default_rng(8)
    bad = [dataclasses.replace(v, calibration_id=999) for v in _fish(rng)]  # no calibration 999: refused
    with pytest.raises(ProjectError) as refused:
        with store.transaction():
            first = store.add_object("length", _fish(rng), "kept?")
            store.set_record(first, ObservationRecord(genus="Pagrus", species="auratus"))
            store.add_object("length", bad, "refused")
            store.update_object(first, notes="after it")  # a server may hear of the refusal only here …
            store.set_record(first, ObservationRecord(genus="Gadus"))  # … or at the commit
    message = str(refused.value)
    assert "\n" not in message and "foreign key" in message.lower()
    assert store.objects() == [] and store.history() == [] and store.records() == {}
    again = store.add_object("length", _fish(rng), "after")
    assert [o.id for o in store.objects()] == [again] and [h.change for h in store.history()] == ["add"]
    with pytest.raises(ProjectError, match="(?i)foreign key"):
        store.add_object("length", bad, "refused alone")
    assert [o.id for o in store.objects()] == [again] and len(store.history()) == 1


def test_a_fish_stored_in_one_transaction_reads_back_whole(store):  # noqa: F811
    """What the bench's row does (an object, two vertices and its record in one transaction), many times,
    checked against what was written: every vertex, covariance, record and history row."""
    rng = np.random.default_rng(9)
    written = {}
    for k in range(40):
        vertices = _fish(rng)
        record = ObservationRecord(genus="Pagrus", species="auratus", number=1 + k % 3)
        with store.transaction():
            object_id = store.add_object("length", vertices, f"fish {k}")
            store.set_record(object_id, record)
        written[object_id] = (vertices, record)
    assert sorted(written) == [o.id for o in store.objects()]
    for stored in store.objects():
        vertices, record = written[stored.id]
        assert [(v.xl, v.yl, v.xr, v.yr, v.xyz) for v in stored.vertices] == \
            [(v.xl, v.yl, v.xr, v.yr, v.xyz) for v in vertices]
        assert all(np.array_equal(a.covariance, b.covariance) for a, b in zip(stored.vertices, vertices, strict=True))
        assert store.record(stored.id) == record
        assert [h.change for h in store.history(stored.id)] == ["add", "record"]


def _count_exchanges(monkeypatch) -> list[list[str]]:
    """From now until ``monkeypatch.undo()``, every exchange with the server (the first word of each statement
    sent together), appended to the list returned: each goes through ``PostgresBackend._send``, or is a commit
    with nothing held."""
    from usvips.store.postgres import PostgresBackend

    exchanges: list[list[str]] = []
    send, commit = PostgresBackend._send, PostgresBackend.commit

    def counted_send(self, statements, ending=()):
        exchanges.append([s.sql.split()[0] for s in statements] + list(ending))
        return send(self, statements, ending)

    def counted_commit(self):
        if not self._later and self._starting is None:
            exchanges.append(["COMMIT"])
        return commit(self)

    monkeypatch.setattr(PostgresBackend, "_send", counted_send)
    monkeypatch.setattr(PostgresBackend, "commit", counted_commit)
    return exchanges


def test_a_fish_on_a_server_is_three_round_trips(new_database, monkeypatch):
    """The bench's fish (issue 34: ≤ 3 × SQLite) on a server: the transaction's start, the id reservation,
    the rows, the record's one read and the commit go in 3 round trips (it was 14: one per statement).
    Every exchange with the server goes through ``PostgresBackend._send`` or a commit with nothing held."""
    from usvips.store.postgres import ServerProject

    rng = np.random.default_rng(10)

    with ServerProject.create(new_database("round_trips")) as survey:
        survey.add_object("length", _fish(rng), "before")  # the survey's first write (its schema read once)
        exchanges = _count_exchanges(monkeypatch)
        with survey.transaction():
            object_id = survey.add_object("length", _fish(rng), "snapper")
            survey.set_record(object_id, ObservationRecord(genus="Pagrus", species="auratus"))
        monkeypatch.undo()
        assert exchanges == [["UPDATE"], ["SELECT"], ["COMMIT"]], exchanges
        assert survey.record(object_id).genus == "Pagrus" and len(survey.object(object_id).vertices) == 2
        assert [h.change for h in survey.history(object_id)] == ["add", "record"]


def test_an_edit_of_a_fish_on_a_server_is_three_round_trips(new_database, monkeypatch):
    """Issue 34: an edit of a fish on a server — kind, attribute, notes and its vertices re-picked on a pair, the
    fish accepted before (so it goes back to unreviewed) — in 3 round trips (it was ~15): what the edit reads
    (the object, its vertices' stamps, its review, the pair), then the held writes with the object read back as
    changed, then the history rows with the commit. And what was written is what reads back."""
    from usvips.store.postgres import ServerProject

    rng = np.random.default_rng(11)

    with ServerProject.create(new_database("edit_round_trips")) as survey:
        survey.add_pair("p1")
        object_id = survey.add_object("length", _fish(rng), "before")
        survey.set_review(object_id, "accepted")
        modified = survey.object(object_id).modified
        picked = [dataclasses.replace(v, pair="p1") for v in _fish(rng)] + [
            dataclasses.replace(_fish(rng)[0], pair="p1")]
        exchanges = _count_exchanges(monkeypatch)
        survey.update_object(object_id, attribute="snapper", notes="re-picked", vertices=picked, kind="arc",
                             expected_modified=modified)
        monkeypatch.undo()
        assert len(exchanges) == 3 and exchanges[-1][-1] == "COMMIT", exchanges
        stored = survey.object(object_id)
        assert (stored.kind, stored.attribute, stored.notes) == ("arc", "snapper", "re-picked")
        assert [(v.xl, v.yl, v.xr, v.yr, v.pair) for v in stored.vertices] == \
            [(v.xl, v.yl, v.xr, v.yr, "p1") for v in picked]
        assert stored.modified > modified and survey.review(object_id).state == "unreviewed"
        changes = survey.history(object_id)
        assert [h.change for h in changes] == ["add", "review", "re-pick", "review"]
        assert changes[2].new["attribute"] == "snapper" and len(changes[2].new["vertices"]) == 3
        assert changes[3].new == {"state": "unreviewed", "reason": "edited after review"}
        assert len(survey.vertex_history(object_id)) == 2  # the two 3-D values replaced
