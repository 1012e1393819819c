"""Where the stereo instants in which a calibration target is looked for come from: image pairs or a
stereo video, behind one interface (:class:`FrameSet`) so that one detection loop
(:mod:`usvips.app.view_detection`) serves both.

A frame set is a sequence of :class:`StereoFrame` s, each with its label (the view's name), its source
(what the calibration records: the two image paths, or the video and its frames) and a way to read its
two images, one camera at a time, lazily: a frame is decoded only when the loop gets to it (a cancel
before it costs nothing). A camera's image that cannot be read is that camera's problem (a line naming
the file and why), not an exception: the loop sets the view aside with it.

Images are handed over as the files hold them (grey or colour, 8 or 16 bits); video frames as grey.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from usvips.core.errors import InputFileError, UsvipsError
from usvips.io.images import read_image
from usvips.io.video_stream import PairReader, VideoStream

SIDES = ("left", "right")


@dataclass
class StereoFrame:
    """One instant of a frame set: ``label``, ``source`` (recorded with the view) and :meth:`image`."""

    label: str
    source: dict
    _reader: object = field(repr=False, default=None)

    def image(self, side: str) -> np.ndarray | str:
        """The ``side`` camera's image, or one line saying why it cannot be read."""
        return self._reader(side)


class FrameSet(ABC):
    """Stereo instants to look for a target in (see the module's notes). Subclasses: :class:`ImagePairs`,
    :class:`VideoFrames`."""

    #: what one frame is called in messages ("pair", "instant")
    unit = "frame"

    @abstractmethod
    def __len__(self) -> int:
        """How many instants."""

    @abstractmethod
    def __iter__(self) -> Iterator[StereoFrame]:
        """The instants in order."""

    def cancelled(self, done: int, frame: StereoFrame) -> str:
        """The message of a cancel after ``done`` frames, before ``frame``."""
        return f"target detection cancelled after {done} of {len(self)} {self.unit}s"

    def close(self) -> None:  # noqa: B027 (a set of image pairs holds nothing open: nothing to release)
        """Release what the set holds open (a video's decoders)."""

    def __enter__(self) -> FrameSet:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def _labels(pairs: Sequence[tuple[Path, Path]], labels: Sequence[str] | None) -> list[str]:
    if labels is not None:
        if len(labels) != len(pairs) or len(set(labels)) != len(labels):
            raise UsvipsError(f"{len(labels)} view labels for {len(pairs)} pairs; give one distinct label per pair")
        return [str(label) for label in labels]
    stems = [Path(left).stem for left, _ in pairs]
    return stems if len(set(stems)) == len(stems) else [f"{k + 1}:{stem}" for k, stem in enumerate(stems)]


class ImagePairs(FrameSet):
    """Image pairs (left, right), labelled by ``labels`` or by the left image's name. Every file must exist:
    a missing one is an :class:`~usvips.core.errors.InputFileError` naming it, raised when the set is made
    (before anything is detected), never a view quietly set aside. A file that exists but cannot be read
    as an image is that camera's problem in its view."""

    unit = "pair"

    def __init__(self, pairs: Sequence[tuple[str | Path, str | Path]], labels: Sequence[str] | None = None) -> None:
        self.pairs = [(Path(left), Path(right)) for left, right in pairs]
        self.labels = _labels(self.pairs, labels)
        for pair in self.pairs:
            for path in pair:
                if not path.is_file():
                    raise InputFileError(str(path), "no such image file" if not path.exists() else "not a file")

    def __len__(self) -> int:
        return len(self.pairs)

    def __iter__(self) -> Iterator[StereoFrame]:
        for label, (left, right) in zip(self.labels, self.pairs, strict=True):
            paths = {"left": left, "right": right}
            yield StereoFrame(label, {"left": str(left), "right": str(right)},
                              lambda side, paths=paths: _read(paths[side]))


def _read(path: Path) -> np.ndarray | str:
    try:
        return read_image(path)
    except (UsvipsError, OSError) as error:
        return str(error)


class VideoFrames(FrameSet):
    """Every ``every``-th instant of a stereo video: left frame ``i`` with right frame ``i + offset``, for
    each left frame that has a right partner; labels ``<label>-<left frame>``; source ``{"video",
    "frame", "right_frame"}``. The streams are closed with the set."""

    unit = "instant"

    def __init__(self, left: VideoStream, right: VideoStream, offset: int, label: str, every: int = 1) -> None:
        self.left, self.right, self.offset, self.label = left, right, int(offset), label
        first = max(0, -self.offset)
        stop = min(left.frame_count, right.frame_count - self.offset)
        self.instants = list(range(first, stop, int(every)))
        self._reader: PairReader | None = None

    def __len__(self) -> int:
        return len(self.instants)

    def __iter__(self) -> Iterator[StereoFrame]:
        self._reader = self._reader or PairReader(self.left, self.right)
        for frame in self.instants:
            decoded: dict[str, np.ndarray] = {}

            def image(side: str, frame: int = frame, decoded: dict = decoded) -> np.ndarray | str:
                if not decoded:
                    pictures = self._reader.pictures(frame, frame + self.offset)
                    decoded.update(zip(SIDES, (p.array(grey=True) for p in pictures), strict=True))
                return decoded[side]

            yield StereoFrame(f"{self.label}-{frame}",
                              {"video": self.label, "frame": frame, "right_frame": frame + self.offset}, image)

    def cancelled(self, done: int, frame: StereoFrame) -> str:
        return f"video {self.label!r}: scanning cancelled at frame {frame.source['frame']}"

    def close(self) -> None:
        if self._reader is not None:
            self._reader.close()
            self._reader = None
