"""What a PostgreSQL server adds to the storage contract: annotators writing one survey at once (each edit
a transaction, stale edits of one object refused by name), copies file ↔ server that compare equal row by
row, and one-line refusals of bad servers, logins and databases that never print the password and never
change anything. Against the real server of tests/store/conftest.py."""

from __future__ import annotations

import hashlib
import sqlite3
import threading
from pathlib import Path
from urllib.parse import urlsplit, urlunsplit

import numpy as np
import psycopg
import pytest

from usvips.cli import main
from usvips.core.campaign import Campaign
from usvips.core.deployment import Deployment, Georeference
from usvips.core.observation_record import ObservationRecord, Species
from usvips.core.observations import ControlPoints, StereoObservations
from usvips.core.pointing import WeakMatch
from usvips.store import SCHEMA_VERSION, Project, ProjectError
from usvips.store.opening import create_project, open_project
from usvips.store.postgres import ServerProject
from usvips.store.postgres_schema import TABLES
from usvips.store.records import StaleEditError, Vertex
from usvips.store.transfer import file_rows, pull, push


def _vertex(rng, pair=None, calibration_id=None) -> Vertex:
    a = rng.normal(size=(3, 3)) * 1e-3
    return Vertex(*map(float, rng.uniform(0, 2000, 4)), tuple(map(float, rng.normal(size=3))), a @ a.T,
                  calibration_id, pair)


def _fill(project, folder: Path, rng) -> None:
    """A project holding something in every table, with random numbers (float64 to the last bit)."""
    images = []
    for k in range(int(rng.integers(1, 4))):
        left, right = folder / f"l{k}.png", folder / f"r{k}.png"
        left.write_bytes(rng.bytes(64))
        right.write_bytes(rng.bytes(64))
        images.append((f"pair{k}", left, right))
    project.add_image_pairs(images, "water", [(640, 480)] * len(images))
    (folder / "v.mp4").write_bytes(rng.bytes(32))
    project.add_video("dive", [(folder / "v.mp4", 50, 25.0)], [(folder / "v.mp4", 50, 25.0)], 25.0, 50, (64, 48))
    project.set_video_offset("dive", int(rng.integers(-5, 5)), {"method": "audio", "score": float(rng.random())})
    project.add_period("dive", "transect", 3, 40)
    calibration = project.add_calibration("cal", {"phase": "water", "sigma0_px": float(rng.random()),
                                                  "k": rng.normal(size=5).tolist()}, ("pair0", "dive"))
    project.set_control(ControlPoints(("3", "1", "2"), rng.normal(size=(3, 3)), np.abs(rng.normal(size=(3, 3)))))
    project.add_control_observations(StereoObservations(("1", "2"), rng.uniform(0, 999, (2, 2)),
                                                        rng.uniform(0, 999, (2, 2))), "check", "pair0")
    ids = []
    for _ in range(int(rng.integers(3, 9))):
        kind, count = [("point", 1), ("length", 2), ("polygon", 4)][int(rng.integers(0, 3))]
        vertices = [_vertex(rng, "pair0", calibration) for _ in range(count)]
        ids.append(project.add_object(kind, vertices, "cod", f"note {rng.random()}", "ann"))
    on_video = Vertex(1.0, 2.0, 3.0, 4.0, None, None, None, "dive", "dive", 7, 9, 0.28)
    ids.append(project.add_object("point", [on_video]))
    weak = Vertex(5.0, 6.0, 7.0, 8.0, None, None, None, "pair0", source="auto-match",
                  weak=WeakMatch(float(rng.uniform(0, 0.5)), "a second peak scores 0.95 of the best"),
                  pointing_px=(0.4, float(rng.uniform(0.3, 1))), pointing_origin="estimated")
    project.add_object("point", [weak])  # schema 11: each vertex's pointing and a weak match, pushed and pulled
    kind = project.object(ids[0]).kind
    project.update_object(ids[0], vertices=[_vertex(rng, "pair0", calibration)
                                            for _ in project.object(ids[0]).vertices])  # history
    same = [i for i in ids[1:-1] if project.object(i).kind == kind]
    if same:
        project.add_instant(ids[0], same[0], tracked_from=int(rng.integers(0, 50)))  # schema 10: how it was made
    if len(same) > 1:
        project.add_instant(ids[0], same[1])  # picked by hand
    project.delete_object(ids[-2])
    project.set_species_list([Species("Gadidae", "Gadus", "morhua", "COD", float(rng.uniform(0.5, 2)))])
    project.set_record(ids[0], ObservationRecord("Gadidae", "Gadus", "morhua", "COD", 2, "adult", "", "x"))
    project.set_review(ids[0], "flagged", f"reason {rng.random()}")  # schema 9
    project.set_review(ids[1], "accepted")
    project.set_deployment(Deployment(opcode="OP1", depth_m=float(rng.uniform(5, 50))))
    project.set_deployment(Deployment(opcode="OP2"), "dive")
    project.set_georeference(Georeference(*map(float, rng.uniform(0, 10, 4))))
    project.add_term("cod")
    project.add_term("murky", "visibility")
    project.set_enhancement("pair0/left", '{"steps": []}')
    project.set_draft("wizard", "half done")
    project.set_campaign(Campaign("2024-03_Reef_stereo-BRUVs", "Reef", "stereo-BRUVs", submitter="Ana"))


def _file_digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


PASSWORD_USER, PASSWORD = "annotator", "s3cret-Pw"  # the role tests/store/conftest.py makes


def _with_password(url: str, user: str, password: str) -> str:
    parts = urlsplit(url)
    return urlunsplit((parts.scheme, f"{user}:{password}@", parts.path, parts.query, ""))


# ------------------------------------------------------------------------------------------ copies
@pytest.mark.parametrize("seed", range(4))
def test_push_then_pull_gives_back_every_row_of_every_table(tmp_path, new_database, seed):
    rng = np.random.default_rng(seed)
    original = tmp_path / "original.usvips"
    with Project.create(original) as project:
        _fill(project, tmp_path, rng)
    before = _file_digest(original)
    url = new_database("push")
    push(original, url)
    assert _file_digest(original) == before  # the source is never changed
    with open_project(url, read_only=True) as survey:  # the survey reads as the file does
        with Project.open(original, read_only=True) as file:
            assert survey.pairs() == file.pairs() and survey.videos() == file.videos()
            assert [o.id for o in survey.objects()] == [o.id for o in file.objects()]
            assert survey.instant_links() == file.instant_links() and survey.deployments() == file.deployments()
            assert survey.instant_sources() == file.instant_sources()
            assert survey.campaign() == file.campaign() is not None
            assert [v.weak for o in survey.objects() for v in o.vertices] == [v.weak for o in file.objects()
                                                                               for v in o.vertices]
    back = pull(url, tmp_path / "back.usvips")
    want, got = file_rows(original), file_rows(back)
    assert set(got) == set(TABLES)
    for table in TABLES:
        assert got[table] == want[table], table
    assert sum(len(rows) for rows in want.values()) > 30


def test_the_cli_pushes_and_pulls_and_refuses_bad_input_in_one_line_without_the_password(tmp_path, new_database,
                                                                                          capsys):
    original = tmp_path / "original.usvips"
    with Project.create(original) as project:
        _fill(project, tmp_path, np.random.default_rng(11))
    url = _with_password(new_database("cli"), PASSWORD_USER, PASSWORD)
    assert main(["project", "push", str(original), url]) == 0
    assert PASSWORD not in capsys.readouterr().out
    assert main(["project", "pull", url, str(tmp_path / "back.usvips")]) == 0
    assert file_rows(tmp_path / "back.usvips") == file_rows(original)
    # pushing again into the now filled database, pulling over an existing file: refused, nothing changed
    before = (_file_digest(original), _file_digest(tmp_path / "back.usvips"))
    assert main(["project", "push", str(original), url]) == 2
    assert main(["project", "pull", url, str(tmp_path / "back.usvips")]) == 2
    assert main(["project", "pull", url, str(original)]) == 2
    wrong = _with_password(new_database("cli"), PASSWORD_USER, "not-the-password")
    assert main(["project", "push", str(original), wrong]) == 2
    assert main(["project", "push", url, str(original)]) == 2  # the arguments swapped
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 5 and all(line.startswith("usvips project: ") for line in err)
    assert "already holds tables" in err[0] and "already exists" in err[1] and "already exists" in err[2]
    assert "refused the user name or password" in err[3] and "URL" in err[4]
    assert not any(PASSWORD in line or "not-the-password" in line for line in err)
    assert (_file_digest(original), _file_digest(tmp_path / "back.usvips")) == before
    assert main(["project", "info", f"{url}&media={tmp_path}"]) == 0  # its video is found in the media folder
    info = capsys.readouterr().out
    assert f"schema {SCHEMA_VERSION}" in info and "pair0" in info and PASSWORD not in info
    fresh = _with_password(new_database("cli"), PASSWORD_USER, PASSWORD)
    assert main(["project", "new", fresh]) == 0 and main(["project", "info", fresh]) == 0
    assert "0 objects" in capsys.readouterr().out


def test_a_push_that_fails_half_way_leaves_no_database_and_the_file_unchanged(tmp_path, new_database,
                                                                              postgres_server):
    original = tmp_path / "original.usvips"
    with Project.create(original) as project:
        _fill(project, tmp_path, np.random.default_rng(3))
    connection = sqlite3.connect(original)  # a vertex refers to a pair that is not there (SQLite lets it be)
    connection.execute("UPDATE vertices SET pair_id = 999 WHERE rowid = (SELECT max(rowid) FROM vertices)")
    connection.commit()
    connection.close()
    before = _file_digest(original)
    url = new_database("broken")
    with pytest.raises(ProjectError) as refused:
        push(original, url)
    message = str(refused.value)
    assert "\n" not in message and urlsplit(url).path.strip("/") in message and "nothing was written" in message
    assert _file_digest(original) == before
    with psycopg.connect(postgres_server) as server:
        names = {r[0] for r in server.execute("SELECT datname FROM pg_database")}
    assert urlsplit(url).path.strip("/") not in names


# ------------------------------------------------------------------------------------------ bad servers
def test_bad_servers_logins_and_databases_are_one_line_naming_the_location(tmp_path, new_database,
                                                                          postgres_server):
    # a database that is not a USVIPS survey, one of a newer schema, one that does not exist
    foreign = new_database("foreign")
    with ServerProject.create(new_database("seed")):
        pass
    with psycopg.connect(postgres_server, autocommit=True) as server:
        server.execute(f"CREATE DATABASE {urlsplit(foreign).path.strip('/')}")
    with psycopg.connect(foreign, autocommit=True) as other:
        other.execute("CREATE TABLE meta (key text, value text)")
    newer = new_database("newer")
    with create_project(newer) as survey:
        survey.add_term("kept")
    with psycopg.connect(newer, autocommit=True) as raw:
        raw.execute("UPDATE meta SET value = '99' WHERE key = 'schema_version'")
    missing = new_database("missing")
    nobody = "postgresql://someone:pw-123@127.0.0.1:1/survey"
    cases = [(foreign, "not a USVIPS survey"), (newer, "newer USVIPS"), (missing, "no database"),
             (nobody, "no server answers"),
             (_with_password(new_database("x"), PASSWORD_USER, "wrong-password"), "refused the user name")]
    for url, words in cases:
        for read_only in (True, False):
            with pytest.raises(ProjectError) as refused:
                open_project(url, read_only=read_only)
            message = str(refused.value)
            assert words in message and "\n" not in message, message
            assert "wrong-password" not in message and "pw-123" not in message
            assert message.startswith("postgresql://")
    with psycopg.connect(newer) as raw:
        assert raw.execute("SELECT term FROM vocabulary").fetchall() == [("kept",)]  # nothing was changed
    with psycopg.connect(postgres_server) as server:
        names = {r[0] for r in server.execute("SELECT datname FROM pg_database")}
    assert urlsplit(missing).path.strip("/") not in names  # opening never creates


def test_a_password_login_works_and_the_location_never_shows_the_password(new_database):
    url = _with_password(new_database("login"), PASSWORD_USER, PASSWORD)
    with create_project(url) as survey:
        survey.add_term("cod")
        with pytest.raises(ProjectError) as refused:
            survey.object(12345)
    assert PASSWORD not in str(refused.value)
    with open_project(url, read_only=True) as survey:
        assert survey.vocabulary() == ["cod"] and PASSWORD not in survey.location


# ------------------------------------------------------------------------------------------ annotators
def test_a_stale_edit_of_an_object_is_refused_by_name_and_changes_nothing(new_database, tmp_path):
    rng = np.random.default_rng(21)
    url = new_database("stale")
    with create_project(url) as first, open_project(url) as second:
        object_id = first.add_object("length", [_vertex(rng), _vertex(rng)], "cod")
        read_by_first = first.object(object_id)
        read_by_second = second.object(object_id)
        first.update_object(object_id, attribute="haddock", expected_modified=read_by_first.modified)
        for stale_edit in (lambda: second.update_object(object_id, attribute="whiting",
                                                        expected_modified=read_by_second.modified),
                           lambda: second.delete_object(object_id, expected_modified=read_by_second.modified)):
            with pytest.raises(StaleEditError, match=f"object {object_id} was changed by someone else"):
                stale_edit()
        assert second.object(object_id).attribute == "haddock"
        fresh = second.object(object_id)
        assert fresh.modified > read_by_second.modified
        second.update_object(object_id, notes="checked", expected_modified=fresh.modified)
        got = first.object(object_id)
        assert (got.attribute, got.notes) == ("haddock", "checked")


def test_two_annotators_editing_one_object_and_adding_others_at_once_lose_nothing(new_database):
    """Each annotator (own connection, own thread) adds objects and increments a count kept in one shared
    object by read-modify-write with its version, retrying when refused (stale or busy): every addition
    arrives once and no increment is lost."""
    url = new_database("together")
    with create_project(url) as survey:
        shared = survey.add_object("point", [Vertex(1.0, 2.0, 3.0, 4.0)], notes="0")
    rounds, errors, added = 15, [], {}
    refusals = {"stale": 0}

    def annotator(name: str) -> None:
        rng = np.random.default_rng(len(name))
        mine = []
        try:
            with open_project(url) as handle:
                for _ in range(rounds):
                    for _attempt in range(200):
                        try:
                            mine.append(handle.add_object("point", [_vertex(rng)], name))
                            break
                        except ProjectError:
                            continue
                    for _attempt in range(200):
                        seen = handle.object(shared)
                        try:
                            handle.update_object(shared, notes=str(int(seen.notes) + 1),
                                                 expected_modified=seen.modified)
                            break
                        except StaleEditError:
                            refusals["stale"] += 1
                        except ProjectError:
                            continue
            added[name] = mine
        except Exception as error:  # noqa: BLE001 - reported below
            errors.append(error)

    threads = [threading.Thread(target=annotator, args=(name,)) for name in ("ann", "bob")]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert errors == []
    with open_project(url, read_only=True) as survey:
        assert survey.object(shared).notes == str(2 * rounds)
        stored = {o.id: o.attribute for o in survey.objects() if o.id != shared}
    assert len(stored) == 2 * rounds
    for name, ids in added.items():
        assert sorted(ids) == sorted(i for i, who in stored.items() if who == name)


def test_every_update_moves_the_version_forward_on_both_backends(tmp_path, new_database):
    for store in (Project.create(tmp_path / "v.usvips"), ServerProject.create(new_database("versions"))):
        with store:
            object_id = store.add_object("point", [Vertex(1.0, 2.0, 3.0, 4.0)])
            stamps = [store.object(object_id).modified]
            for k in range(20):  # faster than any clock tick would separate
                store.update_object(object_id, notes=str(k))
                stamps.append(store.object(object_id).modified)
            assert stamps == sorted(set(stamps)) and len(stamps) == 21


_ANNOTATOR = """
import sys
from usvips.store.opening import open_project
from usvips.store.records import ProjectError, StaleEditError, Vertex
url, name, shared, rounds = sys.argv[1], sys.argv[2], int(sys.argv[3]), int(sys.argv[4])
with open_project(url) as survey:
    for k in range(rounds):
        while True:
            try:
                survey.add_object("point", [Vertex(1.0 + k, 2.0, 3.0, 4.0)], name)
                break
            except ProjectError:
                continue
        while True:
            seen = survey.object(shared)
            try:
                survey.update_object(shared, notes=str(int(seen.notes) + 1), expected_modified=seen.modified)
                break
            except ProjectError:  # stale (someone else's increment came first) or busy: read again
                continue
"""


def test_two_annotator_processes_on_one_survey_lose_nothing(new_database, tmp_path):
    import subprocess
    import sys

    url = new_database("processes")
    with create_project(url) as survey:
        shared = survey.add_object("point", [Vertex(1.0, 2.0, 3.0, 4.0)], notes="0")
    rounds = 10
    script = tmp_path / "annotator.py"
    script.write_text(_ANNOTATOR)
    workers = [subprocess.Popen([sys.executable, str(script), url, name, str(shared), str(rounds)],
                                stderr=subprocess.PIPE, text=True) for name in ("ann", "bob")]
    for worker in workers:
        _, err = worker.communicate(timeout=300)
        assert worker.returncode == 0, err
    with open_project(url, read_only=True) as survey:
        assert survey.object(shared).notes == str(2 * rounds)
        made = [o.attribute for o in survey.objects() if o.id != shared]
    assert sorted(made) == ["ann"] * rounds + ["bob"] * rounds


def test_a_connection_cut_in_the_middle_of_a_transaction_is_one_line_and_keeps_nothing(new_database):
    rng = np.random.default_rng(31)
    url = new_database("cut")
    with create_project(url) as survey:
        kept = survey.add_object("point", [_vertex(rng)], "kept")
        backend = survey._db.raw.info.backend_pid
        with pytest.raises(ProjectError) as refused, survey.transaction():
            survey.add_object("point", [_vertex(rng)], "lost")
            with psycopg.connect(url, autocommit=True) as admin:  # the network goes: the server ends the session
                admin.execute("SELECT pg_terminate_backend(%s)", (backend,))
            survey.add_object("point", [_vertex(rng)], "lost too")
        message = str(refused.value)
        assert "\n" not in message and "connection" in message and str(survey.path) in message
    with open_project(url, read_only=True) as survey:
        assert [(o.id, o.attribute) for o in survey.objects()] == [(kept, "kept")]


def test_batch_export_takes_a_survey_on_a_server_as_it_takes_a_file(tmp_path, new_database, capsys):
    original = tmp_path / "reef.usvips"
    with Project.create(original) as project:
        _fill(project, tmp_path, np.random.default_rng(41))
    url = new_database("reef")
    push(original, url)
    assert main(["batch", "export", "--out-dir", str(tmp_path / "from_file"), "--jobs", "1", str(original)]) == 0
    assert main(["batch", "export", "--out-dir", str(tmp_path / "from_server"), "--jobs", "1", url]) == 0
    name = urlsplit(url).path.strip("/")
    assert (tmp_path / "from_server" / f"{name}.csv").read_bytes() == (tmp_path / "from_file" / "reef.csv").read_bytes()
    assert "ok" in capsys.readouterr().out
