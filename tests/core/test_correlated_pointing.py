"""The pointing covariance of vertices whose right pointing follows the left one
(usvips.core.measurements.correlated_pointing), against Monte Carlo truth over random rigs of every housing
kind: the right error is the left error plus an independent match error, so the disparity carries the
match error alone."""

import numpy as np
import pytest

from usvips.core import housing as housings
from usvips.core.calibration.uncertainty import intersect_with_calibration
from usvips.core.errors import InvalidParameterError
from usvips.core.measurements import measure_picks
from usvips.core.measurements.batch import measure_picks_many
from usvips.core.measurements.correlated_pointing import correlated_covariances, correlations
from usvips.core.pointing import (
    FRAME_CORRELATION,
    RIGHT_FOLLOWS_LEFT,
    frame_correlation_of,
    frame_correlation_qualifier,
    right_follows_left,
    vertex_correlation,
)
from usvips.core.stereo_calibration import StereoCalibration
from usvips.core.synth.stereo_survey import random_rig


def _calibration(seed: int) -> StereoCalibration:
    kinds = housings.names()
    rig = random_rig(np.random.default_rng(seed), kinds[seed % len(kinds)], (640, 480))
    return StereoCalibration.from_cameras(rig.left, rig.right, "water", 0.3, station="s1")


def _fish(rng: np.random.Generator, calibration: StereoCalibration) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A fish's snout and fork (2, 3) m 1-2.5 m in front of the left camera, and their pixels in each image."""
    rig = calibration.rig(0, "object")
    centre = rig.left.exterior.position + rig.left.exterior.rotation.T @ np.array(
        [rng.uniform(-0.2, 0.2), rng.uniform(-0.15, 0.15), -rng.uniform(1.0, 2.5)])
    heading = rng.normal(size=3) * [1, 0.3, 0.4]
    heading /= np.linalg.norm(heading)
    points = centre + np.outer([-0.5, 0.5], heading) * rng.uniform(0.1, 0.5)
    left, right = rig.left.project(points), rig.right.project(points)
    return points, left.pixels, right.pixels


def test_without_correlation_it_is_the_intersections_own_covariance():
    calibration = _calibration(3)
    _, left, right = _fish(np.random.default_rng(1), calibration)
    sigma = np.array([[1.5, 1.5], [2.0, 2.5]])
    own = intersect_with_calibration(calibration, left, right, 0, "object", False, sigma).covariance
    ours = correlated_covariances(calibration, left, right, sigma, np.zeros(2))
    assert np.allclose(ours, own, rtol=2e-3, atol=1e-12)


@pytest.mark.parametrize("seed", range(4))
def test_correlated_pixel_errors_give_an_honest_point_and_length_sigma(seed):
    """Over random rigs (the seed's housing kind), fish and draws: the right error = the left error
    (σ_L = 2 px) + a match error (σ_m = 0.4 px). The points' and lengths' NEES with the correlated pointing
    are near 1; taken as independent (σ_L, σ_R), the length's NEES is far below 1 (a σ far too large)."""
    rng = np.random.default_rng(100 + seed)
    calibration = _calibration(seed)
    sigma_left, sigma_match = 2.0, 0.4
    sigma_right = np.hypot(sigma_left, sigma_match)
    sigma = np.array([[sigma_left, sigma_right]] * 2)
    rho = np.full(2, sigma_left / sigma_right)
    point_z2, length_z2, independent_z2 = [], [], []
    for _ in range(60):
        truth, left, right = _fish(rng, calibration)
        error_left = rng.normal(0, sigma_left, (2, 2))
        noisy_left = left + error_left
        noisy_right = right + error_left + rng.normal(0, sigma_match, (2, 2))
        measured = measure_picks("length", calibration, noisy_left, noisy_right, 0, "object",
                                 pointing_sigma_px=sigma, pointing_correlation=rho)
        for i in range(2):
            e = measured.points[i] - truth[i]
            point_z2.append(e @ np.linalg.solve(measured.covariance[3 * i:3 * i + 3, 3 * i:3 * i + 3], e) / 3)
        true_length = np.linalg.norm(truth[1] - truth[0])
        length_z2.append(((measured.main.value - true_length) / measured.main.sigma) ** 2)
        plain = measure_picks("length", calibration, noisy_left, noisy_right, 0, "object", pointing_sigma_px=sigma)
        independent_z2.append(((plain.main.value - true_length) / plain.main.sigma) ** 2)
    assert 0.7 < np.mean(point_z2) < 1.35
    assert 0.6 < np.mean(length_z2) < 1.5
    assert np.mean(independent_z2) < 0.6 * np.mean(length_z2)


def test_many_objects_at_once_are_measured_as_one_at_a_time():
    calibration = _calibration(5)
    rng = np.random.default_rng(9)
    fish = [_fish(rng, calibration) for _ in range(3)]
    sigma = [np.array([[1.0, 1.2], [2.0, 2.1]])] * 3
    rho = [np.array([1.0 / 1.2, 2.0 / 2.1]), None, np.array([0.0, 0.5])]
    many = measure_picks_many(["length"] * 3, calibration, [f[1] for f in fish], [f[2] for f in fish], 0, "object",
                              sigma, None, rho)
    for f, s, r, m in zip(fish, sigma, rho, many, strict=True):
        one = measure_picks("length", calibration, f[1], f[2], 0, "object", pointing_sigma_px=s, pointing_correlation=r)
        assert m.main.sigma == pytest.approx(one.main.sigma, rel=1e-9)
        assert (m.pointing_correlation is None) == (r is None)


def test_correlations_are_checked_and_a_source_says_when_its_right_follows_its_left():
    assert correlations(None, 2) is None and correlations(0.0, 2) is None
    assert correlations(0.5, 2).tolist() == [0.5, 0.5]
    for bad in (1.0, -0.1, [0.2, 0.3, 0.4], np.nan):
        with pytest.raises(InvalidParameterError):
            correlations(bad, 2)
    label = f"keypoint (snout, model fish sha256:0123456789ab, {RIGHT_FOLLOWS_LEFT})"
    assert right_follows_left(label) and not right_follows_left("keypoint (snout, model fish sha256:0123456789ab)")
    rho = vertex_correlation([label, "hand click", label], np.array([[1.0, 2.0], [1.0, 2.0], [2.0, 1.0]]))
    assert rho.tolist() == [0.5, 0.0, 0.0]
    assert vertex_correlation(["hand click"], np.array([[0.5, 0.5]])) is None


def test_a_vertex_the_steps_cannot_intersect_keeps_its_independent_covariance():
    from usvips.core.measurements.correlated_pointing import kept_where_failed

    correlated = np.stack([np.eye(3), np.full((3, 3), np.nan)])
    independent = np.stack([2 * np.eye(3), 3 * np.eye(3)])
    assert np.array_equal(kept_where_failed(correlated, independent), np.stack([np.eye(3), 3 * np.eye(3)]))


def test_a_model_keypoints_frame_correlation_is_stated_in_its_source_and_read_back():
    label = (f"keypoint (snout, model fish sha256:0123456789ab, {RIGHT_FOLLOWS_LEFT}, "
             f"{frame_correlation_qualifier(0.4123)})")
    assert FRAME_CORRELATION in label and frame_correlation_of(label) == pytest.approx(0.412)
    assert right_follows_left(label)
    assert frame_correlation_of("keypoint (snout, model fish sha256:0123456789ab)") is None
    assert frame_correlation_of("hand click (snout, by ana)") is None
    assert frame_correlation_of("keypoint (snout, frame correlation x)") is None
    assert frame_correlation_of("keypoint (snout, frame correlation 1.0)") is None
    for bad in (1.0, -0.01, float("nan")):
        with pytest.raises(InvalidParameterError, match="frame_correlation"):
            frame_correlation_qualifier(bad)
