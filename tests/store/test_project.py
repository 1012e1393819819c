"""The project database: round trips, migration, crash safety, bad files."""

import dataclasses
import os
import shutil
import sqlite3
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from usvips.core.observations import ControlPoints, StereoObservations
from usvips.store import SCHEMA_VERSION, Project, ProjectError
from usvips.store.project import Vertex
from usvips.store.records import Pair

DATA = Path(__file__).parent / "data"
ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture()
def project(tmp_path):
    with Project.create(tmp_path / "p.usvips") as p:
        yield p


def test_every_table_round_trips(project, tmp_path):
    image = tmp_path / "left.png"
    image.write_bytes(b"\x89PNG fake")
    project.add_pair("w1", image, image, medium="water", frame=12, size=(1280, 960))
    assert project.pairs()[0] == Pair(1, "w1", "left.png", "left.png", 1280, 960, 12, "water")
    control = ControlPoints(("1", "T2"), np.array([[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]]), np.full((2, 3), 0.001))
    project.set_control(control)
    again = project.control()
    assert again.ids == control.ids and np.allclose(again.xyz, control.xyz) and np.allclose(again.sigmas, 0.001)
    obs = StereoObservations(("1", "T2"), np.array([[1.5, 2.5], [3, 4]]), np.array([[5, 6], [7, 8.25]]))
    project.add_control_observations(obs, "calibration-water", "w1")
    stored = project.control_observations("calibration-water", "w1")
    assert stored.ids == obs.ids and np.allclose(stored.right, obs.right)
    cal = project.add_calibration("water", {"format": "usvips-calibration", "sigma0_px": 0.4}, active_for=("w1",))
    assert project.active_calibration("w1") == cal and project.calibration(cal)["sigma0_px"] == 0.4
    cov = np.diag([1e-6, 2e-6, 5e-6])
    vertices = [Vertex(10, 20, 5, 21, (0.1, 0.2, -2.0), cov, cal, "w1"),
                Vertex(30, 40, 25, 41, (0.5, 0.2, -2.1), cov, cal)]
    oid = project.add_object("line", vertices, attribute="cod", notes="snout to fork", creator="me")
    obj = project.object(oid)
    assert obj.kind == "length" and obj.attribute == "cod" and obj.vertices[0].pair == "w1"
    assert np.allclose(obj.vertices[1].covariance, cov) and obj.vertices[1].xyz == (0.5, 0.2, -2.1)
    project.add_term("cod")
    project.add_term("haddock")
    assert project.vocabulary() == ["cod", "haddock"]
    project.set_enhancement("w1/left", '[{"op": "gamma", "gamma": 0.8}]')
    assert project.enhancement("w1/left") == '[{"op": "gamma", "gamma": 0.8}]'
    moved = [Vertex(10, 20, 5, 21, (0.11, 0.2, -2.0), cov, cal), Vertex(30, 40, 25, 41, (0.51, 0.2, -2.1), cov, cal)]
    project.update_object(oid, notes="recomputed", vertices=moved)
    assert project.object(oid).vertices[0].xyz == (0.11, 0.2, -2.0)
    assert [h[1] for h in project.vertex_history(oid)] == [0.1, 0.5]  # the old values are kept
    project.delete_object(oid)
    assert project.objects() == []
    with pytest.raises(ProjectError, match="no object"):
        project.object(oid)


def test_reopening_keeps_everything(tmp_path):
    with Project.create(tmp_path / "p.usvips") as p:
        p.add_pair("a")
        p.add_object("point", [Vertex(1, 2, 3, 4)], attribute="rock")
    with Project.open(tmp_path / "p.usvips") as p:
        assert p.version == SCHEMA_VERSION and p.objects()[0].attribute == "rock"


def test_a_version_1_project_is_migrated(tmp_path):
    copy = tmp_path / "old.usvips"
    shutil.copy(DATA / "project_v1.usvips", copy)
    with Project.open(copy) as p:
        assert p.version == SCHEMA_VERSION
        fish = p.objects()[0]
        assert fish.attribute == "cod" and len(fish.vertices) == 2 and fish.vertices[1].xyz == (0.4, 0.2, -2.1)
        # schema 11: a vertex stored before pointing sources were is a hand click of unknown source, default sigma
        assert {(v.source, v.pointing_px, v.pointing_origin, v.weak) for v in fish.vertices} == {
            ("hand click (unknown)", None, "default", None)}
        p.update_object(fish.id, vertices=[Vertex(1, 2, 3, 4, (0, 0, -2))] * 2)   # version-2 history works
        assert len(p.vertex_history(fish.id)) == 2


def test_a_writer_killed_mid_transaction_loses_only_that_edit(tmp_path):
    path = tmp_path / "p.usvips"
    with Project.create(path) as p:
        p.add_object("point", [Vertex(1, 2, 3, 4)], attribute="committed")
    script = f"""
import os, sqlite3
from usvips.store import Project
from usvips.store.project import Vertex
p = Project.open({str(path)!r})
p._db.execute("BEGIN")
p._db.execute("INSERT INTO objects (kind, attribute, created, modified) VALUES ('point', 'lost', 'x', 'x')")
os._exit(1)
"""
    result = subprocess.run([sys.executable, "-c", script], cwd=ROOT)
    assert result.returncode == 1
    with Project.open(path) as p:
        assert [o.attribute for o in p.objects()] == ["committed"]


def test_bad_files_are_refused_clearly(tmp_path):
    junk = tmp_path / "junk.usvips"
    junk.write_bytes(b"hello, not a database")
    with pytest.raises(ProjectError, match="not a USVIPS project"):
        Project.open(junk)
    other = tmp_path / "other.usvips"
    sqlite3.connect(str(other)).execute("CREATE TABLE t (a)").connection.close()
    with pytest.raises(ProjectError, match="SQLite database of something else"):
        Project.open(other)
    newer = tmp_path / "newer.usvips"
    Project.create(newer).close()
    c = sqlite3.connect(str(newer))
    c.execute(f"PRAGMA user_version = {SCHEMA_VERSION + 1}")
    c.close()
    with pytest.raises(ProjectError, match="newer USVIPS"):
        Project.open(newer)
    with pytest.raises(ProjectError, match="no such project file"):
        Project.open(tmp_path / "missing.usvips")
    with Project.create(tmp_path / "p.usvips") as p:
        with pytest.raises(ProjectError, match="does not exist"):
            p.add_pair("x", tmp_path / "nope.png")
        with pytest.raises(ProjectError, match="both picks"):
            p.add_object("point", [Vertex(1, 2, float("nan"), 4)])
        assert p.objects() == [] and p.pairs() == []     # nothing written


def test_a_locked_project_is_reported_and_nothing_is_lost(tmp_path):
    path = tmp_path / "p.usvips"
    with Project.create(path) as p:
        p.add_term("kept")
    holder = sqlite3.connect(str(path), isolation_level=None, timeout=0.1)
    holder.execute("BEGIN EXCLUSIVE")          # another program holds the write lock
    try:
        with Project.open(path) as p, pytest.raises(ProjectError, match="locked|cannot write"):
            p.add_term("new")
    finally:
        holder.execute("ROLLBACK")
        holder.close()
    with Project.open(path) as p:
        assert p.vocabulary() == ["kept"]


# ------------------------------------------------------------------------------------------ hardening
def _digest(path: Path) -> bytes:
    return path.read_bytes()


def test_another_programs_database_is_refused_without_a_single_byte_changed(tmp_path):
    other = tmp_path / "other.db"
    connection = sqlite3.connect(str(other))
    connection.execute("CREATE TABLE t (a)")
    connection.commit()
    connection.close()
    before = _digest(other)
    for read_only in (False, True):
        with pytest.raises(ProjectError, match="something else"):
            Project.open(other, read_only=read_only)
    assert _digest(other) == before and sorted(p.name for p in tmp_path.iterdir()) == ["other.db"]


def test_a_read_only_open_never_migrates_nor_writes(tmp_path):
    copy = tmp_path / "old.usvips"
    shutil.copy(DATA / "project_v1.usvips", copy)
    before = _digest(copy)
    with Project.open(copy, read_only=True) as p:
        assert p.version == 1 and p.objects()[0].attribute == "cod"
        with pytest.raises(ProjectError, match="read-only"):
            p.add_term("x")
    assert _digest(copy) == before and sorted(q.name for q in tmp_path.iterdir()) == ["old.usvips"]


def test_migration_copies_the_old_file_aside_first(tmp_path):
    copy = tmp_path / "old.usvips"
    shutil.copy(DATA / "project_v1.usvips", copy)
    before = _digest(copy)
    with Project.open(copy) as p:
        assert p.version == SCHEMA_VERSION
    backup = tmp_path / "old.usvips.schema1.bak"
    assert backup.is_file()
    with Project.open(backup, read_only=True) as old:   # the copy is the old project, readable as it was
        assert old.version == 1 and [o.attribute for o in old.objects()] == ["cod"]
    assert before[:16] == _digest(backup)[:16]


def test_a_failed_migration_leaves_the_original_intact(tmp_path, monkeypatch):
    from usvips.store import schema

    copy = tmp_path / "old.usvips"
    shutil.copy(DATA / "project_v1.usvips", copy)
    broken = dict(schema.MIGRATIONS)
    last = schema.MIGRATIONS[SCHEMA_VERSION]
    broken[SCHEMA_VERSION] = dataclasses.replace(last, shared=last.shared + "CREATE TABLE objects (a);")  # fails last
    monkeypatch.setattr(schema, "MIGRATIONS", broken)
    with pytest.raises(ProjectError, match="cannot upgrade.*nothing was changed"):
        Project.open(copy)
    monkeypatch.undo()
    with Project.open(copy, read_only=True) as p:
        assert p.version == 1 and len(p.objects()) == 1
        with pytest.raises(ProjectError):
            p.vertex_history(1)                # the version-2 table was rolled back with the rest


def test_create_leaves_nothing_behind_on_failure(tmp_path, monkeypatch):
    from usvips.store import project as module

    def full(*_):
        raise sqlite3.OperationalError("database or disk is full")

    monkeypatch.setattr(module, "migrate", full)
    with pytest.raises(ProjectError, match="disk is full"):
        Project.create(tmp_path / "p.usvips")
    assert list(tmp_path.iterdir()) == []
    monkeypatch.undo()
    Project.create(tmp_path / "p.usvips").close()          # and it can be created afterwards


def test_a_dangling_symlink_is_not_followed(tmp_path):
    link = tmp_path / "p.usvips"
    link.symlink_to(tmp_path / "elsewhere.usvips")
    with pytest.raises(ProjectError, match="already exists"):
        Project.create(link)
    with pytest.raises(ProjectError, match="symbolic link"):
        Project.open(link)
    assert not (tmp_path / "elsewhere.usvips").exists()


def test_a_transaction_is_all_or_nothing(project):
    project.add_term("kept")
    with pytest.raises(ProjectError, match="no image pair"):
        with project.transaction():
            project.set_control(ControlPoints(("1",), np.zeros((1, 3))))
            project.add_term("lost")
            project.add_control_observations(StereoObservations(("1",), np.zeros((1, 2)), np.zeros((1, 2))),
                                             "check", "no-such-pair")
    assert project.vocabulary() == ["kept"] and len(project.control()) == 0


def test_damaged_files_and_stored_json_are_one_line_errors(tmp_path):
    path = tmp_path / "p.usvips"
    with Project.create(path) as p:
        for i in range(200):
            p.add_term(f"term{i:03d}")
        calibration = p.add_calibration("c", {"sigma0_px": 0.5})
        oid = p.add_object("point", [Vertex(1, 2, 3, 4, (0, 0, -1), np.eye(3))])
        p._db.execute("UPDATE calibrations SET json = '{not json' WHERE id = ?", (calibration,))
        p._db.execute("UPDATE vertices SET covariance = '[1, 2' WHERE object_id = ?", (oid,))
        with pytest.raises(ProjectError, match="calibration 1 is damaged"):
            p.calibration(calibration)
        with pytest.raises(ProjectError, match="covariance is damaged"):
            p.objects()
    data = bytearray(path.read_bytes())
    data[4096:len(data)] = b"\x5a" * (len(data) - 4096)        # every page after the first overwritten
    path.write_bytes(bytes(data))
    with pytest.raises(ProjectError) as caught:
        with Project.open(path, read_only=True) as p:
            p.vocabulary()
    assert str(caught.value).startswith(str(path)) and "\n" not in str(caught.value)


def test_a_read_only_file_is_refused_for_writing_but_opens_read_only(tmp_path, monkeypatch):
    path = tmp_path / "p.usvips"
    with Project.create(path) as p:
        p.add_term("kept")
    before = _digest(path)
    real = os.access
    # the file is read-only for this user (simulated: the tests may run as root, whom chmod does not stop)
    monkeypatch.setattr(os, "access", lambda f, mode: False if mode & os.W_OK and Path(f) == path else real(f, mode))
    with pytest.raises(ProjectError, match="read-only"):
        Project.open(path)
    with Project.open(path, read_only=True) as p:
        assert p.vocabulary() == ["kept"]
    assert _digest(path) == before


def test_a_write_while_locked_says_so_and_keeps_the_project(tmp_path):
    path = tmp_path / "p.usvips"
    with Project.create(path) as p:
        p.add_object("point", [Vertex(1, 2, 3, 4)], attribute="kept")
    holder = sqlite3.connect(str(path), isolation_level=None, timeout=0.1)
    holder.execute("BEGIN EXCLUSIVE")
    try:
        with Project.open(path) as p:
            for edit in (lambda: p.add_object("point", [Vertex(1, 2, 3, 4)]),
                         lambda: p.update_object(1, attribute="changed"),
                         lambda: p.set_control(ControlPoints(("1",), np.zeros((1, 3))))):
                with pytest.raises(ProjectError, match="locked by another program"):
                    edit()
    finally:
        holder.execute("ROLLBACK")
        holder.close()
    with Project.open(path) as p:
        assert [o.attribute for o in p.objects()] == ["kept"]


def test_listing_objects_while_another_process_deletes_them_is_consistent(tmp_path):
    """A deleting process runs while this one lists: every listing is a consistent snapshot (objects
    complete with their vertices), never a misleading 'no object N'."""
    path = tmp_path / "p.usvips"
    with Project.create(path) as p, p.transaction():
        for i in range(300):
            p.add_object("line", [Vertex(i, 2, 3, 4), Vertex(5, 6, 7, 8)], attribute=f"o{i}")
    script = f"""
from usvips.store import Project
with Project.open({str(path)!r}) as p:
    for i in range(1, 301):
        p.delete_object(i)
"""
    deleter = subprocess.Popen([sys.executable, "-c", script], cwd=ROOT)
    counts = []
    try:
        with Project.open(path, read_only=True) as p:
            while deleter.poll() is None:
                listing = p.objects()
                assert all(len(o.vertices) == 2 for o in listing)
                counts.append(len(listing))
    finally:
        deleter.wait()
    assert deleter.returncode == 0
    assert counts == sorted(counts, reverse=True)          # snapshots only ever shrink


def test_a_full_disk_is_one_line_and_nothing_half_written(project):
    project.add_object("point", [Vertex(1, 2, 3, 4)], attribute="kept")
    pages = project._db.execute("PRAGMA page_count").fetchone()[0]
    project._db.execute(f"PRAGMA max_page_count = {pages}")     # the file cannot grow: as on a full disk
    big = "x" * 200_000
    for edit in (lambda: project.add_object("line", [Vertex(1, 2, 3, 4)] * 2, attribute=big),
                 lambda: project.update_object(1, notes=big),
                 lambda: project.set_control(ControlPoints(tuple(f"{big[:50]}{i}" for i in range(3000)),
                                                           np.zeros((3000, 3))))):
        with pytest.raises(ProjectError, match="the disk is full.*nothing was changed"):
            edit()
    assert [(o.attribute, o.notes) for o in project.objects()] == [("kept", "")] and len(project.control()) == 0


def _wal_header_then_garbage(rng) -> bytes:
    """An SQLite header that says WAL mode (file format 2), then random pages: SQLite opens it and makes
    its -wal and -shm before finding the damage."""
    header = bytearray(b"SQLite format 3\x00" + bytes(84))
    header[16:18] = (4096).to_bytes(2, "big")
    header[18] = header[19] = 2
    header[21:24] = bytes((64, 32, 32))
    return bytes(header) + rng.bytes(3 * 4096 - len(header))


@pytest.mark.parametrize("read_only", [True, False])
def test_a_refused_file_is_left_alone_with_nothing_written_beside_it(tmp_path, read_only):
    """Opening a file that is no USVIPS project — garbage behind a WAL-mode SQLite header, an SQLite database
    of something else in WAL mode — is refused in one line, and nothing is written next to it (its -wal and
    -shm, made by SQLite on the way, are gone again); a folder's other files and a refused file's own
    existing -wal are left as they were."""
    rng = np.random.default_rng(5)
    folder = tmp_path / "folder"
    folder.mkdir()
    (folder / "garbage.usvips").write_bytes(_wal_header_then_garbage(rng))
    other = sqlite3.connect(folder / "other.usvips")
    other.execute("PRAGMA journal_mode = WAL")
    other.execute("CREATE TABLE fish (name TEXT)")
    other.close()
    (folder / "kept.usvips-wal").write_bytes(b"")  # someone else's, beside a file that is refused below
    (folder / "kept.usvips").write_bytes(_wal_header_then_garbage(rng))
    before = {p.name: p.read_bytes() for p in folder.iterdir()}
    for name, reason in (("garbage.usvips", "damaged"), ("other.usvips", "an SQLite database of something else"),
                         ("kept.usvips", "damaged")):
        with pytest.raises(ProjectError, match=reason) as refused:
            Project.open(folder / name, read_only=read_only)
        assert "\n" not in str(refused.value) and name in str(refused.value)
        assert {p.name: p.read_bytes() for p in folder.iterdir()} == before  # nothing added, nothing changed


@pytest.mark.parametrize("left_behind", ["-wal", "-journal"])
def test_a_journal_left_by_a_deleted_project_is_named_not_replayed_into_a_new_one(tmp_path, left_behind):
    """SQLite replays a -wal (or rolls back a hot -journal) it finds beside a database without asking whose
    it is: a project deleted without its journal would come back into a new project of the same name."""
    path = tmp_path / "p.usvips"
    project = Project.create(path)
    project.add_term("from the deleted project")
    journal = Path(f"{path}{left_behind}")
    if left_behind == "-wal":
        assert journal.exists() and journal.stat().st_size > 0  # the write is still in the -wal
        kept = journal.read_bytes()
    else:
        kept = b"\xd9\xd5\x05\xf9\x20\xa1\x63\xd7" + bytes(504)  # a rollback journal's header
    project.close()
    for suffix in ("", "-wal", "-shm", "-journal"):
        Path(f"{path}{suffix}").unlink(missing_ok=True)
    journal.write_bytes(kept)
    with pytest.raises(ProjectError) as refused:
        Project.create(path)
    message = str(refused.value)
    assert str(journal) in message and "\n" not in message
    assert not path.exists() and journal.read_bytes() == kept  # nothing made, the journal left for its owner
    journal.unlink()
    fresh = Project.create(path)
    assert "from the deleted project" not in fresh.vocabulary()
    fresh.close()


def test_a_text_damaged_into_bytes_that_are_not_utf8_is_named_as_damage(tmp_path):
    """A few bytes changed inside a text column: reading it says the file is damaged and to restore a
    backup, naming the column, not SQLite's raw "Could not decode to UTF-8" with the bytes."""
    import sqlite3

    from usvips.store.records import Vertex

    path = tmp_path / "p.usvips"
    with Project.create(path) as project:
        project.annotator = "anne"
        project.add_object("point", [Vertex(1.0, 2.0, 3.0, 4.0)], "cod")
    connection = sqlite3.connect(path)
    with connection:
        connection.execute("UPDATE objects SET creator = CAST(X'fffe65' AS TEXT)")
    connection.close()
    with Project.open(path, read_only=True) as project:
        with pytest.raises(ProjectError, match=r"the file is damaged \(a text in column 'creator' is not UTF-8\); "
                                               "restore it from a backup$"):
            project.objects()
