"""Scale augmentation of rendered training frames for the fish keypoint model (no PyTorch needed).

A training frame is a square input (``size`` × ``size``, BGR uint8) with its fish: each a dict of
``keypoints`` (K × 2, the network's input coordinates, origin at the input's top-left corner), ``visible``
and ``in_frame`` (K booleans), ``box`` (u0, v0, u1, v1) and ``required`` (a fish the model must find).
Zooming the frames makes small and large fish both common, whatever sizes the renderer happened to draw.
"""

from __future__ import annotations

import cv2
import numpy as np

#: a zoomed fish shorter than this (snout to fork, input px) is not one to find: its place is ignored
MIN_REQUIRED_PX = 6.0


def zoomed(image: np.ndarray, fish: list[dict], scale: float, shift: tuple[float, float]
           ) -> tuple[np.ndarray, list[dict]]:
    """A training frame magnified by ``scale`` and moved by ``shift`` (input pixels), as u' = scale·u + shift in
    the network's corner-origin coordinates; uncovered input is grey 114, as the letterbox pads, and the
    pixels are interpolated bilinearly. A keypoint leaving the input is no longer in frame; a fish whose snout
    or fork leaves it, or whose snout–fork length falls under MIN_REQUIRED_PX, is no longer one to find (its
    place is ignored, neither fish nor background)."""
    size = image.shape[0]
    # OpenCV's warp takes pixel-centre coordinates: corner u = centre x + 0.5
    matrix = np.array([[scale, 0.0, shift[0] + 0.5 * scale - 0.5], [0.0, scale, shift[1] + 0.5 * scale - 0.5]])
    out = cv2.warpAffine(image, matrix, (size, size), flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT,
                         borderValue=(114, 114, 114))
    moved = []
    for f in fish:
        points = np.asarray(f["keypoints"], np.float64) * scale + shift
        inside = (points >= 0).all(axis=1) & (points <= size).all(axis=1)
        in_frame = np.asarray(f["in_frame"], bool) & inside
        box = tuple(float(v) * scale + shift[n % 2] for n, v in enumerate(f["box"]))
        long_enough = np.hypot(*(points[0] - points[1])) >= MIN_REQUIRED_PX
        moved.append({**f, "keypoints": points, "in_frame": in_frame, "box": box,
                      "required": bool(f["required"] and in_frame[:2].all() and long_enough)})
    return out, moved


def random_zoom(image: np.ndarray, fish: list[dict], zoom: tuple[float, float], rng: np.random.Generator
                ) -> tuple[np.ndarray, list[dict]]:
    """``zoomed`` with a scale drawn log-uniformly from ``zoom`` (low, high) and a shift keeping the frame
    covering the input (magnified) or inside it (shrunk), so fish of every size are common."""
    size = image.shape[0]
    scale = float(np.exp(rng.uniform(np.log(zoom[0]), np.log(zoom[1]))))
    span = size * (1 - scale)  # < 0 when magnified
    shift = tuple(float(rng.uniform(min(span, 0.0), max(span, 0.0))) for _ in range(2))
    return zoomed(image, fish, scale, shift)
