"""Accepting a changed media file: the file now at a recorded path is taken as the one the project means
(``usvips project accept-media``) only when it can stand in for what was recorded there.

Objects are stored by frame index and pixel, so a replacement must read as the same kind of thing with the
same frames and pixels as the recording: a video chapter with the frame count and frame rate recorded for
it and the video's frame size; an image with the pair's recorded size. A file that is not a video or an
image, a shorter or longer export, or one at another resolution would otherwise be accepted without a word
and every stored pick on it would point at the wrong frame or pixel.

The command line (``usvips project accept-media``) and the window (File › Accept changed media…) ask the same
rule. The window reads the store on its own thread (:func:`recorded_shapes`, then :func:`accept_changed`)
and the files in a worker (:func:`find_changed_media`: each file hashed whole, with progress and a cancel
that stops the reading), so that a large video never freezes it.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

from usvips.app.video_project import ByteProgress, chapter_fps, file_sha256
from usvips.core.errors import InputFileError, UsvipsError
from usvips.io.images import read_image
from usvips.io.video_stream import VideoStream
from usvips.store.interface import ProjectStore
from usvips.store.survey import sampled_hash

#: the largest relative difference between a replacement chapter's frame rate and the recorded one
FPS_TOLERANCE = 1e-3


@dataclass(frozen=True)
class RecordedShape:
    """What a file at a recorded path must be to stand in for the recording there: ``what`` it was (e.g.
    "left chapter of video dive"), its frame ``size`` (width, height px) and, for a video chapter, its
    ``frames`` and ``fps`` (None for an image)."""

    what: str
    size: tuple[int, int]
    frames: int | None = None
    fps: float | None = None


def recorded_shapes(project: ProjectStore) -> dict[str, list[RecordedShape]]:
    """Per recorded media path, what each video chapter or pair image there was (read from the store, on
    the store's thread)."""
    shapes: dict[str, list[RecordedShape]] = {}
    for video in project.videos():
        for camera in ("left", "right"):
            for chapter in video.files(camera):
                shapes.setdefault(chapter.path, []).append(RecordedShape(
                    f"{camera} chapter of video {video.label}", (video.width, video.height), chapter.frame_count,
                    chapter.fps))
    for pair in project.pairs():
        for camera in ("left", "right"):
            stored = getattr(pair, camera)
            if stored is not None and pair.width is not None and pair.height is not None:
                shapes.setdefault(stored, []).append(RecordedShape(f"{camera} image of pair {pair.label}",
                                                                   (pair.width, pair.height)))
    return shapes


def refuse_unlike(path: Path, shapes: Sequence[RecordedShape]) -> None:
    """Raise an :class:`InputFileError` naming ``path`` when the file there cannot stand in for each of
    ``shapes`` (see the module docstring); any thread."""
    for shape in shapes:
        if shape.frames is None:
            image = read_image(path)
            size = (image.shape[1], image.shape[0])
            if size != shape.size:
                raise InputFileError(str(path), f"is {size[0]} × {size[1]} px, but the {shape.what} was "
                                     f"{shape.size[0]} × {shape.size[1]} px: not accepted")
            continue
        with VideoStream(path) as stream:
            frames, fps, size = stream.frame_count, chapter_fps(stream.chapters[0], stream.fps), stream.size
        if size != shape.size:
            raise InputFileError(str(path), f"is {size[0]} × {size[1]} px, but the {shape.what} was "
                                 f"{shape.size[0]} × {shape.size[1]} px: not accepted")
        if frames != shape.frames:
            raise InputFileError(str(path), f"has {frames} frames, but the {shape.what} had {shape.frames}: stored "
                                 "picks are by frame, not accepted")
        if not math.isclose(fps, shape.fps, rel_tol=FPS_TOLERANCE):
            raise InputFileError(str(path), f"runs at {fps:.6g} fps, but the {shape.what} ran at {shape.fps:.6g}: "
                                 "not accepted")


@dataclass(frozen=True)
class ChangedMedia:
    """A recorded media file that is there but not the one added: its ``stored`` path, absolute ``path``,
    ``problem`` (how it differs), ``refusal`` (why it cannot stand in for the recording; '' when it can),
    the SHA-256 recorded for it (``recorded_sha256``) and the file as read now, ``hashed`` (size in bytes,
    SHA-256, sampled hash)."""

    stored: str
    path: Path
    problem: str
    refusal: str
    recorded_sha256: str
    hashed: tuple[int, str, str]

    @property
    def acceptable(self) -> bool:
        return not self.refusal


def find_changed_media(records: Sequence[tuple[str, Path, int, str]], shapes: dict[str, list[RecordedShape]],
                       progress: Callable[[int, int], None] | None = None,
                       cancelled: Callable[[], bool] | None = None) -> list[ChangedMedia]:
    """Every file of ``records`` (:meth:`ProjectStore.media_records`) that is there but differs from the one
    added (size or SHA-256), each read whole, with whether it can stand in for the recording
    (:func:`refuse_unlike` with ``shapes``, :func:`recorded_shapes`); missing files are left to relocating.
    Any thread: ``progress(bytes done, bytes in all)``, and ``cancelled()`` stops the reading at once
    (:class:`usvips.app.video_project.Cancelled`)."""
    present = [(stored, path, size, sha, path.stat().st_size) for stored, path, size, sha in records
               if path.is_file()]
    read = ByteProgress(sum(now for *_, now in present), progress)
    changed = []
    for stored, path, size, sha, now_size in present:
        now_sha = file_sha256(path, read, cancelled)
        if now_size == size and now_sha == sha:
            continue
        problem = (f"{now_size} bytes, but {size} when it was added" if now_size != size
                   else "its contents differ from the file added (SHA-256; same size)")
        try:
            refuse_swapped(records, stored, path, now_sha)
            refusal = _refusal(path, shapes.get(stored, ()))
        except InputFileError as error:
            problem, refusal = "another recorded file's recording (swapped?)", error.problem
        changed.append(ChangedMedia(stored, path, problem, refusal, sha, (now_size, now_sha, sampled_hash(path))))
    return changed


def refuse_swapped(records: Sequence[tuple[str, Path, int, str]], stored: str, path: Path, sha256: str) -> None:
    """Raise an :class:`InputFileError` naming ``path`` when the file now at the recorded path ``stored``
    (its SHA-256 ``sha256``) is another recorded file's recording (:meth:`ProjectStore.media_records`):
    camera files swapped or copied over each other, which no frame count or size tells apart."""
    other = next((other for other, _, _, sha in records if sha == sha256 and other != stored), None)
    if other is not None:
        raise InputFileError(str(path), f"holds what {other} held when it was added (swapped?): it is the "
                             f"recording of {other}, not accepted; put each file back in its place")


def _refusal(path: Path, shapes: Sequence[RecordedShape]) -> str:
    """Why the file at ``path`` cannot stand in for ``shapes`` ('' when it can)."""
    try:
        refuse_unlike(path, shapes)
    except UsvipsError as error:
        return error.problem if isinstance(error, InputFileError) else str(error)
    return ""


def accept_changed(project: ProjectStore, changed: Sequence[ChangedMedia],
                   accepted: list[str] | None = None) -> list[str]:
    """Each of ``changed`` taken as the one the project means, on the store's thread; returns the stored
    paths accepted, appended to ``accepted`` (when given) as each is taken. One that cannot stand in for its
    recording is an error naming it, before any is accepted; the files are not read whole again, and one
    changed since it was read is refused by the store: those before it stay accepted (each is its own
    transaction), and the error names them."""
    for media in changed:
        if not media.acceptable:
            raise InputFileError(str(media.path), media.refusal)
    accepted = [] if accepted is None else accepted
    for media in changed:
        try:
            project.accept_media(media.stored, expected_sha256=media.recorded_sha256, hashed=media.hashed)
        except UsvipsError as error:
            if accepted:
                raise UsvipsError(f"{error}; accepted before it: {', '.join(accepted)}") from error
            raise
        accepted.append(media.stored)
    return accepted

