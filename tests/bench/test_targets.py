"""The target-detection benchmark times our ChArUco detection against OpenCV's bare detector on the same
1080p frame, in which both find the whole board (no timed assertions)."""

import cv2
import numpy as np

from usvips.bench import targets
from usvips.core.calibration_targets import kind


def test_the_row_compares_the_same_frame_in_which_the_whole_board_is_found():
    (row,) = list(targets.benchmarks(scale=0.1))
    assert row["baseline"].startswith("cv2.aruco.CharucoDetector") and row["target"] == 1.2
    assert row["corners_found"] == 54
    assert row["met"] == (row["ratio"] <= row["target"])


def test_our_corners_are_opencvs_on_the_bench_frame():
    board = kind("charuco")("5X5_100", 10, 7, 0.03, 0.022)
    frame = targets.charuco_frame(board)
    assert frame.shape == (1080, 1920)
    corners, ids, _, _ = cv2.aruco.CharucoDetector(board.board).detectBoard(frame)
    ours = board.detect(frame)
    order = np.argsort(ids.ravel())
    assert ours.ids == tuple(str(int(k)) for k in ids.ravel()[order])
    np.testing.assert_allclose(ours.pixels, corners.reshape(-1, 2)[order], atol=1e-9)
