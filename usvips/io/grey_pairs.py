"""Grey frame pairs of a stereo video for tracking, decoded ahead in both cameras at once.

:class:`GreyPairSource` is a frame source for :func:`usvips.core.tracking.track_vertex`: called with a left
frame index it returns that left frame and its partner right frame (``partner(index)``) in grey, uint8
``(H, W)``, the same pixels as ``VideoStream.frame(index, grey=True)``. What makes it fast:

- each camera decodes in its own thread (FFmpeg releases the GIL while it decodes), so a pair costs about
  one frame's decoding on two cores;
- once two calls have shown the direction (frame after frame forward or backward), the next
  :data:`AHEAD_PAIRS` pairs are queued on the two decoders, which run on while the caller tracks the pair it
  has: neither decoder waits for the other's frame or for the caller (prefetch);
- backward, frame by frame, each step would be a seek decoding from the key frame before it (half a GOP on
  average, 15 frames at one key frame a second): instead the frames from that key frame up to the one
  asked for are decoded once, forward, and kept in grey (at most :data:`BACKWARD_CACHE_BYTES` a camera),
  so that the steps back to the key frame cost nothing more.

Each stream is used by its own thread only (a :class:`~usvips.io.video_stream.VideoStream` is not
thread-safe): do not use the streams elsewhere until :meth:`GreyPairSource.close`.
"""

from __future__ import annotations

from collections.abc import Callable
from concurrent.futures import Future, ThreadPoolExecutor

import numpy as np

from usvips.core.errors import InvalidParameterError, UsvipsError
from usvips.io.video_stream import VideoStream

#: the grey frames kept a camera when tracking backward (bytes): 64 frames of 1080p
BACKWARD_CACHE_BYTES = 128 * 2**20
#: frame pairs decoded ahead of a caller stepping frame by frame (4 pairs of 1080p: 16 MiB). One pair
#: ahead kept the two decoders in step with each other and with the caller (each idled while the other,
#: or the tracker, finished); a few pairs let each decoder run on and absorb the spread of frame costs.
AHEAD_PAIRS = 4


class _GreyReader:
    """One stream's grey frames, read on one thread: forward steps continue the decoder; a step back is
    served from the frames kept when the block before it was decoded."""

    def __init__(self, stream: VideoStream, cache_bytes: int) -> None:
        self.stream = stream
        width, height = stream.size
        self.keep = max(1, int(cache_bytes) // max(width * height, 1))
        self.kept: dict[int, np.ndarray] = {}
        self.last = -1

    def grey(self, index: int) -> np.ndarray:
        index = self.stream.check_index(index)
        frame = self.kept.get(index)
        if frame is None:
            if index < self.last:  # backward: decode the block from its key frame once, keep it
                frame = self._block_up_to(index)
            else:
                self.kept = {}  # forward again: the block kept for going back is done with
                frame = self.stream.frame(index, grey=True)
        self.last = index
        return frame

    def _block_up_to(self, index: int) -> np.ndarray:
        key = self.stream.key_frame_before(index)
        first_kept = max(key, index - self.keep + 1)
        self.kept = {}
        for i in range(key, index + 1):  # the first a seek to the key frame, the rest forward steps
            picture = self.stream.picture(i)
            if i >= first_kept:
                frame = self.kept[i] = picture.array(grey=True)
                frame.setflags(write=False)  # kept and handed out again: nobody may change it
        return self.kept[index]


class GreyPairSource:
    """Left frame ``index`` of ``left`` and frame ``partner(index)`` of ``right``, grey, decoded in two
    threads and ahead of the caller (see the module docstring). ``partner`` raising a
    :class:`UsvipsError` (no partner frame) is passed on to the caller. ``cache_bytes``: the grey frames a
    camera keeps for stepping backward; ``remember_bytes``: the pairs returned that are kept for a later
    call asking for them again (the vertices of one object tracked one after the other over the same
    frames), 0 for none. Use as a context manager."""

    def __init__(self, left: VideoStream, right: VideoStream, partner: Callable[[int], int] = int,
                 cache_bytes: int = BACKWARD_CACHE_BYTES, remember_bytes: int = 0) -> None:
        if left is right:
            raise InvalidParameterError("right", "must be another VideoStream than the left one (each is decoded "
                                                 "on its own thread; open the file twice for the same video)")
        self.partner = partner
        self._readers = (_GreyReader(left, cache_bytes), _GreyReader(right, cache_bytes))
        self._threads = tuple(ThreadPoolExecutor(max_workers=1, thread_name_prefix=f"usvips-{side}-grey")
                              for side in ("left", "right"))
        self._ahead: dict[int, tuple[Future, Future]] = {}  # pairs queued ahead, in the order submitted
        self._previous: int | None = None
        self._remember_bytes = int(remember_bytes)
        self._remembered: dict[int, tuple[np.ndarray, np.ndarray]] = {}
        self._remembered_bytes = 0

    def _submit(self, index: int, partner: int) -> tuple[Future, Future]:
        return (self._threads[0].submit(self._readers[0].grey, index),
                self._threads[1].submit(self._readers[1].grey, partner))

    def __call__(self, index: int) -> tuple[np.ndarray, np.ndarray]:
        index = int(index)
        frames = self._remembered.get(index)
        if frames is None:
            pending = self._ahead.pop(index, None)
            if pending is None:
                self._drop_ahead()
                pending = self._submit(index, self.partner(index))
            for future in pending:
                future.exception()  # both finish before either error is raised
            frames = (pending[0].result(), pending[1].result())
            self._remember(index, frames)
        step = index - self._previous if self._previous is not None else 0
        self._previous = index
        if abs(step) == 1:
            self._read_ahead(index, step)
        return frames

    def _read_ahead(self, index: int, step: int) -> None:
        """Queue the :data:`AHEAD_PAIRS` pairs after ``index`` going ``step`` (±1) that are neither queued nor
        remembered; a queued pair off that path is dropped first."""
        path = [i for i in (index + k * step for k in range(1, AHEAD_PAIRS + 1))
                if 0 <= i < self._readers[0].stream.frame_count]
        if any(i not in path for i in self._ahead):
            self._drop_ahead()
        for following in path:
            if following in self._remembered or following in self._ahead:
                continue
            try:
                partner = self.partner(following)
            except UsvipsError:
                return  # no partner there: the caller hears of it when it asks for that frame
            self._ahead[following] = self._submit(following, partner)

    def _remember(self, index: int, frames: tuple[np.ndarray, np.ndarray]) -> None:
        """Keep a pair for a later call (another vertex tracked over the same frames), within the budget."""
        size = frames[0].nbytes + frames[1].nbytes
        if self._remembered_bytes + size <= self._remember_bytes:
            for frame in frames:
                frame.setflags(write=False)  # shared by the calls that ask for it: nobody may change it
            self._remembered[index] = frames
            self._remembered_bytes += size

    def _drop_ahead(self) -> None:
        """Drop the pairs queued ahead: those not started are cancelled, a running one is waited for (its
        decoder must be idle before the next request)."""
        for pending in self._ahead.values():
            for future in pending:
                if not future.cancel():
                    future.exception()  # wait; an error of a frame not asked for is nobody's concern
        self._ahead = {}

    def close(self) -> None:
        self._drop_ahead()
        for thread in self._threads:
            thread.shutdown(wait=True)

    def __enter__(self) -> GreyPairSource:
        return self

    def __exit__(self, *exc) -> None:
        self.close()
