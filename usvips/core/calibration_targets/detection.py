"""What a calibration-target detector returns for one image, and a stereo view of a target.

This module is the seam between the target kinds (``kinds/``: each finds its own target with OpenCV's
detector), the selection of views from images and video (:mod:`usvips.core.calibration_views`) and the
calibration engine (which takes :class:`~usvips.core.observations.ControlPoints` and
:class:`~usvips.core.observations.StereoObservations`: :func:`stereo_observations` makes them).

Pixels: x right, y down, origin at the centre of the top-left pixel (float64). Target coordinates:
metres, in the target's own frame (a board's plane is z = 0, x along its rows of points, y along its
columns).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from usvips.core.errors import DegenerateGeometryError


@dataclass(frozen=True)
class TargetDetection:
    """The target's points found in one image.

    ``ids``: the target's point ids found (each once; strings, as control ids are); ``pixels`` (M, 2);
    ``quality`` (M,): larger is better, each kind says what it is (e.g. a corner's sharpness or a marker's
    agreement), comparable within a kind; ``image_size`` (width, height) in pixels; ``reason``: why nothing
    or too little was found (then the detection is falsy); ``notes``: anything the user should know (an
    ambiguity resolved, points dropped); ``stage``: which of the kind's detectors found it (its cascade,
    :mod:`~usvips.core.calibration_targets.cascade`; empty when nothing was found)."""

    ids: tuple[str, ...]
    pixels: np.ndarray
    quality: np.ndarray
    image_size: tuple[int, int]
    reason: str = ""
    notes: tuple[str, ...] = field(default_factory=tuple)
    stage: str = ""

    def __post_init__(self) -> None:
        pixels = np.asarray(self.pixels, dtype=np.float64).reshape(-1, 2)
        quality = np.asarray(self.quality, dtype=np.float64).reshape(-1)
        if len(pixels) != len(self.ids) or len(quality) != len(self.ids):
            raise ValueError(f"{len(self.ids)} ids, {len(pixels)} pixels and {len(quality)} qualities")
        if len(set(self.ids)) != len(self.ids):
            raise ValueError("a target point found twice in one image")
        object.__setattr__(self, "pixels", pixels)
        object.__setattr__(self, "quality", quality)

    def __bool__(self) -> bool:
        return len(self.ids) > 0 and not self.reason

    def __len__(self) -> int:
        return len(self.ids)

    @classmethod
    def nothing(cls, image_size: tuple[int, int], reason: str) -> TargetDetection:
        """A detection that found nothing, with the reason."""
        return cls((), np.empty((0, 2)), np.empty(0), image_size, reason)

    def subset(self, ids) -> TargetDetection:
        """The detection restricted to ``ids`` (in that order; each must have been found)."""
        index = {pid: i for i, pid in enumerate(self.ids)}
        rows = np.array([index[pid] for pid in ids], dtype=np.intp)
        return TargetDetection(tuple(ids), self.pixels[rows], self.quality[rows], self.image_size, self.reason,
                               self.notes, self.stage)


@dataclass(frozen=True)
class StereoView:
    """One instant seen by both cameras: ``label`` (becomes the calibration's station label), the left
    and right detections, and where it came from (``source``: e.g. ``{"video": "cal", "frame": 120}`` or
    the two image paths)."""

    label: str
    left: TargetDetection
    right: TargetDetection
    source: dict = field(default_factory=dict)

    def common_ids(self) -> tuple[str, ...]:
        """The point ids found in both images, in the left detection's order."""
        right = set(self.right.ids)
        return tuple(pid for pid in self.left.ids if pid in right)


def stereo_observations(views: list[StereoView], minimum_points: int = 4):
    """The engine's observations of ``views``: one pair (station) per view, labelled by the view, with the
    points found in both images. A view with fewer than ``minimum_points`` common points is named in a
    :class:`DegenerateGeometryError` (drop it or detect again)."""
    from usvips.core.observations import StereoObservations

    ids, left, right, pairs = [], [], [], []
    for view in views:
        common = view.common_ids()
        if len(common) < minimum_points:
            raise DegenerateGeometryError(
                f"view {view.label!r}: only {len(common)} target points are found in both images "
                f"(at least {minimum_points} needed); drop the view")
        ids += list(common)
        left.append(view.left.subset(common).pixels)
        right.append(view.right.subset(common).pixels)
        pairs += [view.label] * len(common)
    if not views:
        raise DegenerateGeometryError("no view of the target to calibrate from")
    return StereoObservations(tuple(ids), np.vstack(left), np.vstack(right), tuple(pairs))
