"""Schema 3: measurement kinds are the registry's (no CHECK), legacy lines become lengths and arcs, and
several objects are stored all or nothing."""

import sqlite3

import numpy as np
import pytest

from usvips.store import Project, ProjectError
from usvips.store.project import Vertex, migrate
from usvips.store.schema import MIGRATIONS


def _version_2_project(path):
    connection = sqlite3.connect(str(path), isolation_level=None)
    connection.execute("PRAGMA foreign_keys = ON")
    migrate(connection, 2)
    connection.execute("INSERT INTO meta VALUES ('format', 'usvips-project')")
    for oid, n in ((1, 2), (2, 4), (3, 1)):
        kind = "point" if n == 1 else "line"
        connection.execute("INSERT INTO objects (id, kind, created, modified) VALUES (?, ?, 't', 't')", (oid, kind))
        for i in range(n):
            connection.execute("INSERT INTO vertices (object_id, idx, xl, yl, xr, yr, x, y, z) "
                               "VALUES (?, ?, 1, 2, 3, 4, 0, 0, ?)", (oid, i, -2.0 - i))
    connection.execute("INSERT INTO vertex_history (object_id, idx, replaced) VALUES (2, 0, 't')")
    connection.close()


def test_schema_3_renames_lines_keeps_vertices_and_history_and_drops_the_check(tmp_path):
    path = tmp_path / "old.usvips"
    _version_2_project(path)
    with Project.open(path) as project:
        assert project.version >= 3 and 3 in MIGRATIONS
        assert [(o.kind, len(o.vertices)) for o in project.objects()] == [("length", 2), ("arc", 4), ("point", 1)]
        assert project.objects()[1].vertices[3].xyz == (0.0, 0.0, -5.0)
        assert len(project._db.execute("SELECT * FROM vertex_history").fetchall()) == 1
        assert project._db.execute("PRAGMA foreign_key_check").fetchall() == []
        circle = project.add_object("circle", [Vertex(1, 2, 3, 4)] * 3)
        assert project.object(circle).kind == "circle"
        with pytest.raises(ProjectError, match="unknown measurement kind 'blob'"):
            project.add_object("blob", [Vertex(1, 2, 3, 4)])
        with pytest.raises(ProjectError, match="a point has at most 1 vertices"):
            project.add_object("point", [Vertex(1, 2, 3, 4)] * 2)


def test_several_objects_are_stored_all_or_nothing(tmp_path):
    with Project.create(tmp_path / "p.usvips") as project:
        good = ("length", [Vertex(1, 2, 3, 4, (0, 0, -2.0), np.eye(3))] * 2, "cod", "", "me")
        with pytest.raises(ProjectError, match="circle needs at least 3"):
            project.add_objects([good, ("circle", [Vertex(1, 2, 3, 4)] * 2, "", "", "me")])
        with pytest.raises(ProjectError):
            project.add_objects([good, ("length", [Vertex(1, 2, 3, 4, pair="no such pair")] * 2, "", "", "me")])
        assert project.objects() == []
        assert len(project.add_objects([good, good])) == 2
