"""A sample directory made a project file: whole or not at all under its name."""

import shutil

import pytest

from usvips.app import samples
from usvips.locations import sample_project
from usvips.store import Project


def test_the_project_appears_under_its_name_only_once_it_is_whole(tmp_path, monkeypatch):
    """Filled under a hidden name and linked into place at the end: while it is filled (a kill there
    leaves no half-made project for the next start to open as whole) the name is free; a failure
    leaves neither the name nor the hidden file."""
    directory = shutil.copytree(sample_project("tank_system1"), tmp_path / "tank")
    out = tmp_path / "survey.usvips"
    fill = samples._fill
    seen = []

    def watched(project, *args):
        seen.append((out.exists(), project.path.name))
        fill(project, *args)

    monkeypatch.setattr(samples, "_fill", watched)
    project = samples.create_from_manifest(directory, out)
    try:
        assert seen == [(False, seen[0][1])] and seen[0][1].startswith(".survey.") and seen[0][1] != out.name
        labels = [p.label for p in project.pairs()]
        assert labels and len(project.control()) > 0
    finally:
        project.close()
    with Project.open(out, read_only=True) as reopened:
        assert [p.label for p in reopened.pairs()] == labels

    def failing(project, *args):
        fill(project, *args)
        raise KeyboardInterrupt  # stopped at the last moment

    monkeypatch.setattr(samples, "_fill", failing)
    with pytest.raises(KeyboardInterrupt):
        samples.create_from_manifest(directory, tmp_path / "other.usvips")
    assert not [p.name for p in tmp_path.iterdir() if p.name.startswith((".other", "other"))]
