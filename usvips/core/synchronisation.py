"""Left/right synchronisation of a stereo video: the frame offset from a flash, the soundtracks or the images.

Convention (as the samples' truth): an offset of ``k`` frames means left frame ``i`` and right frame
``i + k`` show the same instant; ``k`` > 0 when the right camera started recording earlier. Offsets are
estimated to a fraction of a frame (``offset_frames``, float) and used as the nearest whole frame
(``frames``); ``confidence`` (0 … 1) says how clearly the best candidate beats the others.

Every estimator searches a window of offsets and knows its limits, by one rule (:func:`search_window`,
:attr:`SyncEstimate.at_edge`): a window is a whole number of frames either way, not negative; an offset
whose nearest whole frame is at the window's edge is not an estimate (the true lag may lie beyond it:
``at_edge``, and the caller refuses to store it); a search with no runner-up (a single candidate, or all
within the best one's own peak) has confidence 0, not 1.

Pure computation on arrays: brightness series, audio samples, images and cameras; the files are read
elsewhere (:mod:`usvips.io.video_stream`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import cv2
import numpy as np

from usvips.core.camera import Camera
from usvips.core.enhance import luminance
from usvips.core.errors import DegenerateGeometryError, InvalidParameterError
from usvips.core.matching import EpipolarCurve, epipolar_curve, match_along_curve

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
    #: standard deviation (frames) of the sub-frame part, where the method measures one (images)
    sigma_frames: float | None = None
    #: the offsets searched (frames, lowest and highest); None when not known
    window: tuple[float, float] | None = None
    #: a lag (frames) outside the window that the method's own evidence points to (a clear flash seen
    #: that far apart), or None
    beyond: float | None = None

    def __bool__(self) -> bool:
        """Falsy when the estimate failed: its offset lies at the edge of the search window (or the evidence
        points beyond it), so it is not stored (:attr:`at_edge`)."""
        return not self.at_edge

    @property
    def at_edge(self) -> bool:
        """True when the offset used lies at (or beyond) the edge of the search window: the best candidate
        may only be the best of those tried, the true lag lying outside; such an offset is not stored."""
        if self.window is None:
            return False
        low, high = self.window
        return self.beyond is not None or self.frames <= low or self.frames >= high

    def edge_problem(self) -> str | None:
        """Why the estimate is not one (at the edge of its window), in words; None when it is inside."""
        if not self.at_edge:
            return None
        low, high = self.window
        if self.beyond is not None:
            return (f"the flash is seen {self.beyond:+g} frames apart, outside the search window ({low:+g} to "
                    f"{high:+g} frames): the offset {self.offset_frames:+.2f} found inside it is not the lag")
        return (f"the offset {self.offset_frames:+.2f} frames lies at the edge of the search window "
                f"({low:+g} to {high:+g} frames): the true lag may be outside it")

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
        row = {"offset_frames": round(self.offset_frames, 3), "offset_frames_used": self.frames,
               "offset_s": round(self.offset_s, 6), "method": self.method,
               "confidence": round(self.confidence, 3)}
        if self.sigma_frames is not None:
            row["offset_sigma_frames"] = round(self.sigma_frames, 3)
        if self.window is not None:
            row["window_frames"] = [round(self.window[0], 3), round(self.window[1], 3)]
            row["at_edge"] = self.at_edge
        if self.beyond is not None:
            row["flash_seen_frames"] = self.beyond
        return row

    def summary(self) -> str:
        """One line: the (sub-frame) offset, its sigma where known, the confidence, and the whole frame used."""
        sigma = f" ± {self.sigma_frames:.2f}" if self.sigma_frames is not None else ""
        return (f"offset {self.offset_frames:+.2f}{sigma} frames ({self.offset_s:+.4f} s) by {self.method}, "
                f"confidence {self.confidence:.2f}"
                + (f"; using the nearest frame, {self.frames:+d}" if self.rounded else ""))


def _check_fps(fps: float) -> float:
    if not (np.isfinite(fps) and fps > 0):
        raise InvalidParameterError("fps", f"must be a positive number of frames per second, got {fps!r}")
    return float(fps)


#: the smallest lag (s) a search window must be able to hold when the user narrows it: two cameras started
#: by hand are rarely closer than this, and a narrower window finds its edge instead of the lag
MIN_WINDOW_S = 0.5


def search_window(max_offset: float | None, fps: float, frame_count: int, parameter: str = "max_offset") -> int:
    """The search window (whole frames either way) for a video pair of ``frame_count`` frames at ``fps``:
    ``max_offset`` when given — a whole number ≥ 0, smaller than the video, and wide enough to hold a lag
    of :data:`MIN_WINDOW_S` (or a third of the video when that is shorter) — else a third of the video,
    at most 300 frames. Anything else is an :class:`InvalidParameterError` naming ``parameter``."""
    fps = _check_fps(fps)
    count = int(frame_count)
    default = max(1, min(count // 3, 300))
    if max_offset is None:
        return default
    window = _window(max_offset, parameter)
    if window >= count:
        raise InvalidParameterError(parameter, f"{window} frames is not smaller than the video ({count} frames)")
    needed = min(int(np.ceil(MIN_WINDOW_S * fps)), default)
    if window < needed:
        raise InvalidParameterError(parameter, f"a window of ±{window} frames ({window / fps:.2f} s at {fps:.6g} fps) "
                                    f"cannot hold the lag of two cameras started by hand; search at least "
                                    f"±{needed} frames")
    return window


def _window(max_offset: float, parameter: str = "max_offset") -> int:
    """A window given in whole frames (≥ 0); else :class:`InvalidParameterError`."""
    try:
        value = float(max_offset)
    except (TypeError, ValueError):
        value = float("nan")
    if not np.isfinite(value) or value < 0 or value != int(value):
        raise InvalidParameterError(parameter, f"must be a whole number of frames, 0 or more, got {max_offset!r}")
    return int(value)


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


#: the chance that noise alone passes the bound a change must clear to be a flash (:func:`_clear_change`)
FALSE_ALARM = 0.01


def _confidence(values: np.ndarray, best: int, guard: int) -> float:
    """1 − (second separate peak / best peak), with peaks at least ``guard`` samples apart; 0 … 1. A search
    with fewer separate runner-ups than the peak's own width (2 ``guard`` + 1: one candidate, or a window
    hardly wider than the peak) has confidence 0: nothing was compared."""
    top = float(values[best])
    if top <= 0:
        return 0.0
    mask = np.ones(len(values), bool)
    mask[max(best - guard, 0): best + guard + 1] = False
    if mask.sum() < 2 * guard + 1:
        return 0.0
    second = float(values[mask].max())
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
    limit = _window(max_offset) if max_offset is not None else min(len(dl), len(dr)) // 2
    if not (np.abs(dl).max() > 0 and np.abs(dr).max() > 0):
        raise DegenerateGeometryError("no brightness change in one of the videos: film a flash seen by both")
    lags = np.arange(-limit, limit + 1)
    # correlation[k] = sum_i dl[i] dr[i + k] / norms
    from scipy import signal  # deferred: scipy.signal (and scipy.stats with it) take ~1 s to import

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
    seen = None  # the lag at which the right video shows the left's strongest change, when both are clear
    partner = int(np.argmax(sign * dr))
    if _clear_change(dl, edge) and _clear_change(dr, partner) and abs(partner - edge) > limit:
        seen = float(partner - edge)
    offset = float(whole)
    if 0 <= edge + whole < len(dr):
        offset = float(np.clip(_centroid(dr, edge + whole, sign) - _centroid(dl, edge, sign), whole - 1, whole + 1))
    return SyncEstimate(offset, fps, "flash", _confidence(values, best, 2),
                        {int(k): float(v) for k, v in zip(lags, values, strict=True)}, window=(-limit, limit),
                        beyond=seen)


def _clear_change(changes: np.ndarray, index: int) -> bool:
    """Whether ``changes[index]`` stands out of the series as a flash does: beyond the median by more than
    the robust spread (1.4826 · MAD) times √(2 ln(n / :data:`FALSE_ALARM`)), a bound n Gaussian values
    pass with about that probability."""
    middle = float(np.median(changes))
    spread = 1.4826 * float(np.median(np.abs(changes - middle)))
    return abs(float(changes[index]) - middle) > spread * np.sqrt(2.0 * np.log(len(changes) / FALSE_ALARM))


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
    if max_offset_s is not None and not (np.isfinite(max_offset_s) and max_offset_s >= 0):
        raise InvalidParameterError("max_offset_s", f"must be a number of seconds, 0 or more, got {max_offset_s!r}")
    left = np.asarray(left_audio, float).ravel()
    right = np.asarray(right_audio, float).ravel()
    if min(len(left), len(right)) < rate * 0.1:
        raise DegenerateGeometryError("audio synchronisation needs at least 0.1 s of sound in each video")
    left, right = left - left.mean(), right - right.mean()
    if np.linalg.norm(left) == 0 or np.linalg.norm(right) == 0:
        raise DegenerateGeometryError("one of the soundtracks is silent")
    from scipy import signal  # deferred, as above

    full = signal.correlate(right, left, mode="full", method="fft")
    centre = len(left) - 1
    limit = int((max_offset_s if max_offset_s is not None else min(len(left), len(right)) / (2 * rate)) * rate)
    lo, hi = max(centre - limit, 0), min(centre + limit + 1, len(full))
    window = np.abs(full[lo:hi]) / (np.linalg.norm(left) * np.linalg.norm(right))
    lags = np.arange(lo, hi) - centre
    offset_samples, best = _peak(window, lags)
    guard = max(int(rate / fps), 1)  # another peak within a frame is the same peak's shoulder
    edges = (float(lags[0]) / rate * fps, float(lags[-1]) / rate * fps)
    return SyncEstimate(offset_samples / rate * fps, fps, "audio", _confidence(window, best, guard), window=edges)


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
                 far: float = 10.0, epipolar_sigma_px: float = 0.0) -> SyncEstimate:
    """The offset from the images by epipolar consistency: a moving thing seen by both cameras lies on
    the refractive epipolar curve of its left pixel only in the right frame of the same instant.

    Corners on moving things in every ``step``-th left frame ``i`` are found within a band around their
    curves in right frames ``i + k`` (``k`` in ``candidates``); where a feature's signed distance from its
    curve changes sign, it votes for the fractional offset at which it crosses
    (:func:`_crossing_votes`). The estimate is the votes' median, to a fraction of a frame, with its
    ``sigma_frames``; the nearest whole frame is the one used. When fewer than three features cross, the
    whole frame whose matches (along the curves) lie closest to them is returned instead.

    ``left``/``right``: the calibrated cameras (with housings); ``candidates``: whole-frame offsets to
    try; ``near``/``far``: range along the rays (m); ``epipolar_sigma_px``: how far the calibration's
    curves may lie from the true ones (pixels; the calibration's pointing precision sigma0 is a fair
    figure): an error every feature shares, so it enters the sigma undivided by the number of votes
    (:func:`_from_votes`)."""
    fps = _check_fps(fps)
    candidates = [int(k) for k in candidates]
    if not candidates:
        raise InvalidParameterError("candidates", "no candidate offsets to try")
    window = (float(min(candidates)), float(max(candidates)))
    n_left, n_right = len(left_frames), len(right_frames)
    grey_left = [luminance(f) for f in left_frames]
    background = np.median(np.stack(grey_left), axis=0)
    features: list[tuple[int, np.ndarray, EpipolarCurve]] = []
    for i in range(0, n_left, max(int(step), 1)):
        for pixel in moving_features(grey_left[i], background):
            curve = epipolar_curve(left, right, pixel, near, far, samples=300)
            if len(curve.pixels) > 0:
                features.append((i, pixel, curve))
    crossings = _crossing_votes(features, grey_left, right_frames, candidates)
    if len(crossings) >= 3:
        votes, speeds = zip(*crossings, strict=True)
        return replace(_from_votes(votes, fps, candidates, speeds, epipolar_sigma_px), window=window)
    # too few features cross their curve: the whole frame whose matches lie closest to the curves
    distances: dict[int, list[float]] = {k: [] for k in candidates}
    for i, pixel, curve in features:
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
    return SyncEstimate(float(ks[best]), fps, "image", confidence, {int(k): float(scores[k]) for k in ks},
                        window=window)


#: a feature's match counts when its normalised cross-correlation exceeds this
MATCH_SCORE = 0.6


def _crossing_votes(features: list[tuple[int, np.ndarray, EpipolarCurve]], grey_left: Sequence[np.ndarray],
                    right_frames: Sequence[np.ndarray], candidates: Sequence[int], window: int = 21,
                    band: int = 12) -> list[tuple[float, float]]:
    """Each moving feature's own estimate of the offset (frames, fractional), from its motion across its
    epipolar curve, with the speed of that motion (pixels a frame).

    The feature of left frame ``i`` is found (normalised cross-correlation) within ``band`` px of its
    curve in right frames ``i + k`` for every candidate ``k``; its signed distance from the curve
    changes sign where the right camera sees it at the left frame's instant. Between consecutive frames
    ``j``, ``j + 1`` whose matches lie on either side (both clear, at most ``band`` px away), the zero of the
    straight line through the two distances is the crossing ``j*``; the vote is ``j* − i``. A feature
    moving along its curve never crosses it and does not vote."""
    n_right = len(right_frames)
    grey_right: dict[int, np.ndarray] = {}
    half = window // 2
    ks = sorted(int(k) for k in candidates)
    votes = []
    for i, pixel, curve in features:
        if len(curve.pixels) < 2:
            continue
        template = cv2.getRectSubPix(np.asarray(grey_left[i], np.float32), (window, window),
                                     (float(pixel[0]), float(pixel[1])))
        if float(template.std()) < 4.0:
            continue
        track: dict[int, float] = {}
        for k in ks:
            j = i + k
            if not 0 <= j < n_right:
                continue
            if j not in grey_right:
                grey_right[j] = np.asarray(luminance(right_frames[j]), np.float32)
            found = _best_near_curve(grey_right[j], template, curve, band, half)
            if found is not None:
                track[k] = found
        crossings = [(k + track[k] / (track[k] - track[k + 1]), abs(track[k]) + abs(track[k + 1]),
                      abs(track[k + 1] - track[k])) for k in ks if _crosses(track, k)]
        if crossings:
            nearest = min(crossings, key=lambda c: c[1])  # the crossing nearest the curve
            votes.append((nearest[0], nearest[2]))
    return votes


#: a feature must move across its curve by at least this much a frame (pixels) to time it: a still one
#: (or one moving along its curve) lies on it in every frame, its distance only noise
MIN_CROSSING_SPEED = 0.5


def _crosses(track: dict[int, float], k: int) -> bool:
    """Whether the signed distances ``track`` (by candidate offset) cross zero between ``k`` and ``k + 1``,
    moving steadily: at least :data:`MIN_CROSSING_SPEED` a frame, and in the same direction as the
    neighbouring frames' where they were found."""
    if k not in track or k + 1 not in track or track[k] * track[k + 1] > 0:
        return False
    change = track[k + 1] - track[k]
    if abs(change) < MIN_CROSSING_SPEED:
        return False
    for a, b in ((k - 1, k), (k + 1, k + 2)):
        if a in track and b in track and (track[b] - track[a]) * change <= 0:
            return False
    return True


def _best_near_curve(target: np.ndarray, template: np.ndarray, curve: EpipolarCurve, band: int,
                     half: int) -> float | None:
    """Signed distance (pixels) from ``curve`` of ``template``'s best match within ``band`` px of it in the
    grey ``target``; None when nothing there correlates above :data:`MATCH_SCORE`."""
    height, width = target.shape[:2]
    margin = band + half + 2
    x0 = max(int(np.floor(curve.pixels[:, 0].min())) - margin, 0)
    y0 = max(int(np.floor(curve.pixels[:, 1].min())) - margin, 0)
    x1 = min(int(np.ceil(curve.pixels[:, 0].max())) + margin, width - 1)
    y1 = min(int(np.ceil(curve.pixels[:, 1].max())) + margin, height - 1)
    if x1 - x0 < 2 * half + 3 or y1 - y0 < 2 * half + 3:
        return None
    surface = cv2.matchTemplate(np.ascontiguousarray(target[y0:y1 + 1, x0:x1 + 1]), template, cv2.TM_CCOEFF_NORMED)
    # the band: surface position (u, v) is the template centred at (x0 + u + half, y0 + v + half)
    line = np.zeros(surface.shape, np.uint8)
    points = np.round(curve.pixels - [x0 + half, y0 + half]).astype(np.int32)
    cv2.polylines(line, [points.reshape(-1, 1, 2)], False, 255, 1)
    if not line.any():
        return None
    distance = cv2.distanceTransform(255 - line, cv2.DIST_L2, 5)
    masked = np.where(distance <= band, surface, -1.0)
    v, u = np.unravel_index(int(np.argmax(masked)), masked.shape)
    peak = float(masked[v, u])
    if peak < MATCH_SCORE:
        return None
    du = dv = 0.0
    if 0 < u < surface.shape[1] - 1:
        a, c = surface[v, u - 1], surface[v, u + 1]
        du = float(np.clip(0.5 * (a - c) / (a - 2 * peak + c), -0.5, 0.5)) if a - 2 * peak + c < 0 else 0.0
    if 0 < v < surface.shape[0] - 1:
        a, c = surface[v - 1, u], surface[v + 1, u]
        dv = float(np.clip(0.5 * (a - c) / (a - 2 * peak + c), -0.5, 0.5)) if a - 2 * peak + c < 0 else 0.0
    return _signed_distance(curve, np.array([x0 + half + u + du, y0 + half + v + dv]))


def _from_votes(votes: Sequence[float], fps: float, candidates: Sequence[int], speeds: Sequence[float] = (),
                epipolar_sigma_px: float = 0.0) -> SyncEstimate:
    """The offset from the features' votes: their median (sub-frame), per whole candidate the share of
    votes nearest it (``scores``), and the confidence 1 − (runner-up's share / best share).

    Its sigma (frames) has two parts: the votes' scatter, 1.4826 · MAD / √n, and what no number of votes
    averages away: curves that lie ``epipolar_sigma_px`` off make every feature cross that much early or
    late, ``epipolar_sigma_px`` / (the median speed across the curves, pixels a frame) frames (slow
    motion across the curves times badly)."""
    values = np.asarray(votes, float)
    middle = float(np.median(values))
    scatter = 1.4826 * float(np.median(np.abs(values - middle))) / np.sqrt(len(values))
    shared = epipolar_sigma_px / float(np.median(speeds)) if len(speeds) and epipolar_sigma_px > 0 else 0.0
    sigma = max(float(np.hypot(scatter, shared)), 0.01)
    nearest = np.round(values).astype(int)
    scores = {int(k): float(np.mean(nearest == k)) for k in candidates}
    ordered = sorted(scores.values(), reverse=True)
    confidence = float(np.clip(1.0 - ordered[1] / ordered[0], 0.0, 1.0)) if ordered[0] > 0 and len(ordered) > 1 \
        else 0.0
    return SyncEstimate(middle, fps, "image", confidence, scores, sigma)


def _signed_distance(curve: EpipolarCurve, point: np.ndarray) -> float:
    """Distance (pixels) from ``point`` to the curve's polyline, positive on the left of its direction of
    increasing depth (the side the z-component of tangent × offset points to)."""
    a, b = curve.pixels[:-1], curve.pixels[1:]
    ab = b - a
    t = np.clip(np.einsum("ij,ij->i", point - a, ab) / np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-300), 0, 1)
    nearest = a + t[:, None] * ab
    j = int(np.argmin(np.linalg.norm(nearest - point, axis=1)))
    offset = point - nearest[j]
    cross = ab[j, 0] * offset[1] - ab[j, 1] * offset[0]
    return float(np.copysign(np.linalg.norm(offset), cross))
