"""Housings (``base.py``: the stack of surfaces and media), the housing-kind registry (``registry.py``)
and the kinds (``kinds/``: one module each). Ask the registry for a kind by name::

    from usvips.core import housing
    cls = housing.kind("flat-port")          # the class; cls.specs, cls.build(...), cls.from_values(...)
    housing.names(), housing.water_names()   # every kind; the kinds a phase-2 calibration estimates

The kinds' classes are re-exported here for code that builds one directly (tests, benchmarks).
"""

from usvips.core.housing.base import GEOMETRY, GeneralHousing, Housing, plane_coefficients, shared_plane_in_camera
from usvips.core.housing.kinds.air import AirHousing
from usvips.core.housing.kinds.dome_cover import DomeCoverHousing, dome_cover_from_object_space
from usvips.core.housing.kinds.dome_port import DomePortHousing
from usvips.core.housing.kinds.flat_port import FlatPortHousing, flat_port_from_object_space
from usvips.core.housing.parameter import HousingParameter
from usvips.core.housing.registry import (
    UnknownHousingError,
    kind,
    names,
    registered_kinds,
    water_names,
)

__all__ = ["GEOMETRY", "AirHousing", "DomeCoverHousing", "DomePortHousing", "FlatPortHousing", "GeneralHousing",
           "Housing", "HousingParameter", "UnknownHousingError", "dome_cover_from_object_space",
           "flat_port_from_object_space", "kind", "names", "plane_coefficients", "registered_kinds",
           "shared_plane_in_camera", "water_names"]
