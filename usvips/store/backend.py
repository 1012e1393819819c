"""The small interface between the survey's rules (:class:`usvips.store.survey.Survey`) and where the rows
live: a :class:`Backend` runs SQL, keeps transactions, names its schema version, and says where media and
derived media are. Everything a survey *means* — history, reviews, versions, instants, media identity,
campaigns — is in the rules, once; a backend knows only its database.

The SQL is written once, in the dialect SQLite and PostgreSQL share (``INSERT … ON CONFLICT … DO UPDATE``,
``RETURNING id``, ``?`` placeholders; :func:`upsert` builds the one statement both spell alike): a
backend's only translation is the placeholder (:meth:`Backend.execute`), in one place. Its driver's errors
never leave it: they become a :class:`BackendError` (a :class:`~usvips.store.records.ProjectError` whose
``problem`` says what went wrong in words a person can act on), a :class:`ConstraintError` when the schema
refused a row, or a :class:`~usvips.store.records.ServerUnreachableError`.

The backends: :mod:`usvips.store.project` (an SQLite file) and :mod:`usvips.store.postgres` (a survey on a
PostgreSQL server). A new one is one module (a ``Backend`` and the class that opens a survey on it) that
passes the unchanged contract suite, and one branch in :mod:`usvips.store.opening`.
"""

from __future__ import annotations

import contextlib
from abc import ABC, abstractmethod
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

from usvips.store.change_watch import ChangeWatch
from usvips.store.records import ProjectError


class BackendError(ProjectError):
    """A database failure, its one line naming the project (``where``) and the ``problem``."""

    def __init__(self, where: object, problem: str):
        super().__init__(f"{where}: {problem}")
        self.where, self.problem = where, problem


class ConstraintError(BackendError):
    """A row the schema refused (a used key, a check, a foreign key, the history's append-only guard)."""


class Result:
    """The rows of one statement, read whole: ``fetchall``/``fetchone``/iteration, ``rowcount`` (rows
    changed) and ``columns`` (the names of the columns returned, () for a statement returning none)."""

    __slots__ = ("columns", "rowcount", "rows")

    def __init__(self, rows: list[tuple], rowcount: int = -1, columns: tuple[str, ...] = ()):
        self.rows, self.rowcount, self.columns = rows, rowcount, columns

    def fetchall(self) -> list[tuple]:
        return self.rows

    def fetchone(self) -> tuple | None:
        return self.rows[0] if self.rows else None

    def __iter__(self) -> Iterator[tuple]:
        return iter(self.rows)


@dataclass(frozen=True)
class Statement:
    """One statement of a :meth:`Backend.batch`: ``sql`` (``?`` placeholders) with its ``parameters`` or, with
    ``many``, a sequence of parameter rows (the statement once for each, as :meth:`Backend.executemany`)."""

    sql: str
    parameters: Sequence = ()
    many: bool = False


class Backend(ABC):
    """Where a survey's rows live (see the module docstring). ``where`` names the survey in messages;
    ``media_folder`` is what relative media paths resolve against; ``insertion_order`` is the column that
    keeps the order rows were stored in (SQLite's ``rowid``, a server's ``ord``)."""

    where: object
    read_only: bool
    media_folder: Path
    insertion_order: str = "rowid"

    @abstractmethod
    def execute(self, sql: str, parameters: Sequence = ()) -> Result:
        """One statement (``?`` placeholders); inside a transaction a failing statement is undone alone."""

    @abstractmethod
    def executemany(self, sql: str, rows: Iterable[Sequence]) -> Result:
        """One statement for each row of ``rows``."""

    def batch(self, statements: Sequence[Statement]) -> list[Result]:
        """Several statements, in order, inside the transaction in progress: all of them or — when one fails —
        none (the batch is undone alone, as a failing statement is); each one's :class:`Result` (a ``many``
        statement's holds no rows). A backend whose round trips cost (a server) sends them at once; this one
        runs them in turn within a savepoint (reads alone need none: they change nothing to undo)."""
        if not self.in_transaction or len(statements) < 2 or all(_reads(s) for s in statements):
            return [self._one(statement) for statement in statements]
        self.execute("SAVEPOINT usvips_batch")
        try:
            results = [self._one(statement) for statement in statements]
        except BackendError:
            if self.in_transaction:  # (some failures — a full disk — have already undone the whole transaction)
                with contextlib.suppress(BackendError):
                    self.execute("ROLLBACK TO SAVEPOINT usvips_batch")
                    self.execute("RELEASE SAVEPOINT usvips_batch")
            raise
        self.execute("RELEASE SAVEPOINT usvips_batch")
        return results

    def write_later(self, statements: Sequence[Statement]) -> None:
        """Writes whose results nobody reads, inside the transaction in progress: a backend whose round trips
        cost may hold them and send them with the next statement or the commit (a failure of one then fails
        that statement or the commit, and the whole transaction: nothing is changed). This one runs them now,
        as one :meth:`batch`."""
        self.batch(statements)

    def _one(self, statement: Statement) -> Result:
        if statement.many:
            return self.executemany(statement.sql, statement.parameters)
        return self.execute(statement.sql, statement.parameters)

    @abstractmethod
    def begin(self, write: bool) -> None:
        """Start a transaction: a write one (writers take turns; a busy survey is a ``BackendError``) or a
        read one (one consistent snapshot)."""

    @abstractmethod
    def commit(self) -> None: ...

    @abstractmethod
    def rollback(self) -> None:
        """Undo the transaction in progress (no error when the connection is gone: nothing was kept)."""

    @property
    @abstractmethod
    def in_transaction(self) -> bool: ...

    @abstractmethod
    def schema_version(self) -> int:
        """The schema version the survey is stored in."""

    @abstractmethod
    def has_table(self, name: str) -> bool:
        """Whether the survey's schema has the table (an older project read as it is may lack one)."""

    @abstractmethod
    def derived_media_folder(self) -> Path:
        """Where media derived from the survey (seek proxies, exported frames) are kept on this machine."""

    @abstractmethod
    def watch(self) -> ChangeWatch:
        """A watch of the survey's commits (:mod:`usvips.store.change_watch`), on its own connection."""

    @abstractmethod
    def close(self) -> None: ...


def _reads(statement: Statement) -> bool:
    """Whether a statement only reads (a SELECT)."""
    return not statement.many and statement.sql.lstrip()[:6].upper() == "SELECT"


@lru_cache(maxsize=128)
def upsert(table: str, columns: tuple[str, ...], keys: tuple[str, ...]) -> str:
    """``INSERT INTO table (columns) VALUES (?, …) ON CONFLICT (keys) DO UPDATE SET …``: a row stored, or
    the one with the same ``keys`` replaced (the dialect both backends share; no ``INSERT OR REPLACE``)."""
    head = f"INSERT INTO {table} ({', '.join(columns)}) VALUES ({', '.join('?' * len(columns))})"
    updates = [f"{c} = excluded.{c}" for c in columns if c not in keys]
    if not updates:
        return f"{head} ON CONFLICT DO NOTHING"
    return f"{head} ON CONFLICT ({', '.join(keys)}) DO UPDATE SET {', '.join(updates)}"


#: a ``meta`` row (key, value) stored or replaced
PUT_META = upsert("meta", ("key", "value"), ("key",))
