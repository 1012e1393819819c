"""The SQLite backend: a USVIPS project in one file — :class:`SqliteBackend` (the file's connection, its
errors in words a person can act on) and :class:`Project`, the survey's rules
(:class:`~usvips.store.survey.Survey`) opened on a file.

WAL journal, foreign keys on, every user edit one transaction (a crash loses at most the edit in
progress). Media paths are stored relative to the project file's folder.

Opening (:meth:`Project.open`) first checks, through a read-only connection that changes nothing, that
the file is a USVIPS project of a schema this USVIPS reads; only then is a writing connection made (and
the file switched to WAL).

* ``Project.open(path, read_only=True)``: for commands that only read (``project info``, exports). The
  file is never written and never migrated; a project of an older schema is read as it is.
* ``Project.open(path)`` (``read_only=False``): for editing. A project made by an older USVIPS is first
  copied aside as ``NAME.usvips.schemaN.bak`` (N = its old schema version) and then migrated forward in
  ONE transaction, so a failed migration leaves the file as it was. A project made by a newer USVIPS is
  refused either way.

Every failure of the database (locked by another program, disk full, a damaged file, no permission) is a
:class:`ProjectError` whose one line names the project file and what to do; nothing is half-written.
"""

from __future__ import annotations

import os
import sqlite3
import tempfile
import time
from collections.abc import Iterable, Sequence
from pathlib import Path

from usvips.store.backend import Backend, BackendError, ConstraintError, Result
from usvips.store.change_watch import ChangeWatch, FileChangeWatch
from usvips.store.records import (  # noqa: F401 - the record types, as the rest of the program long imported them
    ProjectError,
    StaleEditError,
    StoredObject,
    Vertex,
)
from usvips.store.schema import SCHEMA_VERSION, Dialect, script
from usvips.store.survey import (  # noqa: F401 - kept importable from here
    FORMAT,
    SAMPLE_BLOCK_BYTES,
    SAMPLE_BLOCKS,
    Survey,
    _now,
    _sample_key,
    file_hash,
    sampled_hash,
)

SQLITE_MAGIC = b"SQLite format 3\x00"
#: how a file spells the schema's types (:mod:`usvips.store.schema`): a surrogate key is SQLite's rowid
SQLITE = Dialect("sqlite", {"id": "INTEGER PRIMARY KEY", "int": "INTEGER", "real": "REAL", "text": "TEXT"})


def migrate(connection: sqlite3.Connection, target: int = SCHEMA_VERSION) -> int:
    """Bring a file's schema from its ``user_version`` up to ``target`` in ONE transaction: every step of
    :data:`usvips.store.schema.MIGRATIONS` is applied, or (on any error) none and the file is as it was.
    ``connection`` must be in autocommit mode (``isolation_level=None``) with no transaction open."""
    current = connection.execute("PRAGMA user_version").fetchone()[0]
    if current >= target:
        return current
    try:
        connection.executescript(f"BEGIN IMMEDIATE;{script(SQLITE, current, target)}PRAGMA user_version = {target};"
                                 "COMMIT;")
    except sqlite3.Error:
        if connection.in_transaction:
            connection.execute("ROLLBACK")
        # another program opening the same file may have upgraded it between the version read above and
        # this transaction (its steps then fail here: "table … already exists"): the file is upgraded
        if connection.execute("PRAGMA user_version").fetchone()[0] >= target:
            return connection.execute("PRAGMA user_version").fetchone()[0]
        raise
    return connection.execute("PRAGMA user_version").fetchone()[0]


def _umask() -> int:
    """The process's file-mode mask (read by setting it and back, as the store has no other way)."""
    umask = os.umask(0)
    os.umask(umask)
    return umask


def database_problem(error: sqlite3.Error) -> str:
    """What an SQLite error means for the person using the project, in a few words (no traceback)."""
    message = str(error)
    lowered = message.lower()
    if "locked" in lowered or "busy" in lowered:
        return "it is locked by another program; close it there and try again"
    if "full" in lowered:
        return "the disk is full; free some space and try again"
    if "malformed" in lowered or "not a database" in lowered or "corrupt" in lowered:
        return f"the file is damaged ({message}); restore it from a backup"
    if "could not decode to utf-8" in lowered:  # bytes of a text column changed: the file is damaged
        column = message.split("column", 1)[-1].split("with text", 1)[0].strip() if "column" in message else ""
        return (f"the file is damaged (a text{' in column ' + column if column else ''} is not UTF-8); restore it "
                "from a backup")
    if "readonly" in lowered or "read-only" in lowered:
        return "the file or its folder is read-only"
    if "unable to open" in lowered or "permission" in lowered or "access" in lowered:
        return f"cannot access the file ({message}); check its permissions"
    if "disk i/o" in lowered:
        return f"the disk failed to read or write ({message})"
    return message


#: the tables holding an object's rows, parents first (``put_back`` inserts in this order): an object is
def _remove_database(path: Path) -> None:
    for suffix in ("", "-wal", "-shm", "-journal"):
        Path(f"{path}{suffix}").unlink(missing_ok=True)


def backup_path(path: Path, version: int) -> Path:
    """Where the copy of a project is kept before it is migrated from schema ``version``."""
    return path.with_name(f"{path.name}.schema{version}.bak")



def _problem(error: sqlite3.Error, where: object) -> BackendError:
    """SQLite's error as this package's: a refused row is a :class:`ConstraintError` (its message as
    SQLite words it), anything else a :class:`BackendError` saying what it means (:func:`database_problem`)."""
    if isinstance(error, sqlite3.IntegrityError):
        return ConstraintError(where, str(error))
    return BackendError(where, database_problem(error))


class SqliteBackend(Backend):
    """An SQLite project file's connection (autocommit; transactions begun explicitly). ``raw`` is the
    ``sqlite3`` connection (for this module's own use: backups, tests)."""

    insertion_order = "rowid"

    def __init__(self, path: Path, connection: sqlite3.Connection, read_only: bool = False):
        self.where, self.raw, self.read_only = path, connection, read_only
        self.media_folder = path.parent
        self._tables: set[str] = set()  # tables known to exist (see has_table)

    def execute(self, sql: str, parameters: Sequence = ()) -> Result:
        try:
            cursor = self.raw.execute(sql, parameters)
            rows = cursor.fetchall()
            columns = tuple(c[0] for c in cursor.description) if cursor.description else ()
            return Result(rows, cursor.rowcount, columns)
        except sqlite3.Error as error:
            raise _problem(error, self.where) from None

    def executemany(self, sql: str, rows: Iterable[Sequence]) -> Result:
        try:
            return Result([], self.raw.executemany(sql, rows).rowcount)
        except sqlite3.Error as error:
            raise _problem(error, self.where) from None

    def begin(self, write: bool) -> None:
        self.execute("BEGIN IMMEDIATE" if write else "BEGIN")

    def commit(self) -> None:
        self.execute("COMMIT")

    def rollback(self) -> None:
        self.execute("ROLLBACK")

    @property
    def in_transaction(self) -> bool:
        return self.raw.in_transaction

    def schema_version(self) -> int:
        return int(self.execute("PRAGMA user_version").fetchone()[0])

    def has_table(self, name: str) -> bool:
        """Whether the file has the table ``name``. A table found is remembered: no migration removes one, and
        the store asks before most reads (a window storing a Detect run asked hundreds of times)."""
        if name in self._tables:
            return True
        found = bool(self.execute("SELECT 1 FROM sqlite_master WHERE type = 'table' AND name = ?", (name,)).rows)
        if found:
            self._tables.add(name)
        return found

    def derived_media_folder(self) -> Path:
        """The folder of the project file: seek proxies and exported frames are kept beside it."""
        return self.where.parent

    def watch(self) -> ChangeWatch:
        return FileChangeWatch(self.where)

    def close(self) -> None:
        self.raw.close()


class Project(Survey):
    """A project file: the survey's rules on an :class:`SqliteBackend`. Open with :meth:`open` or
    :meth:`create`; use as a context manager or call :meth:`close`."""

    def __init__(self, path: Path, connection: sqlite3.Connection, read_only: bool = False):
        super().__init__(path, SqliteBackend(path, connection, read_only), read_only)

    # ---------------------------------------------------------------------------- opening
    @classmethod
    def create(cls, path: str | Path) -> Project:
        """A new, empty project at ``path``. It is built in a temporary file beside ``path`` and put in
        place only when complete: on any failure (a full disk ...) nothing is left behind."""
        path = Path(path)
        if path.exists() or path.is_symlink():
            raise ProjectError(f"{path}: already exists; open it instead")
        if not path.parent.is_dir():
            raise ProjectError(f"{path}: the folder {path.parent} does not exist")
        for suffix in ("-wal", "-journal"):
            # SQLite replays a -wal (rolls back a hot -journal) it finds beside a database, whoever's it was
            left = Path(f"{path}{suffix}")
            if left.exists() or left.is_symlink():
                raise ProjectError(f"{left}: a journal left by an earlier project of this name lies beside it and "
                                   f"would be replayed into the new one; move it away (or delete it) first")
        temporary: Path | None = None
        try:
            handle, name = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=str(path.parent))
            os.close(handle)
            temporary = Path(name)
            connection = sqlite3.connect(str(temporary), isolation_level=None)
            try:
                connection.execute("PRAGMA journal_mode = DELETE")
                migrate(connection)
                connection.executescript(f"BEGIN; INSERT INTO meta VALUES ('format', '{FORMAT}'); "
                                         f"INSERT INTO meta VALUES ('created', '{_now()}'); COMMIT;")
            finally:
                connection.close()
            os.chmod(temporary, 0o666 & ~_umask())
            try:
                os.link(temporary, path)          # never replaces a file that appeared meanwhile
            except FileExistsError:
                raise ProjectError(f"{path}: already exists; open it instead") from None
            except OSError:
                if path.exists() or path.is_symlink():
                    raise ProjectError(f"{path}: already exists; open it instead") from None
                os.replace(temporary, path)       # a file system without hard links
        except sqlite3.Error as error:
            raise ProjectError(f"{path}: cannot create the project: {database_problem(error)}") from None
        except OSError as error:
            raise ProjectError(f"{path}: cannot create the project: {error.strerror or error}") from None
        finally:
            if temporary is not None:
                _remove_database(temporary)
        return cls.open(path)

    @classmethod
    def open(cls, path: str | Path, read_only: bool = False) -> Project:
        """Open an existing project; ``read_only=True`` never writes the file (see the module docstring)."""
        path = Path(path)
        version = cls._check(path)
        if read_only:
            connection = cls._connect(path, read_only=True)
            return cls(path, connection, read_only=True)
        if not os.access(path, os.W_OK) or not os.access(path.parent, os.W_OK):
            raise ProjectError(f"{path}: cannot write the project: the file or its folder is read-only")
        if version < SCHEMA_VERSION:
            cls._migrate(path, version)
        return cls(path, cls._connect(path))

    @staticmethod
    def _check(path: Path) -> int:
        """The schema version of a USVIPS project; refuses anything else without changing a byte."""
        if path.is_symlink() and not path.exists():
            raise ProjectError(f"{path}: a symbolic link to a file that does not exist")
        if not path.is_file():
            raise ProjectError(f"{path}: is a folder, not a project file" if path.is_dir() else
                               f"{path}: no such project file")
        try:
            with open(path, "rb") as stream:
                magic = stream.read(16)
        except OSError as error:
            raise ProjectError(f"{path}: cannot read the project: {error.strerror or error}") from None
        if magic != SQLITE_MAGIC:
            raise ProjectError(f"{path}: not a USVIPS project (not an SQLite database)")
        # a read-only connection to a file in WAL mode still makes its -wal and -shm files beside it: those it
        # made are removed again when the file is refused (nothing is left next to a file that is not opened)
        beside = [Path(f"{path}{suffix}") for suffix in ("-wal", "-shm")]
        there = [side.exists() for side in beside]
        try:
            return Project._version(path)
        except ProjectError:
            for side, existed in zip(beside, there, strict=True):
                if not existed and side.is_file() and (side.name.endswith("-shm") or side.stat().st_size == 0):
                    side.unlink(missing_ok=True)  # made by the check (a -wal of ours has nothing in it)
            raise

    @staticmethod
    def _version(path: Path) -> int:
        """The schema version of the SQLite file ``path`` if it is a USVIPS project this USVIPS reads (read
        through a read-only connection); else a ``ProjectError`` saying what it is."""
        connection = Project._connect(path, read_only=True)
        try:
            version = connection.execute("PRAGMA user_version").fetchone()[0]
            tables = {r[0] for r in connection.execute("SELECT name FROM sqlite_master WHERE type='table'")}
            if "meta" not in tables or connection.execute(
                    "SELECT value FROM meta WHERE key='format'").fetchone() != (FORMAT,):
                raise ProjectError(f"{path}: not a USVIPS project (an SQLite database of something else)")
        except sqlite3.Error as error:
            raise ProjectError(f"{path}: cannot open the project: {database_problem(error)}") from None
        finally:
            connection.close()
        if version > SCHEMA_VERSION:
            raise ProjectError(f"{path}: made by a newer USVIPS (schema {version}; this one reads up to "
                               f"{SCHEMA_VERSION}); update USVIPS to open it")
        if version < 1:
            raise ProjectError(f"{path}: not a USVIPS project (schema version {version})")
        return int(version)

    @staticmethod
    def _migrate(path: Path, version: int) -> None:
        """Copy the project aside (a consistent copy, WAL included), then migrate it in one transaction."""
        backup = backup_path(path, version)
        temporary, started = None, time.time()
        try:
            source = sqlite3.connect(f"file:{path}?mode=ro", uri=True, timeout=2.0)
            try:
                # a name of its own: two programs upgrading the same file at once each copy to their own
                handle, name = tempfile.mkstemp(prefix=f".{backup.name}.", suffix=".tmp", dir=str(backup.parent))
                os.close(handle)
                temporary = Path(name)
                os.chmod(temporary, 0o666 & ~_umask())  # mkstemp makes 0600: the copy is the project's to read
                target = sqlite3.connect(str(temporary))
                try:
                    source.backup(target)
                    copied = target.execute("PRAGMA user_version").fetchone()[0]
                finally:
                    target.close()
                if copied == version:  # (another program may have upgraded the file since: not this schema)
                    try:
                        os.link(temporary, backup)
                    except FileExistsError:  # a copy from an earlier upgrade is replaced; one another program
                        if backup.stat().st_mtime < started:  # made while this one copied is kept
                            os.replace(temporary, backup)
            finally:
                source.close()
                if temporary is not None:
                    temporary.unlink(missing_ok=True)
        except (sqlite3.Error, OSError) as error:
            problem = database_problem(error) if isinstance(error, sqlite3.Error) else (error.strerror or str(error))
            raise ProjectError(f"{path}: cannot copy the project aside to {backup.name} before upgrading it "
                               f"from schema {version}: {problem} (nothing was changed)") from None
        connection = Project._connect(path)
        try:
            migrate(connection)
        except sqlite3.Error as error:
            raise ProjectError(f"{path}: cannot upgrade the project from schema {version}: "
                               f"{database_problem(error)} (nothing was changed; a copy is in {backup.name})") from None
        finally:
            connection.close()

    @staticmethod
    def _connect(path: Path, read_only: bool = False) -> sqlite3.Connection:
        if sqlite3.sqlite_version_info < (3, 35):  # the shared dialect: RETURNING, ON CONFLICT … DO UPDATE
            raise ProjectError(f"{path}: this Python's SQLite {sqlite3.sqlite_version} is too old to open projects "
                               "(3.35 or newer is needed)")
        try:
            if read_only:
                connection = sqlite3.connect(f"file:{path}?mode=ro", uri=True, timeout=2.0, isolation_level=None)
                connection.execute("PRAGMA query_only = ON")
            else:
                connection = sqlite3.connect(str(path), timeout=2.0, isolation_level=None)
                mode = connection.execute("PRAGMA journal_mode = WAL").fetchone()[0]
                if mode.lower() != "wal":
                    connection.execute("PRAGMA journal_mode = DELETE")
            connection.execute("PRAGMA foreign_keys = ON")
            return connection
        except sqlite3.Error as error:
            raise ProjectError(f"{path}: cannot open the project: {database_problem(error)}") from None

    def copy_to(self, path: str | Path) -> Path:
        """Write a consistent copy of the project to the new file ``path`` (SQLite's online backup, whole
        even while the project is open). Image paths stored relative to this project's folder are
        rewritten relative to the copy's folder (absolute where that is not possible), so the copy finds
        its images and videos (with their recorded sizes and hashes). Written to ``<path>.part`` and
        renamed: a failure leaves nothing half-written."""
        target = Path(path)
        if target.exists():
            raise ProjectError(f"{target}: already exists; choose a new file name for the copy")
        if not target.parent.is_dir():
            raise ProjectError(f"{target}: the folder {target.parent} does not exist")
        part = target.with_name(target.name + ".part")
        old_folder, new_folder = self.path.resolve().parent, target.resolve().parent

        def moved(stored: str | None) -> str | None:
            if stored is None:
                return None
            absolute = (old_folder / stored).resolve()
            try:
                return str(absolute.relative_to(new_folder))
            except ValueError:
                return str(absolute)

        try:
            copy = sqlite3.connect(str(part))
            try:
                self._db.raw.backup(copy)
                rows = copy.execute("SELECT id, left_path, right_path FROM image_pairs").fetchall()
                media = copy.execute("SELECT path FROM media").fetchall() if copy.execute(
                    "SELECT 1 FROM sqlite_master WHERE type = 'table' AND name = 'media'").fetchone() else []
                copy.execute("PRAGMA foreign_keys = ON")  # a video's files follow their media rows
                with copy:
                    copy.executemany("UPDATE image_pairs SET left_path = ?, right_path = ? WHERE id = ?",
                                     [(moved(left), moved(right), pair_id) for pair_id, left, right in rows])
                    for (stored,) in media:  # the media's records (size, hashes) move with their paths
                        if moved(stored) != stored:
                            copy.execute("UPDATE media SET path = ? WHERE path = ?", (moved(stored), stored))
                            copy.execute("UPDATE meta SET key = ? WHERE key = ?",
                                         (_sample_key(moved(stored)), _sample_key(stored)))
                copy.execute("PRAGMA journal_mode = DELETE")
            finally:
                copy.close()
            part.replace(target)
        except (sqlite3.Error, OSError) as error:
            part.unlink(missing_ok=True)
            raise ProjectError(f"{target}: cannot write the copy of the project: {error}") from None
        return target

