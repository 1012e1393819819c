"""The target path of the calibration wizards, without Qt: what the pages of
:mod:`usvips.gui.qt.target_pages` show and change.

The user chooses (or describes) a calibration target, a source of views — image pairs from disk or a stereo
video of the project — and for phase 2 the phase-1 calibration and the housing; the target is detected in
a worker (:meth:`TargetSession.detection_job`), the views found are listed with their coverage and can be
unticked, the calibration is computed in a worker (:meth:`TargetSession.calibration_job`), judged, and
stored in the project (:meth:`TargetSession.save`) only when the user finishes: cancelling or a failure
leaves the project as it was. Jobs take ``(progress, cancelled)`` as :class:`usvips.gui.qt.worker.Worker`
gives them (``progress(fraction)``) and raise :class:`InterruptedError` when cancelled.
"""

from __future__ import annotations

import json
import re
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

import numpy as np

from usvips.app import board_calibration as boards
from usvips.app.board_verdict import judge
from usvips.app.calibrations import read_calibration
from usvips.app.video_project import open_streams
from usvips.core import calibration_views
from usvips.core.calibration import CalibrationOptions
from usvips.core.calibration.phases import DEFAULT_HOUSING
from usvips.core.calibration_targets import CalibrationTarget, StereoView, from_description
from usvips.core.calibration_views import Coverage
from usvips.core.errors import InvalidParameterError, UsvipsError
from usvips.io.images import read_image
from usvips.io.video_stream import PairReader
from usvips.store.interface import ProjectStore

#: where the views come from
SOURCES = ("images", "video")


def natural_key(path: str) -> tuple:
    """Sort key of a file name with its numbers in numeric order (``L2`` before ``L10``)."""
    return tuple((0, int(p), "") if p.isdigit() else (1, 0, p) for p in re.split(r"(\d+)", Path(path).name) if p)


def pair_by_name(left: list[str], right: list[str]) -> list[tuple[str, str]]:
    """Left and right image files paired in natural name order; the counts must match."""
    if len(left) != len(right):
        raise InvalidParameterError("images", f"{len(left)} left and {len(right)} right images chosen; each left "
                                    "image needs its right partner")
    return list(zip(sorted(left, key=natural_key), sorted(right, key=natural_key), strict=True))


def known_options(known: dict[str, tuple[float, float | None]]) -> dict:
    """Known housing values as calibration options: a value alone holds the parameter fixed
    (``fix_values``), a value with a σ weights it (``priors``); symbols apply to both cameras."""
    return {"fix_values": {name: value for name, (value, sigma) in known.items() if sigma is None},
            "priors": {name: (value, sigma) for name, (value, sigma) in known.items() if sigma is not None}}


class TargetSession:
    """The state of one target calibration in the window: phase ``air``, ``water`` or ``joint`` (both
    water phases calibrate through the housing from a phase-1 base)."""

    def __init__(self, project: ProjectStore, phase: str) -> None:
        if phase not in ("air", "water", "joint"):
            raise InvalidParameterError("phase", f"must be air, water or joint, got {phase!r}")
        self.project = project
        self.phase = phase
        self.target: CalibrationTarget | None = None
        self.target_source = ""
        self.source = "images"
        self.pairs: list[tuple[str, str]] = []
        self.video = ""
        self.every = 5
        self.max_views = 30
        self.base_id: int | None = None
        self.housing = next(iter(DEFAULT_HOUSING))
        self.holdout: float | None = 0.2
        self.sigma_px = 0.5
        #: known housing values (phase 2): symbol → (value, σ or None to hold it fixed), both cameras
        self.known: dict[str, tuple[float, float | None]] = {}
        #: phase 2: the cameras did not move since the phase-1 images (a tank or a pool): poses held
        self.cameras_unmoved = False
        self.views: boards.BoardViews | None = None
        self.ticked: dict[str, bool] = {}
        self.result: boards.BoardCalibration | None = None

    # ------------------------------------------------------------------ what to calibrate
    @property
    def water(self) -> bool:
        return self.phase != "air"

    def load_target(self, path: str | Path) -> None:
        """The target described in a JSON file (``usvips target describe`` writes one)."""
        self.target = boards.as_target(path)
        self.target_source = str(path)
        self._forget_views()

    def describe_target(self, description: dict, save_to: str | Path | None = None) -> None:
        """A target from a description (``{"kind": …}``), optionally written to ``save_to`` as JSON."""
        # no file: a bad value is an error naming its field (the page names its own field for it)
        self.target = from_description(dict(description))
        if save_to:
            Path(save_to).write_text(json.dumps(self.target.describe(), indent=2) + "\n", encoding="utf-8")
            self.target_source = str(save_to)
        else:
            self.target_source = "described in the window"
        self._forget_views()

    def set_images(self, left: list[str], right: list[str]) -> None:
        self.pairs = pair_by_name(list(left), list(right))
        self.source = "images"
        self._forget_views()

    def set_video(self, label: str, every: int = 5, max_views: int = 30) -> None:
        if label not in self.videos():
            raise InvalidParameterError("video", f"the project has no stereo video {label!r}")
        self.video, self.every, self.max_views, self.source = label, int(every), int(max_views), "video"
        self._forget_views()

    def videos(self) -> list[str]:
        """The project's stereo videos."""
        return [v.label for v in self.project.videos()]

    def base_calibrations(self) -> list[dict]:
        """The project's phase-1 (in-air) calibrations, a phase-2 base."""
        return [c for c in self.project.calibrations() if c.phase == "air"]

    def readiness(self) -> tuple[bool, str]:
        """Whether detection can start, and if not what is missing (one line)."""
        if self.target is None:
            return False, "choose a target file or describe the target"
        if self.source == "images" and not self.pairs:
            return False, "choose the left and the right images"
        if self.source == "video" and not self.video:
            return False, "choose a video of the project"
        if self.water and self.base_id is None:
            return False, "choose the phase-1 (in-air) calibration to start from"
        return True, (f"{len(self.pairs)} image pairs" if self.source == "images"
                      else f"video {self.video}, every {self.every} frames, at most {self.max_views} views")

    def forget_views(self) -> None:
        """No views and no result (a new detection starts, or one was stopped): nothing to compute from."""
        self._forget_views()

    def _forget_views(self) -> None:
        self.views = None
        self.ticked = {}
        self.result = None

    # ------------------------------------------------------------------ detection
    def detection_job(self) -> Callable[..., boards.BoardViews]:
        """A job finding the target in the chosen source (``progress(fraction)``, ``cancelled()``)."""
        ready, why = self.readiness()
        if not ready:
            raise UsvipsError(why)
        target, source, pairs = self.target, self.source, list(self.pairs)
        video, every, max_views = self.video, self.every, self.max_views
        if source == "video":  # the project's database stays in this thread: open the streams here
            stored, left, right = open_streams(self.project, video)
            offset = int(stored.offset_frames)

        def run(progress=None, cancelled=None) -> boards.BoardViews:
            def step(fraction: float, _message: str = "") -> None:
                if progress is not None:
                    progress(fraction)

            cancel = cancelled or (lambda: False)
            if source == "images":
                return boards.views_from_images(target, pairs, progress=step, cancel=cancel)
            return boards.views_from_streams(left, right, offset, video, target, every, max_views, progress=step,
                                             cancel=cancel)
        return run

    def set_views(self, views: boards.BoardViews) -> None:
        self.views = views
        self.ticked = {v.label: True for v in views.views}
        self.result = None

    def view(self, label: str) -> StereoView:
        for v in self.views.views if self.views else ():
            if v.label == label:
                return v
        raise InvalidParameterError("view", f"no view {label!r}")

    def set_ticked(self, label: str, on: bool) -> None:
        self.view(label)
        self.ticked[label] = bool(on)
        self.result = None

    def kept(self) -> list[StereoView]:
        return [v for v in (self.views.views if self.views else ()) if self.ticked.get(v.label, False)]

    def dropped(self) -> list[str]:
        return [label for label, on in self.ticked.items() if not on]

    def coverage(self) -> Coverage | None:
        """The coverage of the ticked views (None when none is ticked)."""
        kept = self.kept()
        if not kept:
            return None
        return calibration_views.coverage(kept, self.target.control_points())

    def images_job(self, label: str) -> Callable[..., tuple[str, tuple[np.ndarray, np.ndarray]]]:
        """A job reading the left and right images of a view (grey or RGB arrays) from its files or decoding
        them from the video (whose streams are opened here, in the project's thread); returns (label,
        images)."""
        where = self.view(label).source
        if "video" not in where:
            return lambda progress=None, cancelled=None: (label, (read_image(where["left"]),
                                                                  read_image(where["right"])))
        _, left, right = open_streams(self.project, where["video"])

        def run(progress=None, cancelled=None):
            with left, right:
                reader = PairReader(left, right)
                try:
                    pictures = reader.pictures(int(where["frame"]), int(where["right_frame"]))
                    return label, (pictures[0].array(), pictures[1].array())
                finally:
                    reader.close()
        return run

    # ------------------------------------------------------------------ calibration
    def base(self):
        if self.base_id is None:
            return None
        return read_calibration(self.project, self.base_id)

    def calibration_job(self) -> Callable[..., boards.BoardCalibration]:
        """A job calibrating from the ticked views; its ``cancelled()`` is asked at every iteration of the
        adjustment (then :class:`InterruptedError`)."""
        if self.views is None:
            raise UsvipsError("find the target in the views first")
        views, drop, target = list(self.views.views), self.dropped(), self.target
        phase = "water" if self.water else "air"
        base = self.base() if self.water else None
        housing, holdout = self.housing, self.holdout
        options = self.calibration_options()
        source = {"target": self.target_source,
                  **({"video": self.video, "every": self.every, "max_views": self.max_views}
                     if self.source == "video" else
                     {"images": [p for pair in self.pairs for p in pair]})}

        def run(progress=None, cancelled=None) -> boards.BoardCalibration:
            return boards.calibrate_views(target, views, phase, drop=drop, base=base, housing=housing,
                                          holdout=holdout, options=replace(options, cancelled=cancelled),
                                          source=source)
        return run

    def calibration_options(self) -> CalibrationOptions:
        """The options of the calibration: the pointing σ and, for phase 2, the known housing values and
        whether the cameras stayed where phase 1 saw them."""
        if not self.water:
            return CalibrationOptions(sigma_px=self.sigma_px)
        return CalibrationOptions(sigma_px=self.sigma_px, cameras_unmoved=self.cameras_unmoved,
                                  **known_options(self.known))

    def set_result(self, result: boards.BoardCalibration) -> None:
        self.result = result

    def verdict(self) -> str:
        """One paragraph judging the result for a person, consistent with the coverage advice."""
        if self.result is None:
            return ""
        return judge(self.result, self.coverage(), self.sigma_px).text

    def default_name(self) -> str:
        n = len(self.result.kept) if self.result else 0
        return f"{self.phase} from {n} target views"

    def save(self, name: str, active_for: list[str]) -> int:
        """Store the calibration in the project (active for ``active_for``); returns its id."""
        if self.result is None:
            raise UsvipsError("there is no calibration to save: compute it first")
        return boards.store(self.project, self.result, name or self.default_name(), active_for)
