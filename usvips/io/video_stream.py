"""Frame-exact reading of a camera's recording (one file or a chaptered list of files) through FFmpeg (PyAV).

Why PyAV and not OpenCV's reader: OpenCV seeks by ``CAP_PROP_POS_FRAMES``, which FFmpeg's back end turns
into a *time* (frame / nominal fps); on a variable-frame-rate file, or one with dropped or duplicated
timestamps, the frame it returns is not the frame asked for, and it cannot tell. Here every frame is known
by its presentation timestamp (pts), read once from the container's packets when the stream is opened
(no decoding), so that

- frame ``i`` is the ``i``-th presentation timestamp of the stream, whatever the frame rate does;
- a random seek goes to the last key frame at or before the frame's pts (from the same index) and
  decodes forward until the decoder returns exactly that pts: frame-exact in long-GOP H.264/HEVC files;
- stepping forward continues the running decoder (no seek);
- a chaptered recording (GoPro's GX010042.MP4, GX020042.MP4 …) is one stream: the frames of chapter 2
  follow those of chapter 1, its times continue after chapter 1's last frame.

Frames are RGB uint8 ``(H, W, 3)`` (or grey ``(H, W)``), indices count from 0, times are seconds from the
first frame of the first chapter.
"""

from __future__ import annotations

import hashlib
from collections import deque
from collections.abc import Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np

from usvips.core.errors import InputFileError
from usvips.io.lazy_import import lazy_module

av = lazy_module("av")  # PyAV loaded when a video is first read (see usvips.io.lazy_import)

#: relative spread of frame intervals above which a stream is called variable-frame-rate
VFR_TOLERANCE = 0.01
#: forward decoding from the current position instead of seeking, up to this many frames (and never
#: more than a seek would decode)
CONTINUE_LIMIT = 48
#: FFmpeg decoder threading of a stream (see ``VideoStream.thread_type``)
THREAD_TYPE = "SLICE"
#: mean absolute difference (grey levels, 64 × 48 thumbnail) below which a frame repeats the one before
DUPLICATE_LEVEL = 0.5


@dataclass(frozen=True)
class Chapter:
    """One file of a recording: its frames are ``first`` … ``first + count − 1`` of the stream."""

    path: Path
    first: int
    count: int
    pts: np.ndarray          # presentation timestamps of its frames, in its time base, increasing
    keyframe: np.ndarray     # bool per frame: a decoder can start here
    time_base: float         # seconds per pts unit
    digests: tuple[str, ...] = field(repr=False, default=())  # hash of each frame's packet (duplicates)
    stated_fps: float | None = None  # the frame rate the container states (average, else FFmpeg's guess)


@dataclass(frozen=True)
class StreamReport:
    """What was found when the stream was indexed: ``variable_frame_rate``, the frames that repeat the
    one before (``duplicated``: same timestamp or the same coded bytes), the gaps where frames are missing
    (``dropped``: (frame index after the gap, frames missing)), with a one-line ``summary()``."""

    fps: float
    variable_frame_rate: bool
    interval_spread: float
    duplicated: tuple[int, ...]
    dropped: tuple[tuple[int, int], ...]

    @property
    def clean(self) -> bool:
        return not (self.variable_frame_rate or self.duplicated or self.dropped)

    def summary(self) -> str:
        if self.clean:
            return f"constant {self.fps:.6g} fps, no duplicated or dropped frames"
        parts = []
        if self.variable_frame_rate:
            parts.append(f"variable frame rate (frame intervals spread {100 * self.interval_spread:.1f} %)")
        if self.duplicated:
            parts.append(f"{len(self.duplicated)} duplicated frame(s), first at frame {self.duplicated[0]}")
        if self.dropped:
            index, missing = self.dropped[0]
            parts.append(f"{sum(m for _, m in self.dropped)} dropped frame(s), first {missing} before frame {index}")
        return "; ".join(parts)


#: a file whose frames end earlier than its container says by more than this many frame intervals …
CUT_SHORT_FRAMES = 3
#: … and this share of its stated duration is cut short (a copy that did not finish)
CUT_SHORT_SHARE = 0.02


def _refuse_cut_short(path: Path, container, stream, pts: np.ndarray) -> None:
    """An :class:`InputFileError` when the frames found end well before the duration the file states
    (its video stream's, else the container's): a truncated file (Matroska keeps its duration in its
    header, so a copy cut short still says how long it was) read as a shorter video would pair and time
    frames wrongly with no word."""
    if len(pts) < 2:
        return
    time_base = float(stream.time_base)
    interval = float(np.median(np.diff(np.sort(pts)))) * time_base
    if stream.duration:
        stated = float(stream.duration) * time_base
    elif container.duration:
        stated = float(container.duration) / 1e6  # FFmpeg's AV_TIME_BASE: microseconds
    else:
        return
    found = float(pts.max() - pts.min()) * time_base + interval
    if stated - found > max(CUT_SHORT_FRAMES * interval, CUT_SHORT_SHARE * stated):
        raise InputFileError(str(path), f"cut short: the file says it lasts {stated:.3f} s, but its frames end at "
                             f"{found:.3f} s (about {round((stated - found) / interval)} frames missing; an unfinished "
                             "copy? give the complete file)")


def _index_chapter(path: Path, first: int) -> tuple[Chapter, tuple[int, int], str]:
    """Read a file's packets (no decoding): pts, key frames and packet hashes of its first video stream."""
    if not path.is_file():
        raise InputFileError(str(path), "no such video file (a missing chapter of the recording?)")
    try:
        container = av.open(str(path))
    except (av.error.FFmpegError, ValueError, UnicodeDecodeError) as error:
        raise InputFileError(str(path), f"not a video FFmpeg can read ({error.__class__.__name__})") from None
    try:
        if not container.streams.video:
            raise InputFileError(str(path), "not a video (the file has no video stream)")
        stream = container.streams.video[0]
        if stream.time_base is None:
            raise InputFileError(str(path), "the video stream has no time base; cannot number its frames")
        rows = []
        try:
            for packet in container.demux(stream):
                if packet.size == 0:
                    continue
                timestamp = packet.pts if packet.pts is not None else packet.dts
                if timestamp is None:
                    raise InputFileError(str(path), "a video packet carries no timestamp; cannot number its frames")
                rows.append((int(timestamp), bool(packet.is_keyframe), hashlib.blake2b(bytes(packet), digest_size=8)
                             .hexdigest()))
        except av.error.FFmpegError as error:
            raise InputFileError(str(path), f"the video cannot be read past packet {len(rows)}: {error}") from None
        if not rows:
            raise InputFileError(str(path), "the video has no frames")
        rows.sort(key=lambda r: r[0])
        pts = np.array([r[0] for r in rows], dtype=np.int64)
        keyframe = np.array([r[1] for r in rows], dtype=bool)
        if not keyframe[0]:
            keyframe[0] = True  # a decoder starts at the first packet whatever its flag says
        size = (int(stream.codec_context.width), int(stream.codec_context.height))
        if size[0] <= 0 or size[1] <= 0:
            raise InputFileError(str(path), "the video stream has no picture size")
        _refuse_cut_short(path, container, stream, pts)
        rate = stream.average_rate or stream.guessed_rate
        chapter = Chapter(path, first, len(rows), pts, keyframe, float(stream.time_base),
                          tuple(r[2] for r in rows), float(rate) if rate else None)
        return chapter, size, stream.codec_context.name
    finally:
        container.close()


def _report(times: np.ndarray, digests: Sequence[str], same_picture: Sequence[int] = (),
            tick_s: float = 0.0, stated_fps: float | None = None) -> StreamReport:
    """What the frame times (s) and packet digests say (see :class:`StreamReport`). ``tick_s``: the
    coarsest time base of the chapters (s per timestamp unit). Timestamps are whole ticks, so intervals of
    a constant rate that is not a whole number of ticks alternate by one tick (30 fps in Matroska's 1 ms:
    33, 34, 33 ms): a spread of one tick is rounding, not a variable rate, and the rate of such a stream
    is the rate its container states (``stated_fps``) when the mean interval agrees with it to within a
    tick, else its mean interval's."""
    if len(times) < 2:
        return StreamReport(float("nan"), False, 0.0, (), ())
    intervals = np.diff(times)
    positive = intervals[intervals > 0]
    nominal = float(np.median(positive)) if positive.size else float("nan")
    duplicated = sorted({i + 1 for i, dt in enumerate(intervals) if dt <= 0 or digests[i + 1] == digests[i]}
                        | set(same_picture))
    steps = intervals / nominal
    dropped = [(i + 1, round(s) - 1) for i, s in enumerate(steps) if s > 1.5 and abs(s - round(s)) < 0.25]
    gap_free = np.ones(intervals.size, bool)
    for i, _ in dropped:
        gap_free[i - 1] = False
    regular = intervals[(intervals > 0) & gap_free]
    rounding = 1.000001 * tick_s  # one tick, and the floating point of times made from ticks
    spread = float(max(regular.max() - regular.min() - rounding, 0.0) / nominal) if regular.size else 0.0
    irregular_gaps = any(s > 1.5 and abs(s - round(s)) >= 0.25 for s in steps)
    variable = spread > VFR_TOLERANCE or irregular_gaps
    if regular.size and not variable:
        nominal = float(np.mean(regular))
        if stated_fps and abs(1.0 / stated_fps - nominal) <= rounding:
            nominal = 1.0 / stated_fps
    return StreamReport(1.0 / nominal, variable, spread, tuple(duplicated), tuple(dropped))


class Picture:
    """A decoded frame in the decoder's own pixel format (YUV 4:2:0 for most cameras: 1.5 bytes a pixel
    against RGB's 3), converted to RGB or grey by :meth:`array` on demand, always by the same FFmpeg
    conversion (so a cached picture gives the same pixels as a fresh decode)."""

    __slots__ = ("_frame", "nbytes")

    def __init__(self, frame: av.VideoFrame) -> None:
        self._frame = frame
        self.nbytes = int(sum(plane.buffer_size for plane in frame.planes))

    @property
    def size(self) -> tuple[int, int]:
        """(width, height) in pixels."""
        return int(self._frame.width), int(self._frame.height)

    @property
    def display_rotation(self) -> int:
        """Degrees clockwise (0, 90, 180 or 270) a player turns this picture by, from the display matrix a
        phone or a camera mounted upside down writes; USVIPS never turns it (pixels as recorded). (FFmpeg
        states the matrix's rotation counter-clockwise; a player undoes it.)"""
        rotation = getattr(self._frame, "rotation", 0) or 0
        return int(round(-float(rotation))) % 360

    def array(self, grey: bool = False) -> np.ndarray:
        """RGB uint8 (H, W, 3) or grey (H, W)."""
        if grey:
            return self.grey()
        return self._frame.to_ndarray(format="rgb24")

    def grey(self) -> np.ndarray:
        """Grey uint8 (H, W), the same pixels as FFmpeg's conversion to ``gray`` (``to_ndarray(format="gray")``),
        read from the luma plane through :func:`grey_table` where the decoder's format has an 8-bit one: a
        table look-up instead of a scaler pass (a third of the decoding time of a 1080p H.264 frame)."""
        frame = self._frame
        table = grey_table(frame.format.name, int(frame.color_range))
        if table is None:
            return frame.to_ndarray(format="gray")
        plane = frame.planes[0]
        luma = np.frombuffer(plane, np.uint8).reshape(-1, plane.line_size)[:frame.height, :frame.width]
        return _look_up(luma, table)


#: the pixels below which ``cv2.LUT`` runs on the calling thread: OpenCV shares a larger look-up out over its
#: thread pool, whose worker then spins for a millisecond waiting for more, for no gain where the decoders
#: already keep the cores busy (OpenCV's own threshold, 2**18; a later OpenCV may differ: the pixels do not)
SERIAL_LUT_PIXELS = 1 << 18


def _look_up(luma: np.ndarray, table: np.ndarray) -> np.ndarray:
    """``cv2.LUT(luma, table)`` in blocks of rows each below :data:`SERIAL_LUT_PIXELS`: the same pixels, on
    the calling thread, whatever OpenCV's thread count (one while a track runs, see
    :mod:`usvips.core.tracking`), so that a frame costs the same CPU read with or without a tracker."""
    height, width = luma.shape
    grey = np.empty((height, width), np.uint8)
    rows = max(1, (SERIAL_LUT_PIXELS - 1) // max(width, 1))
    for top in range(0, height, rows):
        cv2.LUT(luma[top:top + rows], table, dst=grey[top:top + rows])
    return grey


#: decoders' pixel formats whose first plane is the 8-bit luma (Y) plane, one byte a pixel
LUMA_PLANE_FORMATS = frozenset({"yuv420p", "yuvj420p", "yuv422p", "yuvj422p", "yuv444p", "yuvj444p", "nv12", "nv21",
                                "gray"})
_GREY_TABLES: dict[tuple[str, int], np.ndarray] = {}


def grey_table(pixel_format: str, color_range: int) -> np.ndarray | None:
    """The 256-entry uint8 table that maps a luma value of a ``pixel_format`` frame with FFmpeg's
    ``color_range`` (0 unspecified, 1 limited "MPEG", 2 full "JPEG") to the grey level FFmpeg's scaler gives
    it (limited-range luma 16–235 is stretched to 0–255); None for formats without an 8-bit luma plane.
    Made once per format and range by converting a frame holding every luma value through that scaler, so
    it holds whatever FFmpeg does (the conversion is per pixel: tests/io/test_video_stream.py checks it)."""
    if pixel_format not in LUMA_PLANE_FORMATS:
        return None
    key = (pixel_format, int(color_range))
    table = _GREY_TABLES.get(key)
    if table is None:
        frame = av.VideoFrame(256, 2, pixel_format)
        for plane in frame.planes:
            np.frombuffer(plane, np.uint8)[:] = 128
        luma = np.frombuffer(frame.planes[0], np.uint8).reshape(-1, frame.planes[0].line_size)
        luma[:2, :256] = np.arange(256, dtype=np.uint8)
        frame.color_range = int(color_range)
        table = _GREY_TABLES[key] = np.ascontiguousarray(frame.to_ndarray(format="gray")[0], dtype=np.uint8)
    return table


class PairReader:
    """Decodes a left and a right frame together: the right one in a helper thread while the left one
    decodes on the caller's (FFmpeg releases the GIL while decoding), so a frame pair costs about one
    frame's decoding on two cores. The two streams must not be used elsewhere meanwhile."""

    def __init__(self, left: VideoStream, right: VideoStream) -> None:
        self.left, self.right = left, right
        self._pool = ThreadPoolExecutor(max_workers=1, thread_name_prefix="usvips-right-decoder")

    def pictures(self, left_index: int, right_index: int) -> tuple[Picture, Picture]:
        pending = self._pool.submit(self.right.picture, right_index)
        try:
            left = self.left.picture(left_index)
        finally:
            right = pending.result() if pending.exception() is None else None  # never leave it running
        if right is None:
            raise pending.exception()
        return left, right

    def close(self) -> None:
        self._pool.shutdown(wait=True)


class VideoStream:
    """A camera's recording, one or more files, read frame-exactly. Use as a context manager or
    :meth:`close`. Not thread-safe: one decoder per thread (the GUI's worker owns its own)."""

    def __init__(self, paths: str | Path | Sequence[str | Path]):
        if isinstance(paths, (str, Path)):
            paths = [paths]
        paths = [Path(p) for p in paths]
        if not paths:
            raise InputFileError("(no files)", "a video needs at least one file")
        chapters: list[Chapter] = []
        first = 0
        self.size: tuple[int, int] | None = None
        self.codec = ""
        for path in paths:
            chapter, size, codec = _index_chapter(path, first)
            if self.size is None:
                self.size, self.codec = size, codec
            elif size != self.size:
                raise InputFileError(str(path), f"chapter is {size[0]} × {size[1]} px, but {paths[0].name} is "
                                     f"{self.size[0]} × {self.size[1]} px: not one recording")
            chapters.append(chapter)
            first += chapter.count
        self._setup(paths, chapters)

    @classmethod
    def from_index(cls, path: str | Path, count: int, size: tuple[int, int], codec: str, pts_first: int,
                   pts_step: int, time_base: float) -> VideoStream:
        """A one-file stream whose index is known without reading its packets: ``count`` frames, every one a
        key frame, at presentation timestamps ``pts_first + i · pts_step`` (units of ``time_base`` s). For
        seek proxies (:mod:`usvips.io.video_proxy`), whose index was checked against the file when they were
        built: indexing a proxy by reading it would read gigabytes."""
        path = Path(path)
        if not path.is_file():
            raise InputFileError(str(path), "no such video file")
        pts = pts_first + pts_step * np.arange(int(count), dtype=np.int64)
        chapter = Chapter(path, 0, int(count), pts, np.ones(int(count), bool), float(time_base),
                          tuple(str(i) for i in range(int(count))))
        stream = cls.__new__(cls)
        stream.size, stream.codec = (int(size[0]), int(size[1])), codec
        stream._setup([path], [chapter])
        return stream

    def _setup(self, paths: Sequence[Path], chapters: Sequence[Chapter]) -> None:
        """Number the indexed chapters' frames and times; no decoder open yet."""
        self.paths = tuple(paths)
        self.chapters = tuple(chapters)
        self.frame_count = sum(c.count for c in chapters)
        times = []
        offset = 0.0
        for k, chapter in enumerate(chapters):
            local = (chapter.pts - chapter.pts[0]) * chapter.time_base
            if k:
                # a chapter starts one nominal interval after the previous chapter's last frame
                previous = times[-1]
                step = np.median(np.diff(previous)) if previous.size > 1 else (
                    np.median(np.diff(local)) if local.size > 1 else 0.0)
                offset = previous[-1] + step
            times.append(local + offset)
        self.times_s = np.concatenate(times)
        #: the coarsest timestamp resolution of the chapters (s): what the times are rounded to
        self.tick_s = max(c.time_base for c in chapters)
        #: the frame rate the chapters' containers state, when they all state the same one
        rates = {c.stated_fps for c in chapters}
        self.stated_fps = rates.pop() if len(rates) == 1 else None
        self.report = _report(self.times_s, [d for c in chapters for d in c.digests], tick_s=self.tick_s,
                              stated_fps=self.stated_fps)
        self.fps = self.report.fps if np.isfinite(self.report.fps) else float("nan")
        #: FFmpeg's decoder threading ("AUTO", "FRAME", "SLICE" or "NONE") and whether a seek skips the
        #: non-reference frames before its target (see :meth:`_next_frames`); both leave frames exact.
        #: Slice threads by default: frame threading ("AUTO") must refill a pipeline of one frame per
        #: thread after every seek (measured at 1080p H.264: a random seek 30–50 % slower), and decodes a
        #: forward step no faster when left and right already decode side by side on two cores.
        self.thread_type = THREAD_TYPE
        self.skip_unneeded = True
        self._proxy: VideoStream | None = None  # a lossless all-intra copy seeks go through (io.video_proxy)
        self._proxy_after = 0
        self._container: av.container.InputContainer | None = None
        self._chapter = -1
        self._packets = None  # the running demuxer (packets after the last one decoded)
        self._ready: deque = deque()  # frames decoded but not yet returned, in presentation order
        self._position = -1  # index of the last frame the running decoder returned
        self._keys_back = 0  # key frames a seek starts before the one it needs (see _seek)
        self._read_from_start = False  # whether the running decoder started at the file's first packet

    # ---------------------------------------------------------------------------- numbering
    @property
    def width(self) -> int:
        return self.size[0]

    @property
    def height(self) -> int:
        return self.size[1]

    @property
    def duration_s(self) -> float:
        return float(self.times_s[-1] - self.times_s[0] + (1.0 / self.fps if self.fps > 0 else 0.0))

    def check_index(self, index: int) -> int:
        if not isinstance(index, (int, np.integer)) or not 0 <= index < self.frame_count:
            raise InputFileError(str(self.paths[0]), f"frame {index} is out of range: the video has frames 0 to "
                                 f"{self.frame_count - 1}")
        return int(index)

    def time_of(self, index: int) -> float:
        """Presentation time of frame ``index`` (s from the first frame)."""
        return float(self.times_s[self.check_index(index)])

    def frame_at(self, time_s: float) -> int:
        """The frame shown at ``time_s`` (s): the last frame whose presentation time is not after it."""
        if not np.isfinite(time_s) or time_s < self.times_s[0] - 1e-9 or time_s > self.times_s[-1] + 1.0 / self.fps:
            raise InputFileError(str(self.paths[0]), f"time {time_s} s is outside the video (0 to "
                                 f"{self.duration_s:.3f} s)")
        return int(max(0, np.searchsorted(self.times_s, time_s + 1e-9, side="right") - 1))

    def _locate(self, index: int) -> tuple[int, int]:
        for k, chapter in enumerate(self.chapters):
            if index < chapter.first + chapter.count:
                return k, index - chapter.first
        raise AssertionError("index checked before")

    def key_frame_before(self, index: int) -> int:
        """The last key frame at or before frame ``index`` (where a decoder can start to reach it)."""
        k, local = self._locate(self.check_index(index))
        keys = np.flatnonzero(self.chapters[k].keyframe[: local + 1])
        return self.chapters[k].first + (int(keys[-1]) if keys.size else 0)

    # ---------------------------------------------------------------------------- decoding
    def frame(self, index: int, grey: bool = False) -> np.ndarray:
        """Frame ``index`` exactly as decoded, RGB uint8 (H, W, 3) or grey (H, W)."""
        return self.picture(index).array(grey)

    def picture(self, index: int) -> Picture:
        """Frame ``index`` as the decoder returned it (its native pixel format, e.g. YUV 4:2:0: half the
        bytes of RGB), converted on demand by :meth:`Picture.array`."""
        index = self.check_index(index)
        k, local = self._locate(index)
        chapter = self.chapters[k]
        target = int(chapter.pts[local])
        keys = np.flatnonzero(chapter.keyframe[: local + 1])
        behind = local - (int(keys[-1]) if keys.size else 0)  # frames a seek decodes before the target
        # continue the running decoder when that decodes no more frames than a seek would
        continuing = (k == self._chapter and self._position < index <= self._position + min(CONTINUE_LIMIT, behind + 1)
                      and self._packets is not None)
        if not continuing and self._proxy is not None and behind > self._proxy_after:
            return self._proxy.picture(index)  # the same planes, one intra frame away
        # a frame whose timestamp repeats an earlier one's (a duplicated frame) is told apart by its place in
        # the run of equal timestamps, counted from the first of the run this decoder has not returned yet
        run_start = int(np.searchsorted(chapter.pts, target, side="left"))
        frame = None
        while frame is None:
            if not continuing:
                self._seek(k, local)
            returned = self._position - chapter.first + 1 if continuing else run_start
            frame = self._decode_until(chapter, target, index, int(chapter.pts[keys[-1]]) if keys.size else target,
                                       continuing, later=local - max(run_start, returned))
            if frame is None:  # the seek landed after the key frame the target needs: start earlier
                self._seek_unreliable()
                continuing = False
        self._position = index
        return Picture(frame)

    def attach_proxy(self, proxy: VideoStream, after: int) -> None:
        """Serve a seek from ``proxy`` (same frames, every one a key frame, decoding to the same pixels:
        :mod:`usvips.io.video_proxy`) when this stream would decode more than ``after`` frames to reach
        its target; stepping on from there continues in the proxy until the original is cheaper again."""
        if proxy.frame_count != self.frame_count or proxy.size != self.size:
            raise InputFileError(str(proxy.paths[0]), f"{proxy.frame_count} frames of {proxy.size}, but the "
                                 f"recording has {self.frame_count} of {self.size}: not its proxy")
        if self._proxy is not None:
            self._proxy.close()
        self._proxy, self._proxy_after = proxy, int(after)

    def detach_proxy(self) -> None:
        """Seek in the original again (closing the proxy, e.g. before it is deleted)."""
        if self._proxy is not None:
            self._proxy.close()
        self._proxy = None

    @property
    def has_proxy(self) -> bool:
        return self._proxy is not None

    def _open_chapter(self, k: int) -> None:
        if self._chapter != k or self._container is None:
            self._close_container()
            try:
                self._container = av.open(str(self.chapters[k].path))
            except av.error.FFmpegError as error:
                raise InputFileError(str(self.chapters[k].path), f"cannot be opened any more: {error}") from None
            self._container.streams.video[0].thread_type = self.thread_type
            self._chapter = k

    def _start_at(self, k: int, start: int) -> None:
        """Position the demuxer on chapter ``k``'s key frame ``start`` (local index), decoder flushed."""
        chapter = self.chapters[k]
        stream = self._container.streams.video[0]
        try:
            self._container.seek(int(chapter.pts[start]), stream=stream, backward=True, any_frame=False)
        except av.error.FFmpegError as error:
            raise InputFileError(str(chapter.path), f"cannot seek to frame {chapter.first + start}: {error}") from None
        stream.codec_context.flush_buffers()
        self._packets = self._container.demux(stream)
        self._ready.clear()
        self._position = -1
        self._read_from_start = False

    def _seek(self, k: int, local: int) -> None:
        """Position the decoder before frame ``local`` of chapter ``k``: at the key frame it needs, or
        :attr:`_keys_back` key frames earlier where this file's seeks proved imprecise (MPEG-PS/TS are
        seeked by byte position and land just after the key frame asked for); at key frame 0 the file is
        read from its start, which needs no seek at all."""
        self._open_chapter(k)
        pts = self.chapters[k].pts
        keys = np.flatnonzero(self.chapters[k].keyframe[: local + 1])
        # a key frame that shares its timestamp with another frame is no place to seek to: the seek may land
        # on either of the two (then a run of equal timestamps could not be counted from its first frame)
        shared = np.zeros(len(pts), dtype=bool)
        shared[1:] |= pts[1:] == pts[:-1]
        shared[:-1] |= pts[:-1] == pts[1:]
        keys = keys[~shared[keys]]
        chosen = len(keys) - 1 - self._keys_back
        if chosen < 0 or (chosen == 0 and self._keys_back > 0):
            self._start_from_beginning(k)
        else:
            self._start_at(k, int(keys[chosen]) if keys.size else 0)

    def _start_from_beginning(self, k: int) -> None:
        """Read chapter ``k`` from the first packet of its file: reopened, no seek."""
        self._close_container()
        self._open_chapter(k)
        self._packets = self._container.demux(self._container.streams.video[0])
        self._ready.clear()
        self._position = -1
        self._read_from_start = True

    def _seek_unreliable(self) -> None:
        """A seek or the skipping of non-reference frames lost a frame the target needs: from now on this
        file is seeked one more key frame back and decoded without skipping (exact, a little slower)."""
        self._keys_back += 1
        self.skip_unneeded = False

    def _next_frames(self, target: int) -> bool:
        """Decode the next packet into ``_ready``; False at the end of the file. Packets shown before
        ``target`` that no other frame refers to (non-reference B-frames) are skipped undecoded: exact,
        since nothing at or after ``target`` depends on them, and a third to a half of a long-GOP seek's
        work in files with B-frames."""
        context = self._container.streams.video[0].codec_context
        packet = next(self._packets, None)
        if packet is None or packet.size == 0:
            context.skip_frame = "DEFAULT"
            self._ready.extend(context.decode(None))
            self._packets = iter(())
            return bool(self._ready)
        timestamp = packet.pts if packet.pts is not None else packet.dts
        context.skip_frame = "NONREF" if (self.skip_unneeded and timestamp is not None
                                          and timestamp < target) else "DEFAULT"
        self._ready.extend(context.decode(packet))
        return True

    def _decode_until(self, chapter: Chapter, target: int, index: int, key: int, continuing: bool, later: int = 0):
        """The decoded frame with timestamp ``target`` (the one after ``later`` others with that timestamp),
        or None when the decoder cannot have decoded it from all its references: the key frame it needs
        (timestamp ``key``) was not among the frames this run of the decoder returned (a seek that landed
        after it), or the target never came."""
        # a running decoder already passed its key frame; one that started at the file's first packet, or
        # at its first key frame, has every reference there is (a file cut or edited at its start may never
        # show its first frame)
        seen_key = continuing or self._read_from_start or key == int(chapter.pts[0])
        try:
            while True:
                if not self._ready and not self._next_frames(target):
                    break
                if not self._ready:
                    continue
                frame = self._ready.popleft()
                timestamp = frame.pts if frame.pts is not None else frame.dts
                if timestamp is not None and timestamp == key:
                    seen_key = True
                if timestamp is None or timestamp < target:
                    continue
                if timestamp == target and seen_key:
                    if later > 0:  # an earlier frame of a run of equal timestamps
                        later -= 1
                        continue
                    return frame
                break  # overshot, or the target came without its key frame
        except av.error.FFmpegError as error:
            raise InputFileError(str(chapter.path), f"frame {index} cannot be decoded: {error}") from None
        if self._read_from_start and not self.skip_unneeded:
            raise InputFileError(str(chapter.path), f"frame {index} (pts {target}) is in the file's index but the "
                                 "decoder never returns it, even reading from the start: the file is damaged")
        return None

    def scan_pictures(self, progress=None) -> StreamReport:
        """Decode every frame once (as a 64 × 48 grey thumbnail) and add the frames whose picture repeats
        the one before (mean difference below :data:`DUPLICATE_LEVEL` grey levels) to the report's
        duplicates: a camera or capture that repeats a frame re-encodes it, so its bytes differ. A frame
        the decoder finds damaged, or fewer frames decoded than indexed, is an :class:`InputFileError`
        naming the file. ``progress(done, total)`` is called every 100 frames; returns (and keeps) the new report."""
        same = []
        previous = None
        index = 0
        for chapter in self.chapters:
            with av.open(str(chapter.path)) as container:
                stream = container.streams.video[0]
                stream.thread_type = "AUTO"
                # a damaged packet is an error here, not a picture the decoder quietly patches up
                stream.codec_context.options = {"err_detect": "explode"}
                start = index
                try:
                    for frame in container.decode(stream):
                        thumb = frame.reformat(width=64, height=48, format="gray").to_ndarray().astype(np.int16)
                        if previous is not None and np.abs(thumb - previous).mean() < DUPLICATE_LEVEL:
                            same.append(index)
                        previous = thumb
                        index += 1
                        if progress is not None and index % 100 == 0:
                            progress(index, self.frame_count)
                except av.error.FFmpegError as error:
                    raise InputFileError(str(chapter.path), f"frame {index} cannot be decoded (a damaged file?): "
                                         f"{error}") from None
                if index - start != chapter.count:
                    raise InputFileError(str(chapter.path), f"{index - start} of its {chapter.count} frames could be "
                                         "decoded (a damaged file?)")
        self.report = _report(self.times_s, [d for c in self.chapters for d in c.digests], same, self.tick_s,
                              self.stated_fps)
        return self.report

    def audio(self) -> tuple[np.ndarray, float] | None:
        """The soundtrack of all chapters as one mono float array (mean of the channels) and its sample
        rate (Hz); None when the files carry no audio."""
        pieces: list[np.ndarray] = []
        rate = None
        for chapter in self.chapters:
            with av.open(str(chapter.path)) as container:
                if not container.streams.audio:
                    return None
                stream = container.streams.audio[0]
                rate = rate or stream.codec_context.sample_rate
                resampler = av.AudioResampler(format="flt", layout="mono", rate=rate)
                try:
                    for frame in container.decode(stream):
                        for out in resampler.resample(frame):
                            pieces.append(out.to_ndarray().reshape(-1))
                    for out in resampler.resample(None):
                        pieces.append(out.to_ndarray().reshape(-1))
                except av.error.FFmpegError as error:
                    raise InputFileError(str(chapter.path), f"the soundtrack cannot be decoded: {error}") from None
        if not pieces:
            return None
        return np.concatenate(pieces).astype(np.float64), float(rate)

    def _close_container(self) -> None:
        if self._container is not None:
            self._container.close()
        self._container = None
        self._packets = None
        self._ready.clear()
        self._chapter = -1
        self._position = -1

    def reset_decoder(self) -> None:
        """Forget the running decoder's position, so that the next frame is a true seek (the file stays open:
        reopening a container costs as much as decoding several frames); a proxy stays open."""
        self._packets = None
        self._ready.clear()
        self._position = -1

    def close(self) -> None:
        self._close_container()
        if self._proxy is not None:
            self._proxy.close()

    def __enter__(self) -> VideoStream:
        return self

    def __exit__(self, *exc) -> None:
        self.close()
