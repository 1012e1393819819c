"""Synthetic chessboard views for the view-selection and video-scanning tests: a pinhole rig, board poses,
projected corners (truth) and rendered images, and a test-local chessboard target that finds the board
with OpenCV's ``findChessboardCornersSB`` (no ``kind``: it does not join the registry).

Board frame: inner corners at X = i · square (i = 0 … columns − 1), Y = j · square, Z = 0 (metres);
the squares run one square beyond the corners on every side. Camera frame of OpenCV (x right, y down,
z forward); pixels x right, y down, origin at the centre of the top-left pixel.
"""

from __future__ import annotations

import cv2
import numpy as np

from usvips.core.calibration_targets import CalibrationTarget, StereoView, TargetDetection
from usvips.core.observations import ControlPoints

COLUMNS, ROWS, SQUARE = 9, 6, 0.03
WIDTH, HEIGHT = 320, 240
BASELINE = 0.12


def board(columns: int = COLUMNS, rows: int = ROWS, square: float = SQUARE) -> ControlPoints:
    i, j = np.meshgrid(np.arange(columns), np.arange(rows))
    xyz = np.column_stack([i.ravel() * square, j.ravel() * square, np.zeros(i.size)])
    return ControlPoints(tuple(str(k) for k in range(i.size)), xyz)


def intrinsics(focal: float = 300.0, width: int = WIDTH, height: int = HEIGHT) -> np.ndarray:
    return np.array([[focal, 0.0, (width - 1) / 2], [0.0, focal, (height - 1) / 2], [0.0, 0.0, 1.0]])


def rotation_about(axis: np.ndarray, angle: float) -> np.ndarray:
    return cv2.Rodrigues(np.asarray(axis, float).reshape(3) / np.linalg.norm(axis) * angle)[0]


def board_pose(rng: np.random.Generator, distance: float, tilt: float, tilt_direction: float,
               offset: tuple[float, float] = (0.0, 0.0), spin: float = 0.0, target: ControlPoints | None = None
               ) -> tuple[np.ndarray, np.ndarray]:
    """(R, t) of the board in the left camera: its centre at ``distance`` (m) along a ray through the
    normalised image point ``offset``, its plane turned by ``tilt`` (rad) about the in-plane axis at
    ``tilt_direction`` (rad from the image x axis), spun by ``spin`` about its normal."""
    target = board() if target is None else target
    centre = target.xyz.mean(axis=0)
    axis = np.array([np.cos(tilt_direction), np.sin(tilt_direction), 0.0])
    rotation = rotation_about(axis, tilt) @ rotation_about([0, 0, 1], spin)
    ray = np.array([offset[0], offset[1], 1.0])
    position = ray / np.linalg.norm(ray) * distance
    return rotation, position - rotation @ centre


def project(k: np.ndarray, rotation: np.ndarray, translation: np.ndarray, xyz: np.ndarray) -> np.ndarray:
    camera = xyz @ rotation.T + translation
    uv = camera @ k.T
    return uv[:, :2] / uv[:, 2:]


def right_pose(rotation: np.ndarray, translation: np.ndarray, baseline: float = BASELINE):
    """The board's pose in the right camera (parallel rig, right camera at +baseline along x)."""
    return rotation, translation - np.array([baseline, 0.0, 0.0])


def detection(pixels: np.ndarray, ids=None, size=(WIDTH, HEIGHT)) -> TargetDetection:
    ids = tuple(str(k) for k in range(len(pixels))) if ids is None else tuple(ids)
    return TargetDetection(ids, pixels, np.ones(len(pixels)), size)


def stereo_view(k, rotation, translation, label: str, target: ControlPoints | None = None,
                noise: float = 0.0, rng: np.random.Generator | None = None, size=(WIDTH, HEIGHT)) -> StereoView:
    """The view (projected corners, plus Gaussian ``noise`` px) of the board in both cameras; corners
    outside an image are left out of that image's detection."""
    target = board() if target is None else target
    detections = []
    for r, t in ((rotation, translation), right_pose(rotation, translation)):
        px = project(k, r, t, target.xyz)
        if noise:
            px = px + rng.normal(0.0, noise, px.shape)
        inside = (px[:, 0] > 0) & (px[:, 1] > 0) & (px[:, 0] < size[0] - 1) & (px[:, 1] < size[1] - 1)
        detections.append(detection(px[inside], np.array(target.ids)[inside], size))
    return StereoView(label, detections[0], detections[1], {})


def render(k: np.ndarray, rotation: np.ndarray, translation: np.ndarray, size=(WIDTH, HEIGHT),
           columns: int = COLUMNS, rows: int = ROWS, square: float = SQUARE, blur: float = 0.0,
           motion: int = 0, background: int = 140) -> np.ndarray:
    """A grey uint8 image of the board (2 × supersampled, then averaged), optionally blurred by a
    Gaussian of ``blur`` px or a horizontal motion of ``motion`` px."""
    per_square = 24
    margin = per_square  # one square of white border beyond the outer squares
    squares_x, squares_y = columns + 1, rows + 1
    texture = np.full((squares_y * per_square + 2 * margin, squares_x * per_square + 2 * margin), 235, np.uint8)
    for sy in range(squares_y):
        for sx in range(squares_x):
            if (sx + sy) % 2 == 0:
                texture[margin + sy * per_square:margin + (sy + 1) * per_square,
                        margin + sx * per_square:margin + (sx + 1) * per_square] = 25
    # texture pixel (u, v) centre ↔ board metres: the first square's outer edge (X = -square) at margin - 0.5
    to_metres = np.array([[square / per_square, 0, -square - (margin - 0.5) * square / per_square],
                          [0, square / per_square, -square - (margin - 0.5) * square / per_square],
                          [0, 0, 1.0]])
    plane = k @ np.column_stack([rotation[:, 0], rotation[:, 1], translation])
    upsample = np.array([[2.0, 0, 0.5], [0, 2.0, 0.5], [0, 0, 1.0]])
    homography = upsample @ plane @ to_metres
    big = cv2.warpPerspective(texture, homography, (2 * size[0], 2 * size[1]), flags=cv2.INTER_LINEAR,
                              borderMode=cv2.BORDER_CONSTANT, borderValue=background)
    image = cv2.resize(big, size, interpolation=cv2.INTER_AREA).astype(np.float32)
    if blur:
        image = cv2.GaussianBlur(image, (0, 0), blur)
    if motion:
        kernel = np.full((1, motion), 1.0 / motion, np.float32)
        image = cv2.filter2D(image, -1, kernel, borderType=cv2.BORDER_REPLICATE)
    return np.clip(np.rint(image), 0, 255).astype(np.uint8)


class SectorChessboard(CalibrationTarget):
    """Test-only chessboard found by ``cv2.findChessboardCornersSB`` (no ``kind``: not registered)."""

    def __init__(self, columns: int = COLUMNS, rows: int = ROWS, square: float = SQUARE) -> None:
        self.columns, self.rows, self.square = columns, rows, square

    def describe(self) -> dict:
        return {"kind": "sector-chessboard", "cols": self.columns, "rows": self.rows, "square": self.square}

    @classmethod
    def from_description(cls, description: dict, source: str = "") -> SectorChessboard:
        return cls(description["cols"], description["rows"], description["square"])

    def control_points(self) -> ControlPoints:
        return board(self.columns, self.rows, self.square)

    def detect(self, image: np.ndarray) -> TargetDetection:
        grey = image if image.ndim == 2 else cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)
        size = (grey.shape[1], grey.shape[0])
        found, corners = cv2.findChessboardCornersSB(grey, (self.columns, self.rows))
        if not found:
            return TargetDetection.nothing(size, "chessboard not found")
        corners = corners.reshape(-1, 2).astype(np.float64)
        return TargetDetection(tuple(str(k) for k in range(len(corners))), corners, np.ones(len(corners)), size)
