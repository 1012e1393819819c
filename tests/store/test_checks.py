"""The domain checks above the backends (usvips/store/checks.py) and the opener by location
(usvips/store/opening.py): what every backend refuses before writing, and which backend a location opens."""

from pathlib import Path

import pytest

from usvips.store import SCHEMA_VERSION, Project, ProjectError, Vertex, checks
from usvips.store.location import is_server_location, public_location, shown, without_password
from usvips.store.opening import create_project, open_project
from usvips.store.postgres import ServerProject


def _vertices(count: int) -> list[Vertex]:
    return [Vertex(float(k), 2.0, 3.0, 4.0) for k in range(count)]


@pytest.mark.parametrize(("kind", "count", "stored"), [("line", 2, "length"), ("line", 5, "arc"), ("point", 1, "point"),
                                                      ("polygon", 3, "polygon"), ("circle", 3, "circle")])
def test_kinds_resolve_by_their_vertex_count(kind, count, stored):
    assert checks.object_kind(kind, _vertices(count), "p.usvips") == stored


@pytest.mark.parametrize(("kind", "vertices", "words"), [
    ("hexagon", _vertices(3), "hexagon"), ("length", _vertices(1), "p.usvips"), ("point", _vertices(2), "p.usvips"),
    ("point", [Vertex(1.0, float("nan"), 3.0, 4.0)], "both picks"), ("length", [Vertex(1.0, 2.0, None, 4.0)] * 2,
                                                                     "both picks")])
def test_a_bad_kind_count_or_pick_is_one_line(kind, vertices, words):
    with pytest.raises(ProjectError, match=words) as refused:
        checks.object_kind(kind, vertices, "p.usvips")
    assert "\n" not in str(refused.value)


def test_pair_files_and_labels_are_checked_before_anything_is_added(tmp_path):
    left, right = tmp_path / "l.png", tmp_path / "r.png"
    left.write_bytes(b"l")
    right.write_bytes(b"r")
    checks.pair_images("a", left, right)
    checks.pair_images("a", None, None)
    with pytest.raises(ProjectError, match="right image .*does not exist"):
        checks.pair_images("a", left, tmp_path / "gone.png")
    checks.image_pairs([("a", left, right)], {"b"}, "p")
    for pairs, taken, words in (([("a", left, right)], {"a"}, "'a' already used"),
                                ([("a", left, right), ("a", right, left)], set(), "'a' already used"),
                                ([("a", left, tmp_path / "." / "l.png")], set(), "both the left and the right")):
        with pytest.raises(ProjectError, match=words):
            checks.image_pairs(pairs, taken, "p")


def test_a_location_opens_its_backend_and_is_shown_without_its_password(tmp_path, new_database):
    file = tmp_path / "f.usvips"
    with create_project(file) as project:
        assert type(project) is Project
    with open_project(file, read_only=True) as project:
        assert type(project) is Project and project.read_only
    url = new_database("opener")
    assert is_server_location(url) and not is_server_location(file) and not is_server_location(str(file))
    with create_project(url) as survey:
        assert type(survey) is ServerProject and survey.derived_media_folder() != Path(url)
    with open_project(url) as survey:
        assert type(survey) is ServerProject and survey.version == SCHEMA_VERSION
    secret = "postgresql://ann:hunter2@db.example:5433/survey?sslmode=require&media=/mnt/m"
    assert public_location(secret) == "postgresql://ann@db.example:5433/survey?sslmode=require"
    assert shown(secret) == public_location(secret) and shown(file) == str(file)
    assert "hunter2" not in shown(secret)
    # what a recent-projects list keeps: everything but the password (the media folder too)
    kept = without_password(secret + "&password=hunter3")
    assert kept == "postgresql://ann@db.example:5433/survey?sslmode=require&media=%2Fmnt%2Fm" and "hunter" not in kept
    assert without_password("postgresql://postgres:@/survey?host=/tmp/s") == "postgresql://postgres@/survey?host=%2Ftmp%2Fs"
    with pytest.raises(ProjectError, match="name the survey's database"):
        open_project("postgresql://ann@db.example/")


def test_the_server_schema_has_every_table_and_column_of_the_sqlite_schema(tmp_path, new_database):
    """When the SQLite schema gains a version, this fails until usvips/store/postgres_schema.py follows."""
    import sqlite3

    import psycopg

    from usvips.store.postgres_schema import SERVER_SCHEMA_VERSION, TABLES

    assert SERVER_SCHEMA_VERSION == SCHEMA_VERSION
    Project.create(tmp_path / "s.usvips").close()
    connection = sqlite3.connect(tmp_path / "s.usvips")
    names = [r[0] for r in connection.execute("SELECT name FROM sqlite_master WHERE type = 'table'")]
    sqlite_columns = {t: tuple(r[1] for r in connection.execute(f"PRAGMA table_info({t})")) for t in names}
    connection.close()
    # each backend keeps its own id counters (schema 13 on a server, 15 in a file); they are never copied
    assert sqlite_columns == {**TABLES, "id_counters": ("name", "next")}
    url = new_database("schema")
    create_project(url).close()
    with psycopg.connect(url) as server:
        rows = server.execute("SELECT table_name, column_name FROM information_schema.columns WHERE table_schema = "
                              "current_schema() ORDER BY table_name, ordinal_position").fetchall()
    server_columns: dict[str, tuple[str, ...]] = {}
    for table, column in rows:
        server_columns[table] = (*server_columns.get(table, ()), column)
    assert server_columns == {**TABLES, "control_points": (*TABLES["control_points"], "ord"),
                              "id_counters": ("name", "next")}  # the server's own (schema 13: ids that do not jump)
