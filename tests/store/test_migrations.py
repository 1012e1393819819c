"""One migration list for both backends (usvips.store.schema): a project file and a server survey made at
ANY earlier schema version open for writing, are migrated to the current one, keep their objects, and end
with exactly the tables, columns and triggers a new one has."""

from __future__ import annotations

import os
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


_OPEN_FOR_WRITING = """
import sys, time
from usvips.store import Project
from usvips.store.records import ProjectError
while time.time() < float(sys.argv[2]):  # both start together
    pass
try:
    with Project.open(sys.argv[1]) as project:
        print(project.version, len(project.objects()))
except ProjectError as error:
    print("refused", error)
"""


def test_two_programs_upgrading_one_file_at_once_keep_a_copy_of_the_old_schema(tmp_path):
    """Two starts open an old file for writing at the same moment: each is upgraded or said to be locked
    (never "table already exists"), the file is upgraded once, and the copy aside holds the OLD schema
    (a copy of the upgraded file made by the second would replace it)."""
    import subprocess
    import sys
    import time

    version = EARLIER[0]
    for attempt in range(6):
        old = tmp_path / f"old{attempt}.usvips"
        connection = sqlite3.connect(old, isolation_level=None)
        migrate(connection, version)
        connection.executescript(f"BEGIN; INSERT INTO meta VALUES ('format', '{FORMAT}'); {AN_OBJECT} COMMIT;")
        connection.close()
        start = time.time() + 1.5
        runs = [subprocess.Popen([sys.executable, "-c", _OPEN_FOR_WRITING, str(old), str(start)],
                                 stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True) for _ in range(2)]
        outputs = [run.communicate(timeout=120)[0].strip() for run in runs]
        for output in outputs:
            assert output == f"{SCHEMA_VERSION} 1" or ("refused" in output and "locked" in output), output
        with Project.open(old) as project:  # upgraded once, whole (or now, when both were told it was locked)
            assert project.version == SCHEMA_VERSION and len(project.objects()) == 1
        backups = list(tmp_path.glob(f"old{attempt}.usvips.schema*.bak"))
        for backup in backups:
            umask = os.umask(0o022)
            os.umask(umask)
            assert backup.stat().st_mode & 0o777 == 0o666 & ~umask  # as readable as the project
            kept = sqlite3.connect(backup)
            assert kept.execute("PRAGMA user_version").fetchone()[0] == version, backup.name
            kept.close()
        assert not list(tmp_path.glob(f".old{attempt}*.tmp"))  # no copy in progress left behind
