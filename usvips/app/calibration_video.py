"""Views of a calibration target from a project's synchronised stereo video.

The board (or 3-D target) is moved in front of the rig while both cameras film. Every ``every``-th instant
is decoded in both cameras (left frame ``i`` with right frame ``i + offset``, the stored offset of
:mod:`usvips.app.video_project`; :class:`usvips.app.frame_source.VideoFrames`), and the one detection loop
(:func:`usvips.app.view_detection.detect_frames`, the image pairs' too) keeps an instant when both
cameras see enough of it, it is not blurred (:func:`usvips.core.calibration_views.edge_width`) and it does
not repeat an instant already kept (:func:`~usvips.core.calibration_views.is_duplicate`). Of those, a
diverse subset under a cap (:func:`~usvips.core.calibration_views.select_views`) becomes the views to
calibrate from, with their coverage and advice.

Long work: ``progress(fraction, message)`` after each instant, and ``cancel`` (a :class:`threading.Event`
or a callable returning True) checked before each instant is decoded: a cancel stops the decoding there
and raises :class:`InterruptedError` (as a cancelled proxy build does). Nothing is stored in the project.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

from usvips.app.frame_source import VideoFrames
from usvips.app.video_project import VideoError, open_streams
from usvips.app.view_detection import ViewRules, detect_frames
from usvips.core import calibration_views
from usvips.core.calibration_targets import CalibrationTarget, StereoView, stereo_observations
from usvips.core.calibration_views import Coverage
from usvips.core.errors import InvalidParameterError
from usvips.io import target_file
from usvips.io.tables import write_observations
from usvips.io.video_stream import VideoStream
from usvips.store.interface import ProjectStore

#: a view needs at least this many target points found in both images
MINIMUM_POINTS = 6
#: views kept when no cap is given
DEFAULT_MAX_VIEWS = 30

Progress = Callable[[float, str], None]
Cancel = threading.Event | Callable[[], bool]


@dataclass(frozen=True)
class VideoViews:
    """What a scan found.

    ``views``: the chosen views, in frame order (label ``<video>-<left frame>``; source ``{"video",
    "frame", "right_frame"}``); ``blur``: their edge widths (px, the blurrier camera); ``coverage`` of the
    chosen views; and the tally: instants decoded, instants where both cameras saw the target,
    rejected as blurred, rejected as near-duplicates; ``set_aside``: (label, one line why) for every
    instant not chosen (the detection loop's reasons, and the usable ones the diverse subset left out)."""

    views: tuple[StereoView, ...]
    blur: tuple[float, ...]
    coverage: Coverage
    scanned: int
    seen: int
    blurred: int
    duplicates: int
    set_aside: tuple[tuple[str, str], ...] = ()

    def summary(self) -> list[str]:
        """Lines for a person: the tally, then the coverage and its advice."""
        return ([f"{self.scanned} instants scanned: the target seen by both cameras in {self.seen}, "
                 f"{self.blurred} blurred, {self.duplicates} near-duplicates; {len(self.views)} views chosen"]
                + self.coverage.summary())


def _is_cancelled(cancel: Cancel | None) -> bool:
    if cancel is None:
        return False
    if isinstance(cancel, threading.Event):
        return cancel.is_set()
    return bool(cancel())


def scan_streams(left: VideoStream, right: VideoStream, offset: int, target: CalibrationTarget, label: str,
                 every: int = 5, max_views: int = DEFAULT_MAX_VIEWS,
                 max_blur_px: float = calibration_views.MAX_EDGE_WIDTH_PX,
                 duplicate_px: float = calibration_views.DUPLICATE_PX, focal_px: float | None = None,
                 progress: Progress | None = None, cancel: Cancel | None = None) -> VideoViews:
    """Scan two opened streams (see the module's notes); ``label`` names the video in view labels and
    messages. ``every`` (frames) between instants; ``max_views`` caps the views chosen; ``max_blur_px``
    the edge width (px) beyond which an instant is blurred; ``duplicate_px`` the near-duplicate
    tolerance (px); ``focal_px`` a focal length for the tilts (default: a guess, see
    :func:`~usvips.core.calibration_views.view_geometry`). A video with no usable instant raises
    :class:`VideoError` saying why."""
    every, max_views, offset = int(every), int(max_views), int(offset)
    if every < 1:
        raise InvalidParameterError("every", f"must be at least 1 frame, got {every}")
    if max_views < 1:
        raise InvalidParameterError("maximum views", f"must be at least 1, got {max_views}")
    if focal_px is not None and not 0 < focal_px < float("inf"):  # named before any frame is read
        raise InvalidParameterError("focal length", f"must be a positive number of pixels, got {focal_px}")
    frames = VideoFrames(left, right, offset, label, every)
    if not len(frames):
        raise VideoError(f"video {label!r}: no left frame has a right partner with offset {offset} "
                         f"({left.frame_count} left and {right.frame_count} right frames)")
    rules = ViewRules(MINIMUM_POINTS, max_blur_px, duplicate_px)

    def step(done: int, total: int) -> None:
        if progress is not None and done % 2 == 0:
            progress(done / total, f"instant {done // 2} of {total // 2}")

    with frames:
        found = detect_frames(target, frames, rules, step, lambda: _is_cancelled(cancel))
    if not found.views:
        raise VideoError(
            f"video {label!r}: no usable instant among {found.scanned} (every {every} frames): the target was found "
            f"in {found.found_left} left and {found.found_right} right frames, in both at {found.seen} instants, "
            f"{found.blurred} of them blurred (edge width over {max_blur_px:g} px)")
    points = target.control_points()
    candidates = list(found.views)
    chosen = calibration_views.select_views(candidates, max_views, points, blur=list(found.blur), focal_px=focal_px)
    width_of = {v.label: w for v, w in zip(candidates, found.blur, strict=True)}
    kept = {v.label for v in chosen}
    left_out = tuple((v.label, f"view {v.label}: usable, but not among the {max_views} most diverse views chosen")
                     for v in candidates if v.label not in kept)
    report = calibration_views.coverage(chosen, points, focal_px=focal_px)
    return VideoViews(tuple(chosen), tuple(width_of[v.label] for v in chosen), report, found.scanned, found.seen,
                      found.blurred, found.duplicates, found.set_aside + left_out)


def scan_video(project: ProjectStore, label: str, target: CalibrationTarget, every: int = 5,
               max_views: int = DEFAULT_MAX_VIEWS, max_blur_px: float = calibration_views.MAX_EDGE_WIDTH_PX,
               duplicate_px: float = calibration_views.DUPLICATE_PX, focal_px: float | None = None,
               progress: Progress | None = None, cancel: Cancel | None = None) -> VideoViews:
    """:func:`scan_streams` on the project's stereo video ``label``, with its stored offset."""
    video, left, right = open_streams(project, label)
    with left, right:
        return scan_streams(left, right, int(video.offset_frames), target, label, every, max_views,
                            max_blur_px, duplicate_px, focal_px, progress, cancel)


def read_target(path: str | Path) -> CalibrationTarget:
    """The calibration target described in the file ``path`` (:func:`usvips.io.target_file.read_target`:
    the one reader of target files; errors name the file and field)."""
    return target_file.read_target(path)


def write_views(path: str | Path, views: Sequence[StereoView]) -> int:
    """Write ``views`` as an observations CSV (``id,xl,yl,xr,yr,pair``; pair = the view's label; the points
    found in both images), atomically; returns the rows written."""
    observations = stereo_observations(list(views))
    write_observations(path, observations)
    return len(observations)


def views_from_video(project: ProjectStore, label: str, target: CalibrationTarget | str | Path,
                      out: str | Path | None = None,
                      every: int = 5, max_views: int = DEFAULT_MAX_VIEWS,
                      max_blur_px: float = calibration_views.MAX_EDGE_WIDTH_PX, focal_px: float | None = None,
                      progress: Progress | None = None, cancel: Cancel | None = None) -> VideoViews:
    """The one call for the command line and the wizard: the target (or its description file, read by
    :func:`read_target`), the project's video ``label`` scanned (:func:`scan_video`) and, if ``out`` is
    given, the chosen views written there (:func:`write_views`). Nothing is stored in the project."""
    if not isinstance(target, CalibrationTarget):
        target = read_target(target)
    result = scan_video(project, label, target, every, max_views, max_blur_px, focal_px=focal_px, progress=progress,
                        cancel=cancel)
    if out is not None:
        write_views(out, result.views)
    return result
