"""Who and when (schema 8): the annotator's name, the migration of schema-7 projects and surveys, and
``usvips project history`` on a file and on a server. (The history's semantics on both backends are in
the contract suite, tests/store/test_storage_contract.py.)"""

from __future__ import annotations

import json
import re
import shutil
import sqlite3
from pathlib import Path

import numpy as np
import psycopg
import pytest

from tests.store.conftest import BEFORE_SCHEMA_13
from usvips.cli import main
from usvips.core.errors import UsvipsError
from usvips.core.observation_record import ObservationRecord
from usvips.store import SCHEMA_VERSION, Project
from usvips.store.annotator import ANNOTATOR_ENVIRONMENT, annotating_as, checked_annotator, current_annotator
from usvips.store.opening import create_project, open_project
from usvips.store.project import migrate
from usvips.store.records import ProjectError, Vertex

DATA = Path(__file__).parent / "data"


def _vertex(rng) -> Vertex:
    return Vertex(*map(float, rng.uniform(0, 2000, 4)), tuple(map(float, rng.normal(size=3))))


def test_the_annotator_is_the_option_else_the_environment_else_the_user(monkeypatch):
    monkeypatch.setenv(ANNOTATOR_ENVIRONMENT, "  K. Jones ")
    assert current_annotator() == "K. Jones"
    with annotating_as("R. Smith"):
        assert current_annotator() == "R. Smith"
        with annotating_as(None):
            assert current_annotator() == "R. Smith"
    assert current_annotator() == "K. Jones"
    monkeypatch.delenv(ANNOTATOR_ENVIRONMENT)
    assert current_annotator() not in ("", "K. Jones")
    for bad, why in (("", "empty"), ("a\nb", "control character"), ("x" * 201, "characters long")):
        with pytest.raises(UsvipsError, match=why):
            checked_annotator(bad)
    monkeypatch.setenv(ANNOTATOR_ENVIRONMENT, "two\tparts")
    with pytest.raises(UsvipsError, match=r"\$USVIPS_ANNOTATOR.*control character"):
        current_annotator()


def _schema_7_project(path: Path) -> int:
    """A project as USVIPS of schema 7 made it: one fish with a record."""
    connection = sqlite3.connect(path, isolation_level=None)
    migrate(connection, 7)
    connection.executescript("BEGIN; INSERT INTO meta VALUES ('format', 'usvips-project');"
                             "INSERT INTO objects VALUES (5, 'length', 'cod', '', 'old hand', '2020-01-01', "
                             "'2021-02-03');"
                             "INSERT INTO vertices (object_id, idx, xl, yl, xr, yr) VALUES (5, 0, 1, 2, 3, 4), "
                             "(5, 1, 5, 6, 7, 8);"
                             "INSERT INTO observation_records (object_id, genus) VALUES (5, 'Gadus'); COMMIT;")
    connection.close()
    return 5


def test_a_schema_7_project_is_migrated_its_stamps_filled_and_its_history_starts_empty(tmp_path):
    path = tmp_path / "old.usvips"
    object_id = _schema_7_project(path)
    with Project.open(path, read_only=True) as old:  # read as it is: no history, no vertex stamps yet
        assert old.version == 7 and old.history() == []
        assert old.provenance(object_id).vertices == [("", ""), ("", "")]
    with Project.open(path) as project:
        assert project.version == SCHEMA_VERSION >= 8
        made = project.provenance(object_id)
        assert made.vertices == [("old hand", "2021-02-03")] * 2 and made.record == ("old hand", "2021-02-03")
        assert project.history() == []
        project.annotator = "new hand"
        project.update_object(object_id, attribute="ling")
        assert [(e.change, e.annotator, e.old, e.new) for e in project.history()] == [
            ("edit", "new hand", {"attribute": "cod"}, {"attribute": "ling"})]


def test_a_version_1_project_reaches_schema_8_and_records_its_changes(tmp_path):
    copy = tmp_path / "v1.usvips"
    shutil.copy(DATA / "project_v1.usvips", copy)
    with Project.open(copy) as project:
        fish = project.objects()[0]
        project.delete_object(fish.id)
        assert [e.change for e in project.history(fish.id)] == ["delete"]
        assert project.history(fish.id)[0].old["attribute"] == "cod"


def _downgrade_to_7(url: str) -> None:
    """Make a new survey look as a schema-7 USVIPS made it (no history, no vertex or record stamps)."""
    with psycopg.connect(url, autocommit=True) as raw:
        raw.execute(BEFORE_SCHEMA_13)
        raw.execute("DROP TABLE reviews; DROP TABLE history; DROP FUNCTION usvips_history_append_only();"
                    "ALTER TABLE vertices DROP COLUMN creator, DROP COLUMN created;"
                    "ALTER TABLE observation_records DROP COLUMN creator, DROP COLUMN created;"
                    "ALTER TABLE object_instants DROP COLUMN tracked_from;"
                    "ALTER TABLE vertices DROP COLUMN pointing_source, DROP COLUMN sigma_left_px, "
                    "DROP COLUMN sigma_right_px, DROP COLUMN pointing_origin, DROP COLUMN weak_score, "
                    "DROP COLUMN weak_reason;"
                    "UPDATE meta SET value = '7' WHERE key = 'schema_version'")


def test_a_schema_7_survey_is_migrated_when_opened_for_writing_and_refused_read_only(new_database, tmp_path):
    url = new_database("old")
    rng = np.random.default_rng(1)
    with create_project(url) as survey:
        survey.annotator = "old hand"
        object_id = survey.add_object("length", [_vertex(rng), _vertex(rng)], "cod")
        survey.set_record(object_id, ObservationRecord(genus="Pagrus"))
        created = survey.object(object_id).modified
    _downgrade_to_7(url)
    with pytest.raises(ProjectError, match="schema 7.*open it once for writing") as refused:
        open_project(url, read_only=True)
    assert "\n" not in str(refused.value)
    with open_project(url) as survey:
        assert survey.version == SCHEMA_VERSION and survey.history() == []
        made = survey.provenance(object_id)
        assert made.vertices == [("old hand", created)] * 2 and made.record == ("old hand", created)
        survey.annotator = "new hand"
        survey.set_review(object_id, "accepted")  # schema 9 on top
        survey.delete_object(object_id)
        assert [(e.change, e.annotator) for e in survey.history(object_id)] == [("review", "new hand"),
                                                                                ("delete", "new hand")]
    with open_project(url, read_only=True) as again:  # the second opening finds it up to date
        assert again.version == SCHEMA_VERSION and len(again.history()) == 2


def _fill(store) -> int:
    rng = np.random.default_rng(4)
    object_id = store.add_object("length", [_vertex(rng), _vertex(rng)], "cod")
    store.add_object("point", [_vertex(rng)], "sponge")
    store.update_object(object_id, attribute="ling")
    store.set_record(object_id, ObservationRecord(genus="Gadus", species="morhua", number=2))
    store.delete_object(object_id)
    return object_id


@pytest.mark.parametrize("backend", ["sqlite", "postgresql"])
def test_project_history_prints_one_line_per_change_newest_last_on_both_backends(backend, tmp_path, capsys,
                                                                                   request):
    location = (str(tmp_path / "h.usvips") if backend == "sqlite"
                else request.getfixturevalue("new_database")("history"))
    with annotating_as("R. Smith"), create_project(location) as store:
        object_id = _fill(store)
    assert main(["project", "history", location]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert len(lines) == 5
    changes = [re.search(r"  object (\d+)  ([a-z -]+): ", line) for line in lines]
    assert [m.group(2) for m in changes] == ["add", "add", "edit", "record", "delete"]
    assert [int(m.group(1)) for m in changes] == [object_id, object_id + 1, object_id, object_id, object_id]
    assert all("R. Smith" in line for line in lines)
    assert "attribute 'cod' → 'ling'" in lines[2] and "Gadus morhua ×2" in lines[3]
    assert main(["project", "history", location, "--object", str(object_id), "--json"]) == 0
    entries = json.loads(capsys.readouterr().out)
    assert [e["change"] for e in entries] == ["add", "edit", "record", "delete"]
    assert {e["object_id"] for e in entries} == {object_id} and entries[-1]["old"]["record"]["number"] == 2
    assert main(["project", "history", location, "--object", "999"]) == 0
    assert "no recorded change of object 999" in capsys.readouterr().out
    assert main(["project", "history", location, "--object", "0"]) == 2
    err = capsys.readouterr().err
    assert "--object" in err and len(err.strip().splitlines()) == 1


def test_a_bad_annotator_in_the_environment_refuses_writing_in_one_line_but_not_reading(tmp_path, monkeypatch,
                                                                                        capsys):
    path = tmp_path / "p.usvips"
    with create_project(path) as project:
        project.add_object("point", [_vertex(np.random.default_rng(0))], "sponge")
    monkeypatch.setenv(ANNOTATOR_ENVIRONMENT, "line\nbreak")
    with pytest.raises(UsvipsError, match=r"\$USVIPS_ANNOTATOR"):
        open_project(path)
    with open_project(path, read_only=True) as project:
        assert len(project.history()) == 1
    assert main(["project", "history", str(path)]) == 0 and "sponge" in capsys.readouterr().out
    (tmp_path / "control.csv").write_text("id,X,Y,Z\nA,0,0,0\n")
    importing = ["project", "import", str(path), "--control", str(tmp_path / "control.csv")]
    assert main(importing) == 2
    err = capsys.readouterr().err
    assert "$USVIPS_ANNOTATOR" in err and "control character" in err and len(err.strip().splitlines()) == 1
    assert main([*importing, "--annotator", "K. Jones"]) == 0  # the option overrides the environment
