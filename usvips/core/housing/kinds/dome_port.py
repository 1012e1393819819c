"""The hemispherical dome port: a spherical glass shell of concentric inner and outer surfaces in front
of each camera, the camera's perspective centre decentred from the dome centre.

The model of the Kiel refractive-calibration work (She, Song, Mohrmann, Köser 2019, "Adjustment and
calibration of dome port camera systems for underwater vision"; She, Nakath, Song, Köser 2022,
"Refractive geometry for underwater domes", ISPRS J.): a pinhole exactly at the dome centre sees no
refraction; a decentred one becomes an axial camera whose axis joins the perspective centre and the dome
centre. The decentring is what a calibration estimates; the dome's radius and thickness come from the
manufacturer and are held by priors, and the glass and water indices hardly matter near the centre (they
are held by priors too).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from usvips.core.errors import InvalidParameterError
from usvips.core.housing.base import Housing
from usvips.core.housing.kinds._shared import N3, check_indices, finite, positive
from usvips.core.housing.parameter import HousingParameter
from usvips.core.surfaces import Sphere, Surface


@dataclass(frozen=True, repr=False)
class DomePortHousing(Housing):
    """A dome port: inner sphere radius r, glass thickness t (outer radius r + t), both centred on the dome
    centre; the perspective centre sits at (dx, dy, dz) from the dome centre (camera frame: x right, y up,
    the camera looking along −z; metres), so the dome centre is at (−dx, −dy, −dz) in the camera frame.
    dz > 0: the camera sits behind the centre (away from the dome), dz < 0 in front of it.

    n1 (air inside), n2 (glass: acrylic ≈ 1.49, borosilicate ≈ 1.47), n3 (water). Physical: r > 0,
    t > 0, positive indices and the perspective centre inside the inner sphere (|(dx, dy, dz)| < r).

    Calibration: dx, dy, dz per camera (``dx_l`` … ``dz_r``), r, t, n2, n3 shared (both cameras behind
    domes of one model). Priors: a lens mounted at the centre to within a few millimetres
    (dx, dy = 0 ± 0.005 m; along the axis, where the entrance pupil is hardest to place, dz = 0 ± 0.01 m);
    r = 0.05 ± 0.001 m and t = 0.008 ± 0.0005 m as a manufacturer states them (give the values of your
    dome as known values); n2 = 1.49 ± 0.01 (acrylic), n3 = 1.34 ± 0.01.
    """

    dx: float
    dy: float
    dz: float
    r: float
    t: float
    n2: float = 1.49
    n3: float = 1.34
    n1: float = 1.0

    kind = "dome-port"
    order = 40
    description = "a hemispherical dome port per camera (concentric spheres), the camera decentred from its centre"
    specs = (
        HousingParameter("dx", "m", "x of the perspective centre from the dome centre (decentring, right)",
                         0.0, 0.005),
        HousingParameter("dy", "m", "y of the perspective centre from the dome centre (decentring, up)",
                         0.0, 0.005),
        HousingParameter("dz", "m", "z of the perspective centre from the dome centre (decentring along the "
                         "axis; > 0: behind the centre)", 0.0, 0.01),
        HousingParameter("r", "m", "inner radius of the dome (from the manufacturer)", 0.05, 0.001, 0.0, None),
        HousingParameter("t", "m", "glass thickness of the dome (outer radius r + t; from the manufacturer)",
                         0.008, 0.0005, 0.0, None),
        HousingParameter("n2", "—", "refractive index of the dome (acrylic ≈ 1.49, glass ≈ 1.47–1.52)",
                         1.49, 0.01, 1.0, None),
        N3,
    )
    calibration_names = tuple(f"{s}_{side}" for side in ("l", "r") for s in ("dx", "dy", "dz")) + (
        "r", "t", "n2", "n3")
    start_grid = {"dz": (-0.005, 0.0, 0.005)}
    geometry = {"thickness": "t", "n_glass": "n2", "n_water": "n3"}
    report_note = ("Dome port: each camera's decentring from its dome centre (dx, dy, dz; camera frame) is "
                   "estimated with a weak prior; the dome's radius r and thickness t (from the manufacturer) and "
                   "the indices n2, n3 enter with priors, since a camera near the dome centre hardly sees them. "
                   "Decentring along the axis (dz) is the least observable and correlates with the principal "
                   "distance.")

    def __post_init__(self) -> None:
        finite(self, ("dx", "dy", "dz"))
        positive(self, ("r", "t"))
        check_indices(self)
        offset = float(np.linalg.norm([self.dx, self.dy, self.dz]))
        if offset >= self.r:
            raise InvalidParameterError(
                "dx", f"the perspective centre must lie inside the dome: decentring |(dx, dy, dz)| = {offset:.4g} m "
                f">= r = {self.r:.4g} m")

    @property
    def center(self) -> np.ndarray:
        """The dome centre in the camera frame (metres)."""
        return -np.array([self.dx, self.dy, self.dz], dtype=float)

    @cached_property
    def surfaces(self) -> tuple[Surface, ...]:
        return (Sphere(self.center, self.r), Sphere(self.center, self.r + self.t))

    @property
    def indices(self) -> tuple[float, ...]:
        return (self.n1, self.n2, self.n3)

    def parameters(self) -> dict[str, float]:
        return {k: getattr(self, k) for k in ("dx", "dy", "dz", "r", "t", "n2", "n3")}
