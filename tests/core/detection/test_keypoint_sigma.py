"""A model's keypoint pointing sigma measured per keypoint, from validation data with truth and from
reviewers' corrections, over many random cases: the estimate recovers the sigma the errors were drawn with
(within its own stated uncertainty), blunders do not inflate it, and too few points are refused."""

import numpy as np
import pytest

from usvips.core.detection.keypoint_sigma import MIN_POINTS, sigma_from_corrections, sigma_from_truth
from usvips.core.errors import InvalidParameterError

NAMES = ("snout", "fork")


def test_validation_recovers_each_keypoints_sigma_within_its_stated_uncertainty():
    rng = np.random.default_rng(350)
    z = []
    for _ in range(200):
        sigma = {"snout": rng.uniform(0.5, 3.0), "fork": rng.uniform(0.5, 3.0)}
        n = int(rng.integers(40, 400))
        truth = rng.uniform(0, 1920, (n, 2, 2))
        model = truth + rng.normal(size=(n, 2, 2)) * np.array([sigma[k] for k in NAMES])[None, :, None]
        measured = sigma_from_truth(NAMES, model, truth)
        for name in NAMES:
            s = measured[name].sigma
            assert s.origin == "estimated" and s.n == n
            z.append((s.value_px - sigma[name]) / s.uncertainty_px)
    z = np.array(z)
    assert abs(np.mean(z)) < 0.2            # unbiased
    assert 0.8 < np.mean(z ** 2) < 1.25     # its stated uncertainty is honest (NEES near 1)


def test_blunders_and_misses_do_not_spoil_it():
    rng = np.random.default_rng(7)
    truth = rng.uniform(0, 1000, (500, 2, 2))
    model = truth + rng.normal(0, 1.5, truth.shape)
    model[:25] += rng.uniform(30, 80, (25, 2, 2))  # 5 % on the wrong fin
    model[25:40, 1] = np.nan                       # forks the model did not find
    measured = sigma_from_truth(NAMES, model, truth)
    assert abs(measured["snout"].sigma.value_px - 1.5) < 0.2
    assert measured["fork"].sigma.n == 485


def test_a_bias_is_part_of_the_pointing_error():
    rng = np.random.default_rng(8)
    truth = rng.uniform(0, 1000, (2000, 2, 2))
    model = truth + rng.normal(0, 1.0, truth.shape) + 2.0   # consistently 2 px off in x and y
    assert measured_value(sigma_from_truth(NAMES, model, truth)) > 1.8


def measured_value(measured) -> float:
    return measured["snout"].sigma.value_px


def test_corrections_take_the_reviewers_own_sigma_out():
    rng = np.random.default_rng(9)
    z = []
    for _ in range(100):
        sigma, reviewer = rng.uniform(1.0, 3.0), rng.uniform(0.3, 0.7)
        n = int(rng.integers(60, 300))
        truth = rng.uniform(0, 1920, (n, 2, 2))
        proposed = truth + rng.normal(0, sigma, truth.shape)
        reviewed = truth + rng.normal(0, reviewer, truth.shape)   # the reviewer moves each point to the fish
        measured = sigma_from_corrections(NAMES, proposed, reviewed, reviewer_sigma_px=reviewer)
        s = measured["fork"].sigma
        z.append((s.value_px - sigma) / s.uncertainty_px)
        assert "corrections" in measured["fork"].basis
    assert abs(np.mean(z)) < 0.3 and 0.7 < np.mean(np.square(z)) < 1.4


def test_too_few_points_or_a_model_no_worse_than_its_reviewer_are_refused():
    truth = np.zeros((MIN_POINTS - 1, 2, 2))
    with pytest.raises(InvalidParameterError, match="at least"):
        sigma_from_truth(NAMES, truth + 1.0, truth)
    truth = np.zeros((50, 2, 2))
    rng = np.random.default_rng(1)
    with pytest.raises(InvalidParameterError, match="cannot be told"):
        sigma_from_corrections(NAMES, truth + rng.normal(0, 0.3, truth.shape), truth, reviewer_sigma_px=0.5)
    with pytest.raises(InvalidParameterError, match="shape"):
        sigma_from_truth(NAMES, np.zeros((50, 3, 2)), np.zeros((50, 3, 2)))
