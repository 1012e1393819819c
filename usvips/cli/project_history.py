"""``usvips project history PROJECT [--object ID] [--json]``: the append-only history of a project's
objects (every add, edit, re-pick, delete, put back, observation record set and review), oldest first, one
line per change; ``--json`` prints every entry whole (old and new values) as a JSON list. Works on a
project file or a survey on a server (any location ``usvips.store.opening.open_project`` takes), read-only."""

from __future__ import annotations

import argparse
import dataclasses
import json
from typing import TYPE_CHECKING

from usvips.core.errors import InvalidParameterError

if TYPE_CHECKING:
    from usvips.store.records import HistoryEntry


def register_history_action(actions: argparse._SubParsersAction) -> None:
    history = actions.add_parser("history", help="list every change to the project's objects (who, when, what), "
                                 "oldest first")
    history.add_argument("project", help="the project file, or postgresql://USER@HOST[:PORT]/DATABASE")
    history.add_argument("--object", type=int, metavar="ID", help="only the changes of this object (also after "
                         "it was deleted)")
    history.add_argument("--json", action="store_true", help="every entry whole (old and new values) as JSON")
    history.set_defaults(handler=run_history)


def run_history(args: argparse.Namespace) -> int:
    if args.object is not None and args.object < 1:
        raise InvalidParameterError("--object", f"an object id is a whole number ≥ 1, got {args.object}")
    from usvips.store.opening import open_project, shown  # at run time: the parser stays light

    with open_project(args.project, read_only=True) as project:
        entries = project.history(args.object)
    if args.json:
        print(json.dumps([dataclasses.asdict(e) for e in entries], ensure_ascii=False, indent=1))
        return 0
    if not entries:
        what = f"object {args.object}" if args.object is not None else "its objects"
        print(f"{shown(args.project)}: no recorded change of {what}")
        return 0
    for entry in entries:
        print(history_line(entry))
    return 0


def history_line(entry: HistoryEntry) -> str:
    """One change on one line: number, time, annotator, object, change and what changed."""
    return f"{entry.id:>6}  {entry.at}  {entry.annotator}  object {entry.object_id}  {entry.change}: {_what(entry)}"


def _short(value: object) -> str:
    text = json.dumps(value, ensure_ascii=False) if not isinstance(value, str) else repr(value)
    return text if len(text) <= 60 else text[:57] + "…"


def _summary(state: dict | None) -> str:
    if not state:
        return "nothing"
    vertices = state.get("vertices", [])
    text = f"{state.get('kind', '?')} {state.get('attribute', '')!r}, {len(vertices)} vertices"
    record = state.get("record")
    return text + (f", record {_record(record)}" if record else "")


def _record(record: dict | None) -> str:
    if not record:
        return "none"
    taxon = " ".join(record.get(k, "") for k in ("family", "genus", "species") if record.get(k)) or "unidentified"
    return f"{taxon} ×{record.get('number', 1)}"


def _what(entry: HistoryEntry) -> str:
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
        if name == "vertices":
            before, after = old.get(name, []), new.get(name, [])
            moved = sum(1 for a, b in zip(before, after, strict=False) if a != b) + abs(len(after) - len(before))
            parts.append(f"vertices {len(before)} → {len(after)} ({moved} changed)")
        else:
            parts.append(f"{name} {_short(old.get(name))} → {_short(new.get(name))}")
    return "; ".join(parts) or "no field given"
