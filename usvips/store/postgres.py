"""A survey on a PostgreSQL server: the second implementation of :class:`~usvips.store.interface.ProjectStore`.

Open one with ``usvips.store.opening.open_project("postgresql://user:password@host:port/database")``.
Several annotators work on one survey at once, each with their own connection:

- every edit is one transaction (``BEGIN … COMMIT``), and writers take turns: a write transaction first
  takes the survey's write lock (a transaction-scoped advisory lock), waiting up to ``LOCK_WAIT_S``; a
  writer that cannot get it is refused with one line (nothing written; try again), as SQLite refuses a
  write while another program writes. Reads never wait: each read is one snapshot (``REPEATABLE READ``).
- optimistic versions: an edit may name the ``modified`` stamp of the object as the editor read it
  (``update_object(..., expected_modified=...)``); when someone else changed the object since, the edit is
  refused by a :class:`~usvips.store.records.StaleEditError` naming the object — never silently
  overwritten.

How: the SQL of :class:`~usvips.store.project.Project` is small and plain, so this class IS a ``Project``
whose connection is :class:`_ServerConnection`, which runs those statements on PostgreSQL with the few
SQLite spellings translated (``?`` placeholders, ``INSERT OR REPLACE``/``OR IGNORE``, ``lastrowid``,
``rowid``, ``PRAGMA table_info``), and which reports PostgreSQL's errors as the ``sqlite3`` exceptions
``Project`` already turns into one-line :class:`ProjectError` messages. Both backends therefore share
every domain rule and message and pass the same contract suite. No ORM: the statements are already
written once, portable, and few; an ORM would add a second description of the schema, a dependency and
a layer between the contract suite and the SQL it checks, and buy nothing here.

Where media are: paths stored relative resolve against the *media folder* (URL query ``media=FOLDER``,
else ``$USVIPS_MEDIA_ROOT``, else the working folder); derived media (seek proxies, exported frames) go to
the *cache* (``cache=FOLDER``, else ``$USVIPS_CACHE``, else ``~/.cache/usvips/<host>/<database>``).
Messages name the survey by its URL without the password.
"""

from __future__ import annotations

import os
import re
import sqlite3
import threading
import time
from functools import lru_cache
from pathlib import Path

import psycopg
from psycopg import errors as pg_errors
from psycopg import sql as pg_sql
from psycopg.pq import TransactionStatus

from usvips.store.change_watch import ChangeWatch
from usvips.store.file_copy import SERVER_ONLY_META, check_new_file, table_order, write_file
from usvips.store.location import parse_server_location, public_location
from usvips.store.postgres_schema import (
    CHANGES_CHANNEL,
    IDENTITY_TABLES,
    PRIMARY_KEYS,
    SCHEMA,
    SERVER_MIGRATIONS,
    SERVER_SCHEMA_VERSION,
    TABLES,
)
from usvips.store.project import FORMAT, Project, _now
from usvips.store.records import ProjectError, ServerUnreachableError

LOCK_WAIT_S = 2.0
#: the waits (s) between attempts to connect again when the server went away (stopped, restarted, the
#: network gone): one series per action; when all fail the action is refused ("the server is unreachable")
#: and the next action tries again
RECONNECT_WAITS_S = (0.0, 0.25, 0.5, 1.0, 2.0)
WRITE_LOCK = 0x55535649  # "USVI": the advisory lock key of a survey's writers (per database)
CONNECT_TIMEOUT_S = 5


# ------------------------------------------------------------------------------------------------ locations
def _parameters(url: str, database: str | None = None) -> dict:
    """What the client library is handed to connect (the password as a value, never in a URL; see
    :meth:`usvips.store.location.ServerLocation.connection_parameters`)."""
    return parse_server_location(url).connection_parameters(database)


def database_name(url: str) -> str:
    """The survey's database (a URL that cannot be read, or names none, is refused in one line)."""
    return parse_server_location(url).database


def _own_option(url: str, key: str, environment: str) -> str | None:
    return parse_server_location(url).option(key) or os.environ.get(environment) or None


def media_folder(url: str) -> Path:
    """The folder relative media paths of the survey resolve against on this machine."""
    return Path(_own_option(url, "media", "USVIPS_MEDIA_ROOT") or Path.cwd()).resolve()


def cache_folder(url: str) -> Path:
    """The folder derived media (seek proxies, exported frames) of the survey are kept in on this machine."""
    chosen = _own_option(url, "cache", "USVIPS_CACHE")
    if chosen:
        return Path(chosen).resolve()
    return Path.home() / ".cache" / "usvips" / parse_server_location(url).name()


def _one_line(error: BaseException) -> str:
    """A server error in one line (psycopg's messages carry DETAIL/HINT lines and the socket's path)."""
    if isinstance(error, psycopg.Error) and error.diag.message_primary:
        text = error.diag.message_primary
        if error.diag.message_detail:
            text += f" ({error.diag.message_detail})"
    else:
        text = str(error)
    return " ".join(text.split())


def connection_problem(error: psycopg.Error, url: str) -> str:
    """Why a connection failed, in words a person can act on (never the password)."""
    message = _one_line(error)
    lowered = message.lower()
    if "password authentication failed" in lowered or "no password supplied" in lowered:
        return "the server refused the user name or password"
    if "does not exist" in lowered and "database" in lowered:
        return f"the server has no database {database_name(url)!r} (create it with 'usvips project push' or new)"
    if any(words in lowered for words in ("connection refused", "no such file", "could not connect", "timeout",
                                         "could not translate host", "is the server running", "timed out",
                                         "resolve host", "name or service not known")):
        return "no server answers there (is it running? are host and port right?)"
    return message


def _connect(url: str, read_only: bool) -> psycopg.Connection:
    parameters = _parameters(url)  # a URL that cannot be read is refused before anything is asked of a server
    try:
        connection = psycopg.connect(autocommit=True, connect_timeout=CONNECT_TIMEOUT_S, **parameters)
    except psycopg.Error as error:
        raise ProjectError(f"{public_location(url)}: cannot connect: {connection_problem(error, url)}") from None
    try:
        if read_only:
            connection.execute("SET default_transaction_read_only = on")
        connection.execute(f"SET lock_timeout = '{int(LOCK_WAIT_S * 1000)}ms'")
    except psycopg.Error as error:
        connection.close()
        raise ProjectError(f"{public_location(url)}: cannot connect: {_one_line(error)}") from None
    return connection


#: the survey's roles (cluster-wide group roles, no login of their own): an annotator reads and writes
#: objects, a reviewer also accepts and flags them, an administrator also copies others' rows as they were
#: (push, pull, migrations). A login is given one with ``GRANT usvips_reviewer TO ann``
SURVEY_ROLES = {"usvips_annotator": "", "usvips_reviewer": " IN ROLE usvips_annotator",
                "usvips_administrator": " IN ROLE usvips_reviewer"}


def create_survey_roles(connection: psycopg.Connection) -> bool:
    """Create the survey roles that do not exist yet, when this login may (superuser or CREATEROLE);
    returns whether they all exist now."""
    missing = [name for name in SURVEY_ROLES
               if connection.execute("SELECT to_regrole(%s)", (name,)).fetchone()[0] is None]
    may = connection.execute("SELECT rolsuper OR rolcreaterole FROM pg_roles WHERE rolname = current_user"
                             ).fetchone()
    if missing and may and may[0]:
        for name in missing:
            connection.execute(f"CREATE ROLE {name} NOLOGIN{SURVEY_ROLES[name]}")
        missing = []
    return not missing


def grant_survey_roles(connection: psycopg.Connection) -> None:
    """Give the survey roles what they may do on this survey's tables (so that a second login, made a
    member of one, opens a pushed survey: 'permission denied for table meta' before); nothing when the
    roles do not exist."""
    if any(connection.execute("SELECT to_regrole(%s)", (name,)).fetchone()[0] is None for name in SURVEY_ROLES):
        return
    schema = pg_sql.Identifier(connection.execute("SELECT current_schema()").fetchone()[0])
    for statement in ("GRANT SELECT, INSERT, UPDATE, DELETE ON ALL TABLES IN SCHEMA {} TO usvips_annotator",
                      "GRANT USAGE, SELECT, UPDATE ON ALL SEQUENCES IN SCHEMA {} TO usvips_annotator",
                      "GRANT ALL ON ALL TABLES IN SCHEMA {} TO usvips_administrator"):
        connection.execute(pg_sql.SQL(statement).format(schema))


def new_survey(url: str, fill, doing: str) -> None:
    """Make the database ``url`` names a survey: the database is created when it does not exist (and
    dropped again when this fails), else it must hold no tables; the schema, the ``meta`` rows and what
    ``fill(connection)`` writes are ONE transaction: all of it, or nothing."""
    location = public_location(url)
    parameters = _parameters(url)
    created = False
    try:
        connection = psycopg.connect(autocommit=True, connect_timeout=CONNECT_TIMEOUT_S, **parameters)
    except psycopg.OperationalError as error:
        if "does not exist" not in _one_line(error) or "database" not in _one_line(error):
            raise ProjectError(f"{location}: cannot connect: {connection_problem(error, url)}") from None
        database_command(url, "CREATE DATABASE {} TEMPLATE template0 ENCODING 'UTF8' LC_COLLATE 'C' LC_CTYPE 'C'")
        created = True
        connection = _connect(url, read_only=False)
    except psycopg.Error as error:
        raise ProjectError(f"{location}: cannot connect: {connection_problem(error, url)}") from None
    try:
        tables = connection.execute("SELECT count(*) FROM information_schema.tables WHERE table_schema = "
                                    "current_schema()").fetchone()[0]
        if tables:
            raise ProjectError(f"{location}: the database already holds tables; give a new or empty database "
                               "for a survey (nothing was written)")
        with connection.transaction():
            create_survey_roles(connection)
            connection.execute(SCHEMA)
            connection.execute("INSERT INTO meta VALUES ('format', %s), ('created', %s), ('schema_version', %s)",
                               (FORMAT, _now(), str(SERVER_SCHEMA_VERSION)))
            fill(connection)
            grant_survey_roles(connection)
    except BaseException as error:
        connection.close()
        if created:
            database_command(url, "DROP DATABASE IF EXISTS {}")
        if isinstance(error, psycopg.Error):
            raise ProjectError(f"{location}: {doing}: {_one_line(error)} (nothing was written)") from None
        raise
    connection.close()


def database_command(url: str, command: str) -> None:
    """CREATE or DROP the database ``url`` names, through the server's maintenance database."""
    try:
        with psycopg.connect(autocommit=True, connect_timeout=CONNECT_TIMEOUT_S,
                             **_parameters(url, "postgres")) as server:
            server.execute(pg_sql.SQL(command).format(pg_sql.Identifier(database_name(url))))
    except psycopg.Error as error:
        raise ProjectError(f"{public_location(url)}: cannot create or remove the database: "
                           f"{connection_problem(error, url)}") from None


# ------------------------------------------------------------------------------------------------ the SQL
_PLACEHOLDER = re.compile(r"\?")
_OR_REPLACE = re.compile(r"^\s*INSERT OR (REPLACE|IGNORE) INTO (\w+)\s*(\(([^)]*)\))?\s*(VALUES.*)$", re.S | re.I)
_INSERT = re.compile(r"^\s*INSERT INTO (\w+)\b(?!.*\bSELECT\b)", re.S | re.I)
_TABLE_INFO = re.compile(r"^\s*PRAGMA table_info\((\w+)\)\s*$", re.I)


@lru_cache(maxsize=512)
def translate(sql: str) -> tuple[str, bool]:
    """The PostgreSQL spelling of one of ``Project``'s SQLite statements, and whether it returns the new
    row's id (as SQLite's ``lastrowid``). A construct not handled here is a programming error, loudly."""
    info = _TABLE_INFO.match(sql)
    if info:  # rows whose second value is a column's name, like SQLite's table_info
        return ("SELECT ordinal_position, column_name::text FROM information_schema.columns WHERE table_name = "
                f"'{info.group(1)}' AND table_schema = current_schema() ORDER BY ordinal_position"), False
    if re.search(r"\bPRAGMA\b|\bsqlite_master\b", sql, re.I):
        raise NotImplementedError(f"no PostgreSQL spelling for: {sql}")
    text = sql.replace("%", "%%")
    returning = False
    replace = _OR_REPLACE.match(text)
    if replace:
        verb, table, _, columns, values = replace.groups()
        table = table.lower()
        names = [c.strip() for c in columns.split(",")] if columns else list(TABLES[table])
        keys = PRIMARY_KEYS[table]
        head = f"INSERT INTO {table} ({', '.join(names)}) {values}"
        updates = [f"{c} = EXCLUDED.{c}" for c in names if c not in keys]
        if verb.upper() == "IGNORE" or not updates:
            text = f"{head} ON CONFLICT DO NOTHING"
        else:
            text = f"{head} ON CONFLICT ({', '.join(keys)}) DO UPDATE SET {', '.join(updates)}"
    else:
        insert = _INSERT.match(text)
        if insert and insert.group(1).lower() in IDENTITY_TABLES:
            text, returning = f"{text.rstrip().rstrip(';')} RETURNING id", True
    text = re.sub(r"\bORDER BY rowid\b", "ORDER BY ord", text)
    return _PLACEHOLDER.sub("%s", text), returning


class _Cursor:
    """The rows of one statement, shaped as the part of ``sqlite3.Cursor`` that ``Project`` uses."""

    def __init__(self, rows: list[tuple], rowcount: int, lastrowid: int | None, description=None):
        self._rows, self.rowcount, self.lastrowid = rows, rowcount, lastrowid
        #: as sqlite3's: one 7-tuple per column, its name first (None for a statement that returns no rows)
        self.description = description

    def fetchall(self) -> list[tuple]:
        return self._rows

    def fetchone(self) -> tuple | None:
        return self._rows[0] if self._rows else None

    def __iter__(self):
        return iter(self._rows)


def _as_sqlite_error(error: psycopg.Error) -> sqlite3.Error:
    """PostgreSQL's error as the ``sqlite3`` exception ``Project`` turns into a one-line message."""
    if isinstance(error, pg_errors.LockNotAvailable):
        return sqlite3.OperationalError("another annotator is writing to the survey; try again in a moment")
    if isinstance(error, pg_errors.ReadOnlySqlTransaction):
        return sqlite3.OperationalError("the survey is opened read-only")
    if isinstance(error, psycopg.IntegrityError):
        return sqlite3.IntegrityError(_one_line(error))
    if isinstance(error, psycopg.OperationalError):
        return sqlite3.OperationalError(f"the connection to the server failed: {_one_line(error)}")
    return sqlite3.OperationalError(_one_line(error))


class _ServerConnection:
    """A psycopg connection that runs ``Project``'s statements (see the module docstring).

    A statement that fails inside a transaction is undone alone (a savepoint), as in SQLite, so that the
    transaction may carry on; ``BEGIN IMMEDIATE`` (a write transaction) takes the survey's write lock.

    A server that went away (stopped, killed, restarted, the network gone): the transaction in progress is
    lost on the server (nothing of it is kept), so the statement is refused with a
    :class:`~usvips.store.records.ServerUnreachableError`, and a ROLLBACK on the dead connection is no
    error. The next transaction or lone read connects again, waiting ``RECONNECT_WAITS_S`` between
    attempts (``reconnections`` counts them, so that a window can read its state afresh); a first
    statement of a transaction (BEGIN) or a lone read that meets a connection the server closed is made
    again once, on the new connection.
    """

    def __init__(self, connection: psycopg.Connection, url: str = "", read_only: bool = False):
        self.raw = connection
        self.url, self.read_only = url, read_only
        #: how messages name the survey (its store's ``path``: ``host/database``, or the name it was given)
        self.where: object = public_location(url) if url else ""
        #: how often the connection was made again after the server went away
        self.reconnections = 0

    def _alive(self) -> bool:
        return not (self.raw.closed or self.raw.broken)

    @property
    def in_transaction(self) -> bool:
        return self._alive() and self.raw.info.transaction_status != TransactionStatus.IDLE

    def _unreachable(self, why: str, committing: bool = False) -> ServerUnreachableError:
        written = ("the server did not confirm the change: read the survey again to see whether it was kept"
                   if committing else "nothing was written")
        return ServerUnreachableError(f"{self.where}: the server is unreachable ({why}); {written} "
                                      "— USVIPS connects again on the next action")

    def _reconnect(self) -> None:
        """Connect again, waiting :data:`RECONNECT_WAITS_S` between attempts; all failing: unreachable."""
        problem = "the connection was lost"
        for wait in RECONNECT_WAITS_S:
            time.sleep(wait)
            try:
                fresh = _connect(self.url, self.read_only)
            except ProjectError as error:
                problem = str(error).split("cannot connect: ", 1)[-1]
                continue
            with _quietly():
                self.raw.close()
            self.raw = fresh
            self.reconnections += 1
            return
        raise self._unreachable(problem)

    def execute(self, sql: str, parameters=()) -> _Cursor:
        command = sql.strip().upper()
        if command == "ROLLBACK" and not self._alive():
            return _Cursor([], 0, None)  # the server undid the transaction when the connection died
        fresh_start = command.startswith("BEGIN") or (command.startswith("SELECT") and not self.in_transaction)
        if fresh_start and not self._alive() and self.url:
            self._reconnect()
        try:
            return self._execute(sql, command, parameters)
        except psycopg.OperationalError as error:
            if self._alive() or not self.url:
                raise _as_sqlite_error(error) from None
            if not fresh_start:  # a transaction was under way: it is gone, nothing of it kept
                raise self._unreachable(_one_line(error), command == "COMMIT") from None
        self._reconnect()  # the server closed the connection since the last use: once more, anew
        try:
            return self._execute(sql, command, parameters)
        except psycopg.OperationalError as error:
            if not self._alive():
                raise self._unreachable(_one_line(error)) from None
            raise _as_sqlite_error(error) from None

    def _execute(self, sql: str, command: str, parameters) -> _Cursor:
        """One statement; psycopg's OperationalError (a lost connection) goes to the caller as it is."""
        try:
            if command == "BEGIN IMMEDIATE":
                self.raw.execute("BEGIN ISOLATION LEVEL READ COMMITTED")
                self.raw.execute("SELECT pg_advisory_xact_lock(%s)", (WRITE_LOCK,))
                return _Cursor([], 0, None)
            if command == "BEGIN":
                self.raw.execute("BEGIN ISOLATION LEVEL REPEATABLE READ READ ONLY")
                return _Cursor([], 0, None)
            if command in ("COMMIT", "ROLLBACK"):
                self.raw.execute(command)
                return _Cursor([], 0, None)
            text, returning = translate(sql)
            with self._statement(command), self.raw.cursor() as cursor:
                cursor.execute(text, tuple(parameters))
                rows = cursor.fetchall() if cursor.description is not None else []
                described = None if cursor.description is None else tuple(
                    (column.name, None, None, None, None, None, None) for column in cursor.description)
                return _Cursor(rows, cursor.rowcount, rows[0][0] if returning and rows else None, described)
        except psycopg.Error as error:
            if command.startswith("BEGIN") and self.in_transaction:
                with _quietly():
                    self.raw.execute("ROLLBACK")
            if isinstance(error, psycopg.OperationalError) and not self._alive():
                raise
            raise _as_sqlite_error(error) from None

    def executemany(self, sql: str, rows) -> _Cursor:
        text, _ = translate(sql)
        rows = [tuple(r) for r in rows]
        if not rows:
            return _Cursor([], 0, None)
        try:
            with self._statement("INSERT"), self.raw.cursor() as cursor:
                cursor.executemany(text, rows)
                return _Cursor([], cursor.rowcount, None)
        except psycopg.Error as error:
            if isinstance(error, psycopg.OperationalError) and not self._alive():
                raise self._unreachable(_one_line(error)) from None
            raise _as_sqlite_error(error) from None

    def _statement(self, command: str):
        """A savepoint around a write inside a transaction (a failed statement is undone alone)."""
        if self.in_transaction and not command.startswith("SELECT"):
            return _Savepoint(self.raw)
        return _Nothing()

    def close(self) -> None:
        self.raw.close()


class _quietly:
    """Ignore a psycopg error (cleaning up a connection that may be dead)."""

    def __enter__(self):
        return self

    def __exit__(self, kind, error, trace) -> bool:
        return kind is not None and issubclass(kind, psycopg.Error)


class _Nothing:
    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        return None


class _Savepoint:
    def __init__(self, connection: psycopg.Connection):
        self.connection = connection

    def __enter__(self):
        self.connection.execute("SAVEPOINT usvips_statement")
        return self

    def __exit__(self, kind, error, trace) -> None:
        if kind is None:
            self.connection.execute("RELEASE SAVEPOINT usvips_statement")
        elif self.connection.info.transaction_status == TransactionStatus.INERROR:
            self.connection.execute("ROLLBACK TO SAVEPOINT usvips_statement")
            self.connection.execute("RELEASE SAVEPOINT usvips_statement")


# ------------------------------------------------------------------------------------------------ the change feed
class ServerChangeWatch(ChangeWatch):
    """The watch of a survey (:mod:`usvips.store.change_watch`): its own connection LISTENs on the survey's
    channel, which every transaction that adds history rows NOTIFYs at commit (a trigger, schema 14). A
    connection the server closed is made again on a later :meth:`wait`, which then returns True (changes
    may have been missed meanwhile). Messages name the survey without its password."""

    #: the longest single wait (s) on the connection: :meth:`close` from another thread takes effect within it
    SLICE_S = 0.25

    def __init__(self, url: str, where: object):
        self.url, self.where = url, where
        self._closed = threading.Event()
        self._using = threading.Lock()
        self._connection: psycopg.Connection | None = self._listen()

    def _listen(self) -> psycopg.Connection:
        connection = _connect(self.url, read_only=True)
        try:
            connection.execute(f"LISTEN {CHANGES_CHANNEL}")
        except psycopg.Error as error:
            connection.close()
            raise ProjectError(f"{self.where}: cannot watch the survey for changes: {_one_line(error)}") from None
        return connection

    def wait(self, timeout_s: float) -> bool:
        deadline = time.monotonic() + max(0.0, float(timeout_s))
        with self._using:
            try:
                while not self._closed.is_set():
                    connection = self._connection
                    if connection is None or connection.closed or connection.broken:
                        try:
                            self._connection = self._listen()
                            return True  # changes made while it was away were not heard
                        except ProjectError:
                            self._connection = None
                            if self._closed.wait(min(self.SLICE_S * 4, max(0.0, deadline - time.monotonic()))):
                                return False
                    else:
                        try:
                            heard = list(connection.notifies(
                                timeout=min(self.SLICE_S, max(0.0, deadline - time.monotonic())), stop_after=1))
                            if heard:
                                list(connection.notifies(timeout=0.0))  # one wake-up for a burst
                                return not self._closed.is_set()
                        except psycopg.Error:
                            with _quietly():
                                connection.close()
                    if time.monotonic() >= deadline:
                        return False
                return False
            finally:
                if self._closed.is_set():
                    self._release()

    def _release(self) -> None:
        connection, self._connection = self._connection, None
        if connection is not None:
            with _quietly():
                connection.close()

    def close(self) -> None:
        self._closed.set()
        if self._using.acquire(blocking=False):  # else the waiting thread releases it within SLICE_S
            try:
                self._release()
            finally:
                self._using.release()


# ------------------------------------------------------------------------------------------------ the store
class SurveyPath(type(Path())):
    """A survey's ``path``: a path to the media folder's entry for it (relative media paths resolve against
    its ``parent``, files are opened through it), which prints as the survey's name ``host/database``
    (messages, titles) — a server survey is not named like a file that does not exist."""

    def __str__(self) -> str:
        return getattr(self, "_shown", None) or super().__str__()

    def __fspath__(self) -> str:
        return Path.__str__(self)

    def __repr__(self) -> str:
        return f"SurveyPath({str(self)!r})"


def survey_path(url: str) -> Path:
    """The ``path`` of a survey opened without one: see :class:`SurveyPath`."""
    path = SurveyPath(media_folder(url) / database_name(url))
    path._shown = parse_server_location(url).name()
    return path


class ServerProject(Project):
    """A survey in a PostgreSQL database; open with :meth:`open` or :meth:`create` (see the module docstring).

    ``path`` is the survey's local name: its folder is the media folder relative media paths resolve
    against; ``location`` is the URL without password that messages show.
    """

    def __init__(self, url: str, connection: psycopg.Connection, read_only: bool = False,
                 path: Path | None = None):
        self.url = url
        self.location = public_location(url)
        super().__init__(path or survey_path(url), _ServerConnection(connection, url, read_only), read_only)
        self._db.where = self.path

    @property
    def reconnections(self) -> int:
        """How often the connection to the server was made again after it went away (a window reads its
        state afresh when this moves)."""
        return self._db.reconnections

    @classmethod
    def create(cls, url: str, path: str | Path | None = None) -> ServerProject:
        """A new, empty survey in the database ``url`` names: created on the server when it does not exist
        yet (byte-wise collation, as SQLite sorts), else it must be empty. All or nothing."""
        new_survey(url, lambda connection: None, "cannot create the survey")
        return cls.open(url, path=path)

    @classmethod
    def open(cls, url: str, read_only: bool = False, path: str | Path | None = None) -> ServerProject:
        """An existing survey; refuses (one line naming the URL without password) a server that does not
        answer, a refused login, a database that does not exist or is not a USVIPS survey, and a survey of
        a newer schema."""
        location = public_location(url)
        connection = _connect(url, read_only)
        try:
            version = cls._check(connection, location)
        except BaseException:
            connection.close()
            raise
        if version < SERVER_SCHEMA_VERSION:
            try:
                cls._migrate(connection, location, version, read_only)
            except BaseException:
                connection.close()
                raise
        survey = cls(url, connection, read_only, Path(path) if path is not None else None)
        survey.login_is_annotator()
        return survey

    def login_is_annotator(self) -> None:
        """On a survey with roles, the annotator is the database login (the server records it in the
        history whatever the client says); an administrator's handle keeps the annotator it was given."""
        try:
            login, administrator = self._db.raw.execute(
                "SELECT session_user::text, usvips_is_role_member('usvips_administrator')").fetchone()
        except psycopg.Error as error:
            raise ProjectError(f"{self.path}: cannot open the survey: {_one_line(error)}") from None
        if not administrator:
            self.annotator = login

    @staticmethod
    def _migrate(connection: psycopg.Connection, location: str, version: int, read_only: bool) -> None:
        """Bring a survey of an older schema forward in ONE transaction (under the writers' lock): every
        step of ``SERVER_MIGRATIONS`` or, on any error, none. A read-only opening never migrates and
        refuses an older survey (open it once for writing)."""
        if read_only or version not in range(min(SERVER_MIGRATIONS) - 1, SERVER_SCHEMA_VERSION):
            why = ("open it once for writing to bring it up to date" if read_only
                   else "this USVIPS cannot upgrade it")
            raise ProjectError(f"{location}: a survey of schema {version} (this USVIPS uses "
                               f"{SERVER_SCHEMA_VERSION}); {why}")
        try:
            with connection.transaction():
                connection.execute("SELECT pg_advisory_xact_lock(%s)", (WRITE_LOCK,))
                current = int(connection.execute("SELECT value FROM meta WHERE key = 'schema_version' FOR UPDATE"
                                                 ).fetchone()[0])
                for step in range(current + 1, SERVER_SCHEMA_VERSION + 1):  # another annotator may have done it
                    if SERVER_MIGRATIONS.get(step):
                        connection.execute(SERVER_MIGRATIONS[step])
                grant_survey_roles(connection)
                connection.execute("UPDATE meta SET value = %s WHERE key = 'schema_version'",
                                   (str(SERVER_SCHEMA_VERSION),))
        except psycopg.Error as error:
            raise ProjectError(f"{location}: cannot upgrade the survey from schema {version}: {_one_line(error)} "
                               "(nothing was changed)") from None

    @staticmethod
    def _check(connection: psycopg.Connection, location: str) -> int:
        try:
            if connection.execute("SELECT to_regclass('meta')").fetchone()[0] is None:
                raise ProjectError(f"{location}: not a USVIPS survey (the database has no USVIPS tables)")
            meta = dict(connection.execute("SELECT key, value FROM meta WHERE key IN ('format', 'schema_version')"))
        except pg_errors.InsufficientPrivilege:
            login = connection.execute("SELECT session_user::text").fetchone()[0]
            raise ProjectError(f"{location}: the login {login} is not one of this survey's annotators (its owner or "
                               f"an administrator gives it a role: GRANT usvips_annotator TO {login})") from None
        except psycopg.Error as error:
            raise ProjectError(f"{location}: cannot open the survey: {_one_line(error)}") from None
        if meta.get("format") != FORMAT or not str(meta.get("schema_version", "")).isdigit():
            raise ProjectError(f"{location}: not a USVIPS survey (its 'meta' table is something else's)")
        version = int(meta["schema_version"])
        if version > SERVER_SCHEMA_VERSION:
            raise ProjectError(f"{location}: made by a newer USVIPS (schema {version}; this one reads up to "
                               f"{SERVER_SCHEMA_VERSION}); update USVIPS to open it")
        return version

    def __enter__(self) -> ServerProject:
        return self

    @property
    def version(self) -> int:
        return int(self._query("SELECT value FROM meta WHERE key = 'schema_version'")[0][0])

    def _has_pointing(self) -> bool:
        return True  # a survey is opened at the current schema (an older one is refused read-only)

    def _has_table(self, name: str) -> bool:
        return True  # a server survey is always of the current schema (older ones are refused at opening)

    def watch(self) -> ChangeWatch:
        """A :class:`ServerChangeWatch` on the survey (its own connection, for a background thread)."""
        return ServerChangeWatch(self.url, self.path)

    def derived_media_folder(self) -> Path:
        """This machine's cache for the survey's derived media (see the module docstring)."""
        return cache_folder(self.url)

    def copy_to(self, path: str | Path) -> Path:
        """A consistent copy of the whole survey as a new SQLite project file at ``path`` (``pull``)."""
        check_new_file(path)  # refused before the survey is read
        return write_file(self.table_rows(), path)

    def table_rows(self) -> dict[str, list[tuple]]:
        """Every row of every table of the survey, read in one snapshot (the server's own meta rows left
        out), as :func:`usvips.store.file_copy.write_file` takes them."""
        with self._reading():
            rows = {table: self._db.execute(f"SELECT {', '.join(columns)} FROM {table} ORDER BY "
                                            f"{table_order(table, 'ord')}").fetchall()
                    for table, columns in TABLES.items()}
        rows["meta"] = [row for row in rows["meta"] if row[0] not in SERVER_ONLY_META]
        return rows
