"""System I (thesis 2.2.4): a concave spherical inner cover surface and one plane outer cover surface
shared by both cameras of the rig."""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from usvips.core.errors import InvalidParameterError
from usvips.core.housing.base import Housing, _to_camera, plane_coefficients, shared_plane_in_camera
from usvips.core.housing.kinds._shared import N3, check_indices, finite, positive
from usvips.core.housing.parameter import HousingParameter
from usvips.core.surfaces import Plane, Sphere, Surface


@dataclass(frozen=True, repr=False)
class DomeCoverHousing(Housing):
    """System I: concave sphere (a, b, c, r) then cover plane (d, e, g), camera frame, metres.

    n1 (inside, air), n2 (glass), n3 (water) are refractive indices. Physical: r > 0, the perspective
    centre inside the sphere, the plane in front of the camera (g > 0) and outside the sphere.

    Calibration (:meth:`build`): the sphere centre a, b, c per camera, the left sphere's radius r_l and
    one cover plane d, e in the left camera's frame shared by both, placed by the glass thickness t at the
    left cover's thinnest point (g follows: :func:`dome_cover_g`); the right cover's glass thickness t_r at
    its thinnest point (its radius r_r follows: :func:`dome_cover_right_radius`); n2, n3. Every state with
    t > 0, t_r > 0 and each perspective centre inside its sphere is physical for both cameras. Priors: the
    sphere centred on the perspective centre within a few centimetres (0 ± 0.03 m), r = 0.09 ± 0.02 m,
    the plane square to the axis (d, e = 0 ± 0.05), t = 0.03 ± 0.02 m, n2 = 1.6 ± 0.02, n3 = 1.34 ± 0.01.
    """

    a: float
    b: float
    c: float
    r: float
    d: float
    e: float
    g: float
    n2: float = 1.6
    n3: float = 1.34
    n1: float = 1.0

    kind = "dome-cover"
    order = 30
    description = "System I: a concave spherical cover surface per camera, one plane cover for both"
    specs = (
        HousingParameter("a", "m", "x of the centre of the concave spherical inner cover surface (each camera's own)",
                         0.0, 0.03),
        HousingParameter("b", "m", "y of the centre of that sphere", 0.0, 0.03),
        HousingParameter("c", "m", "z of the centre of that sphere (along the optical axis)", 0.0, 0.03),
        HousingParameter("r", "m", "radius of the spherical inner cover surface", 0.09, 0.02, 0.0, None),
        HousingParameter("d", "—", "x slope of the plane outer cover surface d·x + e·y + z + g = 0 "
                         "(0: square to the axis)", 0.0, 0.05),
        HousingParameter("e", "—", "y slope of that cover plane (0: square to the axis)", 0.0, 0.05),
        HousingParameter("t", "m", "glass thickness at the cover's thinnest point (places the cover plane, its g)",
                         0.03, 0.02, 0.0, None),
        HousingParameter("n2", "—", "refractive index of the cover glass (acrylic ≈ 1.49, glass ≈ 1.5–1.6)",
                         1.6, 0.02, 1.0, None),
        N3,
    )
    calibration_names = ("a_l", "b_l", "c_l", "r_l", "a_r", "b_r", "c_r", "t_r", "d", "e", "t", "n2", "n3")
    # they place the shared cover plane (through g), hence the right housing too
    affects_both = frozenset({"a_l", "b_l", "c_l", "r_l"})
    right_follows_rig = True
    start_grid = {"c": (-0.03, 0.0, 0.03), "t": (0.02, 0.05)}
    geometry = {"thickness": "t", "n_glass": "n2", "n_water": "n3"}
    report_note = ("System I: the sphere centre (a, b, c) of each cover, the left radius r_l, the glass "
                   "thickness at each cover's thinnest point (t left, t_r right; the plane's g and the right "
                   "radius follow from them), the shared cover plane's tilt (d, e; left camera frame) and the "
                   "indices n2, n3 enter with priors by default: a sphere centred near the perspective centre "
                   "hardly bends the rays, and cover tilt correlates with the principal point and decentring "
                   "distortion.")

    def __post_init__(self) -> None:
        finite(self, ("a", "b", "c", "d", "e", "g"))
        positive(self, ("r",))
        check_indices(self)
        if np.linalg.norm([self.a, self.b, self.c]) >= self.r:
            raise InvalidParameterError(
                "r", f"the perspective centre must lie inside the cover sphere: |(a, b, c)| = "
                f"{np.linalg.norm([self.a, self.b, self.c]):.4g} m >= r = {self.r:.4g} m")
        if self.g <= 0:
            raise InvalidParameterError("g", f"the cover plane must be in front of the camera (g > 0), got {self.g:g}")
        clearance = (self.d * self.a + self.e * self.b + self.c + self.g) / np.sqrt(self.d**2 + self.e**2 + 1.0)
        if clearance < self.r:
            raise InvalidParameterError(
                "g", f"the cover plane cuts the cover sphere (the sphere centre is {clearance:.4g} m from the plane, "
                f"less than r = {self.r:.4g} m): the glass would have no thickness somewhere")

    @cached_property
    def surfaces(self) -> tuple[Surface, ...]:
        return (Sphere(np.array([self.a, self.b, self.c]), self.r), Plane.from_coefficients(self.d, self.e, self.g))

    @property
    def indices(self) -> tuple[float, ...]:
        return (self.n1, self.n2, self.n3)

    def parameters(self) -> dict[str, float]:
        return {k: getattr(self, k) for k in ("a", "b", "c", "r", "d", "e", "g", "n2", "n3")}

    @property
    def thickness(self) -> float:
        """The glass thickness at the cover's thinnest point (metres)."""
        return float((self.d * self.a + self.e * self.b + self.c + self.g) / np.sqrt(self.d**2 + self.e**2 + 1.0)
                     - self.r)

    @classmethod
    def build(cls, values: dict[str, float], rotation: np.ndarray,
              translation: np.ndarray) -> tuple[Housing, Housing]:
        for name in ("t", "t_r"):
            if name in values and not values[name] > 0:
                raise InvalidParameterError(name, f"the glass must have a thickness, got {values[name]:.4g} m")
        g = dome_cover_g(values)
        left = cls(values["a_l"], values["b_l"], values["c_l"], values["r_l"], values["d"], values["e"], g,
                   values["n2"], values["n3"])
        d_r, e_r, g_r = shared_plane_in_camera(values["d"], values["e"], g, rotation, translation)
        # calibrations written before t_r was estimated carry the right radius r_r itself
        r_r = values["r_r"] if "t_r" not in values else dome_cover_right_radius(values, d_r, e_r, g_r)
        right = cls(values["a_r"], values["b_r"], values["c_r"], r_r, d_r, e_r, g_r, values["n2"], values["n3"])
        return left, right

    @classmethod
    def calibration_values(cls, left: Housing, right: Housing, rotation: np.ndarray,
                           translation: np.ndarray) -> dict[str, float]:
        assert isinstance(left, cls) and isinstance(right, cls)
        return {"a_l": left.a, "b_l": left.b, "c_l": left.c, "r_l": left.r, "a_r": right.a, "b_r": right.b,
                "c_r": right.c, "t_r": right.thickness, "d": left.d, "e": left.e, "t": left.thickness,
                "n2": left.n2, "n3": left.n3}

    @classmethod
    def from_symbols(cls, values: dict[str, float] | None = None) -> Housing:
        chosen = {s.symbol: s.start for s in cls.specs} | dict(values or {})
        if "g" not in chosen:
            chosen["g"] = dome_cover_g({"t": chosen["t"], "r_l": chosen["r"], "d": chosen["d"], "e": chosen["e"],
                                        "a_l": chosen["a"], "b_l": chosen["b"], "c_l": chosen["c"]})
        return cls.from_values({k: v for k, v in chosen.items() if k in cls.field_names()})


def dome_cover_g(values: dict[str, float]) -> float:
    """The cover plane's g (left camera frame) from the glass thickness ``t`` at the left cover's thinnest
    point: the plane lies t beyond the left sphere, g = t + r·sqrt(d² + e² + 1) − (d·a + e·b + c).

    The adjustment estimates t rather than g: t > 0 keeps the plane outside the sphere, far from the wall
    that a free g would run into while the sphere's radius is barely observable."""
    d, e = values["d"], values["e"]
    return (values["t"] + values["r_l"] * np.sqrt(d * d + e * e + 1.0)
            - (d * values["a_l"] + e * values["b_l"] + values["c_l"]))


def dome_cover_right_radius(values: dict[str, float], d_r: float, e_r: float, g_r: float) -> float:
    """The right sphere's radius from its glass thickness ``t_r`` at its thinnest point and the shared plane
    in the right camera's frame (d_r, e_r, g_r): r_r = (d_r·a_r + e_r·b_r + c_r + g_r)/sqrt(d_r² + e_r² + 1) − t_r.

    Estimating t_r instead of r_r keeps the plane outside the right sphere whatever the relative orientation
    does: a free r_r let the right camera's pose push its sphere into the plane, where every step is invalid."""
    clearance = (d_r * values["a_r"] + e_r * values["b_r"] + values["c_r"] + g_r) / np.sqrt(d_r * d_r + e_r * e_r + 1.0)
    return float(clearance - values["t_r"])


def dome_cover_from_object_space(a: float, b: float, c: float, r: float, d: float, e: float, g: float,
                                 n2: float, n3: float, rotation: np.ndarray, position: np.ndarray,
                                 n1: float = 1.0) -> DomeCoverHousing:
    """System I housing in the camera frame from the seeds' object-space (a, b, c, r, d, e, g).

    ``rotation`` is the camera's M (object → image), ``position`` its perspective centre (X0, Y0, Z0).
    """
    rot, shift = _to_camera(np.asarray(rotation, float), np.asarray(position, float))
    center = rot @ np.array([a, b, c], dtype=float) + shift
    dc, ec, gc = plane_coefficients(Plane.from_coefficients(d, e, g).transformed(rot, shift))
    return DomeCoverHousing(*center, r, dc, ec, gc, n2=n2, n3=n3, n1=n1)
