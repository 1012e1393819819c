"""Benchmarks of calibration-target detection: our detector (OpenCV's plus the corner order, quality and
blur check) against OpenCV's bare detector on the same frame."""

from __future__ import annotations

from collections.abc import Iterator

import cv2
import numpy as np

from usvips.bench import ratio_row
from usvips.core.calibration_targets import kind


def charuco_frame(board, size: tuple[int, int] = (1920, 1080), seed: int = 0) -> np.ndarray:
    """A grey frame with the ChArUco ``board`` seen in perspective over a textured background."""
    width, height = size
    rng = np.random.default_rng(seed)
    background = cv2.resize(rng.integers(60, 160, (height // 24, width // 24), dtype=np.uint8), (width, height),
                            interpolation=cv2.INTER_CUBIC)
    pixels_per_square = 120
    art = board.board.generateImage((board.cols * pixels_per_square, board.rows * pixels_per_square),
                                    marginSize=pixels_per_square // 2, borderBits=1)
    h, w = art.shape
    corners = np.float32([[0, 0], [w, 0], [w, h], [0, h]])
    target = np.float32([[0.28 * width, 0.18 * height], [0.74 * width, 0.12 * height],
                         [0.70 * width, 0.86 * height], [0.31 * width, 0.80 * height]])
    warp = cv2.getPerspectiveTransform(corners, target)
    sheet = cv2.warpPerspective(art, warp, (width, height), flags=cv2.INTER_AREA, borderValue=0)
    mask = cv2.warpPerspective(np.full_like(art, 255), warp, (width, height), flags=cv2.INTER_AREA)
    frame = np.where(mask > 127, sheet, background).astype(np.float64)
    frame = cv2.GaussianBlur(frame, (0, 0), 0.8) + rng.normal(0, 2.0, frame.shape)
    return np.clip(np.rint(frame), 0, 255).astype(np.uint8)


def benchmarks(scale: float = 1.0) -> Iterator[dict]:
    board = kind("charuco")("5X5_100", 10, 7, 0.03, 0.022)
    frame = charuco_frame(board)
    bare = cv2.aruco.CharucoDetector(board.board)
    found = len(board.detect(frame))
    repeats = max(3, int(round(10 * scale)))
    yield ratio_row("ChArUco board 10x7 (54 corners) detection, 1920x1080 grey", 1, lambda: board.detect(frame),
                    lambda: bare.detectBoard(frame), "cv2.aruco.CharucoDetector.detectBoard, bare, same frame", 1.2,
                    repeats=repeats, corners_found=found)
