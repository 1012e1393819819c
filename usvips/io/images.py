"""Reading and writing images (8- or 16-bit, grey or colour) with clear errors.

Arrays are numpy, row-major ``[row, col]`` (y down, x right, as the pixel convention), grey images
(H, W), colour images (H, W, 3) in RGB order (OpenCV's BGR is converted here, once).
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from usvips.core.errors import InputFileError

SUPPORTED_DTYPES = (np.uint8, np.uint16)


def read_image(path: str | Path) -> np.ndarray:
    """Read an image file as uint8 or uint16, grey (H, W) or RGB (H, W, 3); alpha is dropped."""
    path = Path(path)
    if not path.is_file():
        raise InputFileError(str(path), "no such image file")
    data = np.fromfile(str(path), dtype=np.uint8)
    if data.size == 0:
        raise InputFileError(str(path), "the file is empty")
    image = cv2.imdecode(data, cv2.IMREAD_UNCHANGED)
    if image is None:
        raise InputFileError(str(path), "not an image OpenCV can read (PNG, TIFF, JPEG, BMP ...)")
    if image.dtype not in SUPPORTED_DTYPES:
        raise InputFileError(str(path), f"unsupported bit depth {image.dtype}; use 8- or 16-bit images")
    if image.ndim == 3:
        if image.shape[2] == 4:
            image = cv2.cvtColor(image, cv2.COLOR_BGRA2RGB)
        elif image.shape[2] == 3:
            image = cv2.cvtColor(image, cv2.COLOR_BGR2RGB)
        elif image.shape[2] == 1:
            image = image[:, :, 0]
        else:
            raise InputFileError(str(path), f"unsupported number of channels {image.shape[2]}")
    return np.ascontiguousarray(image)


def write_image(path: str | Path, image: np.ndarray) -> None:
    """Write a grey (H, W) or RGB (H, W, 3) uint8/uint16 image; the format follows the suffix."""
    path = Path(path)
    image = np.asarray(image)
    if image.dtype not in SUPPORTED_DTYPES:
        raise InputFileError(str(path), f"cannot write {image.dtype} pixels; use uint8 or uint16")
    if image.ndim == 3:
        image = cv2.cvtColor(image, cv2.COLOR_RGB2BGR)
    ok, encoded = cv2.imencode(path.suffix or ".png", image)
    if not ok:
        raise InputFileError(str(path), f"cannot encode an image as '{path.suffix}'")
    encoded.tofile(str(path))
