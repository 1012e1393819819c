"""A point: one vertex; its figures are X, Y, Z (m) with their sigmas."""

from __future__ import annotations

import numpy as np

from usvips.core.measurements.registry import MeasurementKind


class Point(MeasurementKind):
    name = "point"
    order = 10
    description = "Point: each intersected point is stored as an object"
    minimum_vertices = 1
    maximum_vertices = 1
    drawing = "marker"
    figure_names = (("X", "m"), ("Y", "m"), ("Z", "m"))
    main_figure = "Z"
    relative_rule = False  # a coordinate has no relative precision
    eventmeasure = "3DPoints"

    @classmethod
    def values(cls, points: np.ndarray) -> np.ndarray:
        return np.asarray(points[0], dtype=np.float64)
