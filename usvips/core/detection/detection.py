"""What a detector finds in one image: :class:`Detection` (a box, a class, a score and named keypoints,
each with its own confidence) and the :class:`Detector` protocol every model family's runner meets.

Pixels: x right, y down, origin at the centre of the top-left pixel, as everywhere in USVIPS.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np

from usvips.core.errors import InvalidParameterError


@dataclass(frozen=True)
class Keypoint:
    """A named point (``snout``, ``fork`` ...) at (``x``, ``y``) pixels with the model's ``confidence``
    (0..1) that it is visible there."""

    name: str
    x: float
    y: float
    confidence: float

    @property
    def pixel(self) -> np.ndarray:
        """(x, y) pixels as an array."""
        return np.array([self.x, self.y])


@dataclass(frozen=True)
class Detection:
    """One object found in one image: ``box`` (x0, y0, x1, y1) pixels with x0 ≤ x1 and y0 ≤ y1, the class
    name, the model's ``score`` (0..1) and its keypoints in the model's order."""

    box: tuple[float, float, float, float]
    class_name: str
    score: float
    keypoints: tuple[Keypoint, ...] = ()

    def __post_init__(self) -> None:
        box = np.asarray(self.box, dtype=np.float64).ravel()
        if box.shape != (4,) or not (np.isfinite(box).all() and box[0] <= box[2] and box[1] <= box[3]):
            raise InvalidParameterError("box", f"expected finite (x0, y0, x1, y1) with x0 <= x1 and y0 <= y1, "
                                               f"got {self.box}")

    @property
    def keypoint_names(self) -> tuple[str, ...]:
        return tuple(k.name for k in self.keypoints)

    def keypoint(self, name: str) -> Keypoint:
        """The keypoint called ``name``; a name the model does not give is an :class:`InvalidParameterError`."""
        for point in self.keypoints:
            if point.name == name:
                return point
        raise InvalidParameterError("keypoint", f"no keypoint {name!r}; this detection has "
                                                f"{', '.join(self.keypoint_names) or 'none'}")


@runtime_checkable
class Detector(Protocol):
    """Anything that finds objects in an image (H × W × 3 BGR or H × W grey, 8-bit)."""

    def detect(self, image: np.ndarray) -> tuple[Detection, ...]:
        ...
