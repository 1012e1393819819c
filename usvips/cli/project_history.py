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
    from usvips.store.location import shown  # at run time: the parser stays light
    from usvips.store.opening import open_project

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
    from usvips.app.history_text import what_changed  # at run time: the parser stays light

    return (f"{entry.id:>6}  {entry.at}  {entry.annotator}  object {entry.object_id}  {entry.change}: "
            f"{what_changed(entry)}")
