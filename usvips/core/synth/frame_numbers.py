"""Frames that carry their own number: a row of bright/dark blocks (bit ``b`` of the number in block
``b``) over a textured background that changes every frame, readable after lossy coding. For checking
that a decoder returns exactly the frame asked for (tests, ``usvips bench``)."""

from __future__ import annotations

import cv2
import numpy as np

from usvips.core.errors import InvalidParameterError

BITS = 16


def numbered_frame(number: int, width: int = 160, height: int = 120, seed: int = 0,
                   brightness: float = 0.0) -> np.ndarray:
    """RGB uint8 (height, width, 3) frame showing ``number`` (0 … 2¹⁶ − 1) in a band across the middle;
    ``brightness`` (grey levels) is added to the background (a flash, a light switched on)."""
    if not 0 <= number < 2**BITS:
        raise InvalidParameterError("number", f"must be in 0 … {2**BITS - 1}, got {number}")
    block = width // BITS
    if block < 4 or height < 24:
        raise InvalidParameterError("width", f"a {width} × {height} frame is too small for {BITS} blocks")
    rng = np.random.default_rng(seed * 1_000_003 + number)
    small = rng.integers(0, 255, (max(height // 8, 1), max(width // 8, 1), 3), dtype=np.uint8)
    frame = cv2.resize(small, (width, height), interpolation=cv2.INTER_LINEAR).astype(np.float32) * 0.6 + 30
    frame = np.clip(frame + brightness, 0, 255).astype(np.uint8)
    top, bottom = height // 3, 2 * height // 3
    frame[top:bottom] = 40
    for b in range(BITS):
        if (number >> b) & 1:
            frame[top:bottom, block * b:block * (b + 1)] = 215
    return frame


def frame_number(frame: np.ndarray) -> int:
    """The number :func:`numbered_frame` wrote into ``frame`` (grey or RGB)."""
    height, width = frame.shape[:2]
    block = width // BITS
    top, bottom = height // 3, 2 * height // 3
    band = np.asarray(frame[top + (bottom - top) // 4: bottom - (bottom - top) // 4], float)
    band = band.mean(axis=2) if band.ndim == 3 else band
    row = band.mean(axis=0)
    quarter = max(block // 4, 1)
    return sum(1 << b for b in range(BITS) if row[block * b + quarter: block * (b + 1) - quarter].mean() > 128)


def panning_numbered_frame(number: int, width: int = 160, height: int = 120, seed: int = 0,
                           speed: int = 3) -> np.ndarray:
    """Like :func:`numbered_frame`, but the background is one texture panning ``speed`` px a frame (a
    camera turning): consecutive frames predict each other, so encoders write B-frames (and pyramids of
    them) as they do for camera footage, where :func:`numbered_frame`'s fresh texture gets P-frames only."""
    if not 0 <= number < 2**BITS:
        raise InvalidParameterError("number", f"must be in 0 … {2**BITS - 1}, got {number}")
    block = width // BITS
    if block < 4 or height < 24:
        raise InvalidParameterError("width", f"a {width} × {height} frame is too small for {BITS} blocks")
    shift = (speed * number) % 4096
    rng = np.random.default_rng(seed)
    small = rng.integers(0, 255, (max(height // 8, 1), (width + 4096) // 8 + 1, 3), dtype=np.uint8)
    strip = small[:, shift // 8: shift // 8 + width // 8 + 2]
    wide = cv2.resize(strip, (strip.shape[1] * 8, height), interpolation=cv2.INTER_LINEAR)
    frame = (wide[:, shift % 8: shift % 8 + width].astype(np.float32) * 0.6 + 30).astype(np.uint8)
    top, bottom = height // 3, 2 * height // 3
    frame[top:bottom] = 40
    for b in range(BITS):
        if (number >> b) & 1:
            frame[top:bottom, block * b:block * (b + 1)] = 215
    return np.ascontiguousarray(frame)
