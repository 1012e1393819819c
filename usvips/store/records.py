"""What a project stores, as the rest of the program sees it, whatever the backend: the record types
(:class:`Vertex`, :class:`StoredObject`, :class:`Pair` …) and the error family (:class:`ProjectError`).

They live apart from every implementation so that the interface (``usvips.store.interface``), the
services and a new backend import them without importing the SQLite module.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from usvips.core.errors import UsvipsError
from usvips.core.pointing import WeakMatch


class ProjectError(UsvipsError):
    """A project that cannot be opened, read or written; the one-line message names the project (a file,
    or a server's address without its password) and what is wrong."""


class StaleEditError(ProjectError):
    """An edit refused because someone else changed the same object since it was read (optimistic
    versions of a shared survey): reload the object and edit again."""


class ServerUnreachableError(ProjectError):
    """The server a survey is on did not answer (stopped, restarted, the network gone): what was being
    written was not stored. The store connects again (with back-off) on the next use; a window keeps the
    unsaved edit for retry or discard and reads its state afresh once connected."""


@dataclass(frozen=True)
class Vertex:
    """One vertex of a measured object: its picks (pixels) and, once intersected, X, Y, Z (m) and the
    3 × 3 covariance (m²) with the calibration used.

    Its pointing (schema 11, :mod:`usvips.core.pointing`): ``source``, the label of where its pixels come
    from ("hand click", "auto-match", "hand click (snout, by ana)", …; a vertex stored before schema 11
    reads "hand click (unknown)"); ``pointing_px``, its pointing sigmas (left, right) in pixels per image
    coordinate, None for the source's documented default; ``pointing_origin``, where a stated sigma comes
    from (``given``, ``estimated``; ``default`` with None); ``weak``, the auto-match's ambiguity when a
    weak proposal was accepted (a fact of the vertex, not of the object's notes)."""

    xl: float
    yl: float
    xr: float
    yr: float
    xyz: tuple[float, float, float] | None = None
    covariance: np.ndarray | None = None
    calibration_id: int | None = None
    pair: str | None = None
    # on a stereo video: its label, the left and right frame numbers and the time (s) of the left frame
    video: str | None = None
    frame_left: int | None = None
    frame_right: int | None = None
    time_s: float | None = None
    source: str = "hand click"
    pointing_px: tuple[float, float] | None = None
    pointing_origin: str = "default"
    weak: WeakMatch | None = None


@dataclass(frozen=True)
class Pair:
    """A stored image pair — or a stereo video, which is measured like a pair (no image files): its id and
    label, the stored paths of its left and right images (relative to the store's media folder where
    possible; None for a video; locate them with ``ProjectStore.media_location``), their size in pixels
    (None when not recorded), the video frame it was taken from (None when not from a video) and the medium
    the cameras looked through ("air" or "water")."""

    id: int
    label: str
    left: str | None
    right: str | None
    width: int | None
    height: int | None
    frame: int | None
    medium: str


@dataclass(frozen=True)
class VideoFile:
    """One chapter file of one camera of a stored video: its stored path (relative to the store's media
    folder where possible; locate it with ``ProjectStore.media_path``), its number of frames and its frame
    rate in frames per second as read when the video was added."""

    path: str
    frame_count: int
    fps: float


@dataclass(frozen=True)
class Video:
    """A stored stereo video (schema 4): its id and label (also the label of the pair it is measured as),
    the pair's frame rate ``fps`` (frames per second) and ``frame_count`` (both the left stream's), the
    frame size ``width`` × ``height`` in pixels, the synchronisation — left frame i and right frame
    i + ``offset_frames`` show the same instant (0 until set), ``offset_estimate`` how it was found (the
    JSON-shaped estimate: method, confidence …; None when never estimated) — the ``report`` of what was
    found when the streams were read (frame-rate problems; '' when nothing) and each camera's chapter files
    in order (``left``, ``right``)."""

    id: int
    label: str
    fps: float
    frame_count: int
    width: int
    height: int
    offset_frames: int
    offset_estimate: dict | None
    report: str
    left: tuple[VideoFile, ...]
    right: tuple[VideoFile, ...]

    def files(self, camera: str) -> tuple[VideoFile, ...]:
        """The chapter files of ``camera`` ("left" or "right") in order."""
        if camera not in ("left", "right"):
            raise ValueError(f"a video's camera is 'left' or 'right', got {camera!r}")
        return self.left if camera == "left" else self.right

    def paths(self, camera: str) -> list[str]:
        """The stored paths of ``camera``'s chapter files in order."""
        return [file.path for file in self.files(camera)]


@dataclass(frozen=True)
class StoredCalibration:
    """A stored calibration as listed (its whole file dictionary is ``ProjectStore.calibration(id)``): its
    id, name, phase ("air", "water", "joint" …; None when its file names none), its reprojection sigma0 in
    pixels (None when not given) and when it was stored (ISO 8601 UTC text)."""

    id: int
    name: str
    phase: str | None
    sigma0_px: float | None
    created: str


@dataclass(frozen=True)
class Provenance:
    """Who made what of an object and when (times ISO 8601 UTC text): ``object`` (creator, created,
    modified), ``vertices`` (one (creator, created) per vertex in order: who picked it; a re-pick keeps the
    stamps of the vertices whose picks did not change) and ``record`` ((creator, created) of its observation
    record as it stands, None without one)."""

    object: tuple[str, str, str]
    vertices: list[tuple[str, str]]
    record: tuple[str, str] | None


@dataclass(frozen=True)
class StoredObject:
    """A measured object as stored: its id, registered kind, attribute, notes, who made it, when it was
    created and last modified (ISO 8601 UTC text; ``modified`` is also its version for optimistic edits)
    and its vertices in order."""

    id: int
    kind: str
    attribute: str
    notes: str
    creator: str
    created: str
    modified: str
    vertices: tuple[Vertex, ...]


@dataclass(frozen=True)
class RemovedObject:
    """Everything :meth:`Project.take_object` removed of one object, row for row (its id, kind, texts and
    times, vertices, video frames, the history of replaced 3-D values, the observation record, its instant
    links), for :meth:`Project.put_back` to restore exactly. Opaque to callers: only the store reads ``rows``."""

    object_id: int
    rows: tuple[tuple[str, tuple[str, ...], tuple[tuple, ...]], ...]

    @property
    def modified(self) -> str | None:
        """The object's ``modified`` stamp (its version) in these rows: an undo that puts them back names it
        to check that nobody changed the object since (None when the rows hold no object)."""
        for table, columns, values in self.rows:
            if table == "objects" and values and "modified" in columns:
                return values[0][columns.index("modified")]
        return None


#: the kinds of change the history records: an object added, edited (kind, attribute, notes), re-picked
#: (its vertices replaced), deleted, put back (an undo restoring it as it was), its observation record set
#: (or removed), reviewed (schema 9: its review state set)
CHANGES = ("add", "edit", "re-pick", "delete", "put back", "record", "review")

#: the review states of an object (schema 9): not yet looked at by a second reader (every object starts
#: so), accepted, or flagged with a reason
REVIEW_STATES = ("unreviewed", "accepted", "flagged")


@dataclass(frozen=True)
class Review:
    """An object's review: its state (one of :data:`REVIEW_STATES`), the reason (required when flagged; an
    optional remark when accepted; '' when unreviewed), who reviewed it and when (ISO 8601 UTC text; both
    '' while unreviewed)."""

    object_id: int
    state: str = "unreviewed"
    reason: str = ""
    reviewer: str = ""
    reviewed: str = ""


@dataclass(frozen=True)
class HistoryEntry:
    """One change in a project's append-only history: its number (increasing in the order the changes
    were made), when (ISO 8601 UTC text), by whom (the annotator's name), which object (its id, kept after
    the object is deleted), what kind of change (one of :data:`CHANGES`), and the values before and after
    (JSON-shaped: dicts of the fields concerned; None where there was or is nothing)."""

    id: int
    at: str
    annotator: str
    object_id: int
    change: str
    old: dict | None
    new: dict | None
