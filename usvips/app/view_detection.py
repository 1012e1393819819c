"""The one detection loop: a calibration target found in every instant of a frame set (image pairs or a
stereo video, :mod:`usvips.app.frame_source`), with one set of rules for which instants become views.

For each instant, in order, both cameras' images are read and the target detected in each (its kind's
detector cascade). The instant becomes a view unless one of these rules sets it aside, with one line
saying why (``view <label>: …``):

1. a camera's image cannot be read (the file and why);
2. a camera's image is not the size of that camera's earlier images;
3. the target is not found in a camera's image (the detector's reason; and which camera alone saw it);
4. fewer than :attr:`ViewRules.minimum_points` points are found in both images;
5. the target is blurred in either image: its edges (:func:`usvips.core.calibration_views.edge_width`) are
   wider than :attr:`ViewRules.max_blur_px` and than half the spacing of its points
   (:func:`usvips.core.calibration_views.blur_limit_px`);
6. it repeats a view already kept: every shared point within :attr:`ViewRules.duplicate_px` in both
   cameras (:func:`usvips.core.calibration_views.is_duplicate`; compared with the last 50 views kept).

Long work: ``progress(done, total)`` after each camera's image (total = 2 × instants), ``cancelled()``
checked before each camera's image (then :class:`InterruptedError` saying where it stopped; a video
instant not yet decoded is never decoded).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from usvips.app.frame_source import SIDES, FrameSet
from usvips.core import calibration_views
from usvips.core.calibration_targets import CalibrationTarget, StereoView, TargetDetection
from usvips.core.errors import InvalidParameterError

#: how many of the last views kept an instant is compared with for near-duplicates
DUPLICATE_WINDOW = 50


@dataclass(frozen=True)
class ViewRules:
    """The rules an instant must pass to become a view (see the module's notes): ``minimum_points`` found
    in both images; edges at most ``max_blur_px`` pixels wide or at most ``blur_share`` of the spacing of
    the points; not within ``duplicate_px`` pixels of a view kept (0 keeps near-duplicates)."""

    minimum_points: int = 4
    max_blur_px: float = calibration_views.MAX_EDGE_WIDTH_PX
    duplicate_px: float = calibration_views.DUPLICATE_PX
    blur_share: float = calibration_views.BLUR_SHARE

    def __post_init__(self) -> None:
        if int(self.minimum_points) < 1:
            raise InvalidParameterError("minimum points", f"a view needs at least 1 point, got {self.minimum_points}")
        if not 0 < self.max_blur_px < float("inf"):
            raise InvalidParameterError("largest edge width", f"must be a finite positive number of pixels, got "
                                        f"{self.max_blur_px}")
        if not self.blur_share > 0:
            raise InvalidParameterError("blur share", f"must be a positive share of the point spacing, got "
                                        f"{self.blur_share}")
        if not self.duplicate_px >= 0:
            raise InvalidParameterError("near-duplicate tolerance", f"must be 0 or more pixels, got "
                                        f"{self.duplicate_px}")


@dataclass(frozen=True)
class DetectedViews:
    """What the loop found in a frame set.

    ``views``: the instants kept, in order; ``blur``: their edge widths (px, the blurrier camera);
    ``set_aside``: (label, one line why) for every other instant; the tally: ``scanned`` instants,
    ``found_left``/``found_right`` instants where that camera found the target, ``seen`` instants where
    both did with enough points in common, ``blurred`` and ``duplicates`` of those set aside."""

    views: tuple[StereoView, ...]
    blur: tuple[float, ...]
    set_aside: tuple[tuple[str, str], ...]
    scanned: int
    found_left: int
    found_right: int
    seen: int
    blurred: int
    duplicates: int

    def __bool__(self) -> bool:
        """Falsy when no instant gave a usable view (:meth:`reasons` says why each was set aside)."""
        return bool(self.views)

    def reasons(self) -> dict[str, str]:
        """The reason each instant set aside was, by its label."""
        return dict(self.set_aside)


def _blur(images: dict[str, np.ndarray], detections: dict[str, TargetDetection],
          rules: ViewRules) -> tuple[float, float]:
    """The edge width (px) of the blurrier camera (NaN when it cannot be read: no contrast) and the
    widest it may be (:func:`usvips.core.calibration_views.blur_limit_px`) — of the camera nearer to or
    over its limit."""
    pairs = [(calibration_views.edge_width(images[side], detections[side]),
              calibration_views.blur_limit_px(detections[side], rules.max_blur_px, rules.blur_share))
             for side in SIDES]
    if any(np.isnan(width) for width, _ in pairs):
        return float("nan"), pairs[0][1]
    return max(pairs, key=lambda pair: pair[0] / pair[1])


def detect_frames(target: CalibrationTarget, frames: FrameSet, rules: ViewRules | None = None,
                  progress: Callable[[int, int], None] | None = None,
                  cancelled: Callable[[], bool] | None = None) -> DetectedViews:
    """Find ``target`` in every instant of ``frames`` under ``rules`` (see the module's notes)."""
    rules = rules or ViewRules()
    total, done = 2 * len(frames), 0
    sizes: dict[str, tuple[int, int]] = {}
    views: list[StereoView] = []
    blur: list[float] = []
    set_aside: list[tuple[str, str]] = []
    found_count = {side: 0 for side in SIDES}
    seen = blurred = duplicates = scanned = 0
    for frame in frames:
        images: dict[str, np.ndarray] = {}
        detections: dict[str, TargetDetection] = {}
        problems: list[str] = []
        for side in SIDES:
            if cancelled is not None and cancelled():
                raise InterruptedError(frames.cancelled(done // 2, frame))
            image = frame.image(side)
            if isinstance(image, str):
                problems.append(f"{side} image: {image}")
            else:
                images[side] = image
                detection = target.detect(image)
                size = detection.image_size
                name = _image_name(frame.source, side)
                if sizes.setdefault(side, size) != size:
                    problems.append(f"{side} image{name} is {size[0]} × {size[1]} px, the earlier {side} images "
                                    f"{sizes[side][0]} × {sizes[side][1]}")
                elif not detection:
                    problems.append(f"{side} image{name}: {detection.reason}")
                else:
                    detections[side] = detection
                    found_count[side] += 1
            done += 1
            if progress is not None:
                progress(done, total)
        scanned += 1
        label = frame.label
        if problems:
            if len(detections) == 1:
                problems.append(f"the target is seen by the {next(iter(detections))} camera only")
            set_aside.append((label, f"view {label}: " + "; ".join(problems)))
            continue
        view = StereoView(label, detections["left"], detections["right"], frame.source)
        common = len(view.common_ids())
        if common < rules.minimum_points:
            set_aside.append((label, f"view {label}: only {common} target points are found in both images (at "
                              f"least {rules.minimum_points} needed)"))
            continue
        seen += 1
        width, limit = _blur(images, detections, rules)
        if not width <= limit:  # NaN (no contrast) counts as blurred
            blurred += 1
            shown = "cannot be measured (no contrast)" if np.isnan(width) else f"are {width:.1f} px wide"
            set_aside.append((label, f"view {label}: the target is blurred: its edges {shown} (at most "
                              f"{limit:.1f} px: half the spacing of its points, or {rules.max_blur_px:g} px); hold "
                              "it still, focus, or expose shorter"))
            continue
        twin = next((kept for kept in reversed(views[-DUPLICATE_WINDOW:]) if rules.duplicate_px > 0
                     and calibration_views.is_duplicate(kept, view, rules.duplicate_px)), None)
        if twin is not None:
            duplicates += 1
            set_aside.append((label, f"view {label}: a near-duplicate of view {twin.label} (every shared point "
                              f"within {rules.duplicate_px:g} px in both cameras)"))
            continue
        views.append(view)
        blur.append(width)
    return DetectedViews(tuple(views), tuple(blur), tuple(set_aside), scanned, found_count["left"],
                         found_count["right"], seen, blurred, duplicates)


def _image_name(source: dict, side: str) -> str:
    """`` NAME`` of an image file in messages (empty for a video frame)."""
    path = source.get(side)
    return f" {Path(path).name}" if isinstance(path, str) else ""
