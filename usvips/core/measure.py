"""The geo-calculator: figures of measured objects with standard deviations propagated from the
vertices' covariances (thesis 3.4.5; the store and the GUI call these).

Points are (N, 3) in metres in the project frame; covariances (N, 3, 3) in m² (one per vertex, as the
intersection gives them) or a full (3N, 3N) matrix when vertices are correlated (e.g. through a common
calibration). Every figure is a :class:`Figure` with its value, standard deviation and unit; the
propagation is first order, σ² = J Σ Jᵀ, with J by central differences of the figure's own formula.

Project frame conventions for bearing and slope: Z is up; the bearing is measured in the XY plane from
+Y towards +X (clockwise seen from above, like a compass with +Y as north), in radians in [0, 2π); the
slope is the angle above the XY plane, in radians in [−π/2, π/2].
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from usvips.core.errors import DegenerateGeometryError, InvalidParameterError

KINDS = ("point", "line", "polygon")


@dataclass(frozen=True)
class Figure:
    """A measured quantity: ``value`` ± ``sigma`` in ``unit``."""

    name: str
    value: float
    sigma: float
    unit: str

    @property
    def relative_precision(self) -> float:
        return self.sigma / abs(self.value) if self.value else float("inf")


@dataclass(frozen=True)
class MeasuredObject:
    """A point, line (polyline) or polygon: vertices (N, 3) metres with covariances (N, 3, 3)."""

    id: str
    kind: str
    points: np.ndarray
    covariances: np.ndarray
    attribute: str = ""
    notes: str = ""

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise InvalidParameterError("kind", f"must be one of {KINDS}, got {self.kind!r}")
        points = np.asarray(self.points, dtype=np.float64).reshape(-1, 3)
        covariances = np.asarray(self.covariances, dtype=np.float64).reshape(-1, 3, 3)
        if len(points) != len(covariances):
            raise InvalidParameterError("covariances", "one 3 × 3 covariance per vertex is needed")
        minimum = {"point": 1, "line": 2, "polygon": 3}[self.kind]
        if len(points) < minimum:
            raise DegenerateGeometryError(f"a {self.kind} needs at least {minimum} vertices, got {len(points)}")
        object.__setattr__(self, "points", points)
        object.__setattr__(self, "covariances", covariances)


def _block_diagonal(covariances: np.ndarray) -> np.ndarray:
    n = len(covariances)
    full = np.zeros((3 * n, 3 * n))
    for i, c in enumerate(covariances):
        full[3 * i:3 * i + 3, 3 * i:3 * i + 3] = c
    return full


def propagate(function: Callable[[np.ndarray], float], points: np.ndarray, covariance: np.ndarray,
              step: float = 1e-6) -> tuple[float, float]:
    """Value and first-order standard deviation of ``function(points)``; ``covariance`` is (N, 3, 3)
    per vertex or (3N, 3N) in full."""
    points = np.asarray(points, dtype=np.float64)
    covariance = np.asarray(covariance, dtype=np.float64)
    full = _block_diagonal(covariance) if covariance.ndim == 3 else covariance
    flat = points.ravel()
    value = float(function(points))
    gradient = np.empty(flat.size)
    for k in range(flat.size):
        ahead, behind = flat.copy(), flat.copy()
        ahead[k] += step
        behind[k] -= step
        gradient[k] = (function(ahead.reshape(points.shape)) - function(behind.reshape(points.shape))) / (2 * step)
    variance = float(gradient @ full @ gradient)
    return value, float(np.sqrt(max(variance, 0.0)))


def _length(points: np.ndarray) -> float:
    return float(np.sum(np.linalg.norm(np.diff(points, axis=0), axis=1)))


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
    points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    if len(points) < 2:
        raise DegenerateGeometryError("a polyline needs at least 2 vertices")
    return Figure("length", *propagate(_length, points, covariance), "m")


def best_fit_plane(points: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """Centroid, unit normal and RMS distance (m) of the least-squares plane through points (N >= 3)."""
    centroid = points.mean(axis=0)
    _, singular, vt = np.linalg.svd(points - centroid)
    if singular[1] <= 1e-12 * max(singular[0], 1e-300):
        raise DegenerateGeometryError("the points are collinear (or coincide): no plane through them")
    normal = vt[2]
    rms = float(np.sqrt(np.mean(((points - centroid) @ normal) ** 2)))
    return centroid, normal, rms


def _upward(normal: np.ndarray) -> np.ndarray:
    """The normal oriented with a positive Z (or, for a vertical plane, positive Y, then X) component."""
    for k in (2, 1, 0):
        if abs(normal[k]) > 1e-12:
            return normal if normal[k] > 0 else -normal
    return normal


def _polygon_area(points: np.ndarray) -> float:
    centroid, normal, _ = best_fit_plane(points)
    u = np.cross(normal, [1.0, 0.0, 0.0])
    if np.linalg.norm(u) < 0.5:
        u = np.cross(normal, [0.0, 1.0, 0.0])
    u /= np.linalg.norm(u)
    v = np.cross(normal, u)
    xy = np.column_stack([(points - centroid) @ u, (points - centroid) @ v])
    x, y = xy[:, 0], xy[:, 1]
    return float(0.5 * abs(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1))))


def polygon_figures(points: np.ndarray, covariance: np.ndarray) -> dict[str, Figure]:
    """Area (m², on the best-fit plane), perimeter (m) and planarity RMS (m) of a closed polygon."""
    points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    if len(points) < 3:
        raise DegenerateGeometryError(f"a polygon needs at least 3 vertices, got {len(points)}")
    _, _, planarity = best_fit_plane(points)
    closed = np.vstack([points, points[:1]])
    area = Figure("area", *propagate(_polygon_area, points, covariance), "m²")
    if area.value <= 0:
        raise DegenerateGeometryError("the polygon has no area")

    def perimeter(p: np.ndarray) -> float:
        return _length(np.vstack([p, p[:1]]))

    return {"area": area, "perimeter": Figure("perimeter", *propagate(perimeter, points, covariance), "m"),
            "planarity_rms": Figure("planarity RMS", planarity, 0.0, "m"),
            "closed_length": Figure("closed length", _length(closed), 0.0, "m")}


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
        return float((p[0] - centroid) @ _upward(normal))

    return Figure("point-plane distance", *propagate(dist, points, covariance), "m")


def bearing_and_slope(points: np.ndarray, covariance: np.ndarray) -> tuple[Figure, Figure]:
    """Bearing (from +Y towards +X, radians in [0, 2π)) and slope (above the XY plane) from p to q."""
    points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    if len(points) != 2 or np.linalg.norm(points[1] - points[0]) == 0:
        raise DegenerateGeometryError("bearing and slope need two distinct points")

    def bearing(p: np.ndarray) -> float:
        d = p[1] - p[0]
        return float(np.arctan2(d[0], d[1]) % (2 * np.pi))

    def slope(p: np.ndarray) -> float:
        d = p[1] - p[0]
        return float(np.arctan2(d[2], np.hypot(d[0], d[1])))

    return (Figure("bearing", *propagate(bearing, points, covariance), "rad"),
            Figure("slope", *propagate(slope, points, covariance), "rad"))


@dataclass(frozen=True)
class QualityRules:
    """Acceptance rules applied to every measurement. Defaults: the stereo-video fish-survey ones —
    ray-intersection RMS ≤ 20 mm, precision/length ≤ 10 %, range ≤ 8 m."""

    max_ray_rms_m: float = 0.020
    max_relative_precision: float = 0.10
    max_range_m: float = 8.0
    extra: dict[str, float] = field(default_factory=dict)

    def check(self, figure: Figure, ray_rms_m: float, range_m: float) -> list[str]:
        """The rules a measurement breaks (empty when it passes)."""
        failures = []
        if ray_rms_m > self.max_ray_rms_m:
            failures.append(f"ray-intersection RMS {ray_rms_m * 1000:.1f} mm > {self.max_ray_rms_m * 1000:.0f} mm")
        if figure.relative_precision > self.max_relative_precision:
            failures.append(f"precision {figure.relative_precision:.1%} of the {figure.name} > "
                            f"{self.max_relative_precision:.0%}")
        if range_m > self.max_range_m:
            failures.append(f"range {range_m:.2f} m > {self.max_range_m:g} m")
        for name, limit in self.extra.items():
            if name == "max_sigma_m" and figure.unit == "m" and figure.sigma > limit:
                failures.append(f"sigma {figure.sigma * 1000:.1f} mm > {limit * 1000:.1f} mm")
        return failures
