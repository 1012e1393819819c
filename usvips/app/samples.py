"""Sample project directories (``project.json`` + images) opened as project files.

Sits above io and store (it joins a manifest read by io to a database written by store); the command
line and the workstation both open samples through here.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

from usvips.core.errors import InputFileError
from usvips.store.interface import ProjectStore
from usvips.store.location import is_server_location
from usvips.store.opening import create_project, open_project
from usvips.store.records import ProjectError


def create_from_manifest(directory: str | Path, out: str | Path) -> ProjectStore:
    """A new project at ``out`` holding a sample directory's pairs, control, observations and calibrations."""
    # the readers only when a sample's project is first made (opening its file again needs none of them)
    from usvips.io.calibration_file import load_calibration
    from usvips.io.manifest import read_manifest
    from usvips.io.tables import read_control, read_observations

    manifest = read_manifest(directory)
    control = read_control(manifest.control) if manifest.control is not None else None
    observation_files = [(entry, read_observations(entry.file)) for entry in manifest.observations]
    known = {pair.label for pair in manifest.pairs}
    for entry, observations in observation_files:
        unknown = [label for label in (entry.pairs or observations.pair_labels) if label not in known]
        if unknown:
            raise InputFileError(str(manifest.path), f"observations {entry.file.name}: pair {unknown[0][:40]!r} is "
                                 "not one of the manifest's pairs (give the entry's 'pairs')")
    calibrations = []
    for entry in manifest.calibrations:
        load_calibration(entry.file)                      # checked whole before anything is stored
        try:
            calibrations.append((entry, json.loads(entry.file.read_text(encoding="utf-8"))))
        except (OSError, ValueError) as error:
            raise InputFileError(str(entry.file), f"cannot read the calibration: {error}") from None
    if is_server_location(out):
        project = create_project(out)
        try:
            with project.transaction():
                _fill(project, manifest, control, observation_files, calibrations)
        except BaseException:
            project.close()
            raise
        return project
    # a project file is made whole under a hidden name beside its place, then linked there: a run stopped
    # half-way (killed, the power gone) never leaves a half-made project under the name, which a next
    # start would open as if it were whole
    out = Path(out)
    if out.exists() or out.is_symlink():
        raise ProjectError(f"{out}: already exists; open it instead")
    partial = out.with_name(f".{out.stem}.{os.getpid()}.partial{out.suffix}")
    try:
        with create_project(partial) as project:
            with project.transaction():
                _fill(project, manifest, control, observation_files, calibrations)
        try:
            os.link(partial, out)  # never replaces a file that appeared meanwhile
        except FileExistsError:
            raise ProjectError(f"{out}: already exists; open it instead") from None
    finally:
        for suffix in ("", "-wal", "-shm", "-journal"):
            Path(f"{partial}{suffix}").unlink(missing_ok=True)
    return open_project(out)


def _fill(project: ProjectStore, manifest, control, observation_files, calibrations) -> None:
    """Store a manifest's contents (already read and checked) in a new project."""
    from usvips.app.calibrations import store_calibration
    from usvips.app.video_project import add_sample_video

    for pair in manifest.pairs:
        project.add_pair(pair.label, pair.left, pair.right, pair.medium)
    if control is not None:
        project.set_control(control)
    for entry, observations in observation_files:
        labels = entry.pairs or observations.pair_labels
        for label in labels:
            rows = observations.pair(label) if label in observations.pair_labels else observations
            project.add_control_observations(rows, entry.role, label)
    for entry, data in calibrations:
        store_calibration(project, entry.file.stem, data, entry.active_for)
    if manifest.video is not None:  # the sample's stereo video with its known offset
        add_sample_video(project, manifest.video.left, manifest.video.right, manifest.video.frame_offset)


def open_or_create_from_manifest(directory: str | Path) -> ProjectStore:
    """Open ``<directory>/project.usvips``, creating it from the directory's ``project.json`` first."""
    path = Path(directory) / "project.usvips"
    if path.is_symlink():
        raise ProjectError(f"{path}: a symbolic link; a sample's project file must be a plain file in its "
                           "folder (remove the link)")
    return open_project(path) if path.exists() else create_from_manifest(directory, path)
