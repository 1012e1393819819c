"""A length: two vertices (a fish: snout then fork); length (m), with the bearing and slope of the
segment from the first vertex to the second (radians; bearing from +Y towards +X in [0, 2π), slope above
the XY plane)."""

from __future__ import annotations

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
        d = points[1] - points[0]
        if not np.any(d):
            raise DegenerateGeometryError("the length's two vertices coincide")
        return np.array([np.linalg.norm(d), np.arctan2(d[0], d[1]) % (2 * np.pi),
                         np.arctan2(d[2], np.hypot(d[0], d[1]))])
