"""The geo-calculator's model (Qt-free): figures of one or two measured objects, with sigmas and the
quality rules, from the objects' vertices and their joint covariance.

Points are (N, 3) metres in the frame the objects were measured in; ``covariance`` is the full
(3N, 3N) matrix in m² (a common calibration correlates vertices, so lengths are not given block-diagonal
sigmas when the full matrix is known).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from usvips.core.errors import UsvipsError
from usvips.core.measure import (
    Figure,
    QualityRules,
    angle_between_lines,
    bearing_and_slope,
    distance,
    point_to_line,
    point_to_plane,
    polygon_figures,
    polyline_length,
)


@dataclass(frozen=True)
class Geometry:
    """One object's vertices (N, 3) m with the full covariance (3N, 3N) m², ray-intersection RMS (m) and
    largest range from the left camera (m)."""

    kind: str
    points: np.ndarray
    covariance: np.ndarray
    ray_rms_m: float = 0.0
    range_m: float = 0.0


@dataclass(frozen=True)
class Result:
    """Figures of a selection, the quality rules each main figure breaks, and why nothing could be
    computed when the selection does not fit any figure."""

    figures: tuple[Figure, ...]
    failures: tuple[str, ...] = ()
    reason: str = ""


def _point_figures(points: np.ndarray, covariance: np.ndarray) -> list[Figure]:
    sigmas = np.sqrt(np.clip(np.diag(covariance)[:3], 0, None))
    return [Figure(axis, float(points[0, i]), float(sigmas[i]), "m") for i, axis in enumerate("XYZ")]


def object_figures(geometry: Geometry, rules: QualityRules | None = None) -> Result:
    """Point: X, Y, Z; line: length (and bearing, slope for two vertices); polygon: area, perimeter,
    planarity RMS. The main figure (length or area) is checked against ``rules``."""
    rules = rules or QualityRules()
    p, c = geometry.points, geometry.covariance
    try:
        if geometry.kind == "point":
            return Result(tuple(_point_figures(p, c)), tuple(vertex_failures(rules, geometry.ray_rms_m,
                                                                             geometry.range_m)))
        if geometry.kind == "line":
            main = polyline_length(p, c)
            figures = [main]
            if len(p) == 2:
                figures.extend(bearing_and_slope(p, c))
        else:
            polygon = polygon_figures(p, c)
            main = polygon["area"]
            figures = [main, polygon["perimeter"], polygon["planarity_rms"]]
    except UsvipsError as error:
        return Result((), (), str(error))
    failures = rules.check(main, geometry.ray_rms_m, geometry.range_m)
    return Result(tuple(figures), tuple(failures))


def vertex_failures(rules: QualityRules, ray_rms_m: float, range_m: float) -> list[str]:
    """The rules an intersected point breaks by itself: ray-intersection RMS (m) and range (m); the
    precision rule needs a figure and is checked on lengths and areas."""
    return rules.check(Figure("position", 1.0, 0.0, "m"), ray_rms_m, range_m)


def _joined(first: Geometry, second: Geometry, joint: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    points = np.vstack([first.points, second.points])
    if joint is not None:
        return points, joint
    n1 = 3 * len(first.points)
    covariance = np.zeros((len(points) * 3,) * 2)
    covariance[:n1, :n1] = first.covariance
    covariance[n1:, n1:] = second.covariance
    return points, covariance


def pair_figures(first: Geometry, second: Geometry, joint: np.ndarray | None = None) -> Result:
    """Figures between two objects: point–point distance, point–line distance, point–plane distance (the
    plane of a polygon), angle between two two-vertex lines. ``joint`` is their common (3N, 3N)
    covariance when known (same calibration), otherwise the objects are taken as uncorrelated."""
    if second.kind == "point" and first.kind != "point":
        return pair_figures(second, first, None if joint is None else _swap(joint, len(first.points)))
    points, covariance = _joined(first, second, joint)
    try:
        if first.kind == "point" and second.kind == "point":
            return Result((distance(points, covariance),))
        if first.kind == "point" and second.kind == "line" and len(second.points) == 2:
            return Result((point_to_line(points, covariance),))
        if first.kind == "point" and second.kind == "polygon":
            return Result((point_to_plane(points, covariance),))
        if first.kind == "line" and second.kind == "line" and len(first.points) == len(second.points) == 2:
            return Result((angle_between_lines(points, covariance),))
    except UsvipsError as error:
        return Result((), (), str(error))
    return Result((), (), f"no figure between a {first.kind} with {len(first.points)} vertices and a "
                          f"{second.kind} with {len(second.points)}: select two points, a point and a "
                          "two-vertex line, a point and a polygon, or two two-vertex lines")


def _swap(joint: np.ndarray, n_first: int) -> np.ndarray:
    """The joint covariance with the two objects' blocks exchanged."""
    order = np.r_[np.arange(3 * n_first, len(joint)), np.arange(3 * n_first)]
    return joint[np.ix_(order, order)]


def format_figure(figure: Figure) -> str:
    """``name value ± sigma unit`` in readable units (mm below a metre, degrees for angles)."""
    if figure.unit == "rad":
        return f"{figure.name} {np.degrees(figure.value):.2f}° ± {np.degrees(figure.sigma):.2f}°"
    if figure.unit == "m²":
        return f"{figure.name} {figure.value:.4f} m² ± {figure.sigma:.4f} m²"
    if figure.unit == "m" and abs(figure.value) < 1.0 and figure.name not in "XYZ":
        return f"{figure.name} {figure.value * 1000:.1f} mm ± {figure.sigma * 1000:.1f} mm"
    return f"{figure.name} {figure.value:.4f} m ± {figure.sigma * 1000:.1f} mm"
