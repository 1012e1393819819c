"""Reading and writing images (8- or 16-bit, grey or colour) with clear errors.

Arrays are numpy, row-major ``[row, col]`` (y down, x right, as the pixel convention), grey images
(H, W), colour images (H, W, 3) in RGB order (OpenCV's BGR is converted here, once).
"""

from __future__ import annotations

import io
import os
import re
import struct
from pathlib import Path

import cv2
import numpy as np

from usvips.core.errors import InputFileError, InvalidParameterError
from usvips.io.atomic import write_bytes_atomic

SUPPORTED_DTYPES = (np.uint8, np.uint16)
#: Environment variable that raises (or lowers) the largest image read, in pixels (width × height).
MAX_PIXELS_VARIABLE = "USVIPS_MAX_IMAGE_PIXELS"
#: Default largest image: 120 megapixels (a 16-bit colour image of that size needs 720 MB).
DEFAULT_MAX_PIXELS = 120_000_000


def max_pixels() -> int:
    """The largest image (pixels) :func:`read_image` decodes: ``$USVIPS_MAX_IMAGE_PIXELS`` or the default."""
    text = os.environ.get(MAX_PIXELS_VARIABLE)
    if text is None:
        return DEFAULT_MAX_PIXELS
    try:
        value = int(text)
    except ValueError:
        raise InvalidParameterError(MAX_PIXELS_VARIABLE, f"{text[:24]!r} is not a whole number of pixels") from None
    if value <= 0:
        raise InvalidParameterError(MAX_PIXELS_VARIABLE, f"must be positive, got {value}")
    return value


def declared_size(head: bytes) -> tuple[int, int] | None:
    """(width, height) in pixels as an image file's header declares it (PNG, JPEG, BMP, TIFF, PNM, WebP),
    read without decoding; None when the format is not one of these or the header is cut short."""
    try:
        if head.startswith(b"\x89PNG\r\n\x1a\n") and head[12:16] == b"IHDR":
            return struct.unpack(">II", head[16:24])
        if head.startswith(b"BM"):
            width, height = struct.unpack("<ii", head[18:26])
            return abs(width), abs(height)
        if head[:4] in (b"II*\x00", b"MM\x00*"):
            return _tiff_size(head)
        if head.startswith(b"RIFF") and head[8:12] == b"WEBP":
            return _webp_size(head)
        if head[:2] == b"\xff\xd8":
            return _jpeg_size(head)
        if head[:1] == b"P" and head[1:2] in b"123456":
            numbers = re.match(rb"P[1-6](?:\s+|#[^\n]*\n)+(\d+)(?:\s+|#[^\n]*\n)+(\d+)", head)
            return (int(numbers.group(1)), int(numbers.group(2))) if numbers else None
    except struct.error:
        return None
    return None


def _jpeg_size(head: bytes) -> tuple[int, int] | None:
    i = 2
    while i + 9 < len(head):
        if head[i] != 0xFF:
            return None
        marker = head[i + 1]
        if marker in (0xD8, 0x01) or 0xD0 <= marker <= 0xD7:
            i += 2
            continue
        length = struct.unpack(">H", head[i + 2:i + 4])[0]
        if 0xC0 <= marker <= 0xCF and marker not in (0xC4, 0xC8, 0xCC):
            height, width = struct.unpack(">HH", head[i + 5:i + 9])
            return width, height
        i += 2 + length
    return None


def _tiff_size(head: bytes) -> tuple[int, int] | None:
    order = "<" if head[:2] == b"II" else ">"
    offset = struct.unpack(order + "I", head[4:8])[0]
    count = struct.unpack(order + "H", head[offset:offset + 2])[0]
    size = {}
    for k in range(count):
        entry = head[offset + 2 + 12 * k: offset + 14 + 12 * k]
        tag, kind = struct.unpack(order + "HH", entry[:4])
        if tag in (256, 257):
            size[tag] = struct.unpack(order + ("H" if kind == 3 else "I"), entry[8:10] if kind == 3 else entry[8:12])[0]
    return (size[256], size[257]) if len(size) == 2 else None


def _webp_size(head: bytes) -> tuple[int, int] | None:
    chunk = head[12:16]
    if chunk == b"VP8X":
        width = int.from_bytes(head[24:27], "little") + 1
        height = int.from_bytes(head[27:30], "little") + 1
        return width, height
    if chunk == b"VP8 ":
        width, height = struct.unpack("<HH", head[26:30])
        return width & 0x3FFF, height & 0x3FFF
    if chunk == b"VP8L":
        bits = int.from_bytes(head[21:25], "little")
        return (bits & 0x3FFF) + 1, ((bits >> 14) & 0x3FFF) + 1
    return None


def jpeg_damage(data: bytes) -> str | None:
    """Why a JPEG's compressed data is damaged, or None when no decoder error shows (always None for
    other formats).

    OpenCV's decoder (libjpeg) conceals damage in a JPEG's entropy-coded data: it returns a picture, partly
    grey or smeared, and only prints a warning. FFmpeg's decoder, made strict (``err_detect=explode``),
    refuses such data instead. A file that FFmpeg's decoder cannot read at all even when lenient (a JPEG
    variant it lacks) is not judged. JPEG carries no checksum: damage that still decodes as valid data
    (changed coefficients) shows in no decoder."""
    if data[:3] != b"\xff\xd8\xff":
        return None
    strict = _ffmpeg_first_picture(data, strict=True)
    if strict is None:
        return None
    if _ffmpeg_first_picture(data, strict=False) is not None:
        return None  # not even the lenient decoder reads it: a variant FFmpeg lacks, not judged
    return f"the JPEG's compressed data is damaged ({strict}); copy it again from the camera's card"


def _ffmpeg_first_picture(data: bytes, strict: bool) -> str | None:
    """None when FFmpeg's JPEG decoder returns the file's first picture, else its error."""
    import av  # PyAV (FFmpeg's decoders) imported when a JPEG is first checked, not with the window

    try:
        with av.open(io.BytesIO(data), format="jpeg_pipe") as container:
            stream = container.streams.video[0]
            if strict:
                stream.codec_context.options = {"err_detect": "explode"}
            for _frame in container.decode(stream):
                return None
            return "no picture decoded"
    except (av.error.FFmpegError, ValueError, IndexError) as error:
        return str(getattr(error, "strerror", None) or error.__class__.__name__)


def read_image(path: str | Path, limit: int | None = None, strict: bool = False) -> np.ndarray:
    """Read an image file as uint8 or uint16, grey (H, W) or RGB (H, W, 3); alpha is dropped.

    The size the file's header declares is checked BEFORE decoding: an image over ``limit`` pixels
    (default :func:`max_pixels`, raised with ``$USVIPS_MAX_IMAGE_PIXELS``) is refused, naming the file.
    ``strict`` (when a file is added to a project): a JPEG whose compressed data a decoder finds damaged is
    refused too (:func:`jpeg_damage`; OpenCV's decoder would return a partly wrong picture).
    """
    path = Path(path)
    limit = max_pixels() if limit is None else limit
    if not path.is_file():
        raise InputFileError(str(path), "no such image file")
    try:
        data = np.fromfile(str(path), dtype=np.uint8)
    except OSError as error:
        raise InputFileError(str(path), f"cannot read the image: {error.strerror or error}") from None
    if data.size == 0:
        raise InputFileError(str(path), "the file is empty")
    size = declared_size(data[:1 << 16].tobytes())
    if size is not None and size[0] * size[1] > limit:
        raise InputFileError(str(path), f"declares {size[0]} × {size[1]} pixels, more than the limit of {limit:,} "
                             f"(raise it with the environment variable {MAX_PIXELS_VARIABLE})")
    damage = jpeg_damage(data.tobytes()) if strict else None  # (before OpenCV, which would print a warning)
    if damage is not None:
        raise InputFileError(str(path), damage)
    image = cv2.imdecode(data, cv2.IMREAD_UNCHANGED)
    if image is None:
        raise InputFileError(str(path), "not an image OpenCV can read (PNG, TIFF, JPEG, BMP ...)")
    if image.dtype not in SUPPORTED_DTYPES:
        raise InputFileError(str(path), f"unsupported bit depth {image.dtype}; use 8- or 16-bit images")
    if image.shape[0] * image.shape[1] > limit:   # a format whose header is not read above
        raise InputFileError(str(path), f"{image.shape[1]} × {image.shape[0]} pixels, more than the limit of "
                             f"{limit:,} (raise it with the environment variable {MAX_PIXELS_VARIABLE})")
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
    try:
        ok, encoded = cv2.imencode(path.suffix or ".png", image)
    except cv2.error:
        ok = False
    if not ok:
        raise InputFileError(str(path), f"cannot encode an image as '{path.suffix}'")
    write_bytes_atomic(path, encoded.tobytes())
