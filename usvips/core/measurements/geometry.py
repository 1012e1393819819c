"""Plain geometry of measured vertices (N, 3) in metres, shared by the measurement kinds and the
geo-calculator: polyline length, best-fit plane, area on that plane, circle through points."""

from __future__ import annotations

import numpy as np

from usvips.core.errors import DegenerateGeometryError


def polyline_length(points: np.ndarray) -> float:
    """Sum of the segment lengths (m) of the open polyline through ``points`` in order."""
    return float(np.sum(np.linalg.norm(np.diff(points, axis=0), axis=1)))


def best_fit_plane(points: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """Centroid, unit normal and RMS distance (m) of the least-squares plane through points (N >= 3)."""
    centroid = points.mean(axis=0)
    _, singular, vt = np.linalg.svd(points - centroid)
    if singular[1] <= 1e-12 * max(singular[0], 1e-300):
        raise DegenerateGeometryError("the points are collinear (or coincide): no plane through them")
    normal = vt[2]
    rms = float(np.sqrt(np.mean(((points - centroid) @ normal) ** 2)))
    return centroid, normal, rms


def upward(normal: np.ndarray) -> np.ndarray:
    """The normal oriented with a positive Z (or, for a vertical plane, positive Y, then X) component."""
    for k in (2, 1, 0):
        if abs(normal[k]) > 1e-12:
            return normal if normal[k] > 0 else -normal
    return normal


def plane_axes(normal: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors u, v spanning the plane of ``normal`` (u, v, normal right-handed)."""
    u = np.cross(normal, [1.0, 0.0, 0.0])
    if np.linalg.norm(u) < 0.5:
        u = np.cross(normal, [0.0, 1.0, 0.0])
    u /= np.linalg.norm(u)
    return u, np.cross(normal, u)


def polygon_area(points: np.ndarray) -> float:
    """Area (m²) of the closed polygon through ``points``, projected onto their best-fit plane."""
    centroid, normal, _ = best_fit_plane(points)
    u, v = plane_axes(normal)
    x, y = (points - centroid) @ u, (points - centroid) @ v
    return float(0.5 * abs(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1))))


def fit_circle(points: np.ndarray) -> tuple[np.ndarray, float, np.ndarray]:
    """Centre (m), radius (m) and upward unit normal of the circle fitted to N >= 3 points: the
    best-fit plane, then the algebraic least-squares circle (Kåsa) of the points projected onto it
    (exact through three points)."""
    centroid, normal, _ = best_fit_plane(points)
    normal = upward(normal)
    u, v = plane_axes(normal)
    x, y = (points - centroid) @ u, (points - centroid) @ v
    design = np.column_stack([2 * x, 2 * y, np.ones_like(x)])
    solution, *_ = np.linalg.lstsq(design, x * x + y * y, rcond=None)
    a, b, c = solution
    radius_squared = c + a * a + b * b
    if not np.isfinite(radius_squared) or radius_squared <= 0:
        raise DegenerateGeometryError("no circle fits the points")
    return centroid + a * u + b * v, float(np.sqrt(radius_squared)), normal
