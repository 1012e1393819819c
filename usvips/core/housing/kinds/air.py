"""No housing: the camera in air (the pinhole model with distortion; phase 1)."""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

from usvips.core.housing.base import Housing
from usvips.core.surfaces import Surface


@dataclass(frozen=True, repr=False)
class AirHousing(Housing):
    """No housing: the camera in air (no surfaces, one medium of index 1)."""

    kind = "air"
    order = 0
    description = "no housing: the camera in air (phase 1)"

    @cached_property
    def surfaces(self) -> tuple[Surface, ...]:
        return ()

    @property
    def indices(self) -> tuple[float, ...]:
        return (1.0,)
