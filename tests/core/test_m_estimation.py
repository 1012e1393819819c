"""The adjustment engine's M-estimator (Huber, IRLS with a robust scale) against closed-form truth.

A straight line observed with heavy-tailed noise (Student-t, 4 degrees of freedom) of known standard
deviation: over many draws, sigma0 estimates that standard deviation, the stated covariance of the line's
parameters holds (their mean squared normalised error is near 1; least squares' own covariance would
not be the M-estimate's), clean observations are kept, and planted gross errors are named."""

from __future__ import annotations

import numpy as np
import pytest

from tests.core.test_adjustment import _line_problem
from usvips.core.adjustment import GROSS, Parameter, adjust, robust_scale
from usvips.core.errors import InvalidParameterError

TRUTH = np.array([2.0, 0.5])
DEGREES = 4.0


def _draw(rng, n: int, sigma: float, degrees: float | None = DEGREES):
    x = np.linspace(0.0, 10.0, n)
    if degrees is None:
        noise = rng.normal(0.0, sigma, n)
    else:
        noise = sigma * np.sqrt((degrees - 2.0) / degrees) * rng.standard_t(degrees, n)
    return x, TRUTH[0] + TRUTH[1] * x + noise


def _fit(x, y, a_priori: float):
    problem = _line_problem(x, y, a_priori, [Parameter("a", 0.0), Parameter("b", 0.0)])
    return adjust(problem, estimator="huber")


@pytest.mark.parametrize("degrees", [DEGREES, None])
def test_sigma0_and_the_covariance_hold_over_many_draws(degrees):
    rng = np.random.default_rng(11)
    sigma, a_priori = 0.3, 1.0  # the a-priori sigma is only a start: the data set the scale
    ratios, nees, set_aside = [], [], 0
    for _ in range(300):
        x, y = _draw(rng, 200, sigma, degrees)
        result = _fit(x, y, a_priori)
        assert result.converged and result.estimation["estimator"] == "huber"
        ratios.append(result.sigma0 * a_priori / sigma)
        error = np.array([result.value("a"), result.value("b")]) - TRUTH
        nees.append(float(error @ np.linalg.solve(result.covariance, error)) / 2)
        set_aside += len(result.excluded)
    assert 0.95 < np.median(ratios) < 1.05
    assert 0.85 < np.mean(nees) < 1.15, np.mean(nees)
    # of 60,000 clean observations: the heavy tails are kept, down-weighted (a Student-t of 4 degrees of
    # freedom lies beyond GROSS robust sigmas with probability 4e-4; a Gaussian never)
    assert set_aside / 60000 < (1e-3 if degrees else 1e-5)
    # the M-estimate is more precise than least squares for heavy tails: the covariance says so
    if degrees is not None:
        assert result.estimation["parameter_variance_factor"] < result.estimation["noise_variance_factor"]


def test_gross_errors_are_named_and_set_aside_while_the_tails_stay():
    rng = np.random.default_rng(5)
    x, y = _draw(rng, 300, 0.2)
    planted = [17, 123, 250]
    y[planted] += np.array([4.0, -6.0, 25.0])  # 20 to 125 standard deviations
    result = _fit(x, y, 0.5)
    assert result.converged
    named = sorted(int(s.point) for s in result.excluded)
    assert named == planted
    assert all(s.reason.startswith("gross error") and abs(s.w) > GROSS for s in result.excluded)
    assert result.value("b") == pytest.approx(TRUTH[1], abs=0.01)
    assert result.estimation["gross_errors"] == 3 and 0.0 < result.estimation["down_weighted"] < 0.3


def test_a_wrong_model_is_doubted_rather_than_trimmed():
    rng = np.random.default_rng(2)
    x, y = _draw(rng, 200, 0.05)
    y[::4] += 3.0  # a quarter of the data from another line: not blunders
    result = _fit(x, y, 0.05)
    assert result.model_doubt and "cannot be blunders" in result.model_doubt
    assert len(result.excluded) == 0


def test_robust_scale_and_a_wrong_estimator():
    rng = np.random.default_rng(3)
    assert robust_scale(rng.normal(0.0, 2.0, 20000)) == pytest.approx(2.0, rel=0.03)
    assert robust_scale(np.zeros(0)) == 0.0
    x, y = _draw(rng, 20, 0.1)
    with pytest.raises(InvalidParameterError, match="estimator"):
        adjust(_line_problem(x, y, 0.1, [Parameter("a", 0.0), Parameter("b", 0.0)]), estimator="median")
