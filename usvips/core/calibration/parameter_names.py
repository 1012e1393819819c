"""A calibration's named parameters and the camera parts they make: the seeds' symbols (``f_l``, ``X0_r@2``,
housing symbols), a housing kind's parameter names, and the housings, exteriors and interiors built from a
dict of values (metres, radians, pixels). The model (:mod:`.model`) and its derivatives
(:mod:`.derivatives`) both build from here."""

from __future__ import annotations

import numpy as np

from usvips.core import housing as housings
from usvips.core.camera import EXTERIOR_PARAMETERS, Exterior
from usvips.core.housing import Housing
from usvips.core.interior import INTERIOR_PARAMETERS, Interior
from usvips.core.rig import relative_orientation

#: the left camera's pose in the rig frame (origin at its perspective centre, its axes)
ORIGIN = Exterior(0.0, 0.0, 0.0, 0.0, 0.0, 0.0)


def symbol(name: str) -> str:
    """The seeds' symbol of a parameter name (``f_l`` → ``f``, ``X0_l@2`` → ``X0``, ``Z@7`` → ``Z``)."""
    base = name.split("@")[0]
    for suffix in ("_l", "_r"):
        if base.endswith(suffix):
            return base[: -len(suffix)]
    return base


def housing_parameter_names(kind: str) -> list[str]:
    """The calibration's parameter names of a housing kind (the registry's ``calibration_names``)."""
    return list(housings.kind(kind).calibration_names)


def build_housings(kind: str, values: dict[str, float]) -> tuple[Housing, Housing]:
    """Left and right housings (each in its camera frame) from parameter values: the kind builds them, given
    the rig's relative orientation when its right housing follows the rig."""
    cls = housings.kind(kind)
    rotation, translation = np.eye(3), np.zeros(3)
    if cls.right_follows_rig:
        rel = relative_orientation(exterior_of(values, "l"), exterior_of(values, "r"))
        rotation, translation = rel.rotation, -rel.rotation @ rel.base
    return cls.build(values, rotation, translation)


def exterior_of(values: dict[str, float], side: str, station: str | None = None) -> Exterior:
    """A camera's exterior orientation from parameter values (``X0_l``, ``omega_r@2`` …; metres, radians)."""
    suffix = f"_{side}" + (f"@{station}" if station else "")
    return Exterior(*(values[f"{p}{suffix}"] for p in EXTERIOR_PARAMETERS))


def interior_of(values: dict[str, float], side: str) -> Interior:
    """A camera's interior orientation from parameter values (``f_l``, ``k1_r`` …; pixels)."""
    return Interior(*(values[f"{p}_{side}"] for p in INTERIOR_PARAMETERS))
