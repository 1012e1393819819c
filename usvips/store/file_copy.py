"""An SQLite project file's rows read whole, and a new project file written from rows: the file side of
copying a project between a file and a server (:mod:`usvips.store.transfer`) and of a survey's copy
(``ServerProject.copy_to``), without the server's code (so that neither backend imports the other's
copying).

Every table is copied as stored (:data:`usvips.store.postgres_schema.TABLES`); the new file appears only when
complete, and an existing file is never replaced.
"""

from __future__ import annotations

import os
import sqlite3
from pathlib import Path

from usvips.store.postgres_schema import SERVER_SCHEMA_VERSION, TABLES
from usvips.store.project import Project, database_problem
from usvips.store.records import ProjectError

#: meta rows that belong to one backend (each writes its own)
SERVER_ONLY_META = ("schema_version",)


def table_order(table: str, rowid: str) -> str:
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
                                          f"{table_order(table, 'rowid')}").fetchall()
                for table, columns in TABLES.items()}
        connection.execute("COMMIT")
        return rows
    except sqlite3.Error as error:
        raise ProjectError(f"{path}: cannot read the project: {database_problem(error)}") from None
    finally:
        connection.close()


def check_new_file(path: str | Path) -> Path:
    """``path`` as a new project file's: refused by name when something is there or its folder is not."""
    target = Path(path)
    if target.exists() or target.is_symlink():
        raise ProjectError(f"{target}: already exists; choose a new file name for the copy")
    if not target.parent.is_dir():
        raise ProjectError(f"{target}: the folder {target.parent} does not exist")
    return target


def write_file(rows: dict[str, list[tuple]], path: str | Path) -> Path:
    """A new SQLite project file at ``path`` holding ``rows`` (every table of
    :data:`~usvips.store.postgres_schema.TABLES`); returns its path. The file appears only when complete;
    an existing file is never replaced."""
    target = check_new_file(path)
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
