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


def test_a_sigma_growing_with_size_is_fitted_with_its_gross_misses():
    """Over random cases: errors normal with σ(s) = √(a² + (b·s)²), 5 % of them gross misses (a larger normal
    share growing with s). The fit recovers a and b of clean errors, and with misses it is the errors' second
    moment by size: the normalised errors' mean square is near 1 in each third of the sizes."""
    from usvips.core.detection.keypoint_sigma import fit_size_sigma

    rng = np.random.default_rng(35)
    for _ in range(12):
        a, b = rng.uniform(0.3, 2.0), rng.uniform(0.0, 0.03)
        size = rng.uniform(10, 300, 800)
        sigma = np.sqrt(a ** 2 + (b * size) ** 2)
        errors = rng.normal(size=(800, 2)) * sigma[:, None]
        fitted = fit_size_sigma(size, errors)
        assert fitted.a == pytest.approx(a, rel=0.15, abs=0.05) and fitted.b == pytest.approx(b, abs=0.004)
        missed = rng.random(800) < 0.05
        errors[missed] *= 3 + size[missed, None] / 50
        fitted = fit_size_sigma(size, errors)
        z2 = np.sum(errors ** 2, axis=1) / 2 / fitted(size) ** 2
        for third in np.array_split(np.argsort(size), 3):
            assert 0.6 < np.mean(z2[third]) < 1.6
    with pytest.raises(InvalidParameterError):
        fit_size_sigma(np.ones(5), np.ones((5, 2)))


def test_a_refined_right_keypoint_follows_the_left_one():
    from usvips.core.detection.keypoint_sigma import SizeSigma, StereoSigma

    stereo = StereoSigma({"snout": SizeSigma(1.0, 0.01), "fork": SizeSigma(1.0, 0.0)},
                         {"snout": SizeSigma(0.5, 0.0), "fork": SizeSigma(0.3, 0.002)})
    sigmas, rho = stereo.pointing(("snout", "fork"), 200.0, 0.5, [True, False])
    left = np.sqrt(1 + (0.01 * 100) ** 2) / 0.5  # the size in input px: 100; the sigma back in image px
    assert sigmas[0, 0] == pytest.approx(left) and sigmas[0, 1] == pytest.approx(np.hypot(left, 0.5))
    assert rho[0] == pytest.approx(left / np.hypot(left, 0.5))
    assert sigmas[1].tolist() == [2.0, 2.0] and rho[1] == 0.0  # not refined, no unmatched sigma: the left's
    stereo = StereoSigma(stereo.left, stereo.match, "", {"fork": SizeSigma(3.0, 0.0)})
    sigmas, rho = stereo.pointing(("snout", "fork"), 200.0, 0.5, [True, False])
    assert sigmas[1].tolist() == [2.0, 6.0] and rho[1] == 0.0
    with pytest.raises(InvalidParameterError):
        stereo.pointing(("snout", "upper caudal"), 100.0, 0.5, [True, True])
