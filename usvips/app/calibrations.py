"""The calibration service: every stored calibration is read (its stored dictionary checked and made a
:class:`~usvips.core.calibration.StereoCalibration`), stored and made active through here, whatever the
store behind the project.

A damaged stored calibration is an error naming the project and the calibration's id.
"""

from __future__ import annotations

from collections.abc import Sequence

from usvips.core.stereo_calibration import StereoCalibration
from usvips.io.calibration_file import calibration_from_dict, calibration_to_dict
from usvips.store.interface import ProjectStore


def read_calibration(project: ProjectStore, calibration_id: int) -> StereoCalibration:
    """The stored calibration ``calibration_id`` of ``project``, read and checked."""
    return calibration_from_dict(project.calibration(calibration_id), f"{project.path} calibration {calibration_id}")


def require_readable_calibrations(project: ProjectStore) -> None:
    """Every stored calibration's record read: one whose stored text is damaged (no longer JSON) is its
    error. Exports and checks call this first: their figures would otherwise come from the vertices' stored
    values for the objects measured with it, and differ from the calibration's own without a word. (A
    record that reads but holds no calibration the figures can use keeps the stored values, as before.)"""
    for stored in project.calibrations():
        project.calibration(stored.id)


def active_calibration_id(project: ProjectStore, label: str) -> int | None:
    """The id of the calibration active for the pair or video ``label``; None when none is."""
    return project.active_calibration(label)


def active_calibration(project: ProjectStore, label: str) -> tuple[int, StereoCalibration] | None:
    """(id, calibration) active for the pair or video ``label``; None when none is."""
    calibration_id = project.active_calibration(label)
    return None if calibration_id is None else (calibration_id, read_calibration(project, calibration_id))


def store_calibration(project: ProjectStore, name: str, calibration: StereoCalibration | dict,
                      active_for: Sequence[str] = ()) -> int:
    """Store a calibration (a :class:`StereoCalibration`, or its file dictionary as read from a checked
    file) under ``name``, active for the pairs or videos named; returns its id. All or nothing."""
    data = calibration_to_dict(calibration) if isinstance(calibration, StereoCalibration) else calibration
    return project.add_calibration(name, data, tuple(active_for))


def make_active(project: ProjectStore, label: str, calibration_id: int) -> None:
    """Make the stored calibration ``calibration_id`` the active one of the pair or video ``label``."""
    project.activate_calibration(label, calibration_id)
