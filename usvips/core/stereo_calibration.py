"""A calibrated stereo rig: what a calibration produces and every later computation uses.

Both cameras carry their interior orientation and housing (in their own frame). The rig's relative
orientation is fixed; each calibrated pair (station) has its own pose, given as the left camera's
exterior orientation in the object (control) frame. ``rig(station)`` places the rig at a station;
``rig(frame="rig")`` puts the left perspective centre at the origin with the left camera's axes.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from usvips.core.camera import Camera, Exterior
from usvips.core.errors import InvalidParameterError
from usvips.core.rig import RelativeOrientation, StereoRig, relative_orientation, right_exterior

PHASES = ("air", "water", "joint")
RIG_ORIGIN = Exterior(0.0, 0.0, 0.0, 0.0, 0.0, 0.0)


@dataclass(frozen=True)
class ParameterEstimate:
    """One named parameter (seeds' symbol with ``_l``/``_r``): value, a-posteriori sigma (None when
    fixed), and how it entered the adjustment: ``free``, ``fixed`` or ``prior``."""

    value: float
    sigma: float | None = None
    status: str = "free"


#: where a calibration's sigma0 comes from (``statistics["sigma0_origin"]``; see
#: :attr:`StereoCalibration.sigma0_origin`)
SIGMA0_ORIGINS = ("estimated", "stated", "given", "assumed")


@dataclass(frozen=True)
class StereoCalibration:
    """left/right: cameras (interior, housing, frame size; exterior = station 0's pose).

    stations: pair labels; poses: the left camera's exterior at each station (object frame);
    relative: the right camera in the left camera's frame; phase: ``air``, ``water`` or ``joint``;
    sigma0_px: a-posteriori standard deviation of unit weight (pixels); parameters: every estimated or
    fixed parameter; covariance: (names, matrix) of the free parameters, or None; statistics: the
    adjustment's figures (rms_px, redundancy, condition_number, ...; ``sigma0_origin``, one of
    :data:`SIGMA0_ORIGINS`, where an import put it); source: where the data came from.
    """

    left: Camera
    right: Camera
    stations: tuple[str, ...]
    poses: tuple[Exterior, ...]
    relative: RelativeOrientation
    phase: str
    sigma0_px: float
    parameters: dict[str, ParameterEstimate] = field(default_factory=dict)
    covariance: tuple[tuple[str, ...], np.ndarray] | None = None
    statistics: dict = field(default_factory=dict)
    source: dict = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.phase not in PHASES:
            raise InvalidParameterError("phase", f"must be one of {PHASES}, got {self.phase!r}")
        if len(self.stations) != len(self.poses) or not self.stations:
            raise InvalidParameterError("stations", "one pose per station, at least one station")
        if not np.isfinite(self.sigma0_px) or self.sigma0_px <= 0:
            raise InvalidParameterError("sigma0_px", f"must be finite and > 0, got {self.sigma0_px}")

    @classmethod
    def from_cameras(cls, left: Camera, right: Camera, phase: str, sigma0_px: float,
                     station: str = "1", **kwargs) -> StereoCalibration:
        """A one-station calibration from two placed cameras (relative orientation derived)."""
        return cls(left, right, (station,), (left.exterior,),
                   relative_orientation(left.exterior, right.exterior), phase, sigma0_px, **kwargs)

    @property
    def sigma0_origin(self) -> str:
        """Where :attr:`sigma0_px` comes from (:data:`SIGMA0_ORIGINS`): ``estimated`` by an adjustment
        (the default: every calibration USVIPS computes), ``stated`` by an imported file's residuals,
        ``given`` by the user at import, or ``assumed`` (an import that states no residual)."""
        origin = self.statistics.get("sigma0_origin", "estimated")
        return origin if origin in SIGMA0_ORIGINS else "estimated"

    def station_index(self, station: int | str) -> int:
        if isinstance(station, str):
            if station in self.stations:
                return self.stations.index(station)
            raise InvalidParameterError("station", f"no calibrated station {station!r}; "
                                        f"stations: {', '.join(self.stations)}")
        if not 0 <= int(station) < len(self.stations):
            raise InvalidParameterError("station", f"station index {station} out of range 0..{len(self.stations) - 1}")
        return int(station)

    def rig(self, station: int | str = 0, frame: str = "object") -> StereoRig:
        """The two cameras placed at a calibrated station (``frame="object"``) or in the rig frame."""
        if frame == "rig":
            left_pose = RIG_ORIGIN
        elif frame == "object":
            left_pose = self.poses[self.station_index(station)]
        else:
            raise InvalidParameterError("frame", f"must be 'object' or 'rig', got {frame!r}")
        return StereoRig(self.left.with_exterior(left_pose),
                         self.right.with_exterior(right_exterior(left_pose, self.relative)))
