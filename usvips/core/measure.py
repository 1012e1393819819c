"""The geo-calculator: figures of measured vertices with standard deviations propagated from their
covariance (thesis 3.4.5). Figures of one object come from its kind (``usvips.core.measurements``);
the figures *between* objects (distance, point–line, point–plane, angle, bearing and slope) are here.

Points are (N, 3) in metres in the project frame; covariances (N, 3, 3) in m² (one per vertex, as the
intersection gives them) or a full (3N, 3N) matrix when vertices are correlated (e.g. through a common
calibration). Every figure is a :class:`Figure` with its value, standard deviation and unit; the
propagation is first order, σ² = J Σ Jᵀ, with J by central differences of the figure's own formula.

Project frame conventions for bearing and slope: Z is up; the bearing is measured in the XY plane from
+Y towards +X (clockwise seen from above, like a compass with +Y as north), in radians in [0, 2π); the
slope is the angle above the XY plane, in radians in [−π/2, π/2].
"""

from __future__ import annotations

import numpy as np

from usvips.core.errors import DegenerateGeometryError
from usvips.core.measurements import kind
from usvips.core.measurements.figures import Figure, QualityRules, propagate
from usvips.core.measurements.geometry import best_fit_plane, upward
from usvips.core.measurements.geometry import polyline_length as _length

__all__ = ["Figure", "QualityRules", "angle_between_lines", "bearing_and_slope", "best_fit_plane", "distance",
           "fish_length", "point_to_line", "point_to_plane", "polygon_figures", "polyline_length", "propagate"]


def distance(points: np.ndarray, covariance: np.ndarray) -> Figure:
    """Distance between two points (m)."""
    points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    if len(points) != 2:
        raise DegenerateGeometryError(f"a distance needs exactly 2 points, got {len(points)}")
    return Figure("distance", *propagate(_length, points, covariance), "m")


def fish_length(snout: np.ndarray, fork: np.ndarray, covariance: np.ndarray) -> Figure:
    """Snout-to-fork length (m) from the two picked points."""
    value, sigma = propagate(_length, np.vstack([snout, fork]), covariance)
    return Figure("fork length", value, sigma, "m")


def polyline_length(points: np.ndarray, covariance: np.ndarray) -> Figure:
    """Length (m) of an open polyline (an arc) with its sigma."""
    points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    return kind("arc").figures(points, covariance)[0]


def polygon_figures(points: np.ndarray, covariance: np.ndarray) -> dict[str, Figure]:
    """Area (m², on the best-fit plane), perimeter (m) and planarity RMS (m) of a closed polygon."""
    points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    return {f.name: f for f in kind("polygon").figures(points, covariance)}


def angle_between_lines(points: np.ndarray, covariance: np.ndarray) -> Figure:
    """Angle (radians, 0..π/2) between line a0-a1 and line b0-b1, points ordered a0, a1, b0, b1."""
    points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    if len(points) != 4:
        raise DegenerateGeometryError("an angle between two lines needs 4 points")

    def angle(p: np.ndarray) -> float:
        a, b = p[1] - p[0], p[3] - p[2]
        na, nb = np.linalg.norm(a), np.linalg.norm(b)
        if na == 0 or nb == 0:
            raise DegenerateGeometryError("a line's two points coincide")
        cosine = abs(float(a @ b)) / (na * nb)
        return float(np.arctan2(np.linalg.norm(np.cross(a, b)) / (na * nb), cosine))

    return Figure("angle", *propagate(angle, points, covariance), "rad")


def point_to_line(points: np.ndarray, covariance: np.ndarray) -> Figure:
    """Distance (m) of point p from the line through a and b; points ordered p, a, b."""
    points = np.asarray(points, dtype=np.float64).reshape(-1, 3)

    def dist(p: np.ndarray) -> float:
        direction = p[2] - p[1]
        length = np.linalg.norm(direction)
        if length == 0:
            raise DegenerateGeometryError("the line's two points coincide")
        return float(np.linalg.norm(np.cross(p[0] - p[1], direction)) / length)

    return Figure("point-line distance", *propagate(dist, points, covariance), "m")


def point_to_plane(points: np.ndarray, covariance: np.ndarray) -> Figure:
    """Signed distance (m) of the first point from the best-fit plane of the others (N >= 4 points),
    positive on the side the plane's upward normal points to (Z up; for a vertical plane +Y, then +X)."""
    points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    if len(points) < 4:
        raise DegenerateGeometryError("a point-to-plane distance needs the point and at least 3 plane points")

    def dist(p: np.ndarray) -> float:
        centroid, normal, _ = best_fit_plane(p[1:])
        return float((p[0] - centroid) @ upward(normal))

    return Figure("point-plane distance", *propagate(dist, points, covariance), "m")


def bearing_and_slope(points: np.ndarray, covariance: np.ndarray) -> tuple[Figure, Figure]:
    """Bearing (from +Y towards +X, radians in [0, 2π)) and slope (above the XY plane) from p to q."""
    points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    if len(points) != 2 or np.linalg.norm(points[1] - points[0]) == 0:
        raise DegenerateGeometryError("bearing and slope need two distinct points")
    figures = kind("length").figures(points, covariance)
    return figures[1], figures[2]
