"""How an instant was made (schema 10): the migration of schema-9 projects and surveys, whose tracked
instants were recognised by their notes ("tracked from frame N") and now say so in their link. (The
semantics on both backends are in the contract suite, tests/store/test_storage_contract.py.)"""

from __future__ import annotations

import sqlite3
from pathlib import Path

import numpy as np
import psycopg
import pytest

from tests.store.conftest import BEFORE_SCHEMA_13
from usvips.store import SCHEMA_VERSION, Project
from usvips.store.opening import create_project, open_project
from usvips.store.project import migrate
from usvips.store.records import Vertex

#: notes of the further instants of object 1 → how the migration reads them (the frame, or None: by hand)
NOTES = {"tracked from frame 17": 17, "tracked from frame 0": 0, "picked by hand": None, "": None,
         "tracked from frame 250, corrected": 250, "Tracked from frame 3": None, "tracked from frame x": None,
         "was tracked from frame 4": None}


def _vertex(rng) -> Vertex:
    return Vertex(*map(float, rng.uniform(0, 2000, 4)), tuple(map(float, rng.normal(size=3))))


def _schema_9_project(path: Path) -> dict[int, int | None]:
    """A project as USVIPS of schema 9 made it: object 1 with one further instant per note of NOTES,
    and an object of its own whose notes also say "tracked"; returns instant id → the expected frame."""
    connection = sqlite3.connect(path, isolation_level=None)
    migrate(connection, 9)
    statements = ["BEGIN", "INSERT INTO meta VALUES ('format', 'usvips-project')"]
    expected = {}
    for object_id, notes in enumerate(["first", *NOTES, "tracked from frame 9"], start=1):
        statements.append(f"INSERT INTO objects VALUES ({object_id}, 'point', 'cod', '{notes}', 'old hand', "
                          "'2024-01-01', '2024-01-01')")
        statements.append(f"INSERT INTO vertices (object_id, idx, xl, yl, xr, yr) VALUES ({object_id}, 0, 1, 2, 3, 4)")
        if 1 < object_id <= len(NOTES) + 1:
            statements.append(f"INSERT INTO object_instants VALUES ({object_id}, 1)")
            expected[object_id] = NOTES[notes]
    connection.executescript(";".join(statements) + "; COMMIT;")
    connection.close()
    return expected


def test_a_schema_9_project_is_migrated_with_its_tracked_instants_read_once_from_their_notes(tmp_path):
    path = tmp_path / "old.usvips"
    expected = _schema_9_project(path)
    with Project.open(path, read_only=True) as old:  # read as it is: what its migration will store
        assert old.version == 9 and old.instant_sources(1) == expected == old.instant_sources()
    with Project.open(path) as project:
        assert project.version == SCHEMA_VERSION >= 10
        assert project.instant_sources(1) == expected and project.instant_links() == dict.fromkeys(expected, 1)
        for instant in expected:  # from now on the notes are only text
            project.update_object(instant, notes="tracked from frame 1" if expected[instant] is None else "")
        assert project.instant_sources() == expected
    assert path.with_name("old.usvips.schema9.bak").is_file()


def test_a_schema_9_survey_is_migrated_with_its_tracked_instants_read_once_from_their_notes(new_database):
    url = new_database("nine")
    rng = np.random.default_rng(3)
    with create_project(url) as survey:
        first = survey.add_object("point", [_vertex(rng)], "cod")
        expected = {}
        for notes, frame in NOTES.items():
            instant = survey.add_object("point", [_vertex(rng)], "cod", notes)
            survey.add_instant(first, instant)  # linked by hand: the migration below reads the notes
            expected[instant] = frame
    with psycopg.connect(url, autocommit=True) as raw:  # as a schema-9 USVIPS made it
        raw.execute(BEFORE_SCHEMA_13)
        raw.execute("ALTER TABLE object_instants DROP COLUMN tracked_from; "
                    "ALTER TABLE vertices DROP COLUMN pointing_source, DROP COLUMN sigma_left_px, "
                    "DROP COLUMN sigma_right_px, DROP COLUMN pointing_origin, DROP COLUMN weak_score, "
                    "DROP COLUMN weak_reason;"
                    "UPDATE meta SET value = '9' WHERE key = 'schema_version'")
    with pytest.raises(Exception, match="schema 9"):
        open_project(url, read_only=True).close()  # a read-only opening never migrates
    with open_project(url) as survey:
        assert survey.version == SCHEMA_VERSION
        assert survey.instant_sources(first) == expected
        for instant in expected:
            survey.update_object(instant, notes="tracked from frame 1" if expected[instant] is None else "")
        assert survey.instant_sources() == expected
