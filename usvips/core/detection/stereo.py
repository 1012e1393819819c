"""Detections of one stereo frame paired through the housing, and each pair measured with its sigma.

Pairing: a left and a right detection of one fish put each keypoint on the other image's REFRACTIVE
epipolar curve of its partner (:func:`usvips.core.matching.epipolar_curve`'s construction, batched here:
the keypoint's ray in the water sampled from ``near`` to ``far`` metres and projected through the other
housing). The cost of a candidate pair is the RMS, over the keypoints both give (confidence ≥
``min_confidence``) and over both directions (left keypoint's curve in the right image, and back), of the
distance of each keypoint to its partner's curve, in pixels; detections of different classes or without a
common keypoint cannot pair. One assignment over the frame (:func:`scipy.optimize.linear_sum_assignment`,
not greedy) maximises Σ (gate − cost) over the pairs it makes: no pair costs ``gate_px`` or more, and
leaving two detections unpaired weighs as much as pairing them at the gate. Detections left over are
returned as unpaired.

Measuring: the paired keypoints (e.g. snout and fork) are intersected and their length computed by the
project's one figure path (:func:`usvips.core.measurements.measure_picks_many`, the same as a person's
picks), with the keypoints' pointing sigma GIVEN by the caller: a model keypoint's sigma is to be measured
per keypoint (on validation, then from reviewers' corrections); this module never assumes it measured.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace

import numpy as np
from scipy.optimize import linear_sum_assignment

from usvips.core import validation
from usvips.core.camera import Camera
from usvips.core.detection.detection import Detection
from usvips.core.errors import InvalidParameterError, UsvipsError
from usvips.core.measurements.batch import measure_picks_many
from usvips.core.measurements.evaluate import Measurement
from usvips.core.measurements.figures import QualityRules
from usvips.core.rig import StereoRig
from usvips.core.stereo_calibration import StereoCalibration

#: what every length measured from model keypoints says of its pointing sigma
STATED_KEYPOINT_SIGMA = "keypoint pointing sigma stated by the caller, not measured"
#: how the mark of a length measured with a MEASURED keypoint sigma begins (its basis follows)
MEASURED_KEYPOINT_SIGMA = "keypoint pointing sigma measured on"


@dataclass(frozen=True)
class StereoPair:
    """A left and a right detection of one object (their indices in the frame's lists) and the pair's
    cost: the RMS distance (px) of their keypoints to each other's refractive epipolar curves."""

    left: Detection
    right: Detection
    left_index: int
    right_index: int
    cost_px: float


@dataclass(frozen=True)
class Pairing:
    """A frame's pairs, and the indices of the left and right detections left unpaired."""

    pairs: tuple[StereoPair, ...]
    unpaired_left: tuple[int, ...]
    unpaired_right: tuple[int, ...]


def epipolar_curves(source: Camera, target: Camera, pixels: np.ndarray, near: float = 0.3, far: float = 10.0,
                    samples: int = 200) -> tuple[np.ndarray, np.ndarray]:
    """The refractive epipolar curves in ``target`` of pixels (n, 2) of ``source``: samples (n, M, 2) px and
    a mask (n, M) of the samples the target sees (inside its frame when its size is known); depths from
    ``near`` to ``far`` metres along each ray in the water, geometrically spaced."""
    near, far = validation.positive("near", near), validation.positive("far", far)
    if far <= near:
        raise InvalidParameterError("far", f"must exceed near ({near:g} m), got {far:g}")
    if int(samples) < 2:
        raise InvalidParameterError("samples", f"a curve needs at least 2 samples, got {samples}")
    pixels = np.asarray(pixels, dtype=np.float64).reshape(-1, 2)
    depths = np.geomspace(near, far, int(samples))
    bundle = source.rays(pixels)
    points = bundle.origins[:, None, :] + depths[None, :, None] * bundle.directions[:, None, :]
    projection = target.project(points.reshape(-1, 3))
    ok = projection.ok.reshape(len(pixels), len(depths)) & bundle.ok[:, None]
    return projection.pixels.reshape(len(pixels), len(depths), 2), ok


def curve_distances(curves: np.ndarray, ok: np.ndarray, points: np.ndarray) -> np.ndarray:
    """(n, m) shortest distances (px) from points (m, 2) to curves (n, M, 2) taken as polylines through their
    seen samples (``ok`` (n, M)); inf for a curve with fewer than two consecutive seen samples."""
    a, b = curves[:, :-1], curves[:, 1:]
    usable = ok[:, :-1] & ok[:, 1:]
    ab = np.where(usable[..., None], b - a, 0.0)
    a = np.where(usable[..., None], a, 0.0)
    ap = points[None, :, None, :] - a[:, None, :, :]
    t = np.clip(np.einsum("nmsk,nsk->nms", ap, ab) / np.maximum(np.einsum("nsk,nsk->ns", ab, ab), 1e-300)[:, None],
                0.0, 1.0)
    gap = np.linalg.norm(ap - t[..., None] * ab[:, None], axis=-1)
    gap = np.where(usable[:, None, :], gap, np.inf)
    return gap.min(axis=2) if gap.shape[2] else np.full(gap.shape[:2], np.inf)


def _keypoint_table(detections: Sequence[Detection], names: tuple[str, ...],
                    min_confidence: float) -> np.ndarray:
    """(n, K, 2) keypoint pixels, NaN where a detection lacks the keypoint or trusts it below the bar."""
    table = np.full((len(detections), len(names), 2), np.nan)
    for i, detection in enumerate(detections):
        for point in detection.keypoints:
            if point.name in names and point.confidence >= min_confidence:
                table[i, names.index(point.name)] = (point.x, point.y)
    return table


def pairing_costs(left: Sequence[Detection], right: Sequence[Detection], rig: StereoRig,
                  keypoints: tuple[str, ...] | None = None, min_confidence: float = 0.0, near: float = 0.3,
                  far: float = 10.0, samples: int = 100) -> np.ndarray:
    """(n_left, n_right) costs (px) of every candidate pair (see the module docstring); inf where the two
    cannot pair (different classes, no common keypoint, a curve that misses the other image).
    ``keypoints``: the names used (default: every name the detections give)."""
    names = tuple(keypoints) if keypoints is not None else tuple(dict.fromkeys(
        p.name for d in (*left, *right) for p in d.keypoints))
    costs = np.full((len(left), len(right)), np.inf)
    if not left or not right or not names:
        return costs
    ours, theirs = _keypoint_table(left, names, min_confidence), _keypoint_table(right, names, min_confidence)
    total, count = np.zeros(costs.shape), np.zeros(costs.shape)
    for k in range(len(names)):
        have_left, have_right = np.flatnonzero(~np.isnan(ours[:, k, 0])), np.flatnonzero(~np.isnan(theirs[:, k, 0]))
        if not have_left.size or not have_right.size:
            continue
        forward = curve_distances(*epipolar_curves(rig.left, rig.right, ours[have_left, k], near, far, samples),
                                  theirs[have_right, k])
        backward = curve_distances(*epipolar_curves(rig.right, rig.left, theirs[have_right, k], near, far, samples),
                                   ours[have_left, k]).T
        block = np.ix_(have_left, have_right)
        total[block] += forward ** 2 + backward ** 2
        count[block] += 2
    same_class = np.array([[a.class_name == b.class_name for b in right] for a in left])
    usable = same_class & (count > 0)
    costs[usable] = np.sqrt(total[usable] / count[usable])
    return costs


def assign(costs: np.ndarray, gate_px: float) -> list[tuple[int, int]]:
    """The (row, column) pairs of one assignment over a cost matrix (px; inf: cannot pair) that maximises
    Σ (gate − cost) over the pairs it makes, none at or beyond the gate (not greedy: a row's cheapest column
    goes to another row when that pairs more of the frame at less total cost)."""
    costs = np.asarray(costs, dtype=np.float64)
    feasible = costs < gate_px
    if not feasible.any():
        return []
    rows, columns = linear_sum_assignment(np.where(feasible, costs - gate_px, 0.0))
    return [(int(i), int(j)) for i, j in zip(rows, columns, strict=True) if feasible[i, j]]


def pair_detections(left: Sequence[Detection], right: Sequence[Detection], rig: StereoRig, gate_px: float = 4.0,
                    keypoints: tuple[str, ...] | None = None, min_confidence: float = 0.0, near: float = 0.3,
                    far: float = 10.0, samples: int = 100) -> Pairing:
    """The frame's pairs by one assignment over :func:`pairing_costs` (see the module docstring), gated at
    ``gate_px`` pixels; ``near``/``far`` (m) bound the depths searched along each keypoint's ray."""
    gate = validation.positive("gate_px", gate_px)
    costs = pairing_costs(left, right, rig, keypoints, min_confidence, near, far, samples)
    pairs = tuple(StereoPair(left[i], right[j], i, j, float(costs[i, j])) for i, j in assign(costs, gate))
    paired_left, paired_right = {p.left_index for p in pairs}, {p.right_index for p in pairs}
    return Pairing(tuple(sorted(pairs, key=lambda p: p.left_index)),
                   tuple(i for i in range(len(left)) if i not in paired_left),
                   tuple(j for j in range(len(right)) if j not in paired_right))


def _sigma_of(keypoint_sigma_px: float | Mapping[str, float], name: str) -> float:
    sigma = keypoint_sigma_px.get(name) if isinstance(keypoint_sigma_px, Mapping) else keypoint_sigma_px
    if sigma is None:
        raise InvalidParameterError("keypoint_sigma_px", f"no pointing sigma given for keypoint {name!r}")
    return validation.positive("keypoint_sigma_px", sigma)


def measure_pairs(pairs: Sequence[StereoPair], calibration: StereoCalibration,
                  keypoint_sigma_px: float | Mapping[str, float], keypoints: tuple[str, str] = ("snout", "fork"),
                  station: int | str = 0, frame: str = "object",
                  rules: QualityRules | None = None, measured_basis: str = "",
                  pair_pointing: Sequence[tuple[np.ndarray, np.ndarray]] | None = None
                  ) -> list[Measurement | UsvipsError]:
    """Each pair's length between ``keypoints`` (m, with its sigma) by the project's one figure path, the
    keypoints' pointing sigma (px, one image coordinate; one value or one per keypoint name) as GIVEN —
    or, with ``measured_basis`` (what the sigmas were measured on, :mod:`usvips.core.detection.keypoint_sigma`),
    as measured: the figures then carry origin "estimated" and say what the sigma rests on.
    A pair lacking a keypoint, or whose rays fail, gives the :class:`UsvipsError` saying so in its place.
    ``pair_pointing``: per pair, its keypoints' own (sigmas (K, 2) px [left, right], left–right correlations
    (K,)) — :meth:`usvips.core.detection.keypoint_sigma.StereoSigma.pointing` — in place of
    ``keypoint_sigma_px`` alike in both images."""
    sigmas = np.array([_sigma_of(keypoint_sigma_px, name) for name in keypoints])
    out: list[Measurement | UsvipsError | None] = [None] * len(pairs)
    lefts, rights, where = [], [], []
    for i, pair in enumerate(pairs):
        try:
            lefts.append(np.array([pair.left.keypoint(n).pixel for n in keypoints]))
            rights.append(np.array([pair.right.keypoint(n).pixel for n in keypoints]))
        except InvalidParameterError as error:
            out[i] = error
            continue
        where.append(i)
    own = [pair_pointing[i] for i in where] if pair_pointing is not None else None
    measured = measure_picks_many(["length"] * len(where), calibration, lefts, rights, station, frame,
                                  [p[0] for p in own] if own else [sigmas] * len(where), rules,
                                  [p[1] for p in own] if own else None)
    origin, mark = (("estimated", f"{MEASURED_KEYPOINT_SIGMA} {measured_basis}") if measured_basis
                    else ("given", STATED_KEYPOINT_SIGMA))
    for i, result in zip(where, measured, strict=True):
        out[i] = result if isinstance(result, UsvipsError) else replace(
            result, pointing_origin=origin, marks=result.marks + (mark,))
    return out
