"""A polygon: three or more vertices, closed. Figures: area (m², on the best-fit plane), perimeter (m)
and planarity RMS (m, the RMS distance of the vertices from that plane), all with sigmas from one
Jacobian. The planarity sigma is first order: it describes the RMS well when the RMS is large compared
with the vertices' sigmas; for a polygon flat within its noise the RMS is biased up and its spread is
smaller than the first-order sigma of a clearly non-planar one (a folded distribution near zero)."""

from __future__ import annotations

import numpy as np

from usvips.core.errors import DegenerateGeometryError
from usvips.core.measurements.geometry import best_fit_plane, polygon_area, polyline_length
from usvips.core.measurements.registry import MeasurementKind


class Polygon(MeasurementKind):
    name = "polygon"
    order = 40
    description = "Polygon: an area digitised vertex by vertex (Enter finishes)"
    minimum_vertices = 3
    closes = True
    drawing = "polygon"
    figure_names = (("area", "m²"), ("perimeter", "m"), ("planarity_rms", "m"))
    eventmeasure = "Polygons"

    @classmethod
    def values(cls, points: np.ndarray) -> np.ndarray:
        area = polygon_area(points)  # names collinear vertices (no best-fit plane)
        if area <= 0:
            raise DegenerateGeometryError("the polygon has no area")
        return np.array([area, polyline_length(np.vstack([points, points[:1]])), best_fit_plane(points)[2]])
