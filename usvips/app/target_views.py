"""Stereo views of a calibration target from image pairs: the pairs as a frame set
(:class:`usvips.app.frame_source.ImagePairs`) through the one detection loop
(:func:`usvips.app.view_detection.detect_frames`), which video uses too.

A pair that cannot be used — an image that cannot be read, a target not found, found by one camera only,
too few points in both, an image of another size than the others from that camera, blurred, a
near-duplicate of a pair kept — is set aside with one line naming the view, the image and why; the others
become :class:`StereoView` s for the calibration (:func:`~usvips.core.calibration_targets.stereo_observations`).
Reads files only (no project), so the window runs it in a worker: ``progress(done, total)`` after each
image, ``cancelled()`` checked before each image (then :class:`InterruptedError`).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

from usvips.app.frame_source import ImagePairs
from usvips.app.view_detection import DetectedViews, ViewRules, detect_frames
from usvips.core.calibration_targets import CalibrationTarget, StereoView


@dataclass(frozen=True)
class TargetViews:
    """The views in which both cameras see the target, and the pairs set aside (label, one-line reason);
    ``blur``: the views' edge widths (px, the blurrier camera); ``detected``: the detection loop's whole
    result (its tally)."""

    views: tuple[StereoView, ...]
    set_aside: tuple[tuple[str, str], ...]
    total: int
    blur: tuple[float, ...] = ()
    detected: DetectedViews | None = None

    def summary(self) -> str:
        """One line: how many pairs became views."""
        points = sum(len(view.common_ids()) for view in self.views)
        return (f"the target is found in both images of {len(self.views)} of {self.total} pairs "
                f"({points} points seen by both cameras); {len(self.set_aside)} set aside")


def detect_views(target: CalibrationTarget, pairs: Sequence[tuple[str | Path, str | Path]],
                 labels: Sequence[str] | None = None, minimum_points: int = 4,
                 progress: Callable[[int, int], None] | None = None,
                 cancelled: Callable[[], bool] | None = None, rules: ViewRules | None = None) -> TargetViews:
    """Find ``target`` in every (left, right) image pair with the one detection loop
    (:func:`usvips.app.view_detection.detect_frames`: its rules, blur and near-duplicates included).
    ``labels`` name the views (default: the left image's name); a view needs ``minimum_points`` points
    found in both images (``rules``, when given, overrides it). A missing image file is an
    :class:`~usvips.core.errors.InputFileError` naming it, before anything is detected."""
    frames = ImagePairs(pairs, labels)
    rules = rules or ViewRules(minimum_points=minimum_points)
    found = detect_frames(target, frames, rules, progress, cancelled)
    return TargetViews(found.views, found.set_aside, len(frames), found.blur, found)
