"""Accepting a changed media file: the file now at a recorded path is taken as the one the project means
(``usvips project accept-media``) only when it can stand in for what was recorded there.

Objects are stored by frame index and pixel, so a replacement must read as the same kind of thing with the
same frames and pixels as the recording: a video chapter with the frame count and frame rate recorded for
it and the video's frame size; an image with the pair's recorded size. A file that is not a video or an
image, a shorter or longer export, or one at another resolution would otherwise be accepted without a word
and every stored pick on it would point at the wrong frame or pixel.
"""

from __future__ import annotations

import math
from pathlib import Path

from usvips.app.video_project import chapter_fps
from usvips.core.errors import InputFileError
from usvips.io.images import read_image
from usvips.io.video_stream import VideoStream
from usvips.store.interface import ProjectStore

#: the largest relative difference between a replacement chapter's frame rate and the recorded one
FPS_TOLERANCE = 1e-3


def refuse_unlike_recorded(project: ProjectStore, stored: str) -> None:
    """Raise an :class:`InputFileError` naming the file at the recorded media path ``stored`` when it cannot
    stand in for the recording there (see the module docstring); nothing when it can, or when no video
    or pair of the project uses that path."""
    path = project.media_location(stored)
    for video in project.videos():
        for camera in ("left", "right"):
            for chapter in video.files(camera):
                if chapter.path == stored:
                    _refuse_unlike_chapter(path, chapter.frame_count, chapter.fps, (video.width, video.height),
                                           f"{camera} chapter of video {video.label}")
    for pair in project.pairs():
        for camera in ("left", "right"):
            if getattr(pair, camera) == stored and pair.width is not None and pair.height is not None:
                image = read_image(path)
                size = (image.shape[1], image.shape[0])
                if size != (pair.width, pair.height):
                    raise InputFileError(str(path), f"is {size[0]} × {size[1]} px, but the {camera} image of pair "
                                         f"{pair.label} was {pair.width} × {pair.height} px: not accepted")


def _refuse_unlike_chapter(path: Path, frames: int, fps: float, size: tuple[int, int], what: str) -> None:
    with VideoStream(path) as stream:
        now = (stream.frame_count, chapter_fps(stream.chapters[0], stream.fps), stream.size)
    if now[2] != size:
        raise InputFileError(str(path), f"is {now[2][0]} × {now[2][1]} px, but the {what} was {size[0]} × "
                             f"{size[1]} px: not accepted")
    if now[0] != frames:
        raise InputFileError(str(path), f"has {now[0]} frames, but the {what} had {frames}: stored picks are "
                             "by frame, not accepted")
    if not math.isclose(now[1], fps, rel_tol=FPS_TOLERANCE):
        raise InputFileError(str(path), f"runs at {now[1]:.6g} fps, but the {what} ran at {fps:.6g}: not accepted")
