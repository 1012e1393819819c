"""What colleagues changed in a shared survey since a window last looked, free of Qt and of threads.

A window keeps the stored objects it shows, each at the version it read (its ``modified`` stamp). Other
annotators — other windows, other processes, on the same SQLite file or the same PostgreSQL survey — add,
change and delete objects meanwhile. The survey's append-only history says what happened, in order
(:meth:`~usvips.store.interface.ProjectStore.changes_since` after a history id, the cursor). This module
turns those history rows into per-object events a window can apply:

- :func:`read_changes` (on the feed's own store handle, in a background thread): the history rows after a
  cursor and the version each of their objects is stored at now (absent: deleted) — a :class:`ChangeBatch`;
- :func:`fold` (on the window's side): the batch against the versions the window holds, one
  :class:`ColleagueChange` per object whose stored version differs from the window's: ``added`` (stored,
  not shown), ``changed`` (shown at another version), ``deleted`` (shown, no longer stored), each with who
  made the latest change and when.

The window's own writes need no bookkeeping by annotator name (two windows may run under one name): a
write of this window already brought its cache to the stored version, so :func:`fold` finds nothing new
for it. Reading the versions after the rows makes a batch safe to apply twice or late: what is compared is
always the stored state, never the rows alone.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass

from usvips.app.history_text import moment_text
from usvips.store.interface import ProjectStore
from usvips.store.records import HistoryEntry

#: what happened to an object, as a window shows it
WHATS = ("added", "changed", "deleted")

#: history rows read per query (a large import is read in several)
PAGE = 10_000


@dataclass(frozen=True)
class ChangeBatch:
    """What the feed read after a cursor: the history rows (oldest first), the version each of their
    objects is stored at now (object id → ``modified``; an id absent is no longer stored) and the newest
    history id read (the next cursor; the cursor given when there were no rows)."""

    entries: tuple[HistoryEntry, ...]
    versions: Mapping[int, str]
    last: int

    @property
    def object_ids(self) -> tuple[int, ...]:
        """The ids of the objects the rows concern, in the order first changed."""
        return tuple(dict.fromkeys(e.object_id for e in self.entries))


@dataclass(frozen=True)
class ColleagueChange:
    """An object someone else added, changed or deleted (``what``, one of :data:`WHATS`): who made the
    latest change (``annotator``), when (``at``, ISO 8601 UTC text) and the kinds of change folded in
    (``changes``: the history's words — "edit", "review", "re-pick" …, each once, in order)."""

    object_id: int
    what: str
    annotator: str
    at: str
    changes: tuple[str, ...] = ()

    @property
    def who(self) -> str:
        """The annotator's name, or "someone" when the history has none."""
        return self.annotator or "someone"

    def text(self) -> str:
        """``changed by bob at 12:41`` (local time)."""
        return f"{self.what} by {self.who} at {clock_text(self.at)}"

    def sentence(self) -> str:
        """``bob changed object 7 at 12:41 (edit, review)``: one line for a log or a status bar."""
        kinds = f" ({', '.join(self.changes)})" if self.changes and self.what == "changed" else ""
        return f"{self.who} {self.what} object {self.object_id} at {clock_text(self.at)}{kinds}"


def clock_text(at: str) -> str:
    """An ISO 8601 time as the hour and minute of this computer's clock (``12:41``); text that is not such
    a time is given back as it is."""
    return moment_text(at, "%H:%M")


def read_changes(store: ProjectStore, after: int, page: int = PAGE) -> ChangeBatch:
    """The history rows of ``store`` after history id ``after`` and the versions their objects are stored
    at now (read after the rows: a change committed in between is seen in the versions, and its rows come
    in the next batch, where they find nothing new). Reads only."""
    entries: list[HistoryEntry] = []
    cursor = int(after)
    while True:
        rows = store.changes_since(cursor, page)
        entries.extend(rows)
        if rows:
            cursor = max(cursor, max(row.id for row in rows))
        if len(rows) < page:
            break
    ids = list(dict.fromkeys(e.object_id for e in entries))
    versions = {o.id: o.modified for o in store.objects_with_ids(ids)} if ids else {}
    return ChangeBatch(tuple(entries), versions, cursor)


def fold(batch: ChangeBatch, known: Mapping[int, str]) -> list[ColleagueChange]:
    """The objects of ``batch`` whose stored state differs from what the window holds (``known``: object
    id → the version it shows), by id order: added, changed or deleted, each with the latest change's
    annotator and time. Objects the window holds at the stored version (its own writes, or a batch seen
    before) and objects added and deleted before the window saw them give nothing."""
    latest: dict[int, HistoryEntry] = {}
    kinds: dict[int, list[str]] = {}
    for entry in batch.entries:
        latest[entry.object_id] = entry
        seen = kinds.setdefault(entry.object_id, [])
        if entry.change not in seen:
            seen.append(entry.change)
    found = []
    for object_id in sorted(latest):
        stored, shown = batch.versions.get(object_id), known.get(object_id)
        if stored is not None and shown is None:
            what = "added"
        elif stored is not None and stored != shown:
            what = "changed"
        elif stored is None and shown is not None:
            what = "deleted"
        else:
            continue
        entry = latest[object_id]
        found.append(ColleagueChange(object_id, what, entry.annotator, entry.at, tuple(kinds[object_id])))
    return found


def summary(changes: Iterable[ColleagueChange]) -> str:
    """One line over a batch's changes: ``bob: 2 objects added, 1 changed; carl: 1 deleted`` (by annotator,
    in the order they appear); '' when there are none."""
    by_whom: dict[str, dict[str, int]] = {}
    for change in changes:
        counts = by_whom.setdefault(change.who, {})
        counts[change.what] = counts.get(change.what, 0) + 1
    parts = []
    for who, counts in by_whom.items():
        words = [f"{n} {what}" for what in WHATS if (n := counts.get(what))]
        first = words[0].split(" ", 1)
        words[0] = f"{first[0]} object{'s' if first[0] != '1' else ''} {first[1]}"
        parts.append(f"{who}: {', '.join(words)}")
    return "; ".join(parts)
