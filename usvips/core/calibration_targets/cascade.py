"""A detection cascade: a kind's OpenCV detectors and flags tried in turn until one finds the target.

Real footage defeats any one detector now and then (uneven light, a cut border, a small board in a large
frame, JPEG blocks), and each of OpenCV's detectors fails on different images. A kind (``kinds/``) lists
its :class:`Stage` s, cheapest and most often right first; :func:`run` tries them in order on the grey
image and stops at the first that succeeds, so the common case costs one detector. A stage may search a
reduced copy of a large image (:func:`reduced`); its points are brought back to full-size pixels
(:func:`to_full_size`) and the kind refines them there.

When every stage fails, :func:`not_found` words the reason: what was looked for, by how many detectors,
and the kind's hint (what must be in view).

Pixels: x right, y down, origin at the centre of the top-left pixel.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import cv2
import numpy as np

#: What a stage's search returns: the points found (pixels of the image it was handed, (N, 2)), or those
#: points and what else the kind needs of them (e.g. their ids) as a pair, or None.
Search = Callable[[np.ndarray], "np.ndarray | tuple[np.ndarray, object] | None"]


@dataclass(frozen=True)
class Stage:
    """One detector with its settings: ``name`` says it in words (shown with a detection: which detector
    found the target); ``search(grey)`` returns the points found in the (possibly reduced) grey image or
    None; ``factor`` > 1 makes the stage search the image reduced by that whole factor (its points are
    then brought back to full size); ``minimum_side`` (pixels): the stage is tried only on images whose
    longer side is at least this (a downscaled search is pointless on a small image); ``pad`` (pixels of
    the searched image) extends the image by that many pixels each side, repeating its edge pixels: a
    board whose outer squares the image cuts then shows the margin some detectors need."""

    name: str
    search: Search
    factor: int = 1
    minimum_side: int = 0
    pad: int = 0


@dataclass(frozen=True)
class Found:
    """The points one stage found (full-size pixels, (N, 2) float64), the stage, the stages tried before
    it (their names), and what else the stage's search returned with the points (``extra``; None when
    it returned the points alone)."""

    pixels: np.ndarray
    stage: Stage
    tried: tuple[str, ...]
    extra: object = None


def reduced(grey: np.ndarray, factor: int) -> np.ndarray:
    """``grey`` reduced by the whole ``factor`` (area averaging); the image itself when ``factor`` is 1."""
    if factor <= 1:
        return grey
    height, width = grey.shape[:2]
    return cv2.resize(grey, (width // factor, height // factor), interpolation=cv2.INTER_AREA)


def padded(grey: np.ndarray, pad: int) -> np.ndarray:
    """``grey`` extended by ``pad`` pixels each side, its edge pixels repeated; itself when ``pad`` is 0."""
    return grey if pad <= 0 else cv2.copyMakeBorder(grey, pad, pad, pad, pad, cv2.BORDER_REPLICATE)


def to_full_size(pixels: np.ndarray, factor: int) -> np.ndarray:
    """Points found in an image reduced by ``factor`` as pixels of the full image (a reduced pixel averages
    factor × factor full pixels: centre to centre)."""
    pixels = np.asarray(pixels, np.float64).reshape(-1, 2)
    return pixels if factor <= 1 else (pixels + 0.5) * factor - 0.5


def search_factor(grey: np.ndarray, largest_side: int) -> int:
    """The smallest whole factor that brings the image's longer side to at most ``largest_side`` pixels."""
    return max(1, int(np.ceil(max(grey.shape[:2]) / float(largest_side))))


def run(stages: Sequence[Stage], grey: np.ndarray) -> Found | None:
    """Try ``stages`` in order on ``grey`` and return what the first successful one found (full-size
    pixels), or None when none finds the target. Reduced copies are made once per factor."""
    copies: dict[tuple[int, int], np.ndarray] = {(1, 0): grey}
    side = max(grey.shape[:2])
    tried: list[str] = []
    for stage in stages:
        if side < stage.minimum_side:
            continue
        factor, pad = max(1, int(stage.factor)), max(0, int(stage.pad))
        if (factor, pad) not in copies:
            copies[(factor, pad)] = padded(copies.get((factor, 0), reduced(grey, factor)), pad)
        found = stage.search(copies[(factor, pad)])
        found, extra = found if isinstance(found, tuple) else (found, None)
        if found is not None and len(found):
            return Found(to_full_size(np.asarray(found, np.float64).reshape(-1, 2) - pad, factor), stage,
                         tuple(tried), extra)
        tried.append(stage.name)
    return None


def tried_names(stages: Sequence[Stage], grey: np.ndarray) -> list[str]:
    """The names of the stages :func:`run` tries on an image of this size."""
    side = max(grey.shape[:2])
    return [stage.name for stage in stages if side >= stage.minimum_side]


def not_found(what: str, stages: Sequence[Stage], grey: np.ndarray, hint: str) -> str:
    """The reason nothing was found, in words: ``what`` (e.g. "no 9 × 6 chessboard"), the number of
    detectors tried and the kind's ``hint``."""
    count = len(tried_names(stages, grey))
    tried = "the detector" if count == 1 else f"any of {count} detectors and settings"
    return f"{what} found by {tried} ({hint})"


def found_note(found: Found) -> tuple[str, ...]:
    """A note for the detection when a stage other than the first found the target (which one)."""
    return (f"found by {found.stage.name}",) if found.tried else ()
