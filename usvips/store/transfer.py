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

from pathlib import Path

from usvips.store.file_copy import SERVER_ONLY_META, file_rows
from usvips.store.location import parse_server_location
from usvips.store.postgres import ServerProject, new_survey, public_location
from usvips.store.postgres_schema import SERVER_SCHEMA_VERSION, TABLES

__all__ = ["file_rows", "pull", "push"]


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
                wanted = [r for r in rows[table] if table != "meta" or r[0] not in SERVER_ONLY_META]
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
    if isinstance(source, str):
        with ServerProject.open(source, read_only=True) as survey:
            return survey.copy_to(path)
    return source.copy_to(path)
