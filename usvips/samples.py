"""Sample project directories (``project.json`` + images) opened as project files.

Sits above io and store (it joins a manifest read by io to a database written by store); the command
line and the workstation both open samples through here.
"""

from __future__ import annotations

import json
from pathlib import Path

from usvips.io.manifest import read_manifest
from usvips.io.tables import read_control, read_observations
from usvips.store import Project
from usvips.video_project import add_sample_video


def create_from_manifest(directory: str | Path, out: str | Path) -> Project:
    """A new project at ``out`` holding a sample directory's pairs, control, observations and calibrations."""
    manifest = read_manifest(directory)
    project = Project.create(out)
    try:
        for pair in manifest.pairs:
            project.add_pair(pair.label, pair.left, pair.right, pair.medium)
        if manifest.control is not None:
            project.set_control(read_control(manifest.control))
        for entry in manifest.observations:
            observations = read_observations(entry.file)
            labels = entry.pairs or observations.pair_labels
            for label in labels:
                rows = observations.pair(label) if label in observations.pair_labels else observations
                project.add_control_observations(rows, entry.role, label)
        for entry in manifest.calibrations:
            project.add_calibration(entry.file.stem, json.loads(entry.file.read_text(encoding="utf-8")),
                                    entry.active_for)
        if manifest.video is not None:  # the sample's stereo video with its known offset
            add_sample_video(project, manifest.video.left, manifest.video.right, manifest.video.frame_offset)
    except BaseException:
        project.close()
        Path(out).unlink(missing_ok=True)
        raise
    return project


def open_or_create_from_manifest(directory: str | Path) -> Project:
    """Open ``<directory>/project.usvips``, creating it from the directory's ``project.json`` first."""
    path = Path(directory) / "project.usvips"
    return Project.open(path) if path.exists() else create_from_manifest(directory, path)
