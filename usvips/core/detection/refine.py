"""Keypoints of a stereo pair refined along the refractive epipolar curve.

A model points at the snout in the left image and, independently, in the right one: the two errors are
independent, so their difference — the disparity — carries both, and the depth of the intersected point
(and with it the length) suffers most. Refinement keeps the left keypoint and moves the right one to the
conjugate of the LEFT keypoint: a small patch around the left keypoint is matched by normalised
cross-correlation along the left keypoint's refractive epipolar curve in the right image
(:func:`usvips.core.matching.match_along_curve`, the auto-match of hand picks), searched only within
``radius_px`` of the model's right keypoint so that the match cannot jump to another fish.

The refined right point then shows, up to the match's own error, the same surface point as the left
keypoint: the pair's 3-D point lies near the fish, and its error is the left keypoint's error carried along
the surface plus the match's error carried through the disparity. The match's error is NOT a tenth of a
pixel at a snout or a fork: the patch there is half background, which moves with its own disparity. With
the true keypoints of rendered fish (``tests/core/detection/test_refine.py``'s scenes, 1-1.6 m, 12 fish
per housing) refinement moves them by a median of 0.4-1.7 px, 1.8-5 px at the 90th percentile and up to
9-16 px. A refined pair's length is measured with correlated left–right pointing
(:func:`usvips.core.detection.stereo.measure_pairs` with ``pair_pointing``, as the detection service gives
it from the model's measured ``[stereo_sigma]``): the right error is the left one carried over plus the
match's own (:mod:`usvips.core.measurements.correlated_pointing`). A larger move than ``max_shift_px`` is
refused when it is given (the detection service gives 3 standard deviations of the move the keypoints' measured
sigma by the fish's size explains, :func:`usvips.app.detection_service.shift_limits`). A match the
matcher refuses (ambiguous, textureless, a low correlation) leaves the model's right keypoint as it was,
and says why.

Pixels: x right, y down, origin at the centre of the top-left pixel.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace

import numpy as np

from usvips.core import validation
from usvips.core.detection.detection import Detection, Keypoint
from usvips.core.detection.stereo import StereoPair, epipolar_curves
from usvips.core.errors import InvalidParameterError
from usvips.core.matching import EpipolarCurve, epipolar_curve, match_along_curve
from usvips.core.rig import StereoRig


@dataclass(frozen=True)
class KeypointRefinement:
    """What refinement did to one keypoint of a pair: its ``name``, the model's right pixel ``before`` and
    the refined one ``after`` (equal when not refined), the correlation ``score`` (NCC, −1..1; None without a
    candidate) and ``reason`` ('' when refined; else why the model's point was kept)."""

    name: str
    before: tuple[float, float]
    after: tuple[float, float]
    score: float | None
    reason: str = ""

    @property
    def refined(self) -> bool:
        return not self.reason

    @property
    def beyond_limit(self) -> bool:
        """Whether the match was found but lay further from the model's right point than the limit: the
        model's two keypoints are then not the same point of the fish (one of them is off by more than its
        measured sigma explains), and the pair's length has no honest sigma."""
        return not self.refined and self.reason.startswith(BEYOND_LIMIT)

    @property
    def at_edge(self) -> bool:
        """Whether the left keypoint, or the model's right one, lies too near its image's edge for the patch:
        the fish may be cut by the frame, its true point outside it, where the model cannot point."""
        return not self.refined and self.reason.startswith(AT_EDGE)

    @property
    def off_curve(self) -> bool:
        """Whether the left keypoint's epipolar curve passes further from the model's right point than the
        search radius: the two keypoints cannot be one point of the fish."""
        return not self.refined and self.reason.startswith(FAR_FROM_CURVE)

    @property
    def shift_px(self) -> float:
        """How far refinement moved the right keypoint (px)."""
        return float(np.hypot(self.after[0] - self.before[0], self.after[1] - self.before[1]))


@dataclass(frozen=True)
class RefinedPair:
    """A pair whose right keypoints were refined (``pair.right`` holds the refined points) and what was
    done to each keypoint asked for."""

    pair: StereoPair
    keypoints: tuple[KeypointRefinement, ...]


def _near(curve: EpipolarCurve, centre: np.ndarray, radius: float) -> EpipolarCurve:
    keep = np.linalg.norm(curve.pixels - centre, axis=1) <= radius
    return EpipolarCurve(curve.pixels[keep], curve.depths[keep])


#: how the reason of a match refused for moving the model's point too far begins
BEYOND_LIMIT = "the match would move it"
#: how the reason of a keypoint too near its image's edge for the patch begins
AT_EDGE = "at the image's edge"
#: how the reason of a keypoint whose curve misses the model's right point begins
FAR_FROM_CURVE = "the epipolar curve passes no closer than"
#: samples of each epipolar curve (geometrically spaced depths from near to far)
CURVE_SAMPLES = 400


def refine_keypoint(left_image: np.ndarray, right_image: np.ndarray, rig: StereoRig, left: Keypoint,
                    right: Keypoint, window: int = 15, radius_px: float = 12.0, near: float = 0.3,
                    far: float = 10.0, min_score: float = 0.6, curve: EpipolarCurve | None = None,
                    max_shift_px: float | None = None) -> KeypointRefinement:
    """The right keypoint moved to the match of a ``window`` px patch around the left keypoint along its
    refractive epipolar curve, searched within ``radius_px`` of the model's right point (see the module
    docstring); the model's point kept, with the reason, when the matcher refuses. ``curve``: the left
    keypoint's curve when already traced (:func:`refine_pairs` traces a frame's curves at once).
    ``max_shift_px``: a match that would move the model's point further than this is not taken (the model's
    point kept, with the reason) — given as 3 standard deviations of the move the two keypoints' own
    errors make (:func:`usvips.app.detection_service.shift_limits`), reached by them in about 1 % of cases,
    it keeps the wrong matches of the module docstring out."""
    radius = validation.positive("radius_px", radius_px)
    before = (float(right.x), float(right.y))
    height, width = right_image.shape[:2]
    half = int(window) // 2
    if not (half <= right.x <= width - 1 - half and half <= right.y <= height - 1 - half):
        return KeypointRefinement(left.name, before, before, None,
                                  f"{AT_EDGE}: the model's right point ({right.x:g}, {right.y:g}) is too close to "
                                  f"the edge of the {width} × {height} right image for a {int(window)} px template")
    if curve is None:
        curve = epipolar_curve(rig.left, rig.right, left.pixel, near, far, samples=CURVE_SAMPLES)
    curve = _near(curve, right.pixel, radius)
    if len(curve.pixels) < 2:
        return KeypointRefinement(left.name, before, before, None,
                                  f"{FAR_FROM_CURVE} {radius:g} px to the model's point")
    try:
        match = match_along_curve(left_image, right_image, left.pixel, curve, window=window, min_score=min_score)
    except InvalidParameterError as error:  # a keypoint too near the edge for the patch
        return KeypointRefinement(left.name, before, before, None, f"{AT_EDGE}: {error.problem}")
    if not match:
        return KeypointRefinement(left.name, before, before, match.score if match.pixel else None,
                                  match.reason or "no match")
    after = (float(match.pixel[0]), float(match.pixel[1]))
    shift = float(np.hypot(after[0] - before[0], after[1] - before[1]))
    if max_shift_px is not None and shift > max_shift_px:
        return KeypointRefinement(left.name, before, before, float(match.score),
                                  f"{BEYOND_LIMIT} {shift:.1f} px, more than {max_shift_px:.1f} px "
                                  "(what the keypoints' measured sigma explains): the model's point kept")
    return KeypointRefinement(left.name, before, after, float(match.score))


def refine_pairs(left_image: np.ndarray, right_image: np.ndarray, pairs: Sequence[StereoPair], rig: StereoRig,
                 keypoints: Sequence[str] = ("snout", "fork"), window: int = 15, radius_px: float = 12.0,
                 near: float = 0.3, far: float = 10.0, min_score: float = 0.6,
                 max_shift_px: Mapping[str, float] | Sequence[Mapping[str, float]] | None = None
                 ) -> list[RefinedPair]:
    """Each of a frame's pairs with each of ``keypoints`` (those both detections give) refined in the right
    image by :func:`refine_keypoint`, every curve traced in one batch; other keypoints are left as the
    model gave them. ``max_shift_px``: per keypoint name, the largest move taken (see
    :func:`refine_keypoint`) — one table for every pair, or one per pair (a limit that grows with the fish's
    size); a name not in it, or None, has no limit. A keypoint's search radius is at least its limit (a
    limit beyond the radius could never be reached)."""
    per_pair = (list(max_shift_px) if max_shift_px is not None and not isinstance(max_shift_px, Mapping)
                else [max_shift_px or {}] * len(pairs))
    if len(per_pair) != len(pairs):
        raise InvalidParameterError("max_shift_px", f"{len(per_pair)} tables of limits for {len(pairs)} pairs")
    jobs = [(i, name) for i, pair in enumerate(pairs) for name in keypoints
            if name in pair.left.keypoint_names and name in pair.right.keypoint_names]
    curves: list[EpipolarCurve] = []
    if jobs:
        pixels = np.array([pairs[i].left.keypoint(name).pixel for i, name in jobs])
        traced, seen = epipolar_curves(rig.left, rig.right, pixels, near, far, CURVE_SAMPLES)
        depths = np.geomspace(near, far, CURVE_SAMPLES)
        curves = [EpipolarCurve(traced[k][seen[k]], depths[seen[k]]) for k in range(len(jobs))]
    steps: dict[int, list[KeypointRefinement]] = {i: [] for i in range(len(pairs))}
    for (i, name), curve in zip(jobs, curves, strict=True):
        pair = pairs[i]
        limit = per_pair[i].get(name)
        steps[i].append(refine_keypoint(left_image, right_image, rig, pair.left.keypoint(name),
                                        pair.right.keypoint(name), window, max(radius_px, limit or 0.0), near,
                                        far, min_score, curve, limit))
    out = []
    for i, pair in enumerate(pairs):
        moved = {step.name: step.after for step in steps[i] if step.refined}
        right: Detection = pair.right
        if moved:
            right = replace(right, keypoints=tuple(replace(k, x=moved[k.name][0], y=moved[k.name][1])
                                                   if k.name in moved else k for k in right.keypoints))
        out.append(RefinedPair(replace(pair, right=right), tuple(steps[i])))
    return out


def refine_pair(left_image: np.ndarray, right_image: np.ndarray, pair: StereoPair, rig: StereoRig,
                keypoints: Sequence[str] = ("snout", "fork"), window: int = 15, radius_px: float = 12.0,
                near: float = 0.3, far: float = 10.0, min_score: float = 0.6,
                max_shift_px: Mapping[str, float] | None = None) -> RefinedPair:
    """One pair refined by :func:`refine_pairs`."""
    return refine_pairs(left_image, right_image, [pair], rig, keypoints, window, radius_px, near, far, min_score,
                        max_shift_px)[0]
