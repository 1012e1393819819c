"""How well a detector finds objects and points at their keypoints, measured against truth: recall and
precision at its score threshold, each keypoint's error, and each keypoint's **pointing σ** — the robust
scale of its errors, the figure a length's σ needs (:mod:`usvips.core.detection.stereo`). Any model can be
measured with it: rendered scenes with truth, or a reviewed set where a person's corrected points are truth.

Matching, per image: a detection and a true object are candidates when the mean distance of their common
keypoints (the ``match_keypoints``, snout and fork by default) is at most ``tolerance`` × the object's size
(the distance between those keypoints in the image; pixels). One assignment over the image
(:func:`scipy.optimize.linear_sum_assignment`) pairs them, closest first. A *required* object that is paired
is found (a true positive), one left unpaired is missed; a detection left unpaired is false; a detection paired
with an object that is not required (mostly hidden, cut by the frame, too small) counts neither way, and so
does an unpaired detection whose match keypoints' midpoint lies in the ``box`` of an object that is not
required (an ignore region, as COCO's crowd boxes: a detector is neither asked for a fish it cannot be
expected to point at, nor blamed for trying).

The pointing σ of a keypoint is 1.4826 × the median of the absolute errors of its x and y coordinates pooled
(pixels, one image coordinate): the standard deviation for Gaussian errors, robust to the few gross misses a
detector makes. Errors are measured from the truth itself, so a bias counts in it.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import linear_sum_assignment

from usvips.core.detection.detection import Detection
from usvips.core.detection.keypoint_sigma import robust_scale
from usvips.core.errors import InvalidParameterError


@dataclass(frozen=True)
class TrueObject:
    """One object's truth in one image: ``keypoints`` {name: (x, y) pixels}, whether a detector must
    find it (``required``; an object mostly hidden, cut by the frame or too small is not) and its drawn box
    (x0, y0, x1, y1 pixels, or ``None``): where it is not required, its ignore region."""

    keypoints: dict[str, tuple[float, float]]
    required: bool = True
    box: tuple[float, float, float, float] | None = None


@dataclass
class ValidationFigures:
    """Counts over a validation set: true positives, missed required objects, false detections; and per
    keypoint the error vectors (n, 2) pixels of the true positives, detection minus truth."""

    found: int = 0
    missed: int = 0
    false: int = 0
    errors: dict[str, list[np.ndarray]] = field(default_factory=dict)

    @property
    def recall(self) -> float:
        """Found / required objects (NaN without any required object)."""
        total = self.found + self.missed
        return self.found / total if total else float("nan")

    @property
    def precision(self) -> float:
        """Found / (found + false) (NaN without any detection counted)."""
        total = self.found + self.false
        return self.found / total if total else float("nan")

    def keypoint_errors(self, name: str) -> np.ndarray:
        """Error vectors (n, 2) pixels of keypoint ``name`` over every true positive."""
        rows = self.errors.get(name, [])
        return np.vstack(rows) if rows else np.zeros((0, 2))

    def median_error(self, name: str) -> float:
        """Median Euclidean error (pixels) of keypoint ``name`` (NaN without any)."""
        e = self.keypoint_errors(name)
        return float(np.median(np.hypot(e[:, 0], e[:, 1]))) if len(e) else float("nan")

    def sigma(self, name: str) -> float:
        """Keypoint ``name``'s pointing σ (pixels, one coordinate; :func:`pointing_sigma`)."""
        return pointing_sigma(self.keypoint_errors(name))

    def summary(self, names: Sequence[str]) -> dict:
        """The figures as plain numbers: recall, precision, counts, per keypoint the median error and σ."""
        return {"recall": self.recall, "precision": self.precision, "found": self.found, "missed": self.missed,
                "false": self.false,
                "keypoints": {n: {"median_error_px": self.median_error(n),
                                  "sigma_px": self.sigma(n) if len(self.keypoint_errors(n)) >= 5 else float("nan"),
                                  "count": len(self.keypoint_errors(n))} for n in names}}


def pointing_sigma(errors: np.ndarray) -> float:
    """The pointing σ (pixels, one image coordinate) of keypoint errors (n, 2) pixels: 1.4826 × the median
    of |e| over both coordinates pooled. Fewer than 5 errors give no figure: an
    :class:`InvalidParameterError`."""
    e = np.asarray(errors, dtype=np.float64).reshape(-1, 2)
    if len(e) < 5:
        raise InvalidParameterError("errors", f"a pointing sigma needs at least 5 keypoint errors, got {len(e)}")
    if not np.isfinite(e).all():
        raise InvalidParameterError("errors", "keypoint errors must be finite")
    return robust_scale(e)[0]


def _size(truth: TrueObject, names: Sequence[str]) -> float:
    points = np.array([truth.keypoints[n] for n in names], dtype=np.float64)
    return float(np.linalg.norm(points[0] - points[-1])) if len(points) > 1 else 1.0


def match_image(detections: Sequence[Detection], truths: Sequence[TrueObject], figures: ValidationFigures,
                match_keypoints: Sequence[str] = ("snout", "fork"), tolerance: float = 0.2, scale: float = 1.0) -> None:
    """Match one image's detections to its true objects and add the counts and keypoint errors to
    ``figures`` (see the module's docstring); errors are multiplied by ``scale`` (e.g. a letterbox's, to give
    them in a model's input pixels)."""
    names = tuple(match_keypoints)
    cost = np.full((len(detections), len(truths)), np.inf)
    for i, detection in enumerate(detections):
        for j, truth in enumerate(truths):
            common = [n for n in names if n in truth.keypoints and n in detection.keypoint_names]
            if not common:
                continue
            gap = np.mean([np.hypot(*(detection.keypoint(n).pixel - np.asarray(truth.keypoints[n]))) for n in common])
            if gap <= tolerance * max(_size(truth, names), 1.0):
                cost[i, j] = gap
    paired = np.zeros(len(detections), bool)
    found = np.zeros(len(truths), bool)
    if len(detections) and len(truths):
        rows, cols = linear_sum_assignment(np.where(np.isfinite(cost), cost, 1e12))
        for i, j in zip(rows, cols, strict=True):
            if not np.isfinite(cost[i, j]):
                continue
            paired[i] = True
            if truths[j].required:
                found[j] = True
                for point in detections[i].keypoints:
                    if point.name in truths[j].keypoints:
                        figures.errors.setdefault(point.name, []).append(
                            scale * (point.pixel - np.asarray(truths[j].keypoints[point.name], np.float64))[None, :])
    ignored = np.array([not paired[i] and _in_ignore_region(d, truths, names) for i, d in enumerate(detections)],
                       bool)
    figures.found += int(found.sum())
    figures.missed += int(sum(1 for j, t in enumerate(truths) if t.required and not found[j]))
    figures.false += int((~paired & ~ignored).sum())


def _in_ignore_region(detection: Detection, truths: Sequence[TrueObject], names: Sequence[str]) -> bool:
    """Whether the midpoint of ``detection``'s match keypoints lies in the box of an object not required."""
    common = [n for n in names if n in detection.keypoint_names]
    if not common:
        return False
    x, y = np.mean([detection.keypoint(n).pixel for n in common], axis=0)
    return any(t.box is not None and not t.required and t.box[0] <= x <= t.box[2] and t.box[1] <= y <= t.box[3]
               for t in truths)
