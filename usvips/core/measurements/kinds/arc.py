"""An arc: an open polyline of two or more vertices (the seeds' word); its figure is its length (m),
the sum of its segments."""

from __future__ import annotations

import numpy as np

from usvips.core.errors import DegenerateGeometryError
from usvips.core.measurements.geometry import polyline_length
from usvips.core.measurements.registry import MeasurementKind


class Arc(MeasurementKind):
    name = "arc"
    order = 30
    description = "Arc: a polyline digitised vertex by vertex (Enter finishes); its length"
    minimum_vertices = 2
    drawing = "polyline"
    figure_names = (("length", "m"),)
    eventmeasure = "Lengths"

    @classmethod
    def values(cls, points: np.ndarray) -> np.ndarray:
        points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        same = np.flatnonzero(~np.any(points[1:] != points[:-1], axis=1))
        if same.size:  # a segment of no length: no direction, so the length has no derivative there
            raise DegenerateGeometryError(f"the arc's vertices {same[0]} and {same[0] + 1} coincide")
        return np.array([polyline_length(points)])
