"""The length kind's formula (scalar arithmetic, called 13 times an object for its Jacobian) against the
vector formula over many random segments, and its degenerate case named."""

import numpy as np
import pytest

from usvips.core.errors import DegenerateGeometryError
from usvips.core.measurements.figures import propagate_all
from usvips.core.measurements.kinds.length import Length


def test_length_bearing_and_slope_match_the_vector_formula_over_random_segments():
    rng = np.random.default_rng(11)
    for _ in range(500):
        points = rng.normal(scale=rng.uniform(0.01, 20), size=(2, 3))
        d = points[1] - points[0]
        expected = [np.linalg.norm(d), np.arctan2(d[0], d[1]) % (2 * np.pi), np.arctan2(d[2], np.hypot(d[0], d[1]))]
        assert np.allclose(Length.values(points), expected, rtol=1e-12, atol=1e-12)
        assert 0 <= Length.values(points)[1] < 2 * np.pi


def test_the_length_sigma_is_the_projection_of_the_covariance_on_the_segment():
    """The first-order σ² of |b − a| is u·(Σa + Σb)·u (u the unit direction), over random segments and
    covariances (the second-order part, tested in tests/core/test_second_order_sigma.py, left out)."""
    rng = np.random.default_rng(12)
    for _ in range(200):
        points = rng.normal(size=(2, 3))
        roots = rng.normal(scale=1e-3, size=(2, 3, 3))
        covariances = roots @ roots.transpose(0, 2, 1)
        values, covariance = propagate_all(Length.values, points, covariances, nonlinear=False)
        u = (points[1] - points[0]) / np.linalg.norm(points[1] - points[0])
        assert covariance[0, 0] == pytest.approx(u @ (covariances[0] + covariances[1]) @ u, rel=1e-4)


def test_two_coinciding_vertices_are_named_degenerate():
    with pytest.raises(DegenerateGeometryError, match="coincide"):
        Length.values(np.array([[1.0, 2.0, 3.0], [1.0, 2.0, 3.0]]))


def test_many_segments_at_once_give_each_one_s_values_and_the_same_figures():
    rng = np.random.default_rng(13)
    stack = rng.normal(scale=3.0, size=(300, 2, 3))
    assert np.allclose(Length.values_many(stack), [Length.values(p) for p in stack], rtol=1e-12, atol=1e-12)
    for points in stack[:50]:
        roots = rng.normal(scale=1e-3, size=(2, 3, 3))
        covariances = roots @ roots.transpose(0, 2, 1)
        one, by_one = propagate_all(Length.values, points, covariances)
        many, by_many = propagate_all(Length.values, points, covariances, many=Length.values_many)
        assert np.allclose(one, many, rtol=1e-12) and np.allclose(by_one, by_many, rtol=1e-6, atol=1e-18)
    with pytest.raises(DegenerateGeometryError, match="coincide"):
        Length.values_many(np.ones((3, 2, 3)))
