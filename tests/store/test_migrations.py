"""One migration list for both backends (usvips.store.schema): a project file and a server survey made at
ANY earlier schema version open for writing, are migrated to the current one, keep their objects, and end
with exactly the tables, columns and triggers a new one has."""

from __future__ import annotations

import sqlite3

import psycopg
import pytest

from usvips.store import SCHEMA_VERSION, Project
from usvips.store.postgres import POSTGRESQL, ServerProject
from usvips.store.project import FORMAT, migrate
from usvips.store.schema import MIGRATIONS, script

EARLIER = [v for v in range(1, SCHEMA_VERSION) if v in MIGRATIONS]
#: one object with one vertex, as any schema since 1 stores it
AN_OBJECT = ("INSERT INTO objects (kind, attribute, created, modified) VALUES ('point', 'cod', 't', 't');"
             "INSERT INTO vertices (object_id, idx, xl, yl, xr, yr) VALUES (1, 0, 1.5, 2.5, 3.5, 4.5);")


def _file_schema(path) -> tuple[dict, set]:
    connection = sqlite3.connect(path)
    try:
        tables = [r[0] for r in connection.execute("SELECT name FROM sqlite_master WHERE type = 'table'")]
        columns = {t: tuple(r[1] for r in connection.execute(f"PRAGMA table_info({t})")) for t in tables}
        others = set(connection.execute("SELECT type, name FROM sqlite_master WHERE type <> 'table'").fetchall())
    finally:
        connection.close()
    return columns, others


def _server_schema(url: str) -> tuple[dict, set]:
    with psycopg.connect(url) as server:
        rows = server.execute("SELECT table_name, column_name FROM information_schema.columns WHERE table_schema = "
                              "current_schema() ORDER BY table_name, ordinal_position").fetchall()
        triggers = set(server.execute("SELECT tgname, tgrelid::regclass::text FROM pg_trigger WHERE NOT tgisinternal"
                                      ).fetchall())
    columns: dict[str, tuple[str, ...]] = {}
    for table, column in rows:
        columns[table] = (*columns.get(table, ()), column)
    return columns, triggers


@pytest.mark.parametrize("version", EARLIER)
def test_a_file_of_every_earlier_schema_is_migrated_to_what_a_new_one_is(tmp_path, version):
    Project.create(tmp_path / "new.usvips").close()
    old = tmp_path / "old.usvips"
    connection = sqlite3.connect(old, isolation_level=None)
    migrate(connection, version)
    connection.executescript(f"BEGIN; INSERT INTO meta VALUES ('format', '{FORMAT}'); {AN_OBJECT} COMMIT;")
    connection.close()
    with Project.open(old, read_only=True) as project:  # read as it is, never migrated
        assert project.version == version and [o.attribute for o in project.objects()] == ["cod"]
    with Project.open(old) as project:
        assert project.version == SCHEMA_VERSION
        [stored] = project.objects()
        assert (stored.kind, stored.attribute, stored.vertices[0].xl) == ("point", "cod", 1.5)
        project.add_object("length", [stored.vertices[0], stored.vertices[0]], "ling")  # and it takes new ones
    assert _file_schema(old) == _file_schema(tmp_path / "new.usvips")


@pytest.mark.parametrize("version", EARLIER)
def test_a_survey_of_every_earlier_schema_is_migrated_to_what_a_new_one_is(new_database, version):
    fresh = new_database("fresh")
    ServerProject.create(fresh).close()
    url = new_database("older")
    ServerProject.create(url).close()
    with psycopg.connect(url, autocommit=True) as raw:  # the same database, rebuilt as that USVIPS made it
        raw.execute("DROP SCHEMA public CASCADE; CREATE SCHEMA public")
        raw.execute(script(POSTGRESQL, 0, version))
        raw.execute("INSERT INTO meta VALUES ('format', %s), ('created', 't'), ('schema_version', %s)",
                    (FORMAT, str(version)))
        raw.execute(AN_OBJECT)
    with pytest.raises(Exception, match=f"schema {version}"):
        ServerProject.open(url, read_only=True).close()  # a read-only opening never migrates
    with ServerProject.open(url) as survey:
        assert survey.version == SCHEMA_VERSION
        [stored] = survey.objects()
        assert (stored.kind, stored.attribute, stored.vertices[0].xl) == ("point", "cod", 1.5)
        survey.add_object("length", [stored.vertices[0], stored.vertices[0]], "ling")
    assert _server_schema(url) == _server_schema(fresh)
