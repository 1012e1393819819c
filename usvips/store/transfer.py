"""Copying a whole project between a file and a server, row by row: ``push`` (an SQLite project file →
a new survey on a PostgreSQL server) and ``pull`` (a survey → a new SQLite project file).

Every table is copied as stored — ids, texts, numbers (float64 bit for bit), timestamps, media paths —
so a round trip gives back the same rows. Paths stored relative stay relative: on the server they resolve
against the media folder (``usvips.store.postgres.media_folder``), in a file against its folder.

Nothing is half written, and the source is never changed: the source is read in one snapshot; a push
writes the schema and all rows in one server transaction (a database it created is dropped again on
failure); a pull writes a temporary file beside the target and puts it in place only when complete.
"""

from __future__ import annotations

import os
import sqlite3
from pathlib import Path

from usvips.store.opening import parse_server_location
from usvips.store.postgres import ServerProject, new_survey, public_location
from usvips.store.postgres_schema import SERVER_SCHEMA_VERSION, TABLES
from usvips.store.project import Project, database_problem
from usvips.store.records import ProjectError

_SERVER_ONLY_META = ("schema_version",)


def _order(table: str, rowid: str) -> str:
    """How a table's rows are read: control points in the order they were stored, the rest by key."""
    if table == "control_points":
        return rowid
    return ", ".join(c for c in TABLES[table] if c in ("id", "key", "object_id", "idx", "pair_id", "term",
                                                         "image_key", "path", "video_id", "camera", "genus",
                                                         "species", "scope")) or "1"


def file_rows(path: Path) -> dict[str, list[tuple]]:
    """Every row of every table of an SQLite project of the current schema, read in one snapshot."""
    with Project.open(path, read_only=True) as project:
        if project.version != SERVER_SCHEMA_VERSION:
            raise ProjectError(f"{path}: a project of schema {project.version}; open it once for writing with "
                               f"this USVIPS to bring it to schema {SERVER_SCHEMA_VERSION}, then copy it")
    connection = sqlite3.connect(f"file:{path}?mode=ro", uri=True, timeout=2.0, isolation_level=None)
    try:
        connection.execute("BEGIN")
        rows = {table: connection.execute(f"SELECT {', '.join(columns)} FROM {table} ORDER BY "
                                          f"{_order(table, 'rowid')}").fetchall()
                for table, columns in TABLES.items()}
        connection.execute("COMMIT")
        return rows
    except sqlite3.Error as error:
        raise ProjectError(f"{path}: cannot read the project: {database_problem(error)}") from None
    finally:
        connection.close()


def server_rows(project: ServerProject) -> dict[str, list[tuple]]:
    """Every row of every table of a survey, read in one snapshot (the server's own meta rows left out)."""
    with project._reading():
        rows = {table: project._db.execute(f"SELECT {', '.join(columns)} FROM {table} ORDER BY "
                                           f"{_order(table, 'ord')}").fetchall()
                for table, columns in TABLES.items()}
    rows["meta"] = [row for row in rows["meta"] if row[0] not in _SERVER_ONLY_META]
    return rows


def push(path: str | Path, url: str) -> str:
    """Copy the SQLite project ``path`` to a new survey at ``url`` (a database that does not exist yet, or
    an empty one); returns the survey's location (without password). All or nothing."""
    path = Path(path)
    parse_server_location(url)  # an address that cannot be read is refused before the file is opened
    rows = file_rows(path)

    def fill(connection) -> None:
        connection.execute("DELETE FROM meta")
        with connection.cursor() as cursor:
            for table, columns in TABLES.items():
                wanted = [r for r in rows[table] if table != "meta" or r[0] not in _SERVER_ONLY_META]
                if wanted:
                    cursor.executemany(f"INSERT INTO {table} ({', '.join(columns)}) VALUES "
                                       f"({', '.join(['%s'] * len(columns))})", wanted)
        connection.execute("INSERT INTO meta VALUES ('schema_version', %s)", (str(SERVER_SCHEMA_VERSION),))
        # the ids' counters followed the explicit ids copied (schema 13: usvips.store.postgres_schema)

    new_survey(url, fill, f"cannot copy {path} to the server")
    return public_location(url)


def pull(source: str | ServerProject, path: str | Path) -> Path:
    """Copy the survey ``source`` (a URL, or an open survey) to the new SQLite project file ``path``;
    returns its path. The file appears only when complete; an existing file is never replaced."""
    target = Path(path)
    if target.exists() or target.is_symlink():
        raise ProjectError(f"{target}: already exists; choose a new file name for the copy")
    if not target.parent.is_dir():
        raise ProjectError(f"{target}: the folder {target.parent} does not exist")
    if isinstance(source, str):
        with ServerProject.open(source, read_only=True) as survey:
            rows = server_rows(survey)
    else:
        rows = server_rows(source)
    part = target.with_name(f".{target.name}.pull.tmp")
    for leftover in (part, Path(f"{part}-journal"), Path(f"{part}-wal"), Path(f"{part}-shm")):
        leftover.unlink(missing_ok=True)
    try:
        Project.create(part).close()
        connection = sqlite3.connect(str(part), isolation_level=None)
        try:
            connection.execute("PRAGMA foreign_keys = ON")
            connection.execute("BEGIN IMMEDIATE")
            connection.execute("DELETE FROM meta")
            for table, columns in TABLES.items():
                connection.executemany(f"INSERT INTO {table} ({', '.join(columns)}) VALUES "
                                       f"({', '.join('?' * len(columns))})", rows[table])
            connection.execute("COMMIT")
            connection.execute("PRAGMA journal_mode = DELETE")
        finally:
            connection.close()
        os.link(part, target)  # never replaces a file that appeared meanwhile
    except FileExistsError:
        raise ProjectError(f"{target}: already exists; choose a new file name for the copy") from None
    except sqlite3.Error as error:
        raise ProjectError(f"{target}: cannot write the copy: {database_problem(error)} (nothing was written)"
                           ) from None
    except OSError as error:
        raise ProjectError(f"{target}: cannot write the copy: {error.strerror or error} (nothing was written)"
                           ) from None
    finally:
        for leftover in (part, Path(f"{part}-journal"), Path(f"{part}-wal"), Path(f"{part}-shm")):
            leftover.unlink(missing_ok=True)
    return target
