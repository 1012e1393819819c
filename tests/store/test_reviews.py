"""Reviews (schema 9): the migration of schema-8 projects and surveys (their history kept whole and still
append-only), and ``usvips project review`` on a file and on a server. (The reviews' semantics on both
backends are in the contract suite, tests/store/test_storage_contract.py.)"""

from __future__ import annotations

import sqlite3
from pathlib import Path

import numpy as np
import psycopg
import pytest

from tests.store.conftest import BEFORE_SCHEMA_13
from usvips.cli import main
from usvips.store import SCHEMA_VERSION, Project
from usvips.store.opening import create_project, open_project
from usvips.store.project import migrate
from usvips.store.records import Vertex


def _vertex(rng) -> Vertex:
    return Vertex(*map(float, rng.uniform(0, 2000, 4)), tuple(map(float, rng.normal(size=3))))


def _schema_8_project(path: Path) -> None:
    """A project as USVIPS of schema 8 made it: two objects and their history."""
    connection = sqlite3.connect(path, isolation_level=None)
    migrate(connection, 8)
    connection.executescript(
        "BEGIN; INSERT INTO meta VALUES ('format', 'usvips-project');"
        "INSERT INTO objects VALUES (3, 'point', 'cod', '', 'old hand', '2024-01-01', '2024-01-02');"
        "INSERT INTO objects VALUES (4, 'point', 'ling', '', 'old hand', '2024-01-01', '2024-01-01');"
        "INSERT INTO vertices (object_id, idx, xl, yl, xr, yr) VALUES (3, 0, 1, 2, 3, 4), (4, 0, 5, 6, 7, 8);"
        "INSERT INTO history (at, annotator, object_id, change, old, new) VALUES "
        "('2024-01-01', 'old hand', 3, 'add', NULL, '{\"kind\": \"point\"}'),"
        "('2024-01-02', 'old hand', 3, 'edit', '{\"notes\": \"\"}', '{\"notes\": \"x\"}'); COMMIT;")
    connection.close()


def test_a_schema_8_project_is_migrated_keeping_its_history_append_only_and_starts_unreviewed(tmp_path):
    path = tmp_path / "old.usvips"
    _schema_8_project(path)
    with Project.open(path, read_only=True) as old:  # read as it is: every object unreviewed
        assert old.version == 8 and [r.state for r in old.reviews()] == ["unreviewed"] * 2
        before = old.history()
    with Project.open(path) as project:
        assert project.version == SCHEMA_VERSION
        assert project.history() == before
        project.annotator = "reader"
        project.set_review(3, "flagged", "two fish overlap")
        assert [(e.change, e.annotator, e.new["state"]) for e in project.history()[2:]] == [
            ("review", "reader", "flagged")]
        for statement in ("UPDATE history SET annotator = 'x'", "DELETE FROM history"):
            with pytest.raises(Exception, match="append-only"):
                with project.transaction():
                    project._db.execute(statement)
    assert path.with_name("old.usvips.schema8.bak").is_file()


def test_a_schema_8_survey_is_migrated_when_opened_for_writing(new_database):
    url = new_database("eight")
    rng = np.random.default_rng(2)
    with create_project(url) as survey:
        object_id = survey.add_object("point", [_vertex(rng)], "cod")
    with psycopg.connect(url, autocommit=True) as raw:  # as a schema-8 USVIPS made it
        raw.execute(BEFORE_SCHEMA_13)
        raw.execute("DROP TABLE reviews; ALTER TABLE history DROP CONSTRAINT history_change_check;"
                    "ALTER TABLE history ADD CHECK (change IN ('add', 'edit', 're-pick', 'delete', 'put back', "
                    "'record')); ALTER TABLE object_instants DROP COLUMN tracked_from;"
                    "ALTER TABLE vertices DROP COLUMN pointing_source, DROP COLUMN sigma_left_px, "
                    "DROP COLUMN sigma_right_px, DROP COLUMN pointing_origin, DROP COLUMN weak_score, "
                    "DROP COLUMN weak_reason;"
                    "UPDATE meta SET value = '8' WHERE key = 'schema_version'")  # named by PostgreSQL
        names = [r[0] for r in raw.execute("SELECT conname FROM pg_constraint WHERE conrelid = 'history'::regclass "
                                           "AND contype = 'c'")]
        assert names == ["history_change_check"]  # the name schema 8's column CHECK was given, too
    with open_project(url) as survey:
        assert survey.version == SCHEMA_VERSION
        survey.set_review(object_id, "accepted")
        assert [e.change for e in survey.history(object_id)] == ["add", "review"]
        with pytest.raises(Exception, match="append-only"):
            with survey.transaction():
                survey._db.execute("DELETE FROM history")


def _survey(location: str, count: int) -> list[int]:
    rng = np.random.default_rng(3)
    with create_project(location) as store:
        store.annotator = "measurer"
        return [store.add_object("point", [_vertex(rng)], "cod") for _ in range(count)]


@pytest.mark.parametrize("backend", ["sqlite", "postgresql"])
def test_project_review_accepts_flags_and_lists_on_both_backends(backend, tmp_path, capsys, request):
    location = str(tmp_path / "r.usvips") if backend == "sqlite" else request.getfixturevalue("new_database")("cli")
    ids = _survey(location, 4)
    assert main(["project", "review", location, "--accept", str(ids[0]), str(ids[2]), "--annotator", "reader"]) == 0
    assert main(["project", "review", location, "--flag", str(ids[1]), "--reason", "fin hidden"]) == 0
    capsys.readouterr()
    assert main(["project", "review", location, "--list", "unreviewed"]) == 0
    assert [int(line.split()[0]) for line in capsys.readouterr().out.splitlines()] == [ids[3]]
    assert main(["project", "review", location, "--list", "flagged"]) == 0
    out = capsys.readouterr().out
    assert out.startswith(f"{ids[1]}") and "fin hidden" in out
    assert main(["project", "review", location]) == 0  # the summary
    assert "2 accepted, 1 flagged, 1 unreviewed" in capsys.readouterr().out
    assert main(["project", "history", location, "--object", str(ids[1])]) == 0
    assert capsys.readouterr().out.splitlines()[-1].endswith(
        f"object {ids[1]}  review: unreviewed → flagged (fin hidden)")
    with open_project(location, read_only=True) as store:
        assert [(r.state, r.reviewer) for r in store.reviews()][:1] == [("accepted", "reader")]
        assert store.history(ids[0])[-1].change == "review"


@pytest.mark.parametrize("backend", ["sqlite", "postgresql"])
@pytest.mark.parametrize("seed", range(2))
def test_project_info_and_review_count_objects_over_instants_once_and_their_reviews(backend, seed, tmp_path, capsys,
                                                                                   request):
    """A survey of random objects, some measured on several instants, in random review states: ``project
    info`` and ``project review`` say "N objects (M further instants)" — an instant is not a further object —
    and how many are accepted, flagged and unreviewed (every instant reviewed on its own)."""
    rng = np.random.default_rng(40 + seed)
    location = (str(tmp_path / "i.usvips") if backend == "sqlite"
                else request.getfixturevalue("new_database")(f"info{seed}"))
    count = int(rng.integers(4, 9))
    ids = _survey(location, count)
    with open_project(location) as store:
        wholes = [int(i) for i in rng.choice(ids, 2, replace=False)]
        instants = [i for i in ids if i not in wholes][:int(rng.integers(1, count - 2))]
        for instant in instants:
            store.add_instant(int(rng.choice(wholes)), instant)
        states = {i: str(rng.choice(["unreviewed", "accepted", "flagged"])) for i in ids}
        for object_id, state in states.items():
            store.set_review(object_id, state, "blurred" if state == "flagged" else "")
    objects, further = count - len(instants), len(instants)
    tally = {state: list(states.values()).count(state) for state in ("accepted", "flagged", "unreviewed")}
    said = (f"{objects} objects ({further} further instant{'s' if further > 1 else ''})")
    counted = f"{tally['accepted']} accepted, {tally['flagged']} flagged, {tally['unreviewed']} unreviewed"
    capsys.readouterr()
    assert main(["project", "info", location]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0].endswith(f"0 control points, {said}")
    assert out[1] == f"  reviews: {counted} (each instant reviewed on its own)"
    assert main(["project", "review", location]) == 0
    assert capsys.readouterr().out.strip().endswith(f": {said}: {counted} (each instant reviewed on its own)")


def test_project_review_accepts_an_object_named_twice_once(tmp_path, capsys):
    """``--accept 1 1 2``: each object accepted once, counted once, one history row each."""
    location = str(tmp_path / "r.usvips")
    ids = _survey(location, 3)
    capsys.readouterr()
    assert main(["project", "review", location, "--accept", str(ids[0]), str(ids[0]), str(ids[1])]) == 0
    assert "accepted 2 " in capsys.readouterr().out
    with open_project(location, read_only=True) as store:
        assert [r.state for r in store.reviews()] == ["accepted", "accepted", "unreviewed"]
        assert [e.change for e in store.history(ids[0])] == ["add", "review"]
        version = store.object(ids[0]).modified
    # accepted again: said, and nothing written (no history row, the same version)
    assert main(["project", "review", location, "--accept", str(ids[0]), str(ids[2])]) == 0
    assert "accepted 1, 1 already accepted as " in capsys.readouterr().out
    assert main(["project", "review", location, "--accept", str(ids[0])]) == 0
    assert ": 1 already accepted as " in capsys.readouterr().out
    with open_project(location, read_only=True) as store:
        assert [e.change for e in store.history(ids[0])] == ["add", "review"]
        assert store.object(ids[0]).modified == version and store.review(ids[2]).state == "accepted"


@pytest.mark.parametrize("arguments, words", [
    (["--flag", "1"], "--reason"),
    (["--flag", "1", "--reason", " "], "a flag needs a reason"),
    (["--accept", "99"], "no object 99"),
    (["--accept", "0"], "whole number"),
    (["--list", "approved"], "invalid choice"),
    (["--reason", "why"], "--reason goes with --flag"),
])
def test_project_review_refuses_bad_input_in_one_line_and_changes_nothing(arguments, words, tmp_path, capsys):
    location = str(tmp_path / "r.usvips")
    _survey(location, 2)
    capsys.readouterr()
    assert main(["project", "review", location, *arguments]) == 2
    error = capsys.readouterr().err
    assert words in error and len(error.strip().splitlines()) == 1
    with open_project(location, read_only=True) as store:
        assert [r.state for r in store.reviews()] == ["unreviewed", "unreviewed"]
        assert [e.change for e in store.history()] == ["add", "add"]


_READER = """
import sys
from usvips.store.opening import open_project
from usvips.store.records import ProjectError, Vertex
url, name, shared, rounds = sys.argv[1], sys.argv[2], int(sys.argv[3]), int(sys.argv[4])
with open_project(url) as survey:
    survey.annotator = name
    for k in range(rounds):
        while True:  # measure one
            try:
                survey.add_object("point", [Vertex(1.0 + k, 2.0, 3.0, 4.0)], name)
                break
            except ProjectError:
                continue
        while True:  # review the shared one, on the version read
            seen = survey.object(shared)
            # every review differs from every other (a review repeating the state and reason is no change)
            state, reason = ("flagged" if k % 2 else "accepted"), f"{name} {k}"
            try:
                survey.set_review(shared, state, reason, expected_modified=seen.modified)
                break
            except ProjectError:  # stale (the other reader came first) or busy: read again
                continue
        while True:  # and edit it: a counter in its notes
            seen = survey.object(shared)
            try:
                survey.update_object(shared, notes=str(int(seen.notes) + 1), expected_modified=seen.modified)
                break
            except ProjectError:
                continue
"""


def test_two_annotator_processes_measure_review_and_edit_one_survey_at_once_and_lose_nothing(new_database,
                                                                                             tmp_path):
    import subprocess
    import sys

    url = new_database("readers")
    with create_project(url) as survey:
        shared = survey.add_object("point", [Vertex(1.0, 2.0, 3.0, 4.0)], notes="0")
    rounds = 8
    script = tmp_path / "reader.py"
    script.write_text(_READER)
    workers = [subprocess.Popen([sys.executable, str(script), url, name, str(shared), str(rounds)],
                                stderr=subprocess.PIPE, text=True) for name in ("ann", "bob")]
    for worker in workers:
        _, err = worker.communicate(timeout=300)
        assert worker.returncode == 0, err
    with open_project(url, read_only=True) as survey:
        assert survey.object(shared).notes == str(2 * rounds)
        assert sorted(o.attribute for o in survey.objects() if o.id != shared) == ["ann"] * rounds + ["bob"] * rounds
        reviews = [e for e in survey.history(shared) if e.change == "review"]
        final = survey.review(shared)
    assert sorted(e.annotator for e in reviews) == ["ann"] * rounds + ["bob"] * rounds
    assert [e.old["state"] for e in reviews[1:]] == [e.new["state"] for e in reviews[:-1]]  # none overwritten
    assert (final.state, final.reviewer, final.reason) == (reviews[-1].new["state"], reviews[-1].annotator,
                                                           reviews[-1].new["reason"])


@pytest.mark.parametrize("backend", ["sqlite", "postgresql"])
def test_a_review_from_the_command_line_names_the_version_it_listed_and_a_stale_one_is_refused_by_name(
        backend, tmp_path, capsys, request):
    """``--list`` prints each object's version last; ``--accept ID@VERSION`` (or ``--flag``) made after a
    colleague changed the object is refused in one line naming them, exit 2, nothing written (another
    process's edit here); with the version as it now is it goes through."""
    location = str(tmp_path / "v.usvips") if backend == "sqlite" else request.getfixturevalue("new_database")("stale")
    ids = _survey(location, 2)
    capsys.readouterr()
    assert main(["project", "review", location, "--list", "unreviewed"]) == 0
    listed = {int(line.split("\t")[0]): line.split("\t")[-1] for line in capsys.readouterr().out.splitlines()}
    with open_project(location) as colleague:
        colleague.annotator = "bob"
        colleague.update_object(ids[0], notes="bob: remeasured")
        kept = colleague.history()
    assert main(["project", "review", location, "--accept", f"{ids[0]}@{listed[ids[0]]}",
                 f"{ids[1]}@{listed[ids[1]]}"]) == 2
    said = capsys.readouterr().err
    assert said.count("\n") == 1 and f"object {ids[0]} was changed by someone else" in said and "edit by bob" in said
    with open_project(location, read_only=True) as store:
        assert [r.state for r in store.reviews()] == ["unreviewed", "unreviewed"] and store.history() == kept
        fresh = store.object(ids[0]).modified
    assert main(["project", "review", location, "--flag", f"{ids[0]}@{fresh}", "--reason", "fin hidden"]) == 0
    with open_project(location, read_only=True) as store:
        assert store.review(ids[0]).state == "flagged"
