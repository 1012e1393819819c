"""The letterbox: an image scaled to fit a network's input without changing its aspect, centred, the rest
padded — and its undo, from the network's coordinates back to the image's pixels.

The network's outputs are taken in its input's continuous coordinates (origin at the top-left CORNER of
the top-left input pixel, as YOLO models give them); image pixels have their origin at the CENTRE of the
top-left pixel, as everywhere in USVIPS. cv2.resize maps an image pixel centre x to the input coordinate
(x + 0.5) · s with s = resized width / image width, so x = (u − pad) / s − 0.5.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np


@dataclass(frozen=True)
class Letterbox:
    """The scales (input pixels per image pixel, x and y), the padding (input pixels left and top) and
    the resized size (width, height) of one image in a network's input."""

    scale_x: float
    scale_y: float
    pad_x: int
    pad_y: int
    resized: tuple[int, int]

    @classmethod
    def fit(cls, image_size: tuple[int, int], input_size: tuple[int, int]) -> Letterbox:
        """The letterbox of an image (width, height) in an input (width, height)."""
        (w, h), (iw, ih) = image_size, input_size
        ratio = min(iw / w, ih / h)
        nw, nh = max(1, min(iw, round(w * ratio))), max(1, min(ih, round(h * ratio)))
        return cls(nw / w, nh / h, (iw - nw) // 2, (ih - nh) // 2, (nw, nh))

    def apply(self, image: np.ndarray, input_size: tuple[int, int], pad_value: int) -> np.ndarray:
        """The image scaled and padded to ``input_size`` (width, height)."""
        resized = cv2.resize(image, self.resized, interpolation=cv2.INTER_LINEAR)
        iw, ih = input_size
        nw, nh = self.resized
        return cv2.copyMakeBorder(resized, self.pad_y, ih - nh - self.pad_y, self.pad_x, iw - nw - self.pad_x,
                                  cv2.BORDER_CONSTANT, value=(pad_value,) * 3)

    def to_image(self, u: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Input coordinates (corner origin) → image pixels (centre origin)."""
        return (np.asarray(u) - self.pad_x) / self.scale_x - 0.5, (np.asarray(v) - self.pad_y) / self.scale_y - 0.5

    def to_input(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Image pixels (centre origin) → input coordinates (corner origin); the inverse of :meth:`to_image`."""
        return (np.asarray(x) + 0.5) * self.scale_x + self.pad_x, (np.asarray(y) + 0.5) * self.scale_y + self.pad_y
