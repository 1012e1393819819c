"""Schema 6: deployment metadata (project-wide or per video) and the georeference, stored and read back; a
schema-5 project migrates (after its backup) and keeps its contents; a read-only older project has none."""

import sqlite3

import pytest

from usvips.core.deployment import Deployment, Georeference
from usvips.core.observation_record import ObservationRecord
from usvips.store import Project, ProjectError
from usvips.store.project import FORMAT, backup_path, migrate
from usvips.store.schema import MIGRATIONS


def _schema_5_project(path):
    connection = sqlite3.connect(path)
    migrate(connection, 5)
    with connection:
        connection.executemany("INSERT INTO meta VALUES (?, ?)", [("format", FORMAT), ("created", "then")])
        connection.execute("INSERT INTO objects (kind, created, modified) VALUES ('length', 'then', 'then')")
        connection.execute("INSERT INTO observation_records (object_id, genus, number) VALUES (1, 'Pagrus', 3)")
    connection.close()


def test_a_schema_5_project_migrates_to_6_keeps_its_records_and_stores_metadata(tmp_path):
    path = tmp_path / "old.usvips"
    _schema_5_project(path)
    with Project.open(path, read_only=True) as project:
        assert project.version == 5 and project.deployments() == {} and project.georeference() is None
    with Project.open(path) as project:
        assert project.version == max(MIGRATIONS) >= 6
        assert backup_path(path, 5).exists()
        assert project.record(1) == ObservationRecord(genus="Pagrus", number=3)
        first = Deployment("BRUV-1", "2024-03-01", "06:30", -32.0, 115.5, 10.0, "S1", "Rottnest", "Fished",
                           successful_length=False, observer="AB", comment="murky")
        project.set_deployment(first)
        project.set_georeference(Georeference(-32.0, 115.5, 10.0, 45.0))
    with Project.open(path) as project:
        assert project.deployments() == {"": first} and project.deployment() == first
        assert project.deployment("any video") == first  # a video without its own: the project's
        assert project.georeference() == Georeference(-32.0, 115.5, 10.0, 45.0)
        with pytest.raises(ProjectError, match="no video pair 'T9'"):
            project.set_deployment(first, "T9")
        project.set_deployment(None)
        project.set_georeference(None)
        assert project.deployments() == {} and project.georeference() is None


def test_a_video_has_its_own_deployment(tmp_path):
    project = Project.create(tmp_path / "p.usvips")
    files = []
    for side in ("l", "r"):
        files.append(tmp_path / f"{side}.mp4")
        files[-1].write_bytes(side.encode())
    project.add_video("T1", [(files[0], 10, 25.0)], [(files[1], 10, 25.0)], 25.0, 10, (64, 48))
    project.set_deployment(Deployment("ALL"))
    project.set_deployment(Deployment("DOV-7", successful_count="no"), "T1")
    assert project.deployment("T1").opcode == "DOV-7" and not project.deployment("T1").successful_count
    assert project.deployment().opcode == "ALL"
    project.close()
