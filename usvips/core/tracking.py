"""Tracking a picked vertex through a stereo video, frame by frame, in both cameras.

From a vertex picked on one instant (its left and right pixels on frame ``start``), the left point is
followed by pyramidal Lucas–Kanade optical flow (``cv2.calcOpticalFlowPyrLK``) with a forward–backward
check (each step first tries the finest level alone, started from the point's last move; where that loses
the point, disagrees with itself both ways or gives a step that would stop the track, the whole pyramid
decides); the right point is followed the same way, and the point stored for it is held to the refractive
epipolar curve of the new left point (:func:`usvips.core.matching.epipolar_curve`): moved to the nearest
point of the curve. (The flow follows the right point as found, not as held: the hold needs the curve traced
through the housing, which costs as much for one frame as for a batch, so it is done for a batch of frames at
once.)
Each frame-to-frame position is refined against the start frame's window (LK from the start frame with the
frame-to-frame position as its first guess, kept when it converges within a pixel), so that the small
errors of successive steps do not add up to a drift. Each step is scored by the normalised
cross-correlation of the point's window with its window on the frame before, in each camera. The track
stops, saying why, when the point

- leaves the frame (its window would leave the image) — ``leaves the frame``;
- is lost by the flow or fails the forward–backward check — ``lost``;
- changes appearance (occluded, or turned away): correlation below ``min_score`` — ``correlation too low``;
- is tracked in the right image off the epipolar curve by more than ``max_epipolar_px``, or the stereo ray
  RMS of the unconstrained pair jumps above ``rms_jump`` × the track's median (and ``min_rms_m``) —
  ``ray RMS jumps``;
- has no frame (the frame source raised a UsvipsError: no partner frame, end of the video) — its message;
- or the work is cancelled — ``cancelled``.

Pure: the frames come from a callable ``frames(index) -> (left, right)`` (the application decodes, and
pairs each left frame with its partner right frame); ``cancel()`` is asked before every frame and
``progress(done, total)`` told after it, so that a worker thread can run it with a cancel that stops it.
Pixels: x right, y down, origin at the centre of the top-left pixel; frames are indices of the left video.

Known limit: the window must lie on the object. A window over its outline (a snout tip, a tail fork
against a textured background) is pulled by the background, which does not move with it: track points
of the body, or expect up to a pixel of bias at the outline.
"""

from __future__ import annotations

import math
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from typing import NamedTuple

import cv2
import numpy as np

from usvips.core import validation
from usvips.core.enhance import luminance
from usvips.core.errors import InvalidParameterError, UsvipsError
from usvips.core.intersection import intersect, intersect_traced, trace
from usvips.core.matching import epipolar_curve_at
from usvips.core.rig import StereoRig

FrameSource = Callable[[int], tuple[np.ndarray, np.ndarray]]

LEAVES, LOST, LOW, RMS, CANCELLED, END = ("leaves the frame", "lost", "correlation too low", "ray RMS jumps",
                                          "cancelled", "reached the end")


@dataclass(frozen=True)
class TrackSettings:
    """``window``: the side (odd, px) of the correlation window and of the flow's window; ``levels``:
    pyramid levels of the flow; ``min_score``: the NCC (−1..1) below which the point is taken as lost
    (occluded); ``max_fb_px``: the largest forward–backward disagreement (px); ``max_epipolar_px``: the
    largest distance (px) of the right flow from the epipolar curve; ``rms_jump``, ``min_rms_m``: the
    ray-RMS stop (× the median so far, and at least this many metres); ``min_contrast``: the standard
    deviation (grey levels) below which a start window is featureless; ``min_edge_ratio``: the ratio of
    the start window's structure-tensor eigenvalues (smaller / larger) below which it is an edge."""

    window: int = 15
    levels: int = 3
    min_score: float = 0.75
    max_fb_px: float = 0.5
    max_epipolar_px: float = 3.0
    rms_jump: float = 4.0
    min_rms_m: float = 0.005
    min_contrast: float = 6.0
    min_edge_ratio: float = 0.05

    def __post_init__(self) -> None:
        if int(self.window) < 7 or int(self.window) % 2 == 0:
            raise InvalidParameterError("window", f"must be odd and >= 7, got {self.window}")
        if not -1.0 < self.min_score < 1.0:
            raise InvalidParameterError("min_score", f"must lie between -1 and 1, got {self.min_score}")
        for name in ("max_fb_px", "max_epipolar_px", "rms_jump", "min_rms_m", "min_contrast", "min_edge_ratio"):
            validation.positive(name, getattr(self, name))


@dataclass(frozen=True)
class Track:
    """A vertex tracked through frames: ``frames`` (M,) in increasing order, ``left`` and ``right`` (M, 2)
    pixels, ``scores`` (M, 2) the left and right correlation with the frame before (1 at the start
    frame), ``ray_rms_m`` (M,) the stereo ray RMS of the unconstrained pair (m); ``start`` the frame
    picked; ``stopped``: (direction, last frame tracked, reason) for backward (−1) and forward (+1);
    ``times_s`` (M,) the left frames' presentation times (s) when the caller that read the video gave them
    (None: not known here — tracking itself works in frames)."""

    frames: np.ndarray
    left: np.ndarray
    right: np.ndarray
    scores: np.ndarray
    ray_rms_m: np.ndarray
    start: int
    stopped: tuple[tuple[int, int, str], ...]
    times_s: np.ndarray | None = None

    def time_at(self, frame: int) -> float | None:
        """The presentation time (s) of left frame ``frame``; None where the track does not reach it or its
        times are not known."""
        found = np.flatnonzero(self.frames == int(frame))
        return None if self.times_s is None or not found.size else float(self.times_s[found[0]])

    def at(self, frame: int) -> tuple[np.ndarray, np.ndarray] | None:
        """The left and right pixels on ``frame``; None where the track does not reach."""
        found = np.flatnonzero(self.frames == int(frame))
        return (self.left[found[0]], self.right[found[0]]) if found.size else None

    def reason(self, direction: int) -> str:
        """Why the track stopped going ``direction`` (+1 forward, −1 backward); '' when not tracked."""
        return next((why for d, _, why in self.stopped if d == direction), "")


def _grey(image: np.ndarray) -> np.ndarray:
    grey = luminance(image) if image.ndim == 3 else image
    return np.ascontiguousarray(grey if grey.dtype == np.uint8 else np.clip(grey, 0, 255).astype(np.uint8))


def _window(image: np.ndarray, point: np.ndarray, size: int) -> np.ndarray:
    return cv2.getRectSubPix(image, (size, size), (float(point[0]), float(point[1]))).astype(np.float32)


def _ncc(a: np.ndarray, b: np.ndarray) -> float:
    """The normalised cross-correlation (−1..1) of two float32 windows of one size; 0 where either is flat
    (OpenCV's ``TM_CCOEFF_NORMED``: one call, where numpy took a dozen; it scores a flat ``b``, its
    template, 1, which here is 0: an occluding blank patch must not pass for a match)."""
    score = float(cv2.matchTemplate(a, b, cv2.TM_CCOEFF_NORMED)[0, 0])
    return 0.0 if score == 1.0 and float(b.min()) == float(b.max()) else score


def _inside(point: np.ndarray, shape: tuple[int, ...], margin: float) -> bool:
    h, w = shape[:2]
    return bool(margin <= point[0] <= w - 1 - margin and margin <= point[1] <= h - 1 - margin)


def _crop(image: np.ndarray, x: float, y: float, half: int) -> tuple[np.ndarray, int, int]:
    """The part of ``image`` within ``half`` px of the whole pixel of (``x``, ``y``) and its top-left corner
    (x0, y0): the flow needs its pyramid over the neighbourhood only, not over a whole 1080p frame. (Plain
    numbers: the flow's few-microsecond steps were paid several times over in small-array overhead.)"""
    h, w = image.shape[:2]
    x0, y0 = max(int(x) - half, 0), max(int(y) - half, 0)
    return image[y0:min(int(y) + half + 1, h), x0:min(int(x) + half + 1, w)], x0, y0


def _point(x: float, y: float) -> np.ndarray:
    """A point as ``cv2.calcOpticalFlowPyrLK`` takes it: float32 (1, 1, 2)."""
    return np.array([[[x, y]]], np.float32)


def _reach(settings: TrackSettings) -> int:
    """Half the side (px) of the neighbourhood the flow works in, in coarsest-level pixels scaled up: half
    the window, 4 px more (where the pyramid's blur and the Scharr derivative meet the crop's edge), and
    the motion the coarsest level can follow (half a window): the flow then sees what it would on the whole
    frame. (It was the whole window plus 64 px: 184 px against 144 for a 15 px window over 3 levels, 1.6 ×
    the pixels for every pyramid the flow builds, four a frame.)"""
    half_window = int(settings.window) // 2
    return (2 * half_window + 4) * 2 ** int(settings.levels)


#: how far (px) the tracked point may drift from the centre of the neighbourhood cropped about it before the
#: neighbourhood is cropped again about the point: the neighbourhood of a frame, cropped and reduced once as
#: the frame a step goes to, serves again as the frame the next step starts from while the point stays
#: within this of its centre (at 3 px a frame, five steps in six)
SLACK = 16
#: the pyramid levels of a neighbourhood reduced once and kept (the level-0 crop, half and quarter
#: resolution); the flow's levels above them are built by ``cv2.calcOpticalFlowPyrLK`` on the quarter one
KEPT_LEVELS = 2


class _Neighbourhood(NamedTuple):
    """A frame's neighbourhood of a tracked point: ``levels[k]`` the crop reduced ``k`` times by
    ``cv2.pyrDown`` (``levels[0]`` the frame's pixels), ``corner`` its top-left pixel (x, y) in the frame,
    ``centre`` the whole pixel it was cropped about. A pixel x of the frame is ``(x - corner) / 2**k`` on
    level k (pyrDown's pixel i is centred on its source's pixel 2i, the flow's own convention). The reduced
    levels are built when the flow first needs them (:func:`_levels`): a step the motion predicts needs
    the crop alone."""

    levels: list[np.ndarray]
    corner: tuple[int, int]
    centre: tuple[int, int]
    #: whether the step that cropped it found the point from its last move alone (:func:`_flow`)
    predicted: bool = False


def _neighbourhood(image: np.ndarray, centre: tuple[int, int], half: int, levels: int = 0) -> _Neighbourhood:
    """The part of ``image`` within ``half`` px of ``centre``, with its first ``min(levels, KEPT_LEVELS)``
    reductions (more are added by :func:`_levels` when needed)."""
    crop, x0, y0 = _crop(image, centre[0], centre[1], half)
    hood = _Neighbourhood([crop], (x0, y0), centre)
    _levels(hood, levels)
    return hood


def _levels(hood: _Neighbourhood, levels: int) -> list[np.ndarray]:
    """``hood``'s levels with its first ``min(levels, KEPT_LEVELS)`` reductions built (once per neighbourhood).
    The crop is copied before it is first reduced: ``cv2.pyrDown`` reads a view of the frame's rows (a row
    every frame's width apart) several times slower than numpy copies them, and the flow's small crops then
    read the copy from the cache. A step the motion predicts reads a window's width of the crop only, and
    needs neither the copy (a cold 1080p frame's 321 rows cost more to copy than the step's flow) nor the
    reductions."""
    wanted = min(int(levels), KEPT_LEVELS)
    if len(hood.levels) == 1 and wanted >= 1:  # (the crop alone is still the frame's view)
        hood.levels[0] = hood.levels[0].copy()
    while len(hood.levels) <= wanted:
        hood.levels.append(cv2.pyrDown(hood.levels[-1]))
    return hood.levels


def _centre(point) -> tuple[int, int]:
    return int(point[0]), int(point[1])


#: the flow's stopping rule: 40 iterations or a step under 0.003 px
_CRITERIA = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 40, 0.003)


def _flow(previous: _Neighbourhood, following: np.ndarray, point: tuple[float, float], settings: TrackSettings,
          motion: tuple[float, float] | None = None) -> tuple[tuple[float, float] | None, float, _Neighbourhood]:
    """The point's position (x, y) on ``following`` by LK, its forward–backward disagreement (px), and the
    neighbourhood of ``following`` it used (cropped about ``previous``'s centre, the next step's start).
    ``previous`` is the neighbourhood of the frame the point is on, cropped about a centre within
    :data:`SLACK` px of the point (:func:`_reach` + SLACK px about it). ``motion`` (px) is the point's
    expected move, its last step's: where the finest level alone, started from it, finds the point both
    ways within ``max_fb_px`` (:func:`_predicted_flow`), that is the answer (the neighbourhood returned says
    so: ``predicted``); else the whole pyramid decides."""
    size = (int(settings.window), int(settings.window))
    after = _neighbourhood(following, previous.centre, _reach(settings) + SLACK)
    if previous.levels[0].shape != after.levels[0].shape:
        return None, np.inf, after
    x0, y0 = previous.corner
    sx, sy = point[0] - x0, point[1] - y0
    predicted = None if motion is None else _predicted_flow(previous.levels[0], after.levels[0], sx, sy, motion, size)
    if predicted is not None and predicted[1] <= settings.max_fb_px:
        (ax, ay), fb = predicted
        return (ax + x0, ay + y0), fb, after._replace(predicted=True)
    start = _point(sx, sy)
    ahead = _pyramidal_lk(previous, after, start, size, settings.levels, _CRITERIA)
    if ahead is None:
        return None, np.inf, after
    back = _pyramidal_lk(after, previous, ahead, size, settings.levels, _CRITERIA)
    if back is None:
        return None, np.inf, after
    (ax, ay), (bx, by), (sx, sy) = ahead[0, 0].tolist(), back[0, 0].tolist(), start[0, 0].tolist()
    return (ax + x0, ay + y0), math.sqrt((bx - sx) ** 2 + (by - sy) ** 2), after


def _predicted_flow(before: np.ndarray, after: np.ndarray, sx: float, sy: float, motion: tuple[float, float],
                    size: tuple[int, int]) -> tuple[tuple[float, float], float] | None:
    """The flow at the finest level only, forward from the point (``sx``, ``sy``) moved by ``motion`` and
    back from the point found moved by ``-motion`` (pixels of ``before``/``after``, one crop's): the point
    found and the forward–backward disagreement (px); None where either way loses the point or moves further
    from its start than a tight level allows (:func:`_tight_level`), for the whole pyramid to decide. In a
    video a point moves much as it did a frame before, and the coarser levels and their pyramids (two
    thirds of a step's flow) are then work that changes nothing; a move the prediction misses by more than
    a few pixels falls back, and a point found only one way is never taken from here."""
    criteria = _CRITERIA
    ahead = _tight_level(before, after, sx, sy, sx + motion[0], sy + motion[1], size, criteria)
    if ahead is None:
        return None
    back = _tight_level(after, before, ahead[0], ahead[1], ahead[0] - motion[0], ahead[1] - motion[1], size,
                        criteria)
    if back is None:
        return None
    return ahead, math.sqrt((back[0] - sx) ** 2 + (back[1] - sy) ** 2)


#: how far (px) a tight level's iterations may move the point from the coarser levels' answer within the
#: small crops of :func:`_pyramidal_lk`; a move nearer that edge is redone over the whole neighbourhood
FINEST_DRIFT = 8


def _pyramidal_lk(before: _Neighbourhood, after: _Neighbourhood, start: np.ndarray, size: tuple[int, int],
                  levels: int, criteria) -> np.ndarray | None:
    """``cv2.calcOpticalFlowPyrLK`` of one point (``start`` (1, 1, 2) float32, pixels of ``before``'s
    level 0) from ``before`` to ``after`` (neighbourhoods of one size cropped about one centre) over
    ``levels`` pyramid levels, None where it loses the point; the same answer for less work. The whole
    call builds both images' pyramids with every level's derivatives over the whole neighbourhood, though
    each level's iterations read a window's width about the point only: here the coarsest levels run on
    the neighbourhoods' kept reduction (:data:`KEPT_LEVELS`: the quarter resolution, built once a frame),
    and the kept levels below it, finest last, on crops a window and :data:`FINEST_DRIFT` wide about the
    point and the coarser levels' answer, from that answer (the same iterations on the same pixels, in
    coordinates shifted by whole pixels: the point agrees within the flow's convergence). Where either
    part loses the point or a tight level moves toward its crop's edge, the whole call decides (a coarser
    level failing on its own is skipped by the whole call, not a loss)."""
    tight = min(int(levels), KEPT_LEVELS)
    if tight >= 1:
        _levels(before, tight)
        _levels(after, tight)
        coarse, status, _ = cv2.calcOpticalFlowPyrLK(before.levels[tight], after.levels[tight], start / 2 ** tight,
                                                     None, winSize=size, maxLevel=int(levels) - tight,
                                                     criteria=criteria)
        if coarse is not None and status[0, 0]:
            (sx, sy), guess = start[0, 0].tolist(), coarse[0, 0].tolist()
            for level in range(tight - 1, -1, -1):
                guess = _tight_level(before.levels[level], after.levels[level], sx / 2 ** level, sy / 2 ** level,
                                     2 * guess[0], 2 * guess[1], size, criteria)
                if guess is None:
                    break
            if guess is not None:
                return _point(*guess)
    found, status, _ = cv2.calcOpticalFlowPyrLK(before.levels[0], after.levels[0], start, None, winSize=size,
                                                maxLevel=int(levels), criteria=criteria)
    return found if found is not None and status[0, 0] else None


def _tight_level(before: np.ndarray, after: np.ndarray, sx: float, sy: float, gx: float, gy: float,
                 size: tuple[int, int], criteria) -> tuple[float, float] | None:
    """One level of :func:`_pyramidal_lk` from the coarser levels' answer (``gx``, ``gy``) for the point
    (``sx``, ``sy``), both in this level's pixels, on small crops: the point found (this level's pixels);
    None where the whole call must decide."""
    reach = size[0] // 2 + 3 + FINEST_DRIFT  # (the two crops of one size, as the call needs)
    side = 2 * reach + 1
    bx, by, ax, ay = int(sx) - reach, int(sy) - reach, int(gx) - reach, int(gy) - reach
    small_before, small_after = before[by:by + side, bx:bx + side], after[ay:ay + side, ax:ax + side]
    if min(bx, by, ax, ay) < 0 or small_before.shape != (side, side) or small_after.shape != (side, side):
        return None  # at the neighbourhood's edge
    found, status, _ = cv2.calcOpticalFlowPyrLK(small_before, small_after, _point(sx - bx, sy - by),
                                                _point(gx - ax, gy - ay), winSize=size, maxLevel=0,
                                                criteria=criteria, flags=cv2.OPTFLOW_USE_INITIAL_FLOW)
    if found is None or not status[0, 0]:
        return None
    fx, fy = found[0, 0].tolist()
    fx, fy = fx + ax, fy + ay
    if max(abs(fx - gx), abs(fy - gy)) > FINEST_DRIFT - 2:  # moved toward the small crop's edge
        return None
    return fx, fy


def _refine(anchor: np.ndarray, anchor_point: tuple[float, float], current: np.ndarray, guess: tuple[float, float],
            settings: TrackSettings) -> tuple[float, float]:
    """The frame-to-frame position refined against the start frame's window (no drift accumulates):
    LK from the start frame with ``guess`` as initial flow, kept when it converges within 1 px of it."""
    size = (int(settings.window), int(settings.window))
    half = int(settings.window) + 8
    (px, py), (gx, gy) = anchor_point, guess
    before, bx, by = _crop(anchor, px, py, half)
    after, ax, ay = _crop(current, gx, gy, half)
    if before.shape != after.shape:  # at an image edge: the frame-to-frame position stands
        return guess
    refined, status, _ = cv2.calcOpticalFlowPyrLK(before, after, _point(px - bx, py - by), _point(gx - ax, gy - ay),
                                                  winSize=size, maxLevel=0, criteria=_CRITERIA,
                                                  flags=cv2.OPTFLOW_USE_INITIAL_FLOW)
    if refined is None or not status[0, 0]:
        return guess
    rx, ry = refined[0, 0].tolist()
    rx, ry = rx + ax, ry + ay
    return (rx, ry) if math.sqrt((rx - gx) ** 2 + (ry - gy) ** 2) < 1.0 else guess


def _nearest_on(curve_pixels: np.ndarray, point: np.ndarray) -> tuple[np.ndarray, float, int]:
    """The nearest point of a polyline to ``point``, its distance (px) and the index of the segment (the
    vertex it starts from) it lies on."""
    if len(curve_pixels) == 1:
        return curve_pixels[0], float(np.linalg.norm(curve_pixels[0] - point)), 0
    held, off, k = _nearest_on_many(curve_pixels[None], np.asarray(point, float)[None])
    return held[0], float(off[0]), int(k[0])


def _nearest_on_many(curves: np.ndarray, points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The nearest point of each of N polylines of one length ``curves`` (N, L ≥ 2, 2) to its point of ``points``
    (N, 2): the nearest points (N, 2), their distances (N,) px and the indices (N,) of the segments (the
    vertex each starts from) they lie on."""
    a, b = curves[:, :-1], curves[:, 1:]
    ab = b - a
    along = np.einsum("nij,nij->ni", points[:, None] - a, ab)
    t = np.clip(along / np.maximum(np.einsum("nij,nij->ni", ab, ab), 1e-300), 0, 1)
    candidates = a + t[:, :, None] * ab
    distances = np.linalg.norm(candidates - points[:, None], axis=2)
    best = np.argmin(distances, axis=1)
    index = np.arange(len(curves))
    return candidates[index, best], distances[index, best], best


#: samples of the epipolar curve either side of the depth looked about (the unconstrained pair's
#: intersection, or the one held before), where the right point's nearest point of the curve is looked for
#: first (at 0.9 % of depth a sample for the default 400 over 0.2–30 m: ±7 % of the depth)
CURVE_STRETCH = 8


def _hold(rig: StereoRig, left: np.ndarray, right: np.ndarray, depths: np.ndarray, around: int | None
          ) -> tuple[np.ndarray, float, int] | None:
    """The nearest point to ``right`` of the epipolar curve of ``left`` sampled at ``depths``, its distance
    (px) and the index of the depth sample its segment starts from; None where the right camera sees no
    sample. Looked for first on the :data:`CURVE_STRETCH` samples either side of ``around`` (the index
    held on the frame before: a few back-projections instead of the whole curve's); the whole curve decides
    where that stretch is not seen whole or its nearest point lies on its first or last segment (a nearer
    one may lie beyond), or ``around`` is None."""
    if around is not None:
        lo, hi = _stretch(around, len(depths))
        stretch = epipolar_curve_at(rig.left, rig.right, left, depths[lo:hi])
        if len(stretch.depths) == hi - lo >= 2:
            held, off, k = _nearest_on(stretch.pixels, right)
            if _decided(k, lo, hi, len(depths)):
                return held, off, lo + k
    curve = epipolar_curve_at(rig.left, rig.right, left, depths)
    if len(curve.pixels) == 0:
        return None
    held, off, k = _nearest_on(curve.pixels, right)
    return held, off, int(np.searchsorted(depths, curve.depths[k]))


def _stretch(around: int, count: int) -> tuple[int, int]:
    """The depth samples [lo, hi) of the stretch of :data:`CURVE_STRETCH` samples either side of ``around``."""
    return max(around - CURVE_STRETCH, 0), min(around + CURVE_STRETCH + 2, count)


def _decided(k: int, lo: int, hi: int, count: int) -> bool:
    """Whether the nearest point found on segment ``k`` of the stretch [lo, hi) is the whole curve's: not on
    the stretch's first or last segment, unless that is also the whole curve's end (a nearer point may lie
    beyond)."""
    return (0 < k or lo == 0) and (k < hi - lo - 2 or hi == count)


def _hold_many(rig: StereoRig, traced_left, right: np.ndarray, points: np.ndarray, met: np.ndarray,
               depths: np.ndarray) -> list[tuple[np.ndarray, float, int] | None]:
    """:func:`_hold` of N frames at once: for each left pixel (its rays ``traced_left``, a
    :class:`~usvips.core.intersection.TracedRays`) the nearest point to ``right`` (N, 2) of its epipolar
    curve, its distance (px) and depth sample, looked for on the stretch about the depth of the pair's
    intersection (``points`` (N, 3) m, ``met`` (N,) where they intersect): every frame's stretch is
    back-projected into the right camera in ONE call (a flat port's solve costs the same for a few points as
    for hundreds: the call's overhead is most of it). None where the stretch does not decide (not seen whole,
    the nearest point at its end, no intersection): :func:`_hold` of the whole curve decides there."""
    bundle = traced_left.rays
    along = np.einsum("ij,ij->i", points - bundle.origins, bundle.directions)
    count = len(depths)
    out: list[tuple[np.ndarray, float, int] | None] = [None] * len(right)
    chosen = np.flatnonzero(met & bundle.ok)
    if not chosen.size:
        return out
    # the stretches [lo, hi) about each chosen frame's depth sample, laid end to end
    around = np.clip(np.searchsorted(depths, along[chosen]), 0, count - 1)
    lo, hi = np.maximum(around - CURVE_STRETCH, 0), np.minimum(around + CURVE_STRETCH + 2, count)
    lengths = hi - lo
    rows = np.repeat(chosen, lengths)
    columns = np.arange(int(lengths.sum())) - np.repeat(np.cumsum(lengths) - lengths - lo, lengths)
    projection = rig.right.project(bundle.origins[rows] + depths[columns, None] * bundle.directions[rows])
    ends = np.cumsum(lengths)
    seen = np.logical_and.reduceat(projection.ok, ends - lengths)
    # the whole stretches (every frame's but at the curve's ends) at once, the others one by one
    full = (lengths == 2 * CURVE_STRETCH + 2) & seen
    nearest: dict[int, tuple[np.ndarray, float, int]] = {}
    if full.any():
        pixels = projection.pixels[np.repeat(full, lengths)]
        held, off, k = _nearest_on_many(pixels.reshape(-1, 2 * CURVE_STRETCH + 2, 2), right[chosen[full]])
        for j, found in zip(np.flatnonzero(full).tolist(), zip(held, off.tolist(), k.tolist(), strict=True),
                            strict=True):
            nearest[j] = found
    for j in np.flatnonzero(~full & seen & (lengths >= 2)).tolist():
        nearest[j] = _nearest_on(projection.pixels[ends[j] - lengths[j]:ends[j]], right[chosen[j]])
    for j, (held, off, k) in nearest.items():
        if _decided(k, int(lo[j]), int(hi[j]), count):
            out[int(chosen[j])] = (held, off, int(lo[j]) + k)
    return out


def check_trackable(image: np.ndarray, point, settings: TrackSettings | None = None, what: str = "left") -> None:
    """Refuse a start point whose window is featureless or too near the edge (an
    :class:`InvalidParameterError` naming the point and why)."""
    settings = settings or TrackSettings()
    point = validation.finite_vector(f"{what} pixel", point, 2)
    grey = _grey(image)
    if not _inside(point, grey.shape, settings.window / 2 + 1):
        raise InvalidParameterError(f"{what} pixel", f"({point[0]:.1f}, {point[1]:.1f}) is too near the edge of "
                                                     f"the image to track with a {settings.window} px window")
    patch = _window(grey, point, int(settings.window))
    if float(patch.std()) < settings.min_contrast:
        raise InvalidParameterError(f"{what} pixel", f"({point[0]:.1f}, {point[1]:.1f}) is on a featureless patch "
                                                     f"(contrast {patch.std():.1f} grey levels over "
                                                     f"{settings.window} px): pick a textured point to track")
    # the structure tensor of the window: an edge (one direction of texture) lets the flow slide along it
    gx = cv2.Sobel(patch, cv2.CV_64F, 1, 0, ksize=3)[1:-1, 1:-1]
    gy = cv2.Sobel(patch, cv2.CV_64F, 0, 1, ksize=3)[1:-1, 1:-1]
    eigen = np.linalg.eigvalsh(np.array([[np.sum(gx * gx), np.sum(gx * gy)], [np.sum(gx * gy), np.sum(gy * gy)]]))
    if eigen[0] < settings.min_edge_ratio * eigen[1]:
        raise InvalidParameterError(f"{what} pixel", f"({point[0]:.1f}, {point[1]:.1f}) lies on an edge (texture in "
                                                     "one direction only): the track would slide along it; pick a "
                                                     "corner or a textured point")


class _SerialOpenCV:
    """OpenCV on one thread while tracks run (:meth:`held`), its thread count before restored when the last
    track running ends. The tracker's OpenCV calls work on neighbourhoods a few hundred pixels wide, too
    small to share out, yet OpenCV splits several of them (``cv2.pyrDown``, the flow's pyramid and
    derivatives) over its thread pool, whose worker then spins for its next share for about a millisecond:
    called every few tens of microseconds, it spins all through the track, up to doubling tracking's CPU
    time (measured on the survey bench's 1080p clip, frames in memory, median of 7 runs: 0.12–0.26 s against
    0.10 s per 100 frame pairs) for no gain in wall time. The thread count is the process's (OpenCV has no other): other
    OpenCV work meanwhile runs on one thread too — the same results, at worst slower."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._tracks = 0
        self._before = 0

    @contextmanager
    def held(self) -> Iterator[None]:
        with self._lock:
            if self._tracks == 0:
                self._before = cv2.getNumThreads()
                cv2.setNumThreads(1)
            self._tracks += 1
        try:
            yield
        finally:
            with self._lock:
                self._tracks -= 1
                if self._tracks == 0:
                    cv2.setNumThreads(self._before)


_SERIAL_OPENCV = _SerialOpenCV()


def track_vertex(frames: FrameSource, rig: StereoRig, start: int, left, right, first: int, last: int,
                 settings: TrackSettings | None = None, cancel: Callable[[], bool] | None = None,
                 progress: Callable[[int, int], None] | None = None, near: float = 0.2, far: float = 30.0) -> Track:
    """Follow the vertex picked at ``left``/``right`` (px) on frame ``start`` backward to ``first`` and
    forward to ``last`` (inclusive) through ``frames`` with the cameras of ``rig`` (see the module
    docstring). ``near``/``far``: the depths (m along the left ray) the epipolar curve spans. A
    featureless or edge start, or depths not positive and increasing, is an :class:`InvalidParameterError`
    (the depths are checked before any frame is read)."""
    settings = settings or TrackSettings()
    start, first, last = int(start), int(first), int(last)
    if not first <= start <= last:
        raise InvalidParameterError("start", f"frame {start} is not within frames {first} to {last}")
    left = validation.finite_vector("left pixel", left, 2)
    right = validation.finite_vector("right pixel", right, 2)
    near, far = validation.positive("near", near), validation.positive("far", far)
    if far <= near:
        raise InvalidParameterError("far", f"must exceed near ({near:g} m), got {far:g}")
    with _SERIAL_OPENCV.held():
        return _track(frames, rig, start, left, right, first, last, settings, cancel, progress, near, far)


def _track(frames, rig, start, left, right, first, last, settings, cancel, progress, near, far) -> Track:
    """:func:`track_vertex` once its arguments are checked."""
    images = frames(start)
    greys = (_grey(images[0]), _grey(images[1]))
    check_trackable(greys[0], left, settings, "left")
    check_trackable(greys[1], right, settings, "right")
    start_rms = _ray_rms(rig, left, right)
    total = max(last - first, 1)
    done = [0]
    rows = {start: (left, right, (1.0, 1.0), start_rms)}
    stopped = []
    for direction, end in ((-1, first), (1, last)):
        if end == start:
            stopped.append((direction, start, END))
            continue
        frame, why = _follow(frames, rig, start, greys, left, right, direction, end, settings, cancel, progress,
                             total, done, rows, near, far)
        stopped.append((direction, frame, why))
        if why == CANCELLED:
            break
    order = sorted(rows)
    return Track(np.array(order), np.array([rows[f][0] for f in order]), np.array([rows[f][1] for f in order]),
                 np.array([rows[f][2] for f in order], float), np.array([rows[f][3] for f in order], float),
                 start, tuple(stopped))


def _ray_rms(rig: StereoRig, left: np.ndarray, right: np.ndarray) -> float:
    return float(_ray_rms_many(rig, left[None], right[None])[0])


def _ray_rms_many(rig: StereoRig, left: np.ndarray, right: np.ndarray) -> np.ndarray:
    """The stereo ray RMS (m) of each pair of pixels (N, 2) intersected on its own; inf where they do not
    intersect. One intersection for several frames: a frame's own costs as much as a dozen's."""
    result = intersect([rig.left, rig.right], [left, right])
    return np.where(result.ok, np.sqrt(np.mean(result.residuals_m ** 2, axis=1)), np.inf)


#: frames whose ray RMS is computed together (see :func:`_follow`)
RMS_BATCH = 32
#: the depths along the left ray (geometrically spaced) at which the epipolar curve is sampled
CURVE_SAMPLES = 400


class _Step(NamedTuple):
    """A frame followed but not yet accepted: its right point is held to the epipolar curve, and its ray RMS
    computed, with the next few frames'. Pixels (x, y)."""

    frame: int
    left: tuple[float, float]
    right: tuple[float, float]
    scores: tuple[float, float]


def _settle(rig: StereoRig, steps: list[_Step], frame: int, rms_history: list[float], rows: dict,
            settings: TrackSettings, depths: np.ndarray, shape: tuple[int, ...]) -> tuple[int, str] | None:
    """Accept ``steps`` in order (after ``frame``, the last frame accepted), each with its right point held
    to the left point's epipolar curve, while their ray RMS stays below the jump, the right point within
    ``max_epipolar_px`` of the curve and the held point inside the right image (``shape``); (the last frame
    accepted, why) where one stops the track, None when all are accepted."""
    if not steps:
        return None
    traced = (trace(rig.left, np.array([s.left for s in steps])), trace(rig.right, np.array([s.right for s in steps])))
    met = intersect_traced(traced)
    rms_values = np.where(met.ok, np.sqrt(np.mean(met.residuals_m ** 2, axis=1)), np.inf)
    holds = _hold_many(rig, traced[0], traced[1].pixels, met.points, met.ok, depths)
    margin = settings.window / 2 + 1
    for step, rms, hold in zip(steps, rms_values.tolist(), holds, strict=True):
        # (at or below min_rms_m no median can stop it: the median is looked at above it only)
        if rms > settings.min_rms_m and rms > settings.rms_jump * float(np.median(rms_history)):
            return frame, RMS
        if hold is None:  # the stretch did not decide: the whole curve does
            hold = _hold(rig, np.array(step.left), np.array(step.right), depths, None)
        if hold is None or hold[1] > settings.max_epipolar_px:
            return frame, RMS
        if not _inside(hold[0], shape, margin):
            return frame, LEAVES
        rms_history.append(rms)
        rows[step.frame] = (np.array(step.left), hold[0], step.scores, rms)
        frame = step.frame
    return None


class _Advance(NamedTuple):
    """One step of both cameras' points onto the following frame: the points found (x, y; None where the
    flow lost one), their forward–backward disagreements (px), the neighbourhoods the flow cropped, and
    once both are found their windows and correlations with the previous windows."""

    points: tuple[tuple[float, float] | None, tuple[float, float] | None]
    fbs: tuple[float, float]
    hoods: tuple[_Neighbourhood, _Neighbourhood]
    windows: tuple[np.ndarray, np.ndarray] | None
    scores: tuple[float, float]

    @property
    def predicted(self) -> bool:
        """Whether either point was found from its last move alone (not by the whole pyramid)."""
        return any(hood.predicted for hood in self.hoods)

    def why(self, images: tuple[np.ndarray, np.ndarray], settings: TrackSettings) -> str:
        """Why the step stops the track ('' when it does not): a point out of its image, lost or too far
        off on its way back, or a window unlike the previous one; in that order."""
        margin = settings.window / 2 + 1
        for new, image in zip(self.points, images, strict=True):
            if new is not None and not _inside(new, image.shape, margin):
                return LEAVES
        if any(point is None for point in self.points) or max(self.fbs) > settings.max_fb_px:
            return LOST
        return LOW if min(self.scores) < settings.min_score else ""


def _advance(hoods, current, points, greys, anchors, windows, settings: TrackSettings,
             motions: tuple[tuple[float, float], tuple[float, float]] | None) -> _Advance:
    """Both points from their frames onto ``current`` (grey left and right): the flow from each point's
    neighbourhood, started from its expected move (``motions``; None: the whole pyramid, no prediction),
    refined against the start frame (``greys``, ``anchors``) and correlated with ``windows``."""
    size = int(settings.window)
    found = [_flow(hood, image, point, settings, motion)
             for hood, image, point, motion in zip(hoods, current, points, motions or (None, None), strict=True)]
    news = tuple(f[0] for f in found)
    fbs = (found[0][1], found[1][1])
    after = (found[0][2], found[1][2])
    if news[0] is None or news[1] is None:
        return _Advance(news, fbs, after, None, (-1.0, -1.0))
    news = tuple(_refine(grey, anchor, image, new, settings)
                 for grey, anchor, image, new in zip(greys, anchors, current, news, strict=True))
    ahead = (_window(current[0], news[0], size), _window(current[1], news[1], size))
    return _Advance(news, fbs, after, ahead, (_ncc(windows[0], ahead[0]), _ncc(windows[1], ahead[1])))


def _follow(frames, rig, start, greys, left, right, direction, end, settings, cancel, progress, total, done, rows,
            near, far) -> tuple[int, str]:
    """One direction of :func:`track_vertex`: (the last frame tracked, why it stopped).

    The flow follows each camera's point on its own (the right one is not moved to the curve between
    frames: the refinement against the start frame keeps it from drifting), so the hold to the epipolar
    curve and the ray RMS, which only place the right point and stop the track, are computed for
    :data:`RMS_BATCH` frames at once and those frames are accepted in order after them: the same track and
    the same stop as frame by frame (a stop found in a batch drops the frames followed after it)."""
    size = int(settings.window)
    point_l, point_r, frame = tuple(left.tolist()), tuple(right.tolist()), start
    # each point's window on the frame it is on: the next step's correlation compares the window it finds with
    # this one (the point followed is the one found, so a step's windows serve as the next step's)
    windows = (_window(greys[0], left, size), _window(greys[1], right, size))
    half = _reach(settings) + SLACK
    depths = np.geomspace(near, far, CURVE_SAMPLES)
    hoods = tuple(_neighbourhood(grey, _centre(point), half)
                  for grey, point in zip(greys, (point_l, point_r), strict=True))
    anchors = point_l, point_r
    motions = ((0.0, 0.0), (0.0, 0.0))  # each point's last move (px): where the flow looks first
    accepted = start  # the last frame whose ray RMS is known and accepted
    rms_history = [rows[start][3]]
    steps: list[_Step] = []

    def stop(why: str, last: int) -> tuple[int, str]:
        """The earlier stop among the frames not yet accepted, else ``why`` at ``last``."""
        return _settle(rig, steps, accepted, rms_history, rows, settings, depths, greys[1].shape) or (last, why)

    while frame != end:
        if len(steps) >= RMS_BATCH:
            stopped = _settle(rig, steps, accepted, rms_history, rows, settings, depths, greys[1].shape)
            if stopped is not None:
                return stopped
            steps, accepted = [], frame
        if cancel is not None and cancel():
            return stop(CANCELLED, frame)
        following = frame + direction
        try:
            images = frames(following)
        except UsvipsError as error:
            return stop(str(error), frame)
        current = (_grey(images[0]), _grey(images[1]))
        points = (point_l, point_r)
        moved = _advance(hoods, current, points, greys, anchors, windows, settings, motions)
        if moved.predicted and moved.why(current, settings):  # a predicted step that fails: the pyramid decides
            moved = _advance(hoods, current, points, greys, anchors, windows, settings, None)
        done[0] += 1
        if progress is not None:
            progress(done[0], total)
        why = moved.why(current, settings)
        if why:
            return stop(why, frame)
        (new_l, new_r), (after_l, after_r) = moved.points, moved.hoods
        steps.append(_Step(following, new_l, new_r, moved.scores))
        motions = ((new_l[0] - point_l[0], new_l[1] - point_l[1]), (new_r[0] - point_r[0], new_r[1] - point_r[1]))
        windows, point_l, point_r, frame = moved.windows, new_l, new_r, following
        hoods = tuple(after if max(abs(point[0] - after.centre[0]), abs(point[1] - after.centre[1])) <= SLACK
                      else _neighbourhood(grey, _centre(point), half)
                      for after, grey, point in zip((after_l, after_r), current, (point_l, point_r), strict=True))
    return stop(END, frame)
