"""Video files: frames in, frames out (OpenCV), with the errors a person can act on.

Frames are uint8 arrays, grey (H, W) or RGB (H, W, 3), as :mod:`usvips.io.images` gives images; the frame
index counts from 0. Writing uses OpenCV's own Motion-JPEG encoder in an AVI container (no FFmpeg
needed, the same bytes on every machine with the same OpenCV build); reading accepts whatever OpenCV's
back ends read (AVI, MP4, MOV ...).
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from usvips.core.errors import InputFileError
from usvips.io.atomic import give_normal_mode

JPEG_QUALITY = 95


@dataclass(frozen=True)
class VideoInfo:
    """``frames`` (count), ``fps`` (frames per second), ``width`` and ``height`` (pixels)."""

    frames: int
    fps: float
    width: int
    height: int

    @property
    def duration_s(self) -> float:
        return self.frames / self.fps if self.fps > 0 else float("nan")


def _open(path: Path) -> cv2.VideoCapture:
    if not path.is_file():
        raise InputFileError(str(path), "no such video file")
    capture = cv2.VideoCapture(str(path))
    if not capture.isOpened():
        capture.release()
        raise InputFileError(str(path), "not a video OpenCV can read (AVI, MP4, MOV with a common codec)")
    return capture


def video_info(path: str | Path) -> VideoInfo:
    path = Path(path)
    capture = _open(path)
    try:
        info = VideoInfo(int(capture.get(cv2.CAP_PROP_FRAME_COUNT)), float(capture.get(cv2.CAP_PROP_FPS)),
                         int(capture.get(cv2.CAP_PROP_FRAME_WIDTH)), int(capture.get(cv2.CAP_PROP_FRAME_HEIGHT)))
    finally:
        capture.release()
    if info.frames <= 0 or info.width <= 0 or info.height <= 0:
        raise InputFileError(str(path), "the video has no frames")
    return info


def read_frames(path: str | Path, start: int = 0, count: int | None = None, grey: bool = False) -> Iterator[np.ndarray]:
    """Frames ``start`` … ``start + count − 1`` (all to the end by default), RGB (or grey) uint8."""
    path = Path(path)
    if start < 0:
        raise InputFileError(str(path), f"frame {start}: frame indices start at 0")
    capture = _open(path)
    try:
        if start:
            capture.set(cv2.CAP_PROP_POS_FRAMES, start)
        index = start
        while count is None or index < start + count:
            ok, frame = capture.read()
            if not ok:
                if count is not None:
                    raise InputFileError(str(path), f"frame {index}: the video ends before it")
                return
            yield cv2.cvtColor(frame, cv2.COLOR_BGR2GRAY if grey else cv2.COLOR_BGR2RGB)
            index += 1
    finally:
        capture.release()


def read_frame(path: str | Path, index: int, grey: bool = False) -> np.ndarray:
    """One frame by its index (0-based)."""
    return next(read_frames(path, index, 1, grey))


def write_video(path: str | Path, frames: Iterable[np.ndarray], fps: float) -> int:
    """Write frames (uint8, all of one size, grey or RGB) at ``fps`` (whole frames per second) as a
    Motion-JPEG AVI; returns the frame count.
    Written to a temporary file first: a failure never leaves a partial video behind."""
    path = Path(path)
    if not (np.isfinite(fps) and fps > 0 and float(fps).is_integer()):
        # OpenCV's Motion-JPEG writer stores whole frames per second (12.5 would read back as 12)
        raise InputFileError(str(path), f"fps must be a positive whole number of frames per second, got {fps!r}")
    if path.suffix.lower() != ".avi":
        raise InputFileError(str(path), "videos are written as Motion-JPEG AVI: use the suffix .avi")
    handle, temporary = tempfile.mkstemp(prefix=f".{path.stem}.", suffix=".avi", dir=str(path.parent))
    os.close(handle)
    writer = None
    count = 0
    try:
        for index, frame in enumerate(frames):
            frame = np.asarray(frame)
            if frame.dtype != np.uint8 or frame.ndim not in (2, 3) or (frame.ndim == 3 and frame.shape[2] != 3):
                raise InputFileError(str(path), f"frame {index}: expected uint8 grey (H, W) or RGB (H, W, 3), "
                                     f"got {frame.dtype} {frame.shape}")
            height, width = frame.shape[:2]
            if writer is None:
                size = (width, height)
                writer = cv2.VideoWriter(temporary, cv2.CAP_OPENCV_MJPEG, cv2.VideoWriter_fourcc(*"MJPG"),
                                         float(fps), size, True)
                if not writer.isOpened():
                    raise InputFileError(str(path), "OpenCV cannot write a Motion-JPEG video here")
                writer.set(cv2.VIDEOWRITER_PROP_QUALITY, JPEG_QUALITY)
            elif (width, height) != size:
                raise InputFileError(str(path), f"frame {index}: {width} × {height} px, but the video is "
                                     f"{size[0]} × {size[1]} px")
            writer.write(cv2.cvtColor(frame, cv2.COLOR_GRAY2BGR if frame.ndim == 2 else cv2.COLOR_RGB2BGR))
            count += 1
        if writer is None:
            raise InputFileError(str(path), "no frames to write")
        writer.release()
        writer = None
        give_normal_mode(temporary)
        os.replace(temporary, path)
    finally:
        if writer is not None:
            writer.release()
        if os.path.exists(temporary):
            os.unlink(temporary)
    return count
