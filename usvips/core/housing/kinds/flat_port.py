"""System II (1997 paper V.C): a flat glass port per camera."""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from usvips.core.errors import InvalidParameterError
from usvips.core.housing.base import Housing, _to_camera, plane_coefficients
from usvips.core.housing.kinds._shared import N3, check_indices, finite, positive
from usvips.core.housing.parameter import HousingParameter
from usvips.core.surfaces import Plane, Surface


@dataclass(frozen=True, repr=False)
class FlatPortHousing(Housing):
    """System II: a flat glass port, inner face d·x + e·y + z + g = 0 (camera frame), thickness t.

    g: distance-like offset (metres; g > 0 puts the port in front of the camera), t: glass thickness
    (metres), n1 (air), n2 (glass), n3 (water). Physical: g > 0, t > 0, positive indices.

    Calibration: d, e, g per camera (``d_l`` … ``g_r``), t, n2, n3 shared. Priors (camera frame): the port
    roughly square to the optical axis (d, e = 0 ± 0.05, a tilt of about 3°) a few centimetres ahead
    (g = 0.05 ± 0.05 m); t (0.01 m) and n2 (1.5) are fixed unless given, since they are nearly inseparable
    from g; n3 = 1.34 ± 0.01 (fresh to sea water).
    """

    d: float
    e: float
    g: float
    t: float
    n2: float = 1.5
    n3: float = 1.34
    n1: float = 1.0

    kind = "flat-port"
    order = 20
    description = "System II: a flat glass port in front of each camera"
    specs = (
        HousingParameter("d", "—", "x slope of the port's inner face d·x + e·y + z + g = 0 (0: square to the axis)",
                         0.0, 0.05),
        HousingParameter("e", "—", "y slope of the port's inner face (0: square to the axis)", 0.0, 0.05),
        HousingParameter("g", "m", "distance of the port's inner face in front of the camera (g > 0)", 0.05, 0.05,
                         0.0, None),
        HousingParameter("t", "m", "thickness of the port glass (outer face parallel, t beyond the inner)",
                         0.01, None, 0.0, None),
        HousingParameter("n2", "—", "refractive index of the port glass (acrylic ≈ 1.49, glass ≈ 1.5–1.6)",
                         1.5, None, 1.0, None),
        N3,
    )
    calibration_names = tuple(f"{s}_{side}" for side in ("l", "r") for s in ("d", "e", "g")) + ("t", "n2", "n3")
    start_grid = {"g": (0.02, 0.05, 0.1)}
    geometry = {"distance": "g", "thickness": "t", "n_glass": "n2", "n_water": "n3"}
    report_note = ("System II: port tilt (d, e) and distance g of each camera enter with priors; glass "
                   "thickness t and n2 are fixed unless given, since they are nearly inseparable from g.")

    def __post_init__(self) -> None:
        finite(self, ("d", "e", "g"))
        positive(self, ("t",))
        check_indices(self)
        if self.g <= 0:
            raise InvalidParameterError("g", f"the port must be in front of the camera (g > 0), got {self.g:g}")

    @cached_property
    def surfaces(self) -> tuple[Surface, ...]:
        inner = Plane.from_coefficients(self.d, self.e, self.g)
        # the outer face is the inner one moved t further along the viewing direction (−normal side)
        outer = Plane(inner.normal, inner.offset + self.t)
        return (inner, outer)

    @property
    def indices(self) -> tuple[float, ...]:
        return (self.n1, self.n2, self.n3)

    def parameters(self) -> dict[str, float]:
        return {k: getattr(self, k) for k in ("d", "e", "g", "t", "n2", "n3")}

    @cached_property
    def axis(self) -> np.ndarray:
        """A flat port is always axial: the port normal through the perspective centre, outwards."""
        normal = np.array([self.d, self.e, 1.0]) / np.sqrt(self.d**2 + self.e**2 + 1.0)
        return -normal

    @property
    def is_planar_stack(self) -> bool:
        return True


def flat_port_from_object_space(d: float, e: float, g: float, t: float, n2: float, n3: float,
                                rotation: np.ndarray, position: np.ndarray,
                                n1: float = 1.0) -> FlatPortHousing:
    """System II housing in the camera frame from the seeds' object-space plane (d, e, g)."""
    rot, shift = _to_camera(np.asarray(rotation, float), np.asarray(position, float))
    dc, ec, gc = plane_coefficients(Plane.from_coefficients(d, e, g).transformed(rot, shift))
    return FlatPortHousing(dc, ec, gc, t, n2=n2, n3=n3, n1=n1)
