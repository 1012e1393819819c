"""An arc: an open polyline of two or more vertices (the seeds' word); its figure is its length (m),
the sum of its segments."""

from __future__ import annotations

import numpy as np

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
        return np.array([polyline_length(points)])
