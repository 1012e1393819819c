"""A change of a project's history in words, for a person (the command line's ``usvips project history``
and the window's object history): what was added or deleted, which fields went from what to what, the
observation record or the review before and after."""

from __future__ import annotations

import json
from datetime import datetime

from usvips.core.redaction import redact
from usvips.store.records import HistoryEntry


def _short(value: object) -> str:
    """A value in at most 60 characters, never with a password (redacted before it is cut short, so that
    no part of one is left)."""
    text = redact(json.dumps(value, ensure_ascii=False) if not isinstance(value, str) else repr(value))
    return text if len(text) <= 60 else text[:57] + "…"


def _summary(state: dict | None) -> str:
    if not state:
        return "nothing"
    count = len(state.get("vertices", []))
    attribute = state.get("attribute", "")
    text = (f"{state.get('kind', '?')}" + (f" {attribute!r}" if attribute else "")
            + f", {count} {'vertex' if count == 1 else 'vertices'}")  # no empty '' nor "1 vertices"
    record = state.get("record")
    return text + (f", record {_record(record)}" if record else "")


def _record(record: dict | None) -> str:
    if not record:
        return "none"
    taxon = " ".join(record.get(k, "") for k in ("family", "genus", "species") if record.get(k)) or "unidentified"
    return f"{taxon} ×{record.get('number', 1)}"


def moment_text(at: str, pattern: str = "%Y-%m-%d %H:%M:%S") -> str:
    """A history row's time (ISO 8601, UTC, to the microsecond) as a person reads it: this computer's local
    date and time, by default to the second (``2026-11-28 14:34:01``; ``pattern`` as :meth:`~datetime.strftime`
    takes it); text that is not such a time is given back."""
    try:
        moment = datetime.fromisoformat(at)
    except (TypeError, ValueError):
        return str(at)
    if moment.tzinfo is not None:
        moment = moment.astimezone()
    return moment.strftime(pattern)


def what_changed(entry: HistoryEntry) -> str:
    """One line: what the change did (``old → new`` of each field it concerned)."""
    old, new = entry.old or {}, entry.new or {}
    if entry.change in ("add", "put back"):
        return _summary(entry.new)
    if entry.change == "delete":
        return _summary(entry.old)
    if entry.change == "record":
        return f"{_record(entry.old)} → {_record(entry.new)}"
    if entry.change == "review":
        reason = new.get("reason")
        return f"{old.get('state', '?')} → {new.get('state', '?')}" + (f" ({reason})" if reason else "")
    parts = []
    for name in sorted(set(old) | set(new)):
        if name in old and name in new and old[name] == new[name]:
            continue  # written but unchanged (an edit stores every field it concerned)
        if name == "vertices":
            before, after = old.get(name, []), new.get(name, [])
            moved = sum(1 for a, b in zip(before, after, strict=False) if a != b) + abs(len(after) - len(before))
            parts.append(f"vertices {len(before)} → {len(after)} ({moved} changed)")
        else:
            parts.append(f"{name} {_short(old.get(name))} → {_short(new.get(name))}")
    return "; ".join(parts) or ("no field changed" if old or new else "no field given")
