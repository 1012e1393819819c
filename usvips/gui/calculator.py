"""The geo-calculator's model (Qt-free): figures of one or two measured objects, with sigmas and the
quality rules, from the objects' vertices and their joint covariance.

Points are (N, 3) metres in the frame the objects were measured in; ``covariance`` is the full
(3N, 3N) matrix in m² (a common calibration correlates vertices, so lengths are not given block-diagonal
sigmas when the full matrix is known).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from usvips.core.errors import UsvipsError
from usvips.core.measure import angle_between_lines, distance, point_to_line, point_to_plane
from usvips.core.measurements import Figure, Measurement, QualityRules, kind
from usvips.gui.wording import article, plural


@dataclass(frozen=True)
class Geometry:
    """One object's vertices (N, 3) m with the full covariance (3N, 3N) m², ray-intersection RMS (m) and
    largest range from the left camera (m)."""

    kind: str
    points: np.ndarray
    covariance: np.ndarray
    ray_rms_m: float | None = None
    range_m: float | None = None


@dataclass(frozen=True)
class Result:
    """Figures of a selection, the quality rules each main figure breaks, and why nothing could be
    computed when the selection does not fit any figure."""

    figures: tuple[Figure, ...]
    failures: tuple[str, ...] = ()
    reason: str = ""
    #: the measurement the figures are of (one object's; None between two objects or with a reason), kept
    #: so that the survey's QA (:mod:`usvips.app.quality`) checks the cached figures without computing again
    measurement: Measurement | None = field(default=None, compare=False, repr=False)


def result_of(measurement: Measurement) -> Result:
    """The calculator's view of a measured object: its figures, main one first, and the rules it breaks."""
    main = measurement.main
    return Result((main, *(f for f in measurement.figures if f is not main)), measurement.failures,
                  measurement=measurement)


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


def _role(geometry: Geometry) -> str:
    """What an object is to the figures between objects, from how its kind is drawn: a ``point`` (a
    marker), a ``segment`` (a two-vertex polyline) or a ``plane`` (a closed outline of 3+ vertices)."""
    try:
        measurement_kind = kind(geometry.kind)
    except UsvipsError:
        return ""
    n = len(geometry.points)
    if measurement_kind.drawing == "marker" and n == 1:
        return "point"
    if measurement_kind.drawing == "polyline" and n == 2:
        return "segment"
    return "plane" if measurement_kind.closes and n >= 3 else ""


#: (role of the first object, role of the second) → the figure between them.
_BETWEEN = {("point", "point"): distance, ("point", "segment"): point_to_line, ("point", "plane"): point_to_plane,
            ("segment", "segment"): angle_between_lines}


def pair_figures(first: Geometry, second: Geometry, joint: np.ndarray | None = None) -> Result:
    """Figures between two objects: point–point distance, point–line distance (a two-vertex length or
    arc), point–plane distance (the plane of a polygon or circle), angle between two two-vertex lines.
    ``joint`` is their common (3N, 3N) covariance when known (same calibration), otherwise the objects
    are taken as uncorrelated."""
    if _role(second) == "point" and _role(first) != "point":
        return pair_figures(second, first, None if joint is None else _swap(joint, len(first.points)))
    points, covariance = _joined(first, second, joint)
    figure = _BETWEEN.get((_role(first), _role(second)))
    if figure is None:
        return Result((), (), f"no figure between {article(first.kind)} with {plural(len(first.points), 'vertex')} "
                              f"and {article(second.kind)} with {len(second.points)}: select two points, a point and a "
                              "two-vertex length, a point and a polygon or circle (its plane), or two "
                              "two-vertex lengths")
    try:
        return Result((figure(points, covariance),))
    except UsvipsError as error:
        return Result((), (), str(error))


def _swap(joint: np.ndarray, n_first: int) -> np.ndarray:
    """The joint covariance with the two objects' blocks exchanged."""
    order = np.r_[np.arange(3 * n_first, len(joint)), np.arange(3 * n_first)]
    return joint[np.ix_(order, order)]


def format_figure(figure: Figure) -> str:
    """``name value ± sigma unit`` in readable units (mm below a metre, degrees for angles)."""
    name = figure.label
    if figure.unit == "rad":
        return f"{name} {np.degrees(figure.value):.2f}° ± {np.degrees(figure.sigma):.2f}°"
    if figure.unit == "m²":
        return f"{name} {figure.value:.4f} m² ± {figure.sigma:.4f} m²"
    if figure.unit == "1":
        return f"{name} {figure.value:.4f} ± {figure.sigma:.4f}"
    if figure.unit == "m" and abs(figure.value) < 1.0 and figure.name not in "XYZ" and "centre" not in name:
        return f"{name} {figure.value * 1000:.1f} mm ± {figure.sigma * 1000:.1f} mm"
    return f"{name} {figure.value:.4f} m ± {figure.sigma * 1000:.1f} mm"
