"""One writer of the kill soak (``test_kill_soak.py``), run as its own process: it adds, edits and deletes
its own fish in a survey until it is killed, and keeps a journal of what it did.

Each operation is journalled twice, flushed and synced to disk: ``intend <op> ...`` before the write and
``done <op> ...`` after the store returned. A write whose ``done`` line is in the journal was committed; a
write with only its ``intend`` line may or may not have been (the process or the server died between the
two). A restarted writer reads its journal to know its fish again.

Usage: ``python soak_writer.py LOCATION JOURNAL NAME SEED``
"""

from __future__ import annotations

import os
import random
import sys
import time
from pathlib import Path

from usvips.store.opening import open_project
from usvips.store.records import ProjectError, ServerUnreachableError, Vertex


def _fish(k: int) -> list[Vertex]:
    """Two vertices (snout and fork), pixels and metres, different for every k."""
    x = float(k % 500)
    return [Vertex(10.0 + x, 20.0, 8.0 + x, 20.0, (0.01 * x, 0.0, 2.0)),
            Vertex(40.0 + x, 20.0, 38.0 + x, 20.0, (0.01 * x + 0.3, 0.0, 2.0))]


class Journal:
    """The writer's journal: appended line by line, each synced before the writer goes on."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.handle = open(path, "a", encoding="utf-8")  # noqa: SIM115 - open for the process's life

    def write(self, line: str) -> None:
        self.handle.write(line + "\n")
        self.handle.flush()
        os.fsync(self.handle.fileno())


def my_fish(path: Path) -> set[int]:
    """The ids of this writer's fish that it surely added and did not surely delete (from its journal)."""
    alive: set[int] = set()
    if path.exists():
        for line in path.read_text(encoding="utf-8").splitlines():
            words = line.split()
            if words[:2] == ["done", "add"]:
                alive.add(int(words[2]))
            elif words[:2] == ["done", "delete"]:
                alive.discard(int(words[2]))
            elif words[0] == "gone":
                alive.discard(int(words[1]))
    return alive


def _open(location: str):
    """The survey, opened again and again while the server is down (bounded: the test kills us anyway)."""
    for _ in range(600):
        try:
            return open_project(location)
        except ProjectError:
            time.sleep(0.1)
    raise SystemExit("the survey could not be opened for a minute")


def main(location: str, journal_path: str, name: str, seed: int) -> None:
    journal = Journal(Path(journal_path))
    alive = my_fish(journal.path)
    rng = random.Random(seed)
    store = _open(location)
    store.annotator = name
    counter = 0
    while True:
        counter += 1
        choice = rng.random()
        try:
            if not alive or choice < 0.5:
                journal.write(f"intend add {counter}")
                object_id = store.add_object("length", _fish(counter + 1000 * seed), name)
                journal.write(f"done add {object_id}")
                alive.add(object_id)
            elif choice < 0.85:
                object_id = rng.choice(sorted(alive))
                read = store.object(object_id)
                notes = f"{name}-{counter}"
                journal.write(f"intend edit {object_id} {notes}")
                store.update_object(object_id, notes=notes, expected_modified=read.modified)
                journal.write(f"done edit {object_id} {notes}")
            else:
                object_id = rng.choice(sorted(alive))
                read = store.object(object_id)
                journal.write(f"intend delete {object_id}")
                store.delete_object(object_id, expected_modified=read.modified)
                journal.write(f"done delete {object_id}")
                alive.discard(object_id)
        except ServerUnreachableError:  # the server is down: the store connects again on the next use
            journal.write("refused unreachable")
            time.sleep(0.05)
        except ProjectError:  # a delete of an earlier life committed before its 'done' line: the fish is gone
            if choice >= 0.5 and alive and object_id in alive and not _exists(store, object_id):
                journal.write(f"gone {object_id}")
                alive.discard(object_id)
            else:
                raise


def _exists(store, object_id: int) -> bool:
    return bool(store.objects_with_ids([object_id]))


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2], sys.argv[3], int(sys.argv[4]))
