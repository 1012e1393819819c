"""Fixtures of synthetic cameras and housings with known truth (fixed seeds)."""

from __future__ import annotations

import numpy as np

from usvips.core.camera import Camera, Exterior
from usvips.core.housing import AirHousing, DomeCoverHousing, DomePortHousing, FlatPortHousing, GeneralHousing
from usvips.core.interior import Interior
from usvips.core.surfaces import ImplicitSurface, Plane

WIDTH, HEIGHT = 1280, 960


def make_interior(distortion: bool = True) -> Interior:
    if distortion:
        return Interior(f=1050.0, xp=652.3, yp=471.8, sy=1.03, k1=-0.12, k2=0.05, p1=4e-4, p2=-3e-4)
    return Interior(f=1050.0, xp=652.3, yp=471.8, sy=1.03)


def _ellipsoid_port() -> GeneralHousing:
    """A general implicit surface: an ellipsoidal dome, then a flat outer face (not axial)."""
    center = np.array([0.003, -0.002, 0.01])
    semi = np.array([0.10, 0.095, 0.09])

    def function(p: np.ndarray) -> np.ndarray:
        q = (p - center) / semi
        return np.sum(q * q, axis=1) - 1.0

    def gradient(p: np.ndarray) -> np.ndarray:
        return 2 * (p - center) / semi**2

    surface = ImplicitSurface(function, gradient, reach=0.5, steps=50)
    return GeneralHousing((surface, Plane.from_coefficients(0.02, -0.01, 0.14)), (1.0, 1.52, 1.34))


HOUSINGS = {
    "air": AirHousing(),
    "flat-port": FlatPortHousing(0.03, -0.02, 0.06, 0.016, 1.65, 1.34),
    "dome-cover": DomeCoverHousing(0.004, -0.003, 0.02, 0.09, 0.01, -0.02, 0.11, 1.6, 1.34),
    "dome-axial": DomeCoverHousing(0.0, 0.0, 0.02, 0.09, 0.0, 0.0, 0.12, 1.6, 1.34),
    "implicit": _ellipsoid_port(),
    "dome-port": DomePortHousing(0.003, -0.002, 0.006, 0.05, 0.008, 1.49, 1.34),
}


def make_camera(housing, distortion: bool = True, exterior: Exterior | None = None) -> Camera:
    exterior = exterior or Exterior(0.31, -0.22, 1.5, 0.05, -0.12, 0.3)
    return Camera(make_interior(distortion), exterior, housing, WIDTH, HEIGHT)


def frame_grid(step: int = 40) -> np.ndarray:
    """Pixels over the whole frame, corners included."""
    xs = np.arange(0, WIDTH, step, dtype=float)
    ys = np.arange(0, HEIGHT, step, dtype=float)
    grid = np.array(np.meshgrid(xs, ys)).reshape(2, -1).T
    corners = np.array([[0, 0], [WIDTH - 1, 0], [0, HEIGHT - 1], [WIDTH - 1, HEIGHT - 1]], dtype=float)
    return np.vstack([grid, corners])
