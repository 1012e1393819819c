"""Opening what the user names: a project file or a sample directory."""

import json

import pytest

from usvips.app.opening import open_project
from usvips.core.errors import InputFileError
from usvips.store import Project, ProjectError
from usvips.store.interface import ProjectStore


def _sample(folder):
    folder.mkdir()
    (folder / "project.json").write_text(json.dumps({"format": "usvips-sample", "version": 1, "name": "s",
                                                     "pairs": [{"label": "a", "medium": "air"}]}))
    return folder


def test_a_sample_directory_gets_its_project_file_on_first_use_and_the_same_one_after(tmp_path):
    sample = _sample(tmp_path / "sample")
    with pytest.raises(InputFileError, match="sample: a sample directory without its project file yet"):
        open_project(sample, read_only=True)
    with open_project(sample) as project:
        assert isinstance(project, ProjectStore)
        assert project.path == sample / "project.usvips" and [p.label for p in project.pairs()] == ["a"]
        project.add_term("kept")
    with open_project(sample, read_only=True) as project:
        assert project.read_only and project.vocabulary() == ["kept"]


def test_a_project_file_opens_for_writing_or_read_only(tmp_path):
    Project.create(tmp_path / "p.usvips").close()
    with open_project(tmp_path / "p.usvips") as project:
        project.add_pair("x")
    with open_project(tmp_path / "p.usvips", read_only=True) as project:
        with pytest.raises(ProjectError, match="read-only"):
            project.add_pair("y")


def test_anything_else_is_named(tmp_path):
    with pytest.raises(InputFileError, match=r"nothing\.usvips: no such project file or sample directory"):
        open_project(tmp_path / "nothing.usvips")
    (tmp_path / "other.db").write_bytes(b"not sqlite at all")
    with pytest.raises(ProjectError, match="other.db"):
        open_project(tmp_path / "other.db")
