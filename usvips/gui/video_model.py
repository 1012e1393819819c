"""The workstation's stereo-video model, Qt-free: which frame pair is shown, stepping and going to a
frame or time code, the frames holding measurements, a bounded frame cache and what to prefetch, and a
thread-safe source of synchronised frame pairs; and one opened video's session (:class:`VideoSession`):
its source and position and the synchronisation decisions (offsets, periods, taken pairs).

Frames are the left stream's numbers; the right partner of left frame ``i`` is ``i + offset``. Only left
frames whose partner exists are shown (``first`` … ``last``).
"""

from __future__ import annotations

import re
import threading
from collections import OrderedDict
from collections.abc import Iterable
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING

import numpy as np

from usvips.core.errors import InvalidParameterError, UsvipsError
from usvips.core.synchronisation import SyncEstimate
from usvips.gui.signals import Signal
from usvips.gui.video_modules import video_project as _video_project
from usvips.gui.video_modules import video_proxy as _video_proxy
from usvips.gui.video_modules import video_stream as _video_stream
from usvips.store.interface import ProjectStore

if TYPE_CHECKING:
    from usvips.io.video_stream import Picture


#: bytes a pixel of a cached frame takes: frames are cached as the decoder returned them (YUV 4:2:0 for
#: H.264/HEVC cameras) and converted to RGB only when shown (about 1 ms a 1080p frame)
CACHED_BYTES_PER_PIXEL = 1.5
#: default frame-cache budget (bytes): 48 frame pairs at 1920 × 1080 YUV 4:2:0 (285 MiB), 12 pairs at 4K
CACHE_BYTES = int(48 * 2 * 1920 * 1080 * CACHED_BYTES_PER_PIXEL)


def format_timecode(seconds: float) -> str:
    """``h:mm:ss.sss`` (hours only when there are any)."""
    seconds = max(float(seconds), 0.0)
    hours, rest = divmod(seconds, 3600)
    minutes, secs = divmod(rest, 60)
    return (f"{int(hours)}:" if hours >= 1 else "") + f"{int(minutes):02d}:{secs:06.3f}"


_TIME = re.compile(r"^(?:(\d+):)?(\d+):(\d+(?:\.\d*)?)$")


def parse_position(text: str, fps: float, times_s: np.ndarray | None = None) -> int:
    """A frame from what a person typed: a frame number (``1234``), seconds (``12.5s``) or a time code
    (``mm:ss.sss``, ``h:mm:ss.sss``). Times go to the frame shown at that time (by presentation time when
    ``times_s`` are given, else ``round(t · fps)``)."""
    text = text.strip()
    if re.fullmatch(r"\d+", text):
        return int(text)
    seconds = None
    if re.fullmatch(r"\d+(\.\d*)?\s*s", text):
        seconds = float(text.rstrip("s "))
    else:
        match = _TIME.match(text)
        if match:
            hours, minutes, secs = match.groups()
            seconds = int(hours or 0) * 3600 + int(minutes) * 60 + float(secs)
    if seconds is None:
        raise InvalidParameterError("go to", f"{text!r}: type a frame number, seconds (12.5s) or a time (mm:ss.sss)")
    if times_s is not None:
        return int(max(0, np.searchsorted(times_s, seconds + 1e-9, side="right") - 1))
    return int(round(seconds * fps))


@dataclass
class VideoNavigator:
    """Where the viewer is in a stereo video. ``frame_count``/``right_count`` frames per stream,
    ``offset`` (right = left + offset), ``fps``; ``jump`` is the Shift+arrow step (frames)."""

    label: str
    frame_count: int
    right_count: int
    offset: int
    fps: float
    frame: int = 0
    jump: int = 10
    rate: float = 1.0
    marks: set[int] = field(default_factory=set)

    def __post_init__(self) -> None:
        self.frame = self.clamp(self.frame)
        #: ``frame_changed(frame)`` when :meth:`go` (and the steps) move to another left frame.
        self.frame_changed = Signal()

    @property
    def first(self) -> int:
        return max(0, -self.offset)

    @property
    def last(self) -> int:
        return min(self.frame_count, self.right_count - self.offset) - 1

    @property
    def partner(self) -> int:
        return self.frame + self.offset

    def clamp(self, frame: int) -> int:
        return int(min(max(int(frame), self.first), self.last))

    def go(self, frame: int) -> int:
        """Go to ``frame`` (clamped to the frames that have a partner); returns it."""
        before, self.frame = self.frame, self.clamp(frame)
        if self.frame != before:
            self.frame_changed.emit(self.frame)
        return self.frame

    def step(self, frames: int) -> int:
        return self.go(self.frame + frames)

    def home(self) -> int:
        return self.go(self.first)

    def end(self) -> int:
        return self.go(self.last)

    def play_interval_ms(self) -> int:
        """Timer interval (ms) for playing at ``rate`` × real time."""
        return max(int(round(1000.0 / (self.fps * self.rate))), 1)

    def next_mark(self, direction: int) -> int | None:
        """The nearest marked frame after (direction > 0) or before the current one."""
        candidates = [m for m in self.marks if (m - self.frame) * direction > 0]
        return (min if direction > 0 else max)(candidates) if candidates else None


def prefetch_order(frame: int, first: int, last: int, direction: int = 1, ahead: int = 8, behind: int = 2) -> list[int]:
    """Frames to decode after ``frame`` is shown: ``ahead`` in the direction of travel, then ``behind``.
    Each group is in increasing frame order, since a decoder only runs forward: the frames before
    ``frame`` cost one seek (to the key frame before the earliest) and then one decode each, where
    decoding them nearest-first would seek again for every frame."""
    direction = 1 if direction >= 0 else -1
    ahead_frames = sorted(frame + direction * k for k in range(1, ahead + 1))
    behind_frames = sorted(frame - direction * k for k in range(1, behind + 1))
    return [f for f in ahead_frames + behind_frames if first <= f <= last]


def _item_bytes(item: tuple) -> int:
    """Bytes of the pictures or arrays in a cached item (numbers, labels: none)."""
    return sum(int(a.nbytes) for a in item if isinstance(a, (np.ndarray, _video_stream().Picture)))


class FrameCache:
    """Decoded frame pairs by left frame number, least recently used dropped beyond ``budget`` bytes.
    Thread-safe (the decoder fills it, the GUI reads it)."""

    def __init__(self, budget: int = CACHE_BYTES) -> None:
        if budget <= 0:
            raise InvalidParameterError("budget", f"must be positive bytes, got {budget}")
        self.budget = int(budget)
        self.used = 0
        self._items: OrderedDict[int, tuple] = OrderedDict()
        self._lock = threading.Lock()

    def __contains__(self, frame: int) -> bool:
        with self._lock:
            return frame in self._items

    def __len__(self) -> int:
        return len(self._items)

    def get(self, frame: int) -> tuple | None:
        with self._lock:
            item = self._items.get(frame)
            if item is not None:
                self._items.move_to_end(frame)
            return item

    def put(self, frame: int, item: tuple) -> None:
        size = _item_bytes(item)
        with self._lock:
            if frame in self._items:
                return
            self._items[frame] = item
            self.used += size
            while self.used > self.budget and len(self._items) > 1:
                _, old = self._items.popitem(last=False)
                self.used -= _item_bytes(old)

    def clear(self) -> None:
        with self._lock:
            self._items.clear()
            self.used = 0


class FrameSource:
    """The two streams of a stored video, decoded one request at a time (a lock: PyAV decoders are not
    shared between threads). ``pictures(frame)`` → (left picture, right picture, right frame, time s),
    the compact form the cache holds; ``pair(frame)`` → the same with RGB arrays."""

    def __init__(self, project: ProjectStore, label: str) -> None:
        self.video, self.left, self.right = _video_project().open_streams(project, label)
        self._reader = _video_stream().PairReader(self.left, self.right)
        self._lock = threading.Lock()

    @property
    def times_s(self) -> np.ndarray:
        return self.left.times_s

    def navigator(self) -> VideoNavigator:
        return VideoNavigator(self.video.label, self.left.frame_count, self.right.frame_count,
                              int(self.video.offset_frames), self.left.fps)

    def pictures(self, frame: int, offset: int | None = None) -> tuple[Picture, Picture, int, float]:
        video = self.video if offset is None else replace(self.video, offset_frames=int(offset))
        with self._lock:
            partner = _video_project().partner_frame(video, frame, self.right.frame_count)
            left, right = self._reader.pictures(frame, partner)  # both cameras at once
            return left, right, partner, _video_project().left_frame_time(self.left, frame)

    def pair(self, frame: int, offset: int | None = None) -> tuple[np.ndarray, np.ndarray, int, float]:
        return rgb_pair(self.pictures(frame, offset))

    @property
    def has_proxies(self) -> bool:
        """Whether both cameras seek through seek proxies."""
        return self.left.has_proxy and self.right.has_proxy

    def proxy_plan(self, folder) -> list[tuple[tuple, object]]:
        """(a camera's files, its proxy path) for each camera without a fresh proxy in ``folder`` (reads
        the proxies' stamps only: the recordings are indexed already)."""
        plan = []
        for stream in (self.left, self.right):
            state = _video_proxy().proxy_state(folder, stream)
            if state.state != "fresh":
                plan.append((stream.paths, state.path))
        return plan

    def attach_proxies(self, folder) -> bool:
        """Seek through the fresh proxies in ``folder`` from the next request on (waits for a decode
        running); returns whether both cameras now have one."""
        with self._lock:
            for stream in (self.left, self.right):
                if not stream.has_proxy:
                    _video_proxy().attach_proxy(stream, folder)
            return self.has_proxies

    def detach_proxies(self) -> None:
        """Seek in the originals again (before the proxies are deleted)."""
        with self._lock:
            for stream in (self.left, self.right):
                stream.detach_proxy()

    def close(self) -> None:
        with self._lock:
            self._reader.close()
            for stream in (self.left, self.right):
                stream.close()


def rgb_pair(item: tuple) -> tuple[np.ndarray, np.ndarray, int, float]:
    """A cached (left picture, right picture, right frame, time) as RGB arrays, for showing."""
    left, right, partner, time_s = item
    return left.array(), right.array(), partner, time_s


def measured_frames(project: ProjectStore, label: str, objects: Iterable | None = None) -> set[int]:
    """Left frames of the video that hold vertices of stored objects (``objects``: the stored objects as the
    window holds them already; None: read from ``project``)."""
    return {v.frame_left for o in (project.objects() if objects is None else objects) for v in o.vertices
            if v.video == label and v.frame_left is not None}


def video_frame_text(stored) -> str:
    """``video: left | right frame  mm:ss.sss`` of an object measured on a video (its first vertex), else ''."""
    vertex = stored.vertices[0] if stored.vertices else None
    if vertex is None or vertex.video is None:
        return ""
    return f"{vertex.video}: {vertex.frame_left} | {vertex.frame_right}  {format_timecode(vertex.time_s)}"


def video_frame_of(stored) -> tuple[str, int] | None:
    """(video, left frame) an object was measured on, or None."""
    vertex = stored.vertices[0] if stored.vertices else None
    return None if vertex is None or vertex.video is None else (vertex.video, int(vertex.frame_left))


def cache_bytes(width: int, height: int, pairs: int, bytes_per_pixel: float = CACHED_BYTES_PER_PIXEL) -> int:
    """Bytes of ``pairs`` cached frame pairs at ``width`` × ``height`` px (YUV 4:2:0 by default; 3 for RGB)."""
    return int(pairs * 2 * int(width) * int(height) * bytes_per_pixel)


__all__ = ["CACHED_BYTES_PER_PIXEL", "CACHE_BYTES", "FrameCache", "FrameSource", "VideoNavigator", "cache_bytes",
           "format_timecode", "measured_frames", "parse_position", "prefetch_order", "rgb_pair", "video_frame_of",
           "video_frame_text"]


#: bytes a pixel of a seek proxy takes on disk (lossless all-intra: 1.3–2.5 MB a 1080p frame, measured on
#: camera footage; usvips.io.video_proxy), low and high
PROXY_BYTES_PER_PIXEL = (1.3e6 / (1920 * 1080), 2.5e6 / (1920 * 1080))


def proxy_disk_bytes(frames: int, width: int, height: int, cameras: int = 2) -> tuple[int, int]:
    """(low, high) bytes the seek proxies of a stereo video of ``frames`` frames of ``width`` × ``height``
    px take on disk (both cameras)."""
    pixels = int(frames) * int(width) * int(height) * int(cameras)
    return int(pixels * PROXY_BYTES_PER_PIXEL[0]), int(pixels * PROXY_BYTES_PER_PIXEL[1])


def format_bytes(count: int) -> str:
    """``812 MiB``, ``2.4 GiB``, ``93 KiB``."""
    for unit, size in (("TiB", 2**40), ("GiB", 2**30), ("MiB", 2**20), ("KiB", 2**10)):
        if count >= size:
            value = count / size
            return f"{value:.1f} {unit}" if value < 10 else f"{value:.0f} {unit}"
    return f"{count} bytes"


def sync_decision(estimate: SyncEstimate) -> tuple[str, str | None]:
    """What the window does with a fresh offset estimate: ``("store", None)`` when it is sure enough,
    ``("ask", why)`` when its confidence is low (the user may store it anyway) and ``("refuse", why)`` when
    it lies at the edge of its search window (:meth:`SyncEstimate.edge_problem`): that is no estimate, and
    the user is not offered to store it (as ``usvips video sync`` never does)."""
    edge = estimate.edge_problem()
    if edge is not None:
        return "refuse", edge
    doubt = _video_project().doubt_about(estimate)
    return ("store", None) if doubt is None else ("ask", doubt)


@dataclass(frozen=True)
class SyncOutcome:
    """What to do with a fresh offset estimate of video ``label`` (:func:`sync_decision` in words):
    ``action`` ``store``, ``ask`` or ``refuse``; the status line (``level``, ``text``) to show before any
    question; and the ``question`` to ask the user on ``ask`` (Yes stores the offset anyway)."""

    action: str
    level: str
    text: str
    question: str | None = None


class VideoSession:
    """One stored video opened in the window, free of Qt: its frame ``source``, where the viewer is
    (``navigator``, with the frames that hold measurements marked), and the synchronisation decisions —
    storing an offset (typed or estimated), marking a period, taking the frames shown as an image pair.
    The controller (``usvips.gui.qt.video_controls``) asks the user, runs the workers and draws; everything
    decided and stored is here. Refusals are :class:`UsvipsError` with one line naming what is wrong.

    Event: ``offset_changed(offset)`` after a new offset is stored (the navigator is a new one, at the
    same left frame, its marks kept)."""

    def __init__(self, project: ProjectStore, label: str) -> None:
        self.project = project
        self.source = FrameSource(project, label)
        self.navigator = self.source.navigator()
        self.navigator.marks = measured_frames(project, label)
        self.offset_changed = Signal()

    @property
    def label(self) -> str:
        return self.navigator.label

    def refresh_marks(self, objects: Iterable | None = None) -> set[int]:
        """The measured frames again (objects changed): of ``objects`` (the window's cache of the stored ones),
        else read from the project; returns them."""
        self.navigator.marks = measured_frames(self.project, self.label, objects)
        return self.navigator.marks

    def close(self) -> None:
        self.source.close()

    # ------------------------------------------------------------------ synchronisation
    def store_offset(self, value: int, how: dict) -> VideoNavigator:
        """Store ``value`` (frames, right = left + offset) as the video's offset with ``how`` it was found
        (``{"method": "by hand"}`` or an estimate's dict); returns the new navigator (same left frame,
        clamped; marks kept). Raises by name when the project refuses it; nothing changes then."""
        old = self.navigator
        self.project.set_video_offset(old.label, int(value), how)
        self.source.video = replace(self.source.video, offset_frames=int(value))
        self.navigator = self.source.navigator()
        self.navigator.marks = old.marks
        self.navigator.frame = self.navigator.clamp(old.frame)
        self.navigator.rate, self.navigator.jump = old.rate, old.jump
        self.offset_changed.emit(int(value))
        return self.navigator

    def sync_plan(self):
        """What the offset estimate needs, read from the project now (the estimate then runs in a worker
        on files only: :func:`usvips.app.video_project.run_sync`)."""
        return _video_project().plan_sync(self.project, self.label)

    def sync_outcome(self, estimate: SyncEstimate) -> SyncOutcome:
        """The decision on a fresh estimate, in words (see :func:`sync_decision`)."""
        label, summary = self.label, estimate.summary()
        action, doubt = sync_decision(estimate)
        if action == "store":
            return SyncOutcome("store", "info", f"video {label}: {summary}; stored")
        if action == "refuse":  # at the edge of its window: no estimate, never offered for storing
            return SyncOutcome("refuse", "warning", f"video {label}: {summary}; not stored: {doubt}")
        return SyncOutcome("ask", "warning", f"video {label}: {summary}; not stored ({doubt})",
                           f"Video {label}: {summary}.\n\nThe {doubt}. Store {estimate.frames:+d} frames as the "
                           "offset anyway?")

    def store_estimate(self, estimate: SyncEstimate) -> VideoNavigator:
        """Store an estimate's whole-frame offset (with the estimate itself, as ``usvips video sync``)."""
        return self.store_offset(estimate.frames, estimate.as_dict())

    # ------------------------------------------------------------------ periods and taken pairs
    def mark_period(self, text: str) -> tuple[str, int, int]:
        """Store a period typed as ``NAME FIRST LAST`` (left frames; the name may hold spaces); returns
        (name, first, last). Refused by name when the text or the interval is wrong."""
        parts = text.split()
        try:
            name, start, end = " ".join(parts[:-2]), int(parts[-2]), int(parts[-1])
        except (ValueError, IndexError):
            raise UsvipsError(f"period {text!r}: type a name, then the first and last frame") from None
        self.project.add_period(self.label, name, start, end)
        return name, start, end

    def plan_taken_pair(self, pair_label: str | None = None) -> tuple[str, int, int, object]:
        """(label, left frame, offset, folder) of the image pair the frames shown would become; refuses a
        label already used before anything is written."""
        nav = self.navigator
        label, folder = _video_project().plan_taken_pair(self.project, nav.label, nav.frame, pair_label)
        return label, nav.frame, nav.offset, folder

    def add_taken_pair(self, pair_label: str, paths, medium: str) -> None:
        """Add written frames as the image pair ``pair_label`` taken in ``medium``; on a refusal the files
        are removed (nothing half-made stays behind) and the error raised."""
        try:
            _video_project().add_taken_pair(self.project, pair_label, paths, medium)
        except UsvipsError:
            for path in paths:
                path.unlink(missing_ok=True)
            raise
