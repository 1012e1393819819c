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

How: this module is the PostgreSQL backend (:class:`PostgresBackend`), a sibling of the SQLite file's
(:mod:`usvips.store.project`) under the one set of survey rules (:class:`~usvips.store.survey.Survey`).
The rules' SQL is written once in the dialect both share (``ON CONFLICT``, ``RETURNING``); the backend's only
translation is the placeholder (``?`` → ``%s``), and psycopg's errors become the store's own
(:class:`~usvips.store.backend.BackendError`, ``ConstraintError``, ``ServerUnreachableError``) here. No ORM:
the statements are few and portable; an ORM would add a second description of the schema, a dependency and
a layer between the contract suite and the SQL it checks, and buy nothing here.

Where media are: paths stored relative resolve against the *media folder* (URL query ``media=FOLDER``,
else ``$USVIPS_MEDIA_ROOT``, else the working folder); derived media (seek proxies, exported frames) go to
the *cache* (``cache=FOLDER``, else ``$USVIPS_CACHE``, else ``~/.cache/usvips/<host>/<database>``).
Messages name the survey by its URL without the password.
"""

from __future__ import annotations

import os
import threading
import time
from collections.abc import Iterable, Sequence
from functools import lru_cache
from pathlib import Path

import psycopg
from psycopg import errors as pg_errors
from psycopg import sql as pg_sql
from psycopg.pq import TransactionStatus

from usvips.store.backend import Backend, BackendError, ConstraintError, Result
from usvips.store.change_watch import ChangeWatch
from usvips.store.file_copy import SERVER_ONLY_META, check_new_file, table_order, write_file
from usvips.store.location import parse_server_location, public_location
from usvips.store.postgres_schema import CHANGES_CHANNEL, SCHEMA, SERVER_MIGRATIONS, SERVER_SCHEMA_VERSION, TABLES
from usvips.store.records import ProjectError, ServerUnreachableError
from usvips.store.survey import FORMAT, Survey, _now

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


# ------------------------------------------------------------------------------------------------ the backend
@lru_cache(maxsize=1024)
def _placeholders(sql: str) -> str:
    """The one difference of the shared dialect: ``?`` placeholders are psycopg's ``%s`` (and a literal
    ``%`` is doubled). Nothing else of a statement is rewritten."""
    return sql.replace("%", "%%").replace("?", "%s")


class PostgresBackend(Backend):
    """A survey's connection to its PostgreSQL server (see the module docstring).

    A statement that fails inside a transaction is undone alone (a savepoint), as in SQLite, so that the
    transaction may carry on; a write transaction takes the survey's write lock.

    A server that went away (stopped, killed, restarted, the network gone): the transaction in progress is
    lost on the server (nothing of it is kept), so the statement is refused with a
    :class:`~usvips.store.records.ServerUnreachableError`, and a rollback on the dead connection is no
    error. The next transaction or lone read connects again, waiting ``RECONNECT_WAITS_S`` between
    attempts (``reconnections`` counts them, so that a window can read its state afresh); beginning a
    transaction or a lone read that meets a connection the server closed is made again once, on the new
    connection. psycopg's errors never leave this class: they are :class:`BackendError`,
    :class:`ConstraintError` or ``ServerUnreachableError``.
    """

    insertion_order = "ord"

    def __init__(self, connection: psycopg.Connection, url: str, read_only: bool, where: object,
                 media: Path):
        self.raw, self.url, self.read_only = connection, url, read_only
        #: how messages name the survey (its store's ``path``: ``host/database``, or the name it was given)
        self.where = where
        self.media_folder = media
        #: how often the connection was made again after the server went away
        self.reconnections = 0

    # ------------------------------------------------------------------------ the connection
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

    def _error(self, error: psycopg.Error) -> BackendError:
        """psycopg's error as this package's (one line, naming the survey, never the password)."""
        if isinstance(error, pg_errors.LockNotAvailable):
            return BackendError(self.where, "another annotator is writing to the survey; try again in a moment")
        if isinstance(error, pg_errors.ReadOnlySqlTransaction):
            return BackendError(self.where, "the survey is opened read-only")
        if isinstance(error, psycopg.IntegrityError | pg_errors.RaiseException):
            return ConstraintError(self.where, _one_line(error))
        if isinstance(error, psycopg.OperationalError):
            return BackendError(self.where, f"the connection to the server failed: {_one_line(error)}")
        return BackendError(self.where, _one_line(error))

    def _afresh(self, action, lone: bool):
        """``action()`` — the start of a transaction, or a lone statement (``lone``) — on a live connection:
        made again once on a new connection when the server had closed this one since its last use."""
        if lone and not self._alive():
            self._reconnect()
        try:
            return action()
        except psycopg.OperationalError:
            if self._alive() or not lone:
                raise
        self._reconnect()
        try:
            return action()
        except psycopg.OperationalError as error:
            if not self._alive():
                raise self._unreachable(_one_line(error)) from None
            raise self._error(error) from None

    # ------------------------------------------------------------------------ statements
    def execute(self, sql: str, parameters: Sequence = ()) -> Result:
        lone = not self.in_transaction
        try:
            return self._afresh(lambda: self._run(sql, tuple(parameters)), lone and self._reads(sql))
        except psycopg.OperationalError as error:
            if not self._alive():  # a transaction was under way: it is gone, nothing of it kept
                raise self._unreachable(_one_line(error)) from None
            raise self._error(error) from None
        except psycopg.Error as error:
            raise self._error(error) from None

    @staticmethod
    def _reads(sql: str) -> bool:
        return sql.lstrip()[:6].upper() == "SELECT"

    def _run(self, sql: str, parameters: tuple) -> Result:
        with self._statement(sql), self.raw.cursor() as cursor:
            cursor.execute(_placeholders(sql), parameters)
            if cursor.description is None:
                return Result([], cursor.rowcount)
            return Result(cursor.fetchall(), cursor.rowcount, tuple(column.name for column in cursor.description))

    def executemany(self, sql: str, rows: Iterable[Sequence]) -> Result:
        rows = [tuple(r) for r in rows]
        if not rows:
            return Result([], 0)
        try:
            with self._statement(sql), self.raw.cursor() as cursor:
                cursor.executemany(_placeholders(sql), rows)
                return Result([], cursor.rowcount)
        except psycopg.Error as error:
            if isinstance(error, psycopg.OperationalError) and not self._alive():
                raise self._unreachable(_one_line(error)) from None
            raise self._error(error) from None

    def _statement(self, sql: str):
        """A savepoint around a write inside a transaction (a failed statement is undone alone)."""
        if self.in_transaction and not self._reads(sql):
            return _Savepoint(self.raw)
        return _Nothing()

    # ------------------------------------------------------------------------ transactions
    def begin(self, write: bool) -> None:
        def start() -> None:
            try:
                if write:  # writers take turns: the survey's write lock, waited for LOCK_WAIT_S at most
                    self.raw.execute("BEGIN ISOLATION LEVEL READ COMMITTED")
                    self.raw.execute("SELECT pg_advisory_xact_lock(%s)", (WRITE_LOCK,))
                else:  # one snapshot: reads never wait
                    self.raw.execute("BEGIN ISOLATION LEVEL REPEATABLE READ READ ONLY")
            except psycopg.Error:
                if self.in_transaction:
                    with _quietly():
                        self.raw.execute("ROLLBACK")
                raise

        try:
            self._afresh(start, lone=True)
        except psycopg.Error as error:
            raise self._error(error) from None

    def commit(self) -> None:
        try:
            self.raw.execute("COMMIT")
        except psycopg.Error as error:
            if isinstance(error, psycopg.OperationalError) and not self._alive():
                raise self._unreachable(_one_line(error), committing=True) from None
            raise self._error(error) from None

    def rollback(self) -> None:
        if not self._alive():
            return  # the server undid the transaction when the connection died
        try:
            self.raw.execute("ROLLBACK")
        except psycopg.Error as error:
            raise self._error(error) from None

    # ------------------------------------------------------------------------ the survey
    def schema_version(self) -> int:
        return int(self.execute("SELECT value FROM meta WHERE key = 'schema_version'").fetchone()[0])

    def has_table(self, name: str) -> bool:
        return True  # a survey is always of the current schema (an older one is migrated or refused at opening)

    def derived_media_folder(self) -> Path:
        """This machine's cache for the survey's derived media (see the module docstring)."""
        return cache_folder(self.url)

    def watch(self) -> ChangeWatch:
        return ServerChangeWatch(self.url, self.where)

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


class ServerProject(Survey):
    """A survey in a PostgreSQL database: the survey's rules on a :class:`PostgresBackend`; open with
    :meth:`open` or :meth:`create` (see the module docstring).

    ``path`` is the survey's local name: its folder is the media folder relative media paths resolve
    against; ``location`` is the URL without password that messages show.
    """

    def __init__(self, url: str, connection: psycopg.Connection, read_only: bool = False,
                 path: Path | None = None):
        self.url = url
        self.location = public_location(url)
        path = path or survey_path(url)
        super().__init__(path, PostgresBackend(connection, url, read_only, path, path.parent), read_only)

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
