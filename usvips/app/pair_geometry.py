"""Where a pair measures: the calibration active for it, placed at its station and frame.

The one place the rule "in which frame does this pair measure" is applied to a project: the calibration
active for the pair (read from the project), at the pair's own station in the object frame when the pair
is a calibrated station, otherwise in the rig frame (origin at the left camera's perspective centre; the
rule itself is :func:`usvips.core.measurements.placement`). The window, ``usvips measure --project`` and
the stored objects' figures all ask here.
"""

from __future__ import annotations

from dataclasses import dataclass

from usvips.app.calibration_size import check_for
from usvips.app.calibrations import active_calibration
from usvips.core.measurements import placement
from usvips.core.stereo_calibration import StereoCalibration
from usvips.store.interface import ProjectStore


@dataclass(frozen=True)
class PairGeometry:
    """The calibration used for a pair, the station and frame it is placed in, and a line saying so."""

    calibration: StereoCalibration
    calibration_id: int
    station: int | str
    frame: str

    @property
    def description(self) -> str:
        where = (f"station {self.station}, object frame" if self.frame == "object"
                 else "rig frame (origin at the left camera; the pair is not a calibrated station)")
        return f"calibration {self.calibration_id} ({self.calibration.phase}), {where}"


def placed(calibration: StereoCalibration, calibration_id: int, label: str | None) -> PairGeometry:
    """A calibration placed where the pair ``label`` measures."""
    return PairGeometry(calibration, calibration_id, *placement(calibration, label))


def pair_geometry(project: ProjectStore, label: str) -> PairGeometry | None:
    """The active calibration of a pair placed at its station, or None when the pair has none; refused
    by name (both sizes) when the pair's pictures are not the calibration's size."""
    active = active_calibration(project, label)
    if active is None:
        return None
    calibration_id, calibration = active
    check_for(project, calibration, [label], f"its calibration {calibration_id}")
    return placed(calibration, calibration_id, label)
