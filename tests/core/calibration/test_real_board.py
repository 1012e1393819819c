"""Real data: 25 stereo views of a printed 9 × 6 chessboard (tests/data/stereo_chessboard, corners found
by OpenCV). Our in-air calibration agrees with OpenCV's stereoCalibrate on the same corners: focal lengths
and baseline within 1 %, RMS within 1.2 × OpenCV's."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from usvips.core.calibration import CalibrationOptions, calibrate_air
from usvips.core.calibration.validation import opencv_stereo
from usvips.io.tables import read_control, read_observations

DATA = Path(__file__).resolve().parents[2] / "data" / "stereo_chessboard"
SIZE = (640, 512)


@pytest.fixture(scope="module")
def board_views():
    return read_control(DATA / "board.csv"), read_observations(DATA / "corners.csv")


@pytest.fixture(scope="module")
def opencv(board_views):
    return opencv_stereo(*board_views, SIZE)


def test_our_calibration_of_real_board_views_agrees_with_opencv(board_views, opencv):
    control, observations = board_views
    assert len(observations.pair_labels) == 25
    # OpenCV fits k1, k2, p1, p2, k3 and keeps every corner: ours with k2 freed and nothing set aside
    options = CalibrationOptions(sigma_px=0.2, image_size=SIZE, control_exact=True, free=("k2",), snooping=False)
    result = calibrate_air(control, observations, options)
    assert result.adjustment.converged
    rig = result.calibration.rig(0, frame="rig")
    ours = {"f_l": rig.left.interior.f, "f_r": rig.right.interior.f,
            "fy_l": rig.left.interior.f / rig.left.interior.sy, "fy_r": rig.right.interior.f / rig.right.interior.sy,
            "baseline_m": float(np.linalg.norm(rig.right.exterior.position))}
    for key, value in ours.items():
        assert value == pytest.approx(opencv[key], rel=0.01), key
    assert 0.08 < ours["baseline_m"] < 0.10  # about 92 mm
    assert result.report.rms_px_all <= 1.2 * opencv["rms_px"]


def test_real_corners_are_kept_and_the_held_out_departure_is_not_blamed_on_the_calibration(board_views):
    """The real corners' errors have heavier tails than a Gaussian: least squares with data snooping sets
    aside a few per cent of them, the M-estimator none, with a sigma0 that describes held-out views'
    corners. Their held-out adjacent distances vary less than two independent corners would (a detector's
    neighbouring corners' errors correlate); the calibration's part of their variance is tiny, so the
    departure is reported and the calibration's covariance kept."""
    from usvips.core.calibration.validation import validate

    control, observations = board_views
    options = CalibrationOptions(sigma_px=0.2, image_size=SIZE, control_exact=True, free=("k2",))
    trimmed = calibrate_air(control, observations, dataclasses.replace(options, estimator="least squares"))
    validation = validate(control, observations, 0.2, lambda obs: calibrate_air(control, obs, options), seed=0)
    report, honesty = validation.result.report, validation.honesty
    assert report.estimation["estimator"] == "huber" and report.set_aside == 0
    assert trimmed.report.set_aside > 0.02 * 2 * len(trimmed.report.residuals)
    assert report.sigma0_px_estimated > trimmed.calibration.sigma0_px
    assert 0.6 < honesty.reprojection_nees < 1.6 and honesty.calibration_share < 0.05
    assert honesty.distance_nees < 0.7 and honesty.covariance_factor == honesty.pointing_factor
    assert any("lies in the corners' pointing" in line for line in honesty.why)
