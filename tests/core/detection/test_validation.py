"""Measuring a detector against truth: the matching counts found, missed and false detections and ignores
objects that need not be found; the pointing σ is the standard deviation of Gaussian errors (Monte Carlo)
and is not pulled by a few gross misses."""

import numpy as np
import pytest

from usvips.core.detection import Detection, Keypoint
from usvips.core.detection.validation import TrueObject, ValidationFigures, match_image, pointing_sigma
from usvips.core.errors import InvalidParameterError


def _detection(snout, fork, score=0.9):
    points = np.array([snout, fork], float)
    x0, y0 = points.min(axis=0) - 5
    x1, y1 = points.max(axis=0) + 5
    return Detection((x0, y0, x1, y1), "fish", score, (Keypoint("snout", *snout, 0.9), Keypoint("fork", *fork, 0.9)))


def test_pointing_sigma_is_the_standard_deviation_of_gaussian_errors():
    rng = np.random.default_rng(1)
    estimates = []
    for _ in range(400):
        sigma = rng.uniform(0.3, 3.0)
        estimates.append(pointing_sigma(rng.normal(0, sigma, (200, 2))) / sigma)
    assert abs(np.mean(estimates) - 1) < 0.01
    assert 0.03 < np.std(estimates) < 0.08  # a median's spread over 400 values


def test_pointing_sigma_is_robust_to_a_few_gross_misses_and_counts_a_bias():
    rng = np.random.default_rng(2)
    errors = rng.normal(0, 1.0, (500, 2))
    errors[:25] = rng.uniform(20, 60, (25, 2))  # 5 % gross misses
    assert 0.95 < pointing_sigma(errors) < 1.15
    assert pointing_sigma(rng.normal(0, 1.0, (500, 2)) + 2.0) > 1.8  # a bias is an error
    with pytest.raises(InvalidParameterError, match="at least 5"):
        pointing_sigma(np.zeros((4, 2)))
    with pytest.raises(InvalidParameterError, match="finite"):
        pointing_sigma(np.full((6, 2), np.nan))


def test_matching_counts_found_missed_false_and_ignores_objects_not_required():
    truths = [TrueObject({"snout": (100.0, 100.0), "fork": (200.0, 100.0)}),
              TrueObject({"snout": (100.0, 300.0), "fork": (200.0, 300.0)}),
              TrueObject({"snout": (400.0, 100.0), "fork": (500.0, 100.0)}, required=False),
              TrueObject({"snout": (400.0, 300.0), "fork": (500.0, 300.0)})]
    detections = [_detection((101.0, 99.0), (198.0, 100.0)),  # the first fish
                  _detection((102.0, 301.0), (201.0, 302.0)),  # the second
                  _detection((401.0, 100.0), (499.0, 101.0)),  # the one not required: neither way
                  _detection((100.0, 100.0), (140.0, 100.0)),  # a fork 60 px off (tolerance 20 px): false
                  _detection((700.0, 400.0), (800.0, 400.0))]  # nothing there: false
    figures = ValidationFigures()
    match_image(detections, truths, figures)
    assert (figures.found, figures.missed, figures.false) == (2, 1, 2)
    assert figures.recall == pytest.approx(2 / 3) and figures.precision == pytest.approx(0.5)
    np.testing.assert_allclose(figures.keypoint_errors("fork"), [[-2.0, 0.0], [1.0, 2.0]])
    np.testing.assert_allclose(figures.keypoint_errors("snout"), [[1.0, -1.0], [2.0, 1.0]])
    assert figures.median_error("fork") == pytest.approx(np.median([2.0, np.sqrt(5)]))


def test_two_detections_of_one_fish_are_one_found_and_one_false_and_errors_scale():
    truths = [TrueObject({"snout": (0.0, 0.0), "fork": (100.0, 0.0)})]
    detections = [_detection((3.0, 0.0), (100.0, 0.0)), _detection((1.0, 0.0), (100.0, 0.0))]
    figures = ValidationFigures()
    match_image(detections, truths, figures, scale=0.5)
    assert (figures.found, figures.missed, figures.false) == (1, 0, 1)
    np.testing.assert_allclose(figures.keypoint_errors("snout"), [[0.5, 0.0]])  # the closer one, scaled
    empty = ValidationFigures()
    match_image([], truths, empty)
    assert (empty.found, empty.missed, empty.false) == (0, 1, 0) and np.isnan(empty.precision)


def test_a_detection_in_the_box_of_an_object_not_required_counts_neither_way():
    hidden = TrueObject({"snout": (400.0, 100.0), "fork": (500.0, 100.0)}, required=False, box=(390, 70, 530, 130))
    cut = TrueObject({"snout": (-40.0, 300.0), "fork": (20.0, 300.0)}, required=False)  # no box: no region
    found = TrueObject({"snout": (100.0, 100.0), "fork": (200.0, 100.0)}, box=(90, 70, 230, 130))
    detections = [_detection((420.0, 110.0), (515.0, 90.0)),  # keypoints off the hidden fish, inside its box
                  _detection((0.0, 300.0), (30.0, 300.0)),  # off the cut fish, which has no box: false
                  _detection((101.0, 100.0), (199.0, 100.0)),  # the required fish
                  _detection((120.0, 100.0), (150.0, 100.0))]  # off inside a REQUIRED fish's box: false
    figures = ValidationFigures()
    match_image(detections, [hidden, cut, found], figures)
    assert (figures.found, figures.missed, figures.false) == (1, 0, 2)
