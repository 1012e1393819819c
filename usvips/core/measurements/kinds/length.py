"""A length: two vertices (a fish: snout then fork); length (m), with the bearing and slope of the
segment from the first vertex to the second (radians; bearing from +Y towards +X in [0, 2π), slope above
the XY plane)."""

from __future__ import annotations

import math

import numpy as np

from usvips.core.errors import DegenerateGeometryError
from usvips.core.measurements.registry import MeasurementKind


class Length(MeasurementKind):
    name = "length"
    order = 20
    description = "Length: two vertices, e.g. a fish snout then fork"
    minimum_vertices = 2
    maximum_vertices = 2
    drawing = "polyline"
    figure_names = (("length", "m"), ("bearing", "rad"), ("slope", "rad"))
    eventmeasure = "Lengths"

    @classmethod
    def values(cls, points: np.ndarray) -> np.ndarray:
        # scalar arithmetic on the six numbers: called 13 times an object for its Jacobian, a survey's
        # 10,000 objects pay numpy's per-call overhead on 3-vectors otherwise
        (x0, y0, z0), (x1, y1, z1) = np.asarray(points, dtype=np.float64).reshape(2, 3).tolist()
        dx, dy, dz = x1 - x0, y1 - y0, z1 - z0
        if dx == 0.0 and dy == 0.0 and dz == 0.0:
            raise DegenerateGeometryError("the length's two vertices coincide")
        horizontal = math.hypot(dx, dy)
        return np.array([math.hypot(horizontal, dz), math.atan2(dx, dy) % (2 * math.pi), math.atan2(dz, horizontal)])

    @classmethod
    def values_many(cls, stack: np.ndarray) -> np.ndarray:
        """:meth:`values` of M vertex pairs (M, 2, 3) at once, (M, 3); the first pair's coinciding vertices
        are degenerate (the others are its Jacobian's shifted copies)."""
        stack = np.asarray(stack, dtype=np.float64).reshape(-1, 2, 3)
        d = stack[:, 1] - stack[:, 0]
        if not np.any(d[0]):
            raise DegenerateGeometryError("the length's two vertices coincide")
        horizontal = np.hypot(d[:, 0], d[:, 1])
        return np.column_stack([np.hypot(horizontal, d[:, 2]), np.arctan2(d[:, 0], d[:, 1]) % (2 * np.pi),
                                np.arctan2(d[:, 2], horizontal)])
