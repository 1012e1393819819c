"""Rendering a printed calibration board through any camera (air, flat port, dome ...), with its truth.

Every pixel is sampled ``supersample`` × ``supersample`` times; each sample's ray is traced through the
housing (``Camera.rays``), intersected with the board's plane and the printed pattern is read there
(``board.ink``: exact, so the supersampling is the anti-aliasing). Then optics blur (Gaussian, σ in
pixels), optional linear motion blur, and noise. :func:`board_pixels` gives the true pixels of the
board's points by back-projection through the same camera. Pixels: x right, y down, origin at the centre
of the top-left pixel; metres.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from usvips.core import validation
from usvips.core.camera import Camera
from usvips.core.rays import RayStatus


@dataclass(frozen=True)
class BoardPose:
    """Where a board is: object point X = ``rotation`` · x + ``position`` for a board point x (metres,
    board frame: x right, y down the sheet, z into it)."""

    rotation: np.ndarray
    position: np.ndarray

    def __post_init__(self) -> None:
        rotation = np.asarray(self.rotation, np.float64).reshape(3, 3)
        if not np.allclose(rotation.T @ rotation, np.eye(3), atol=1e-9) or np.linalg.det(rotation) < 0:
            raise validation.InvalidParameterError("rotation", "must be a proper rotation matrix")
        object.__setattr__(self, "rotation", rotation)
        object.__setattr__(self, "position", validation.finite_vector("position", self.position, 3))

    def to_object(self, xyz: np.ndarray) -> np.ndarray:
        """Board points (N, 3) → object space (N, 3)."""
        return np.asarray(xyz, np.float64).reshape(-1, 3) @ self.rotation.T + self.position

    @classmethod
    def facing(cls, camera: Camera, centre_xy: tuple[float, float], pixel: tuple[float, float], distance: float,
               tilt: float = 0.0, tilt_direction: float = 0.0, spin: float = 0.0) -> BoardPose:
        """The board point ``centre_xy`` (metres) on the ray of ``pixel`` at ``distance`` metres from the
        camera's outer surface; the board square to that ray, upright as the image (its x along the
        image's x), then turned by ``spin`` (radians) in its plane and tilted by ``tilt`` (radians) about
        the in-plane axis at angle ``tilt_direction`` from its x axis."""
        bundle = camera.rays(np.array([pixel], np.float64))
        if not bundle.ok[0]:
            raise validation.InvalidParameterError("pixel", f"no ray leaves the camera at {pixel}")
        d = bundle.directions[0] / np.linalg.norm(bundle.directions[0])
        m = camera.exterior.rotation
        x = m[0] - (m[0] @ d) * d
        x /= np.linalg.norm(x)
        y = np.cross(d, x)
        base = np.column_stack([x, y, d])
        c, s = np.cos(spin), np.sin(spin)
        spun = base @ np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
        axis = spun @ np.array([np.cos(tilt_direction), np.sin(tilt_direction), 0.0])
        rotation = _axis_angle(axis, tilt) @ spun
        centre = bundle.origins[0] + distance * d
        return cls(rotation, centre - rotation @ np.array([centre_xy[0], centre_xy[1], 0.0]))


def _axis_angle(axis: np.ndarray, angle: float) -> np.ndarray:
    axis = axis / np.linalg.norm(axis)
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * (k @ k)


def board_pixels(camera: Camera, board, pose: BoardPose) -> tuple[tuple[str, ...], np.ndarray, np.ndarray]:
    """The board's point ids, their true pixels (N, 2) through ``camera`` and whether each is visible
    (in front, reachable through the housing, inside the frame)."""
    control = board.control_points()
    projection = camera.project(pose.to_object(control.xyz))
    return control.ids, projection.pixels, projection.status == RayStatus.OK


def render_board(camera: Camera, board, pose: BoardPose, size: tuple[int, int] | None = None,
                 supersample: int = 4, paper: float = 215.0, ink: float = 30.0, background: float = 100.0,
                 blur: float = 0.6, motion: float = 0.0, motion_angle: float = 0.0, noise: float = 1.0,
                 seed: int = 0, dtype: type = np.uint8, colour: bool = False, chunk: int = 500_000) -> np.ndarray:
    """The image of ``board`` (a printed board kind: ``ink``) at ``pose`` as ``camera`` sees it.

    Grey levels (0–255) of ``paper``, ``ink`` and the ``background`` off the board; optics blur σ
    ``blur`` px; a linear motion blur ``motion`` px long at ``motion_angle`` radians from the image x axis;
    Gaussian ``noise`` (grey levels, seeded). uint8 or uint16 (× 257); grey (H, W) or RGB (H, W, 3)."""
    width, height = size if size else (camera.width, camera.height)
    if not width or not height:
        raise validation.InvalidParameterError("size", "give the image size or a camera with width and height")
    s = validation.positive("supersample", supersample)
    s = int(s)
    normal, origin = pose.rotation[:, 2], pose.position
    sub = (np.arange(s) + 0.5) / s - 0.5
    values = np.empty(height * width)
    rows_per_chunk = max(1, chunk // (width * s * s))
    for top in range(0, height, rows_per_chunk):
        rows = np.arange(top, min(height, top + rows_per_chunk))
        ys = (rows[:, None] + sub[None, :]).ravel()
        xs = (np.arange(width)[:, None] + sub[None, :]).ravel()
        gy, gx = np.meshgrid(ys, xs, indexing="ij")
        bundle = camera.rays(np.column_stack([gx.ravel(), gy.ravel()]))
        o, d = bundle.origins, bundle.directions
        along = d @ normal
        safe = np.where(np.abs(along) > 1e-12, along, 1.0)
        t = ((origin - o) @ normal) / safe
        hit = bundle.ok & (np.abs(along) > 1e-12) & (t > 0)
        level = np.full(len(o), float(background))
        local = (o[hit] + t[hit, None] * d[hit] - origin) @ pose.rotation
        printed = board.ink(local[:, :2])
        on_sheet = np.isfinite(printed)
        level[np.flatnonzero(hit)[on_sheet]] = paper - (paper - ink) * printed[on_sheet]
        block = level.reshape(len(rows), s, width, s).mean(axis=(1, 3))
        values[top * width:(top + len(rows)) * width] = block.ravel()
    image = values.reshape(height, width)
    if blur > 0:
        image = cv2.GaussianBlur(image, (0, 0), float(blur))
    if motion > 0:
        image = cv2.filter2D(image, -1, _line_kernel(float(motion), float(motion_angle)),
                             borderType=cv2.BORDER_REPLICATE)
    if noise > 0:
        image = image + np.random.default_rng(seed).normal(0.0, float(noise), image.shape)
    if colour:
        image = np.repeat(image[:, :, None], 3, axis=2) * np.array([0.95, 1.0, 1.05])
    if np.dtype(dtype) == np.uint16:
        return np.clip(np.rint(image * 257.0), 0, 65535).astype(np.uint16)
    return np.clip(np.rint(image), 0, 255).astype(np.uint8)


def _line_kernel(length: float, angle: float) -> np.ndarray:
    """A normalised kernel averaging along a segment ``length`` px long at ``angle`` radians."""
    half = int(np.ceil(length / 2)) + 1
    size = 2 * half + 1
    kernel = np.zeros((size * 8, size * 8), np.float32)
    c, s = np.cos(angle) * length / 2 * 8, np.sin(angle) * length / 2 * 8
    centre = size * 8 / 2
    cv2.line(kernel, (int(centre - c), int(centre - s)), (int(centre + c), int(centre + s)), 1.0, 8)
    kernel = cv2.resize(kernel, (size, size), interpolation=cv2.INTER_AREA)
    return kernel / kernel.sum()
