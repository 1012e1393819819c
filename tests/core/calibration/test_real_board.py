"""Real data: 25 stereo views of a printed 9 × 6 chessboard (tests/data/stereo_chessboard, corners found
by OpenCV). Our in-air calibration agrees with OpenCV's stereoCalibrate on the same corners: focal lengths
and baseline within 1 %, RMS within 1.2 × OpenCV's."""

from __future__ import annotations

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
    assert result.report["rms_px_all"] <= 1.2 * opencv["rms_px"]
