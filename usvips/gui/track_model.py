"""The tracks of an object's vertices through its video, as the window holds them (free of Qt).

One :class:`TrackModel` holds, for the object being tracked (its id, its video, the left frame it was
measured on), one :class:`usvips.core.tracking.Track` per vertex (in the object's vertex order) and the
frames where the user corrected each track. A correction is a track followed from the corrected frame
(:func:`merge_correction`): the old track stands between the object's frame and the correction, the new
one from the correction onwards (away from the object's frame), so a track that stopped (occluded, lost)
can be picked up again after the gap.

What the window draws comes from here: :meth:`TrackModel.points_at` (each vertex's left and right
pixels on a frame), :meth:`TrackModel.trail` (the last few tracked positions up to a frame),
:meth:`TrackModel.span` and :meth:`TrackModel.stops` (the timeline's marks). :meth:`TrackModel.
instant_frames` chooses the frames to store as instants. Pixels: x right, y down, origin at the centre of
the top-left pixel; frames: left-video indices.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from types import ModuleType
from typing import TYPE_CHECKING

import numpy as np

from usvips.core.errors import UsvipsError

if TYPE_CHECKING:
    from usvips.core.tracking import Track


def tracking_core() -> ModuleType:
    """:mod:`usvips.core.tracking`, imported when a track is first handled, not with the window (which
    makes its model empty at start). Imported where it is called, so that any thread may be the first to
    ask: the import lock guards it."""
    from usvips.core import tracking

    return tracking


def merge_correction(old: Track, new: Track) -> Track:
    """``old`` (picked on frame ``old.start``) corrected by ``new``, followed from the corrected frame
    ``new.start``: ``old``'s frames on the object's side of the correction, ``new``'s from it onwards
    (away from ``old.start``; both ways when the correction is on ``old.start`` itself). The merged
    track keeps ``old.start`` and says why each direction stopped (the new track's reason away from the
    start). Frames between where ``old`` stopped and the correction are not reached (a gap)."""
    s, f = int(old.start), int(new.start)
    if f == s:
        return new
    away = 1 if f > s else -1
    keep_old = old.frames < f if away > 0 else old.frames > f
    keep_new = new.frames >= f if away > 0 else new.frames <= f
    frames = np.concatenate([old.frames[keep_old], new.frames[keep_new]])
    order = np.argsort(frames, kind="stable")

    def joined(a: np.ndarray, b: np.ndarray) -> np.ndarray:
        return np.concatenate([a[keep_old], b[keep_new]])[order]

    stopped = tuple((d, last, why) for d, last, why in old.stopped if d != away)
    stopped += tuple((d, last, why) for d, last, why in new.stopped if d == away)
    return tracking_core().Track(frames[order], joined(old.left, new.left), joined(old.right, new.right),
                 joined(old.scores, new.scores), joined(old.ray_rms_m, new.ray_rms_m), s, stopped)


@dataclass(frozen=True)
class Stop:
    """Where a vertex's track stopped going ``direction`` (+1 forward, −1 backward): the last frame it
    reached and why (``reason``, the tracker's words)."""

    vertex: int
    direction: int
    frame: int
    reason: str


@dataclass
class TrackModel:
    """The tracks of one stored object's vertices on video ``label`` (see the module docstring).

    ``object_id``: the object (None: nothing tracked); ``start``: the left frame it was measured on;
    ``vertex_count``: its vertices; ``tracks``: vertex index → its track; ``corrected``: vertex index →
    the frames the user corrected it on."""

    object_id: int | None = None
    label: str | None = None
    start: int = 0
    vertex_count: int = 0
    tracks: dict[int, Track] = field(default_factory=dict)
    corrected: dict[int, set[int]] = field(default_factory=dict)

    # ------------------------------------------------------------------ changing
    def begin(self, object_id: int, label: str, start: int, vertex_count: int) -> None:
        """Forget every track: the vertices of object ``object_id`` (measured on left frame ``start`` of
        video ``label``) are about to be tracked."""
        if vertex_count < 1:
            raise UsvipsError(f"object {object_id} has no vertices to track")
        self.object_id, self.label, self.start, self.vertex_count = int(object_id), label, int(start), vertex_count
        self.tracks, self.corrected = {}, {}

    def clear(self) -> None:
        """Nothing tracked (another project, the object deleted)."""
        self.object_id, self.label, self.start, self.vertex_count = None, None, 0, 0
        self.tracks, self.corrected = {}, {}

    def set_track(self, vertex: int, track: Track) -> None:
        """Vertex ``vertex``'s track, picked on the object's frame."""
        self._check_vertex(vertex)
        if int(track.start) != self.start:
            raise UsvipsError(f"the track of vertex {vertex + 1} starts on frame {track.start}, not on the object's "
                              f"frame {self.start}")
        self.tracks[vertex] = track
        self.corrected.pop(vertex, None)

    def correct(self, vertex: int, track: Track) -> None:
        """Vertex ``vertex`` re-picked by the user on frame ``track.start`` and followed from there: the
        part of its track beyond that frame (away from the object's frame) is replaced."""
        self._check_vertex(vertex)
        old = self.tracks.get(vertex)
        if old is None:
            raise UsvipsError(f"vertex {vertex + 1} has no track to correct: track the object first (T)")
        f = int(track.start)
        self.tracks[vertex] = merge_correction(old, track)
        kept = {c for c in self.corrected.get(vertex, set())
                if (c < f if f > self.start else c > f) and f != self.start}
        self.corrected[vertex] = kept | {f}

    def _check_vertex(self, vertex: int) -> None:
        if self.object_id is None:
            raise UsvipsError("no object is being tracked: select an object measured on this video and press T")
        if not 0 <= vertex < self.vertex_count:
            raise UsvipsError(f"object {self.object_id} has vertices 1 to {self.vertex_count}, not {vertex + 1}")

    # ------------------------------------------------------------------ reading
    @property
    def complete(self) -> bool:
        """Whether every vertex has a track."""
        return self.object_id is not None and len(self.tracks) == self.vertex_count

    def ordered_tracks(self) -> list[Track]:
        """The tracks in vertex order (every vertex must have one)."""
        if not self.complete:
            missing = [v + 1 for v in range(self.vertex_count) if v not in self.tracks]
            raise UsvipsError(f"object {self.object_id}: vertices {missing} have no track yet" if self.object_id
                              is not None else "nothing is tracked: select an object and press T")
        return [self.tracks[v] for v in range(self.vertex_count)]

    def points_at(self, frame: int) -> dict[int, tuple[np.ndarray, np.ndarray]]:
        """Vertex index → its (left, right) pixels on ``frame``, for the vertices whose track reaches it."""
        found = {}
        for vertex, track in self.tracks.items():
            at = track.at(frame)
            if at is not None:
                found[vertex] = at
        return found

    def trail(self, vertex: int, frame: int, length: int = 10) -> tuple[np.ndarray, np.ndarray]:
        """The left and right pixels (M, 2) of vertex ``vertex`` on the tracked frames from ``frame`` −
        ``length`` to ``frame`` (the way it came; the frames run away from the object's frame when
        ``frame`` is before it). Empty when the track does not reach those frames."""
        track = self.tracks.get(vertex)
        if track is None:
            return np.zeros((0, 2)), np.zeros((0, 2))
        before = frame < self.start
        low, high = (frame, frame + length) if before else (frame - length, frame)
        keep = (track.frames >= low) & (track.frames <= high)
        return track.left[keep], track.right[keep]

    def span(self) -> tuple[int, int] | None:
        """The first and last frame every vertex's track reaches (None: no complete tracks)."""
        if not self.tracks:
            return None
        firsts = [int(t.frames[0]) for t in self.tracks.values()]
        lasts = [int(t.frames[-1]) for t in self.tracks.values()]
        return max(firsts), min(lasts)

    def tracked_frames(self) -> np.ndarray:
        """The frames every vertex's track reaches (sorted; gaps left out)."""
        if not self.tracks:
            return np.zeros(0, int)
        common = None
        for track in self.tracks.values():
            common = track.frames if common is None else np.intersect1d(common, track.frames)
        return np.asarray(common, int)

    def stops(self) -> list[Stop]:
        """Where the tracks stopped early (not at the end of the frames asked for): each with its reason."""
        found = []
        for vertex, track in sorted(self.tracks.items()):
            for direction, frame, why in track.stopped:
                if why not in (tracking_core().END, ""):
                    found.append(Stop(vertex, direction, int(frame), why))
        return found

    def describe(self) -> str:
        """One line: what is tracked, over which frames, and where and why the tracks stopped."""
        if self.object_id is None:
            return "nothing tracked"
        span = self.span()
        text = (f"object {self.object_id}: {len(self.tracks)} of {self.vertex_count} vertices tracked"
                + (f", frames {span[0]}–{span[1]}" if span is not None and span[0] <= span[1] else ""))
        grouped: dict[tuple[int, int, str], list[int]] = {}  # the same stop of several vertices said once
        cancelled = tracking_core().CANCELLED
        for s in self.stops():
            if s.reason != cancelled:
                grouped.setdefault((s.direction, s.frame, s.reason), []).append(s.vertex + 1)
        if grouped:
            text += "; stopped: " + "; ".join(
                f"{'vertex' if len(v) == 1 else 'vertices'} {', '.join(map(str, v))} "
                f"{'after' if d > 0 else 'before'} frame {f} ({why})" for (d, f, why), v in grouped.items())
        if any(s.reason == cancelled for s in self.stops()):
            text += "; cancelled"
        return text

    def instant_frames(self, every: int, first: int | None = None, last: int | None = None) -> list[int]:
        """Frames to store as instants: every ``every``-th frame counted from the object's own frame,
        within ``first``–``last`` (default: all tracked), that every vertex's track reaches; the object's
        own frame is left out (it is the first instant already)."""
        if int(every) < 1:
            raise UsvipsError(f"instants every {every} frames: give a whole number of frames of at least 1")
        frames = self.tracked_frames()
        if first is not None:
            frames = frames[frames >= int(first)]
        if last is not None:
            frames = frames[frames <= int(last)]
        chosen = frames[((frames - self.start) % int(every) == 0) & (frames != self.start)]
        return [int(f) for f in chosen]

    def nearest_vertex(self, frame: int, left: tuple[float, float]) -> int:
        """The vertex whose tracked left pixel on ``frame`` lies nearest to ``left`` — the one the user
        re-picked. Where a track does not reach ``frame``, its position there is extrapolated from the two
        tracked frames nearest to it (the point's pixel velocity), so that a vertex lost a few frames
        before is still found."""
        if not self.tracks:
            raise UsvipsError("nothing is tracked: select an object measured on this video and press T")
        best, distance = -1, np.inf
        for vertex, track in self.tracks.items():
            gaps = np.abs(track.frames - int(frame))
            k = int(np.argmin(gaps))
            where = track.left[k]
            if gaps[k] and len(track.frames) > 1:
                j = k - 1 if k == len(track.frames) - 1 or (k > 0 and track.frames[k] > frame) else k + 1
                velocity = (track.left[k] - track.left[j]) / float(track.frames[k] - track.frames[j])
                where = where + velocity * (int(frame) - int(track.frames[k]))
            d = float(np.linalg.norm(where - np.asarray(left, float)))
            if d < distance:
                best, distance = vertex, d
        return best


def parse_instant_frames(text: str, model: TrackModel) -> list[int]:
    """The frames a user typed for instants: one whole number N — every N-th frame the tracks reach
    (:meth:`TrackModel.instant_frames`) — or a list of frames separated by commas or spaces (kept as
    typed, sorted; a frame the tracks do not reach is refused by name when storing)."""
    parts = [p for p in text.replace(",", " ").split() if p]
    if not parts:
        raise UsvipsError("no frames given: type N (an instant every N frames) or the frames, e.g. 12, 40, 75")
    try:
        numbers = [int(p) for p in parts]
    except ValueError:
        bad = next(p for p in parts if not p.lstrip("-").isdigit())
        raise UsvipsError(f"frames {text.strip()!r}: {bad!r} is not a whole number (type N, or frames such as "
                          "12, 40, 75)") from None
    if len(numbers) == 1:
        return model.instant_frames(numbers[0])
    return sorted(set(numbers))
