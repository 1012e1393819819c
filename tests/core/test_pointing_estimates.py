"""The pointing-σ estimators against ground truth: simulated clicks with a known σ, many random cases,
Gaussian and heavy-tailed (Student t): σ̂ is unbiased in the variance, and its 95 % interval covers the
true σ about 95 % of the time for Gaussian clicks; for heavy-tailed clicks it is widened and still covers
it in most cases (the figures measured are printed with -s)."""

import numpy as np
import pytest

from usvips.core.errors import InvalidParameterError
from usvips.core.pointing_estimates import (
    _chi2_interval,
    from_double_readings,
    from_pointing_test,
    from_repeats,
    from_tracks,
    second_differences,
)

CASES = 400


def _noise(rng, sigma: float, shape, tails: str) -> np.ndarray:
    """Click errors of standard deviation ``sigma`` (px): Gaussian, or Student t with 5 dof (heavy tails:
    excess kurtosis 6) scaled to the same standard deviation."""
    if tails == "gauss":
        return rng.normal(0.0, sigma, shape)
    dof = 5
    return rng.standard_t(dof, shape) * sigma / np.sqrt(dof / (dof - 2))


def _repeats(rng, sigma, tails):
    groups = []
    for _ in range(int(rng.integers(5, 15))):
        centre = rng.uniform(0, 1000, 2)
        groups.append(centre + _noise(rng, sigma, (int(rng.integers(2, 5)), 2), tails))
    return from_repeats(groups)


def _double(rng, sigma, tails):
    truth = rng.uniform(0, 1000, (int(rng.integers(10, 40)), 2))
    return from_double_readings(truth + _noise(rng, sigma, truth.shape, tails),
                                truth + _noise(rng, sigma, truth.shape, tails))


def _tracks(rng, sigma, tails):
    tracks = []
    for _ in range(int(rng.integers(2, 6))):
        frames = np.arange(int(rng.integers(9, 30)))
        velocity, acceleration = rng.uniform(-3, 3, 2), rng.uniform(-0.01, 0.01, 2)
        path = rng.uniform(100, 900, 2) + frames[:, None] * velocity + 0.5 * frames[:, None] ** 2 * acceleration
        tracks.append(path + _noise(rng, sigma, path.shape, tails))
    return from_tracks(tracks)


def _test(rng, sigma, tails):
    truth = rng.uniform(0, 1000, (int(rng.integers(10, 30)), 2))
    return from_pointing_test(truth + _noise(rng, sigma, truth.shape, tails), truth)


ESTIMATORS = {"repeats": _repeats, "double reading": _double, "tracking": _tracks, "pointing test": _test}


@pytest.mark.parametrize("method", list(ESTIMATORS))
def test_gaussian_clicks_give_an_unbiased_variance_and_an_honest_interval(method):
    rng = np.random.default_rng(32 + len(method))
    ratios, covered, heavy = [], 0, 0
    for _ in range(CASES):
        sigma = rng.uniform(0.2, 2.0)
        found = ESTIMATORS[method](rng, sigma, "gauss")
        assert found.method == method
        ratios.append((found.sigma_px / sigma) ** 2)
        covered += found.low_px <= sigma <= found.high_px
        heavy += found.heavy_tailed
    print(f"{method}: mean σ̂²/σ² {np.mean(ratios):.3f}, coverage {covered / CASES:.3f}, called heavy-tailed "
          f"{heavy / CASES:.2f}")
    assert heavy / CASES < 0.05
    assert abs(np.mean(ratios) - 1.0) < 0.05
    assert 0.92 <= covered / CASES <= 0.98


@pytest.mark.parametrize("method", list(ESTIMATORS))
def test_heavy_tailed_clicks_keep_the_variance_and_widen_the_interval(method):
    rng = np.random.default_rng(64 + len(method))
    ratios, covered, covered_plain, heavy = [], 0, 0, 0
    for _ in range(CASES):
        sigma = rng.uniform(0.2, 2.0)
        found = ESTIMATORS[method](rng, sigma, "t5")
        ratios.append((found.sigma_px / sigma) ** 2)
        covered += found.low_px <= sigma <= found.high_px
        heavy += found.heavy_tailed
        # the plain χ² interval (Gaussian tails assumed) for comparison
        low, high = _chi2_interval(found.sigma_px ** 2, found.dof, 0.95)
        covered_plain += low <= sigma <= high
    print(f"{method} t5: mean σ̂²/σ² {np.mean(ratios):.3f}, coverage {covered / CASES:.3f} (plain χ² "
          f"{covered_plain / CASES:.3f}), called heavy-tailed {heavy / CASES:.2f}")
    assert abs(np.mean(ratios) - 1.0) < 0.08  # the variance is still estimated without bias
    assert covered > covered_plain  # the interval is widened where the tails are heavy
    assert covered / CASES >= 0.85
    assert heavy / CASES > 0.15  # a Gaussian's are called so in < 5 %


def test_a_pointing_test_reports_a_constant_offset_and_counts_it_as_error():
    rng = np.random.default_rng(3)
    truth = rng.uniform(0, 500, (2000, 2))
    found = from_pointing_test(truth + [0.5, -0.3] + rng.normal(0, 0.4, truth.shape), truth)
    assert found.bias_px == pytest.approx((0.5, -0.3), abs=0.03)
    assert found.sigma_px == pytest.approx(np.sqrt(0.4 ** 2 + (0.5 ** 2 + 0.3 ** 2) / 2), rel=0.03)
    assert found.n == 2000 and found.dof == 4000
    assert "mean offset (+0.5" in found.summary()


def test_smooth_motion_is_not_taken_for_tracking_noise():
    frames = np.arange(30.0)
    path = np.column_stack([100 + 2.5 * frames + 0.004 * frames ** 2, 50 - 1.2 * frames])
    assert np.allclose(second_differences(path), [[0.008, 0.0]] * 10)


@pytest.mark.parametrize("call, message", [
    (lambda: from_repeats([]), "none given"),
    (lambda: from_repeats([np.zeros((1, 2))]), "repeats 1"),
    (lambda: from_repeats([np.zeros((3, 2))]), "identical"),
    (lambda: from_repeats([np.array([[1.0, np.nan], [2.0, 3.0]])]), "non-finite"),
    (lambda: from_double_readings(np.zeros((3, 2)), np.zeros((2, 2))), "expected 3"),
    (lambda: from_tracks([np.zeros((2, 2))]), "three frames"),
    (lambda: from_pointing_test(np.zeros((3, 3)), np.zeros((3, 3))), "(N, 2)"),
])
def test_bad_input_is_named(call, message):
    with pytest.raises(InvalidParameterError, match=message.replace("(", r"\(").replace(")", r"\)")):
        call()
