"""A circle fitted to three or more vertices (e.g. the rim of a burrow or a sponge's osculum): its
diameter (m), centre X, Y, Z (m) and unit normal (upward: positive Z, for a vertical circle +Y, then +X),
each with its sigma. A normal has no sign of its own: for a circle standing nearly vertical the "upward"
choice can flip between two measurements of it; its sigma describes the direction. The fit is the
best-fit plane, then the algebraic circle in that plane (``geometry.fit_circle``); with three vertices
the circle passes through all of them."""

from __future__ import annotations

import numpy as np

from usvips.core.measurements.geometry import fit_circle, plane_axes
from usvips.core.measurements.registry import MeasurementKind


class Circle(MeasurementKind):
    name = "circle"
    order = 50
    description = "Circle: three or more vertices on a rim (Enter finishes); diameter, centre and normal"
    minimum_vertices = 3
    closes = True
    outline_fitted = True
    drawing = "circle"
    figure_names = (("diameter", "m"), ("centre_X", "m"), ("centre_Y", "m"), ("centre_Z", "m"),
                    ("normal_X", "1"), ("normal_Y", "1"), ("normal_Z", "1"))
    eventmeasure = "Circles"
    axial_figures = ("normal_X", "normal_Y", "normal_Z")

    @classmethod
    def values(cls, points: np.ndarray) -> np.ndarray:
        centre, radius, normal = fit_circle(points)
        return np.array([2 * radius, *centre, *normal])

    @classmethod
    def outline(cls, points: np.ndarray, samples: int = 72) -> np.ndarray:
        """The fitted circle sampled at ``samples`` + 1 points (closed), metres."""
        centre, radius, normal = fit_circle(points)
        u, v = plane_axes(normal)
        angles = np.linspace(0.0, 2 * np.pi, samples + 1)
        ring = centre + radius * (np.cos(angles)[:, None] * u + np.sin(angles)[:, None] * v)
        ring[-1] = ring[0]  # closed exactly
        return ring
