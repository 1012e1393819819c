"""Left/right synchronisation of a stereo video: the frame offset from a flash, the soundtracks or the images.

Convention (as the samples' truth): an offset of ``k`` frames means left frame ``i`` and right frame
``i + k`` show the same instant; ``k`` > 0 when the right camera started recording earlier. Offsets are
estimated to a fraction of a frame (``offset_frames``, float) and used as the nearest whole frame
(``frames``); ``confidence`` (0 … 1) says how clearly the best candidate beats the others.

Pure computation on arrays: brightness series, audio samples, images and cameras; the files are read
elsewhere (:mod:`usvips.io.video_stream`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import cv2
import numpy as np
from scipy import signal

from usvips.core.camera import Camera
from usvips.core.enhance import luminance
from usvips.core.errors import DegenerateGeometryError, InvalidParameterError
from usvips.core.matching import epipolar_curve, match_along_curve

METHODS = ("flash", "audio", "image")


@dataclass(frozen=True)
class SyncEstimate:
    """``offset_frames`` (sub-frame, float), ``offset_s`` (seconds, at ``fps``), ``method``, ``confidence``
    (0 … 1), and per candidate whole-frame offset its ``scores`` (higher is better) where the method has them."""

    offset_frames: float
    fps: float
    method: str
    confidence: float
    scores: dict[int, float] | None = None

    @property
    def frames(self) -> int:
        """The whole-frame offset used: the nearest frame to :attr:`offset_frames`."""
        return int(np.round(self.offset_frames))

    @property
    def offset_s(self) -> float:
        return self.offset_frames / self.fps

    @property
    def rounded(self) -> bool:
        """True when the estimate is more than 0.05 frame from a whole frame (so rounding moved it)."""
        return abs(self.offset_frames - self.frames) > 0.05

    def as_dict(self) -> dict:
        return {"offset_frames": round(self.offset_frames, 3), "offset_frames_used": self.frames,
                "offset_s": round(self.offset_s, 6), "method": self.method,
                "confidence": round(self.confidence, 3)}


def _check_fps(fps: float) -> float:
    if not (np.isfinite(fps) and fps > 0):
        raise InvalidParameterError("fps", f"must be a positive number of frames per second, got {fps!r}")
    return float(fps)


def _peak(values: np.ndarray, lags: np.ndarray) -> tuple[float, int]:
    """Sub-sample position of the maximum of ``values`` over ``lags`` (parabola through the top three)."""
    best = int(np.argmax(values))
    shift = 0.0
    if 0 < best < len(values) - 1:
        a, b, c = values[best - 1], values[best], values[best + 1]
        denominator = a - 2 * b + c
        if denominator < 0:
            shift = float(np.clip(0.5 * (a - c) / denominator, -0.5, 0.5))
    return float(lags[best] + shift), best


def _confidence(values: np.ndarray, best: int, guard: int) -> float:
    """1 − (second separate peak / best peak), with peaks at least ``guard`` samples apart; 0 … 1."""
    top = float(values[best])
    if top <= 0:
        return 0.0
    mask = np.ones(len(values), bool)
    mask[max(best - guard, 0): best + guard + 1] = False
    second = float(values[mask].max()) if mask.any() else 0.0
    return float(np.clip(1.0 - max(second, 0.0) / top, 0.0, 1.0))


def flash_offset(left_brightness: np.ndarray, right_brightness: np.ndarray, fps: float,
                 max_offset: int | None = None) -> SyncEstimate:
    """The offset from an abrupt brightness change seen by both cameras (a flash, a light switched on).

    ``left_brightness``/``right_brightness``: mean grey level of each frame (any unit, one per frame).
    The frame-to-frame changes are cross-correlated (normalised) over offsets up to ``max_offset`` frames
    (default: half the shorter series) for the whole-frame offset; a change that falls inside a frame's
    exposure spreads over two frames, whose centroid gives the sub-frame offset (exact for exposures of a
    whole frame interval; a change between two short exposures is only known to the frame, and so is a
    flash shorter than two frames, whose switching on and off share a frame)."""
    fps = _check_fps(fps)
    left = np.asarray(left_brightness, float).ravel()
    right = np.asarray(right_brightness, float).ravel()
    if min(len(left), len(right)) < 4:
        raise DegenerateGeometryError("flash synchronisation needs at least 4 frames of each video")
    if not (np.isfinite(left).all() and np.isfinite(right).all()):
        raise InvalidParameterError("brightness", "the brightness series hold non-finite values")
    dl, dr = np.diff(left), np.diff(right)  # signed: light on and light off are told apart
    dl, dr = dl - np.median(dl), dr - np.median(dr)
    limit = int(max_offset) if max_offset is not None else min(len(dl), len(dr)) // 2
    if not (np.abs(dl).max() > 0 and np.abs(dr).max() > 0):
        raise DegenerateGeometryError("no brightness change in one of the videos: film a flash seen by both")
    lags = np.arange(-limit, limit + 1)
    # correlation[k] = sum_i dl[i] dr[i + k] / norms
    full = signal.correlate(dr, dl, mode="full")  # index n ↔ lag n − (len(dl) − 1)
    centre = len(dl) - 1
    values = np.array([full[centre + k] if 0 <= centre + k < len(full) else 0.0 for k in lags])
    values = values / (np.linalg.norm(dl) * np.linalg.norm(dr))
    best = int(np.argmax(values))
    whole = int(lags[best])
    # sub-frame: a change inside a frame's exposure spreads over two frames in proportion to the time
    # on either side; the centroid of the strongest change's frame differences gives its time per camera
    edge = int(np.argmax(np.abs(dl)))
    sign = np.sign(dl[edge])
    offset = float(whole)
    if 0 <= edge + whole < len(dr):
        offset = float(np.clip(_centroid(dr, edge + whole, sign) - _centroid(dl, edge, sign), whole - 1, whole + 1))
    return SyncEstimate(offset, fps, "flash", _confidence(values, best, 2),
                        {int(k): float(v) for k, v in zip(lags, values, strict=True)})


def _centroid(changes: np.ndarray, index: int, sign: float) -> float:
    """Weighted mean position of the changes of one sign within ±2 frames of ``index``."""
    lo, hi = max(index - 2, 0), min(index + 3, len(changes))
    weights = np.clip(sign * changes[lo:hi], 0, None)
    if weights.sum() <= 0:
        return float(index)
    return float(np.dot(np.arange(lo, hi), weights) / weights.sum())


def audio_offset(left_audio: np.ndarray, right_audio: np.ndarray, rate: float, fps: float,
                 max_offset_s: float | None = None) -> SyncEstimate:
    """The offset from the two soundtracks by cross-correlation (FFT).

    ``left_audio``/``right_audio``: mono samples from each file's first video frame on; ``rate``: samples
    per second (Hz, the same for both); ``max_offset_s``: largest offset searched (s; default half the
    shorter track). A sound heard at left time t is heard at right time t + k / fps."""
    fps = _check_fps(fps)
    if not (np.isfinite(rate) and rate > 0):
        raise InvalidParameterError("rate", f"must be a positive sample rate (Hz), got {rate!r}")
    left = np.asarray(left_audio, float).ravel()
    right = np.asarray(right_audio, float).ravel()
    if min(len(left), len(right)) < rate * 0.1:
        raise DegenerateGeometryError("audio synchronisation needs at least 0.1 s of sound in each video")
    left, right = left - left.mean(), right - right.mean()
    if np.linalg.norm(left) == 0 or np.linalg.norm(right) == 0:
        raise DegenerateGeometryError("one of the soundtracks is silent")
    full = signal.correlate(right, left, mode="full", method="fft")
    centre = len(left) - 1
    limit = int((max_offset_s if max_offset_s is not None else min(len(left), len(right)) / (2 * rate)) * rate)
    lo, hi = max(centre - limit, 0), min(centre + limit + 1, len(full))
    window = np.abs(full[lo:hi]) / (np.linalg.norm(left) * np.linalg.norm(right))
    lags = np.arange(lo, hi) - centre
    offset_samples, best = _peak(window, lags)
    guard = max(int(rate / fps), 1)  # another peak within a frame is the same peak's shoulder
    return SyncEstimate(offset_samples / rate * fps, fps, "audio", _confidence(window, best, guard))


def moving_features(grey: np.ndarray, background: np.ndarray, count: int = 12, window: int = 21) -> np.ndarray:
    """Corners (N, 2; x, y pixels) of a grey frame that lie on something moving: where the frame differs
    from ``background`` (e.g. the median of the frames: the still scene) by more than 12 grey levels,
    at least ``window`` / 2 + 3 pixels from the border."""
    moving = np.abs(grey - background) > 12
    moving = cv2.dilate(moving.astype(np.uint8), np.ones((5, 5), np.uint8))
    half = window // 2 + 3
    moving[:half], moving[-half:], moving[:, :half], moving[:, -half:] = 0, 0, 0, 0
    corners = cv2.goodFeaturesToTrack(np.clip(grey, 0, 255).astype(np.uint8), count, 0.01, 8, mask=moving)
    return np.zeros((0, 2)) if corners is None else corners.reshape(-1, 2).astype(float)


def image_offset(left_frames: Sequence[np.ndarray], right_frames: Sequence[np.ndarray], left: Camera,
                 right: Camera, fps: float, candidates: Sequence[int], step: int = 2, near: float = 0.3,
                 far: float = 10.0) -> SyncEstimate:
    """The offset from the images by epipolar consistency: corners on moving things in left frame ``i``
    are matched along their refractive epipolar curves in right frame ``i + k``; only at the true offset
    do the matches lie on the curves (a moving object has left its curve in the other frames). Score of
    a candidate ``k``: minus the median distance (pixels) of the matches from their curves.

    ``left``/``right``: the calibrated cameras (with housings); ``candidates``: whole-frame offsets to
    try; every ``step``-th left frame is used; ``near``/``far``: range along the rays (m)."""
    fps = _check_fps(fps)
    candidates = [int(k) for k in candidates]
    if not candidates:
        raise InvalidParameterError("candidates", "no candidate offsets to try")
    n_left, n_right = len(left_frames), len(right_frames)
    grey_left = [luminance(f) for f in left_frames]
    background = np.median(np.stack(grey_left), axis=0)
    distances: dict[int, list[float]] = {k: [] for k in candidates}
    for i in range(0, n_left, max(int(step), 1)):
        for pixel in moving_features(grey_left[i], background):
            curve = epipolar_curve(left, right, pixel, near, far, samples=300)
            if len(curve.pixels) == 0:
                continue
            for k in candidates:
                if not 0 <= i + k < n_right:
                    continue
                match = match_along_curve(left_frames[i], right_frames[i + k], pixel, curve, window=21)
                if match.pixel is not None and match.score > 0.5:
                    distances[k].append(curve.distance_to(np.array(match.pixel)))
    scores = {k: -float(np.median(d)) for k, d in distances.items() if len(d) >= 3}
    if len(scores) < 2:
        raise DegenerateGeometryError("image synchronisation found too few moving features matched in both "
                                      "videos: is something moving in the overlap of the two views?")
    ks = np.array(sorted(scores))
    values = np.array([scores[k] for k in ks])
    best = int(np.argmax(values))
    ordered = np.sort(-values)
    # confidence: how far the runner-up's distance is above the best's, relative to it (0 … 1)
    confidence = float(np.clip(1.0 - (ordered[0] + 0.25) / (ordered[1] + 0.25), 0.0, 1.0))
    return SyncEstimate(float(ks[best]), fps, "image", confidence, {int(k): float(scores[k]) for k in ks})
