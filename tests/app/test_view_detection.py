"""The one detection loop over any frame set: each rule sets an instant aside with its own reason (an
unreadable image, another size, not found, seen by one camera only, too few points, blurred, a
near-duplicate); progress after each image and a cancel before each."""

import cv2
import numpy as np
import pytest

from usvips.app.frame_source import FrameSet, StereoFrame
from usvips.app.view_detection import ViewRules, detect_frames
from usvips.core.calibration_targets import CalibrationTarget, TargetDetection
from usvips.core.errors import InvalidParameterError
from usvips.core.observations import ControlPoints

SIZE = (200, 160)


def _grid(offset: float, spacing: float = 20.0) -> np.ndarray:
    j, i = np.mgrid[0:4, 0:5]
    return np.column_stack([i.ravel(), j.ravel()]) * spacing + (40.0 + offset, 40.0)


def _picture(points: np.ndarray, blur: float = 0.0) -> np.ndarray:
    """Black squares on white: a square of the grid's spacing at every other point, so that every point
    is a corner with edges."""
    image = np.full((SIZE[1], SIZE[0]), 220, np.uint8)
    for k, (x, y) in enumerate(points):
        if k % 2 == 0:
            cv2.rectangle(image, (int(x), int(y)), (int(x) + 19, int(y) + 19), 30, -1)
    return cv2.GaussianBlur(image, (0, 0), blur) if blur else image


class _Marked(CalibrationTarget):
    """A test target: the image says where its points are (the frames hand it over with the image)."""

    def __init__(self, where: dict[int, np.ndarray | None]):
        self.where = where

    def describe(self):
        return {"kind": "marked in the image"}

    @classmethod
    def from_description(cls, description, source=""):
        return cls({})  # no image tells it where its points are

    def control_points(self):
        """The 5 × 4 grid of the pictures, 20 mm apart (metres)."""
        xy = _grid(0.0) - 40.0
        return ControlPoints(tuple(str(k) for k in range(len(xy))), np.column_stack([xy / 1000.0, np.zeros(len(xy))]))

    def detect(self, image):
        points = self.where.get(id(image))
        size = (image.shape[1], image.shape[0])
        if points is None:
            return TargetDetection.nothing(size, "not here")
        return TargetDetection(tuple(str(k) for k in range(len(points))), points, np.ones(len(points)), size)


class _Frames(FrameSet):
    unit = "test frame"

    def __init__(self, frames):
        self.frames = frames

    def __len__(self):
        return len(self.frames)

    def __iter__(self):
        for label, left, right in self.frames:
            images = {"left": left, "right": right}
            yield StereoFrame(label, {"test": label}, lambda side, images=images: images[side])


def _scene():
    where = {}

    def shot(offset, blur=0.0, found=(True, True), shape=None):
        out = []
        for seen in found:
            points = _grid(offset)
            image = _picture(points, blur) if shape is None else np.full(shape, 128, np.uint8)
            where[id(image)] = points if seen else None
            out.append(image)
        return out

    frames = [("sharp", *shot(0)), ("again", *shot(0.5)), ("moved", *shot(30)), ("soft", *shot(60, blur=6.0)),
              ("one", *shot(10, found=(True, False))), ("small", *shot(0, shape=(80, 100))),
              ("unreadable", "left image: x.png: cannot read the image", _picture(_grid(0)))]
    return _Marked(where), _Frames(frames)


def test_each_rule_sets_an_instant_aside_with_its_reason():
    target, frames = _scene()
    found = detect_frames(target, frames, ViewRules(minimum_points=4))
    assert [view.label for view in found.views] == ["sharp", "moved"]
    reasons = found.reasons()
    assert set(reasons) == {"again", "soft", "one", "small", "unreadable"}
    assert reasons["again"].startswith("view again: a near-duplicate of view sharp")
    assert reasons["soft"].startswith("view soft: the target is blurred: its edges are ")
    assert "not here" in reasons["one"] and "seen by the left camera only" in reasons["one"]
    assert "is 100 × 80 px, the earlier left images 200 × 160" in reasons["small"]
    assert reasons["unreadable"].startswith("view unreadable: left image: left image: x.png: cannot read")
    assert (found.scanned, found.seen, found.blurred, found.duplicates) == (7, 4, 1, 1)
    assert (found.found_left, found.found_right) == (5, 4)
    assert len(found.blur) == 2 and max(found.blur) < 4


def test_too_few_points_and_the_rules_own_checks():
    target, frames = _scene()
    found = detect_frames(target, frames, ViewRules(minimum_points=100))
    assert not found.views and "only 20 target points are found in both images (at least 100 needed)" in \
        found.reasons()["sharp"]
    for bad in ({"minimum_points": 0}, {"max_blur_px": 0}, {"duplicate_px": -1}, {"blur_share": float("nan")}):
        with pytest.raises(InvalidParameterError):
            ViewRules(**bad)


def test_progress_after_each_image_and_cancel_before_each():
    target, frames = _scene()
    seen = []
    detect_frames(target, frames, progress=lambda done, total: seen.append((done, total)))
    assert seen == [(k, 14) for k in range(1, 15)]
    calls = []

    def cancelled():
        calls.append(1)
        return len(calls) > 5

    with pytest.raises(InterruptedError, match="after 2 of 7 test frames"):
        detect_frames(target, frames, cancelled=cancelled)
