"""The geo-calculator: closed forms, and propagated sigmas against Monte Carlo (within 10 %)."""

import numpy as np
import pytest

from usvips.core.errors import DegenerateGeometryError, InvalidParameterError
from usvips.core.measure import (
    Figure,
    MeasuredObject,
    QualityRules,
    angle_between_lines,
    bearing_and_slope,
    distance,
    fish_length,
    point_to_line,
    point_to_plane,
    polygon_figures,
    polyline_length,
)


def covariances(n, seed=0, scale=0.004):
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(n):
        a = rng.normal(0, scale, (3, 3))
        out.append(a @ a.T + np.eye(3) * (scale / 3) ** 2)
    return np.array(out)


def monte_carlo(function, points, covs, trials=2000, seed=1):
    rng = np.random.default_rng(seed)
    noise = np.stack([rng.multivariate_normal(np.zeros(3), c, size=trials) for c in covs], axis=1)
    return float(np.std([function(points + n) for n in noise]))


CASES = [
    ("distance", distance, np.array([[0, 0, -2.0], [0.35, 0.1, -2.2]])),
    ("polyline", polyline_length, np.array([[0, 0, -2.0], [0.3, 0.1, -2.1], [0.5, 0.4, -2.0], [0.8, 0.3, -2.3]])),
    ("area", lambda p, c: polygon_figures(p, c)["area"],
     np.array([[0, 0, -2], [1, 0, -2.1], [1.2, 0.8, -2], [0.1, 1, -1.9]])),
    ("perimeter", lambda p, c: polygon_figures(p, c)["perimeter"], np.array([[0, 0, -2], [1, 0, -2], [0.5, 0.9, -2]])),
    ("angle", angle_between_lines, np.array([[0, 0, -2], [1, 0.2, -2], [0, 0, -2.1], [0.3, 1, -2.0]])),
    ("point-line", point_to_line, np.array([[0.2, 0.5, -2], [0, 0, -2], [1, 0.1, -2.2]])),
    ("point-plane", point_to_plane, np.array([[0.3, 0.3, -1.6], [0, 0, -2], [1, 0, -2], [0, 1, -2], [1, 1, -2.05]])),
    ("bearing", lambda p, c: bearing_and_slope(p, c)[0], np.array([[0, 0, -2.0], [0.5, 0.4, -1.8]])),
    ("slope", lambda p, c: bearing_and_slope(p, c)[1], np.array([[0, 0, -2.0], [0.5, 0.4, -1.8]])),
]


@pytest.mark.parametrize("name, calculator, points", CASES, ids=[c[0] for c in CASES])
def test_propagated_sigmas_agree_with_monte_carlo(name, calculator, points):
    covs = covariances(len(points))
    figure = calculator(points, covs)
    assert isinstance(figure, Figure) and figure.sigma > 0
    empirical = monte_carlo(lambda p: calculator(p, covs).value, points, covs)
    assert figure.sigma == pytest.approx(empirical, rel=0.10)


def test_closed_forms():
    zero = np.zeros((4, 3, 3))
    square = np.array([[0, 0, 0], [2, 0, 0], [2, 2, 0], [0, 2, 0]], float)
    figures = polygon_figures(square, zero)
    assert figures["area"].value == pytest.approx(4.0) and figures["perimeter"].value == pytest.approx(8.0)
    assert figures["planarity_rms"].value == pytest.approx(0.0, abs=1e-12)
    tilted = square @ np.array([[1, 0, 0], [0, np.cos(0.7), np.sin(0.7)], [0, -np.sin(0.7), np.cos(0.7)]])
    assert polygon_figures(tilted, zero)["area"].value == pytest.approx(4.0)
    lines = np.array([[0, 0, 0], [1, 0, 0], [5, 5, 5], [5, 7, 5]], float)
    assert angle_between_lines(lines, zero).value == pytest.approx(np.pi / 2)
    bearing, slope = bearing_and_slope(np.array([[0, 0, 0], [1, 0, 1]], float), zero[:2])
    assert bearing.value == pytest.approx(np.pi / 2) and slope.value == pytest.approx(np.pi / 4)
    assert fish_length(np.array([0, 0, 0.0]), np.array([0.3, 0.4, 0.0]), zero[:2]).value == pytest.approx(0.5)
    assert point_to_plane(np.vstack([[0.5, 0.5, 0.3], square]), np.zeros((5, 3, 3))).value == pytest.approx(0.3)


def test_correlated_vertices_use_the_full_covariance():
    points = np.array([[0, 0, -2.0], [0.5, 0, -2.0]])
    shared = np.zeros((6, 6))
    shared[:3, :3] = shared[3:, 3:] = shared[:3, 3:] = shared[3:, :3] = np.eye(3) * 1e-4
    assert distance(points, shared).sigma == pytest.approx(0.0, abs=1e-9)  # a common shift cancels


def test_quality_rules_and_degenerate_input():
    rules = QualityRules()
    good = Figure("fork length", 0.40, 0.01, "m")
    assert rules.check(good, ray_rms_m=0.005, range_m=3.0) == []
    failures = rules.check(Figure("fork length", 0.10, 0.02, "m"), ray_rms_m=0.03, range_m=9.0)
    assert len(failures) == 3 and "20 mm" in failures[0]
    with pytest.raises(DegenerateGeometryError, match="collinear"):
        polygon_figures(np.array([[0, 0, 0], [1, 1, 1], [2, 2, 2]], float), np.zeros((3, 3, 3)))
    with pytest.raises(DegenerateGeometryError, match="at least 3"):
        MeasuredObject("1", "polygon", np.zeros((2, 3)), np.zeros((2, 3, 3)))
    with pytest.raises(InvalidParameterError, match="kind"):
        MeasuredObject("1", "circle", np.zeros((2, 3)), np.zeros((2, 3, 3)))
    with pytest.raises(DegenerateGeometryError, match="coincide"):
        point_to_line(np.array([[1, 0, 0], [0, 0, 0], [0, 0, 0]], float), np.zeros((3, 3, 3)))
