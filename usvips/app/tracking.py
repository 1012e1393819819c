"""Tracking picks through a project's stereo video, and measuring a tracked object on several instants.

:func:`track_in_video` gives :func:`usvips.core.tracking.track_vertex` its frame source — the video's left
frame i and its synchronised right partner, decoded together and ahead of the tracker
(:class:`usvips.io.grey_pairs.GreyPairSource`), in grey — and the cameras of the calibration active for the
video; a left frame without a right partner ends the track with that reason. The project is read on its own
thread (:meth:`VideoTracker.read`: the video, its calibration's cameras, its files); the tracking itself
(:meth:`VideoTracker.track`, :meth:`VideoTracker.track_many`) runs on any thread (it opens its own streams):
the window's worker calls it with its cancel and progress callables.

:func:`track_vertices_in_video` tracks several vertices picked on one frame, decoding each frame pair once
for all of them. :func:`propose_on_frame` proposes an object's vertices on another frame of its video by tracking them
there from the frame they were measured on (the window's track-based proposal when the previous instant is
measured). :func:`add_tracked_instants` turns the tracks of an object's vertices into further instants of that object:
at each frame asked for, a new object of the same kind with every vertex at its tracked pixels (measured
with the video's calibration, its frames and time kept), linked as an instant (:func:`usvips.app.
object_instants.add_instant`); all in one transaction, or nothing.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from usvips.app.object_instants import add_instant, tracked_note
from usvips.app.pair_geometry import pair_geometry
from usvips.app.video_project import left_frame_time, left_frame_times, partner_frame, proxy_folder
from usvips.core.errors import UsvipsError
from usvips.core.measurements import measure_picks
from usvips.core.pointing import vertex_pointing
from usvips.core.rig import StereoRig
from usvips.core.tracking import Track, TrackSettings, track_vertex
from usvips.io import video_proxy
from usvips.io.grey_pairs import GreyPairSource
from usvips.io.video_stream import VideoStream
from usvips.store.interface import ProjectStore
from usvips.store.project import StoredObject, Vertex
from usvips.store.records import Video


def _geometry(project: ProjectStore, label: str):
    geometry = pair_geometry(project, label)
    if geometry is None:
        raise UsvipsError(f"video {label!r} has no active calibration: tracking holds the right point to the "
                          "epipolar curve, which needs one (make a calibration active for the video)")
    return geometry


@dataclass(frozen=True)
class VideoTracker:
    """What tracking in video ``label`` needs, read from the project on the thread that owns it
    (:meth:`read`): the stored video, the cameras of its active calibration and its media files. Then
    :meth:`track` runs on any thread (a worker's): it opens its own streams, and reads nothing more from
    the project."""

    label: str
    video: Video
    rig: StereoRig
    left_paths: tuple[Path, ...]
    right_paths: tuple[Path, ...]
    proxies: Path

    @classmethod
    def read(cls, project: ProjectStore, label: str) -> VideoTracker:
        geometry = _geometry(project, label)
        video = project.video(label)
        return cls(label, video, geometry.calibration.rig(geometry.station, geometry.frame),
                   tuple(project.media_path(p) for p in video.paths("left")),
                   tuple(project.media_path(p) for p in video.paths("right")), proxy_folder(project))

    def track(self, start: int, left: Sequence[float], right: Sequence[float], first: int, last: int,
              settings: TrackSettings | None = None, cancel: Callable[[], bool] | None = None,
              progress: Callable[[int, int], None] | None = None) -> Track:
        """Track the vertex picked at ``left``/``right`` (px) on left frame ``start`` back to ``first`` and
        on to ``last`` (left frames, clipped to the video) — see :func:`track_vertex`."""
        return self.track_many(start, [(left, right)], first, last, settings, cancel, progress)[0]

    def track_many(self, start: int, picks: Sequence[tuple[Sequence[float], Sequence[float]]], first: int,
                   last: int, settings: TrackSettings | None = None, cancel: Callable[[], bool] | None = None,
                   progress: Callable[[int, int], None] | None = None) -> list[Track]:
        """:meth:`track` for several vertices picked on left frame ``start`` (``picks``: their (left, right)
        pixels), one after the other over the same frames, each frame pair decoded once for all of them
        where :data:`SHARED_FRAMES_BYTES` holds them; ``progress`` is told each vertex's frames."""
        left_stream = VideoStream(list(self.left_paths))
        try:
            right_stream = VideoStream(list(self.right_paths))
        except BaseException:
            left_stream.close()
            raise
        with left_stream, right_stream:
            for stream in (left_stream, right_stream):
                video_proxy.attach_proxy(stream, self.proxies)

            def partner(index: int) -> int:
                return partner_frame(self.video, index, right_stream.frame_count)

            shared = SHARED_FRAMES_BYTES if len(picks) > 1 else 0
            with GreyPairSource(left_stream, right_stream, partner, remember_bytes=shared) as frames:
                first = max(int(first), 0)
                last = min(int(last), self.video.frame_count - 1)
                tracks = [track_vertex(frames, self.rig, start, left, right, first, last, settings, cancel,
                                       progress) for left, right in picks]
            # each tracked frame's time, as the window gives a vertex picked on it (presentation time)
            return [replace(t, times_s=np.array([left_frame_time(left_stream, f) for f in t.frames], float))
                    for t in tracks]


#: the grey frame pairs kept while the vertices of one object are tracked over the same frames (bytes): a
#: pair decoded for the first vertex serves the others (64 pairs of 1080p)
SHARED_FRAMES_BYTES = 256 * 2**20


def track_in_video(project: ProjectStore, label: str, start: int, left: Sequence[float], right: Sequence[float],
                   first: int, last: int, settings: TrackSettings | None = None,
                   cancel: Callable[[], bool] | None = None,
                   progress: Callable[[int, int], None] | None = None) -> Track:
    """Track the vertex picked at ``left``/``right`` (px) on left frame ``start`` of video ``label`` back to
    ``first`` and on to ``last`` (left frames, clipped to the video) — see :func:`track_vertex`."""
    return VideoTracker.read(project, label).track(start, left, right, first, last, settings, cancel, progress)


def track_vertices_in_video(project: ProjectStore, label: str, start: int,
                            picks: Sequence[tuple[Sequence[float], Sequence[float]]], first: int, last: int,
                            settings: TrackSettings | None = None, cancel: Callable[[], bool] | None = None,
                            progress: Callable[[int, int], None] | None = None) -> list[Track]:
    """:func:`track_in_video` for several vertices picked on the same left frame ``start`` (``picks``: their
    (left, right) pixels), each frame pair decoded once for all of them (see :meth:`VideoTracker.track_many`)."""
    return VideoTracker.read(project, label).track_many(start, picks, first, last, settings, cancel, progress)


def add_tracked_instants(project: ProjectStore, object_id: int, tracks: Sequence[Track], frames: Sequence[int],
                         label: str) -> list[int]:
    """Make the stored object ``object_id`` (measured on video ``label``) an object over several instants:
    one further instant at each of ``frames`` from ``tracks`` (one per vertex, in the object's vertex
    order). A frame a track does not reach, or the object's own frame, is refused by name; returns the new
    instants' ids. Each instant's time is its left frame's presentation time
    (:func:`~usvips.app.video_project.left_frame_time`, as a vertex picked on that frame in the window
    gets), from the tracks or else the video's left stream — not ``frame / fps``."""
    stored = project.object(object_id)
    if len(tracks) != len(stored.vertices):
        raise UsvipsError(f"object {object_id} has {len(stored.vertices)} vertices but {len(tracks)} tracks were "
                          "given: track every vertex")
    own = stored.vertices[0].frame_left if stored.vertices and stored.vertices[0].video == label else None
    geometry = _geometry(project, label)
    video = project.video(label)
    frames = [int(f) for f in frames]
    unknown: dict[int, float] | None = None  # times the tracks do not hold, read from the left stream once
    # a tracked vertex carries the pick it was tracked from, with that pick's pointing sigma (the tracker's
    # own noise shows in the instants' spread, which combining them measures)
    start_sigma, _, _ = vertex_pointing([v.source for v in stored.vertices], [v.pointing_px for v in stored.vertices],
                                        [v.pointing_origin for v in stored.vertices])
    start_origins = [v.pointing_origin if v.pointing_px is not None else "default" for v in stored.vertices]
    rows = []
    for frame in frames:
        if frame == own:
            raise UsvipsError(f"object {object_id} is itself measured on frame {frame}: pick other frames")
        found = [t.at(frame) for t in tracks]
        missing = [i for i, f in enumerate(found) if f is None]
        if missing:
            # vertices counted from 1, as everywhere the user reads them; why the track stopped that way
            lost = tracks[missing[0]]
            direction = 1 if frame > lost.start else -1
            raise UsvipsError(f"frame {frame}: the track of vertex {missing[0] + 1} does not reach it (it stopped: "
                              f"{lost.reason(direction) or 'not tracked that way'})")
        left = np.array([f[0] for f in found])
        right = np.array([f[1] for f in found])
        try:
            m = measure_picks(stored.kind, geometry.calibration, left, right, geometry.station, geometry.frame,
                              pointing_sigma_px=start_sigma)
        except UsvipsError as error:
            raise UsvipsError(f"frame {frame}: {error}") from None
        partner = partner_frame(video, frame)
        time_s = tracks[0].time_at(frame)
        if time_s is None:  # tracks made without the video's times: its left stream says them
            if unknown is None:
                reached = [f for f in frames if all(t.at(f) is not None for t in tracks)]
                unknown = dict(zip(reached, left_frame_times(project, label, reached), strict=True))
            time_s = float(unknown[frame])
        blocks = [m.covariance[3 * i:3 * i + 3, 3 * i:3 * i + 3] for i in range(len(m.points))]
        vertices = [Vertex(*map(float, (*lp, *rp)), tuple(map(float, xyz)), block, geometry.calibration_id, label,
                           label, frame, partner, time_s, source="tracked", pointing_px=tuple(map(float, sigma)),
                           pointing_origin=origin)
                    for lp, rp, xyz, block, sigma, origin in zip(left, right, m.points, blocks, start_sigma,
                                                                 start_origins, strict=True)]
        rows.append((stored.kind, vertices, stored.attribute, tracked_note(tracks[0].start), ""))
    with project.transaction():
        ids = project.add_objects(rows)
        for instant_id in ids:
            add_instant(project, object_id, instant_id, tracked_from=tracks[0].start)
    return ids


@dataclass(frozen=True)
class VertexProposal:
    """A vertex of an object proposed on another frame: its ``left`` and ``right`` pixels, or None with
    ``reason`` (why its track stopped before the frame)."""

    left: tuple[float, float] | None
    right: tuple[float, float] | None
    reason: str = ""

    def __bool__(self) -> bool:
        """Falsy when the vertex has no proposal (its track stopped before the frame: ``reason``)."""
        return self.left is not None and self.right is not None


def propose_on_frame(project: ProjectStore, object_id: int, frame: int, settings: TrackSettings | None = None,
                     cancel: Callable[[], bool] | None = None,
                     progress: Callable[[int, int], None] | None = None) -> list[VertexProposal]:
    """Each vertex of the stored object ``object_id`` (measured on a video) proposed on left frame
    ``frame`` of that video, tracked from the frame it was measured on; a vertex whose track stops
    before the frame has no proposal and says why."""
    stored = project.object(object_id)
    if not stored.vertices or stored.vertices[0].video is None:
        raise UsvipsError(f"object {object_id} was not measured on a video: there is no frame to track it from")
    return propose_with(VideoTracker.read(project, stored.vertices[0].video), stored, frame, settings, cancel,
                        progress)


def propose_with(tracker: VideoTracker, stored: StoredObject, frame: int, settings: TrackSettings | None = None,
                 cancel: Callable[[], bool] | None = None,
                 progress: Callable[[int, int], None] | None = None) -> list[VertexProposal]:
    """:func:`propose_on_frame` with the video read already (any thread): ``stored`` is the object."""
    start = int(stored.vertices[0].frame_left)
    first, last = min(start, int(frame)), max(start, int(frame))
    proposals = []
    tracks = tracker.track_many(start, [((v.xl, v.yl), (v.xr, v.yr)) for v in stored.vertices], first, last,
                                settings, cancel, progress)
    for track in tracks:
        found = track.at(frame)
        if found is None:
            direction = 1 if frame > start else -1
            proposals.append(VertexProposal(None, None, f"its track stopped at frame "
                                                        f"{track.frames[-1] if direction > 0 else track.frames[0]}: "
                                                        f"{track.reason(direction)}"))
        else:
            proposals.append(VertexProposal(tuple(map(float, found[0])), tuple(map(float, found[1]))))
    return proposals
