"""The project database: round trips, migration, crash safety, bad files."""

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
    assert project.pairs()[0] == {"id": 1, "label": "w1", "left": "left.png", "right": "left.png", "width": 1280,
                                  "height": 960, "frame": 12, "medium": "water"}
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
