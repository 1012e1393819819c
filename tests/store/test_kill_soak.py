"""The kill soak of issue 34's acceptance: three writers add, edit and delete fish in one survey for over a
minute while the test kills writers — and, on a server, the server itself — with SIGKILL at random moments
(seeded) and starts them again. Afterwards, from each writer's journal (``soak_writer.py``):

* every write the writer saw committed is in the survey (every fish added and not deleted is there with
  the notes of its last edit; every fish deleted is gone); a write in doubt (the writer or the server died
  between the write and its journal line) is either wholly there or wholly absent;
* no partial object: every fish has both its vertices;
* the history is complete and append-only: an 'add' row for every fish ever added, an 'edit' row for every
  committed edit, a 'delete' row for every delete, ids strictly increasing, and no history row refers to
  a write that never happened.

On a SQLite file the writers are killed (a file has no server to kill).
"""

from __future__ import annotations

import os
import random
import shutil
import subprocess
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path

import pytest

from tests.store.conftest import database_url
from tests.store.test_server_failure import Killable
from usvips.store.opening import create_project, open_project

WRITER = Path(__file__).with_name("soak_writer.py")
ROOT = Path(__file__).resolve().parents[2]


def _start_writer(location: str, journal: Path, name: str, seed: int) -> subprocess.Popen:
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")])))
    return subprocess.Popen([sys.executable, str(WRITER), location, str(journal), name, str(seed)], env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)


def _kill(process: subprocess.Popen) -> None:
    process.kill()
    process.wait()


def _soak(location: str, folder: Path, seconds: float, seed: int, server: Killable | None = None) -> dict:
    """Run three writers for ``seconds`` while killing them (and the server) at random; the journals."""
    rng = random.Random(seed)
    names = ("ann", "bob", "cyd")
    journals = {name: folder / f"{name}.journal" for name in names}
    lives = dict.fromkeys(names, 0)
    writers = {name: _start_writer(location, journals[name], name, 100 * k) for k, name in enumerate(names)}
    kills = Counter()
    end = time.monotonic() + seconds
    try:
        while time.monotonic() < end:
            time.sleep(rng.uniform(0.5, 3.0))
            for name, process in writers.items():  # a writer that died by itself is a failure, not a kill
                if process.poll() is not None:
                    raise AssertionError(f"writer {name} stopped by itself: {process.stderr.read().decode()[-2000:]}")
            if server is not None and rng.random() < 0.25:
                server.kill()
                kills["server"] += 1
                time.sleep(rng.uniform(0.2, 1.5))
                server.start()
            else:
                name = rng.choice(names)
                _kill(writers[name])
                kills[name] += 1
                lives[name] += 1
                writers[name] = _start_writer(location, journals[name], name, 100 * names.index(name) + lives[name])
    finally:
        for process in writers.values():
            _kill(process)
    assert sum(kills.values()) >= 10, kills
    if server is not None:
        assert kills["server"] >= 2, kills
    return {name: journals[name].read_text(encoding="utf-8").splitlines() for name in names}


def _check(location: str, journals: dict[str, list[str]]) -> None:
    store = open_project(location, read_only=True)
    try:
        objects = {o.id: o for o in store.objects()}
        history = store.history()
    finally:
        store.close()
    ids = [entry.id for entry in history]
    assert ids == sorted(ids) and len(set(ids)) == len(ids), "history ids are not strictly increasing"
    rows = Counter((entry.object_id, entry.change) for entry in history)
    assert all(len(o.vertices) == 2 for o in objects.values()), "a partial object"
    added_by: dict[str, set[int]] = {}
    committed_ops = 0
    for name, lines in journals.items():
        alive: dict[int, set[str]] = {}  # fish -> the notes it may have (more than one while in doubt)
        deleted: set[int] = set()
        doubtful_adds = 0
        doubtful_delete: set[int] = set()
        intended: list[str] | None = None
        for line in lines:
            words = line.split()
            if words[0] == "intend":
                if intended is not None and intended[1] == "add":
                    doubtful_adds += 1
                intended = words
            elif words[0] == "done":
                op, object_id = words[1], int(words[2])
                committed_ops += 1
                if op == "add":
                    alive[object_id] = {""}
                elif op == "edit":
                    alive[object_id] = {words[3]}
                elif op == "delete":
                    alive.pop(object_id, None)
                    deleted.add(object_id)
                intended = None
            elif words[0] == "refused":  # not stored, says the store; lost acknowledgements keep it in doubt
                if intended is not None and intended[1] == "add":
                    doubtful_adds += 1
                intended = None
            elif words[0] == "gone":
                object_id = int(words[1])
                alive.pop(object_id, None)
                doubtful_delete.add(object_id)
            if words[0] == "intend" and words[1] == "edit":
                alive.setdefault(int(words[2]), set()).add(words[3])  # in doubt until its 'done' line
            if words[0] == "intend" and words[1] == "delete":
                doubtful_delete.add(int(words[2]))
        if intended is not None and intended[1] == "add":
            doubtful_adds += 1
        for object_id, notes in alive.items():
            if object_id in doubtful_delete and object_id not in objects:
                continue  # deleted in doubt: gone, wholly
            assert object_id in objects, f"{name}'s committed fish {object_id} is lost"
            assert objects[object_id].notes in notes, (name, object_id, objects[object_id].notes, notes)
            assert rows[(object_id, "add")] == 1, f"fish {object_id} has no single 'add' history row"
        for object_id in deleted:
            assert object_id not in objects, f"{name}'s deleted fish {object_id} is back"
            assert rows[(object_id, "delete")] == 1
        mine = {o.id for o in objects.values() if o.attribute == name}
        known = set(alive) | deleted | doubtful_delete
        assert len(mine - known) <= doubtful_adds, f"{name} has fish nobody journalled"
        added_by[name] = mine
    assert committed_ops >= 30, "the soak hardly wrote anything"
    every_fish = {object_id for (object_id, change) in rows if change == "add"}
    assert set(objects) <= every_fish, "a fish with no 'add' row in the history"


@pytest.fixture
def soak_server():
    folder = Path(tempfile.mkdtemp(prefix="usvips-pgsoak-"))
    os.environ.setdefault("XDG_RUNTIME_DIR", str(folder))
    server = Killable(folder)
    try:
        yield server
    finally:
        server.server.cleanup()
        shutil.rmtree(folder, ignore_errors=True)


def test_three_writers_and_the_server_killed_at_random_for_a_minute_lose_nothing(soak_server, tmp_path):
    location = database_url(soak_server.url, "soak")
    create_project(location).close()
    journals = _soak(location, tmp_path, seconds=65.0, seed=34, server=soak_server)
    _check(location, journals)


def test_three_writers_killed_at_random_on_one_sqlite_file_lose_nothing(tmp_path):
    location = str(tmp_path / "soak.usvips")
    create_project(location).close()
    journals = _soak(location, tmp_path, seconds=25.0, seed=35)
    _check(location, journals)
