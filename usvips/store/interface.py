"""The storage interface: the operations the rest of the program asks of a project.

:class:`ProjectStore` lists them — what the application services (``usvips.app``), the command line and
the window call on a project, nothing more. One class implements it, :class:`usvips.store.survey.Survey`
(every survey rule, once), over a small :class:`usvips.store.backend.Backend`: an SQLite file
(:class:`usvips.store.project.Project`) or a PostgreSQL server
(:class:`usvips.store.postgres.ServerProject`); both pass the same contract suite
(``tests/store/test_storage_contract.py``). Code that takes a project takes a ``ProjectStore``; code that
creates or opens one calls :func:`usvips.store.opening.open_project` / ``create_project`` with a location
(a file path or a ``postgresql://`` URL) and never names an implementation. The record types and the
error family are in :mod:`usvips.store.records`; the domain checks every backend makes before writing
(kinds, vertex counts, pair files) in :mod:`usvips.store.checks`. Adding a backend = one module (a
``Backend`` and the class opening a ``Survey`` on it) that passes the contract suite, and one line in the
opener.

Conventions every implementation keeps:

- Units: image coordinates in pixels, vertex X, Y, Z in metres, covariances in m².
- Failures are :class:`usvips.store.records.ProjectError` (or another ``UsvipsError``) with one line that
  names the project (``path``) and what is wrong; a store error never leaks as another kind of exception.
- Every write is all or nothing. :meth:`ProjectStore.transaction` groups writes: all are kept or, on any
  error, none; nested uses join the outermost one.
- Every write that changes what exists names the version it read (``expected_modified``,
  ``expected_sha256`` or ``expected``: :mod:`usvips.store.versions`); a write made on something changed
  since is a :class:`~usvips.store.records.StaleEditError` naming who changed it and when, and nothing
  is changed.
- A store opened read-only refuses every write with a ``ProjectError`` and changes nothing.
- Paths of images and media are recorded relative to the project where possible; :meth:`image_path` and
  :meth:`media_path` give them back absolute (naming the file when it has gone missing).
"""

from __future__ import annotations

from collections.abc import Sequence
from contextlib import AbstractContextManager
from pathlib import Path
from typing import Protocol, runtime_checkable

from usvips.core.campaign import Campaign
from usvips.core.deployment import Deployment, Georeference
from usvips.core.observation_record import ObservationRecord, Species
from usvips.core.observations import ControlPoints, StereoObservations
from usvips.store.change_watch import ChangeWatch
from usvips.store.records import (
    HistoryEntry,
    Pair,
    Provenance,
    RemovedObject,
    Review,
    StoredCalibration,
    StoredObject,
    Vertex,
    Video,
)
from usvips.store.versions import UNREAD


@runtime_checkable
class ProjectStore(Protocol):
    """A project: image pairs and videos, control, calibrations, measured objects and what goes with them.

    ``path`` names the project in messages (a file for SQLite; an address for a server) and anchors
    relative media paths. ``read_only`` is True when every write is refused. ``annotator`` is who is
    working through this handle (``usvips.store.annotator.current_annotator()`` when it was opened; it may
    be set): new objects without a creator, vertices and observation records are stamped with it, and
    every history row this handle adds carries it.
    """

    path: Path
    read_only: bool
    annotator: str

    # ------------------------------------------------------------------------ life cycle
    @property
    def version(self) -> int:
        """The schema version the project is stored in."""
        ...

    def close(self) -> None:
        """Release the project (the handle is not used afterwards)."""
        ...

    def __enter__(self) -> ProjectStore: ...

    def __exit__(self, *exc) -> None: ...

    def transaction(self) -> AbstractContextManager[None]:
        """A context in which writes are kept together: all of them, or none on any error."""
        ...

    def copy_to(self, path: str | Path) -> Path:
        """A consistent copy of the whole project at the new ``path``; returns its path."""
        ...

    # ------------------------------------------------------------------------ pairs and media
    def add_pair(self, label: str, left: str | Path | None = None, right: str | Path | None = None,
                 medium: str = "water", frame: int | None = None, size: tuple[int, int] | None = None) -> int:
        """A new image pair (``medium`` "air" or "water"); a label already used is a ``ProjectError``."""
        ...

    def pairs(self) -> list[Pair]:
        """Every pair (a :class:`~usvips.store.records.Pair`; a video is one too), in insertion order."""
        ...

    def add_image_pairs(self, pairs: Sequence[tuple[str, Path, Path]], medium: str = "water",
                        sizes: Sequence[tuple[int, int]] | None = None) -> list[int]:
        """(label, left image, right image) pairs, recording each file's size and hash; all or none."""
        ...

    def derived_media_folder(self) -> Path:
        """The folder where media derived from the project (seek proxies, exported frames) are kept: beside
        the file of a file project, a configurable cache for a server one."""
        ...

    def media_location(self, stored: str) -> Path:
        """Where a recorded image or media path should be, absolute, whether or not a file is there (a path
        stored relative is relative to the store's media folder: a file project's folder, a server's media
        folder). Callers locate media through this, never through ``path``."""
        ...

    def image_path(self, relative: str) -> Path:
        """The absolute path of a stored image path."""
        ...

    def media_path(self, stored: str) -> Path:
        """The absolute path of a stored media path."""
        ...

    def media_problems(self, check_hash: bool = True) -> list[tuple[str, str]]:
        """(stored path, problem) of every recorded media file missing or changed."""
        ...

    def media_identity(self, stored: str, full: bool = False) -> str | None:
        """Why the file at a recorded media path is not the one added (missing, size, contents), or None;
        fast (size and a sampled hash) unless ``full`` (the whole SHA-256)."""
        ...

    def media_records(self) -> list[tuple[str, Path, int, str]]:
        """(stored path, absolute path, size, SHA-256) of every recorded media file."""
        ...

    def accept_media(self, stored: str, expected_sha256: str | None = None,
                     hashed: tuple[int, str, str] | None = None) -> None:
        """Take the file now at a recorded media path as the one meant (size and hashes recorded anew).
        ``expected_sha256``: the SHA-256 recorded when the caller read it (:meth:`media_records`); accepted
        anew or relocated since by someone else is a ``StaleEditError`` naming who and when. ``hashed``:
        (size in bytes, SHA-256, sampled hash) as the caller read the file — not read whole again, and
        refused when its size or sampled hash differs now; None: hashed here."""
        ...

    def relocate_media(self, stored: str, new_path: str | Path, expected_sha256: str | None = None) -> str:
        """Point a recorded media file at its new place (the same file); returns the new stored path.
        ``expected_sha256`` as for :meth:`accept_media`."""
        ...

    # ------------------------------------------------------------------------ videos
    def add_video(self, label: str, left: Sequence[tuple[Path, int, float]], right: Sequence[tuple[Path, int, float]],
                  fps: float, frame_count: int, size: tuple[int, int], report: str = "", medium: str = "water") -> int:
        """A stereo video: each camera's chapters as (path, frames, seconds); fps in frames per second;
        ``medium`` "air" or "water" (what the cameras looked through: its pair's medium)."""
        ...

    def video(self, label: str) -> Video:
        """A stored video (:class:`~usvips.store.records.Video`: label, fps, frame_count, width, height,
        offset_frames, offset_estimate, report, each camera's chapter files)."""
        ...

    def videos(self) -> list[Video]:
        """Every stored video."""
        ...

    def set_video_offset(self, label: str, frames: int, estimate: dict | None = None,
                         expected: object = UNREAD) -> None:
        """Left frame i and right frame i + ``frames`` show the same instant. ``expected``: the offset in
        frames as read (see :mod:`usvips.store.versions` for every ``expected``)."""
        ...

    def add_period(self, video: str, name: str, start: int, end: int) -> int:
        """A named period of a video, left frames ``start`` … ``end`` inclusive."""
        ...

    def periods(self, video: str) -> list[tuple[str, int, int]]:
        """The video's periods as (name, start, end)."""
        ...

    # ------------------------------------------------------------------------ control and calibrations
    def set_control(self, control: ControlPoints, expected: object = UNREAD) -> None:
        """Replace the control points (metres); ``expected``: the control points as read."""
        ...

    def control(self) -> ControlPoints:
        """The control points (none when none were stored)."""
        ...

    def add_control_observations(self, observations: StereoObservations, role: str, pair: str,
                                 replace: bool = False, expected: object = UNREAD) -> None:
        """A pair's control observations (pixels) for a role ("calibration-air", "calibration-water",
        "check", …); ``replace`` swaps the stored set for this one; ``expected``: the set as read."""
        ...

    def control_observations(self, role: str, pair: str) -> StereoObservations:
        """A pair's control observations for a role."""
        ...

    def add_calibration(self, name: str, calibration: dict, active_for: tuple[str, ...] = ()) -> int:
        """Store a calibration (its file dictionary), active for the pairs named; returns its id."""
        ...

    def calibration(self, calibration_id: int) -> dict:
        """A stored calibration's dictionary; an unknown id is a ``ProjectError``."""
        ...

    def calibrations(self) -> list[StoredCalibration]:
        """Every calibration as listed (:class:`~usvips.store.records.StoredCalibration`: id, name, phase,
        sigma0_px, created), oldest first."""
        ...

    def active_calibration(self, label: str) -> int | None:
        """The id of the calibration active for a pair or video, None when none is."""
        ...

    def activate_calibration(self, label: str, calibration_id: int, expected: object = UNREAD) -> None:
        """Make a stored calibration the active one of a pair or video; ``expected``: the active id as read
        (None: none was)."""
        ...

    # ------------------------------------------------------------------------ measured objects
    def add_object(self, kind: str, vertices: list[Vertex], attribute: str = "", notes: str = "",
                   creator: str = "") -> int:
        """Store one object of a registered measurement kind; returns its id. ``creator`` '' is this
        handle's annotator.

        Who and when (schema 8): every write to an object (this method, :meth:`add_objects`,
        :meth:`update_object`, :meth:`delete_object`, :meth:`take_object`, :meth:`put_back`,
        :meth:`set_record`, :meth:`set_review`) appends exactly one row to the history (:meth:`history`) in its own
        transaction, with the annotator, the time, the object's id and the values before and after — and an
        edit that returns an accepted object to unreviewed (see :meth:`update_object`) a second one, the
        "review" row accepted → unreviewed, reason "edited after review", by the editor."""
        ...

    def add_objects(self, objects: list[tuple[str, list[Vertex], str, str, str]]) -> list[int]:
        """Several objects, each (kind, vertices, attribute, notes, creator), all or none."""
        ...

    def update_object(self, object_id: int, attribute: str | None = None, notes: str | None = None,
                      vertices: list[Vertex] | None = None, kind: str | None = None,
                      expected_modified: str | None = None) -> None:
        """Change what is given of an object (replaced 3-D values are kept in its history); its
        ``modified`` stamp always moves forward. ``expected_modified``: the stamp the editor read — when
        the object was changed since (by another annotator), the edit is a
        :class:`~usvips.store.records.StaleEditError` naming the object, and nothing is changed.

        What a review looked at changed — the kind, the attribute or the vertices (a re-pick, a vertex
        deleted), or the observation record (:meth:`set_record`) — returns an accepted object to
        unreviewed in the same transaction, recorded in the history as a "review" change by the editor
        (``{"state": "accepted", …}`` → ``{"state": "unreviewed", "reason": "edited after review"}``); a
        flagged object stays flagged; notes, and linking or unlinking an instant, leave the review as it
        is. :meth:`put_back` of the rows read before the edit (an undo) restores the review as it was."""
        ...

    def delete_object(self, object_id: int, expected_modified: str | None = None) -> None:
        """Remove an object and its vertices (``expected_modified`` as for :meth:`update_object`)."""
        ...

    def take_object(self, object_id: int, expected_modified: str | None = None) -> RemovedObject:
        """Remove an object and return all that went with it (vertices, video frames, history, record);
        ``expected_modified`` as for :meth:`update_object` (an undo of a store, a redo of a delete: the
        object changed since by someone else is a ``StaleEditError`` and stays)."""
        ...

    def object_rows(self, object_id: int) -> RemovedObject:
        """All that is stored of an object (as :meth:`take_object` would return it), changing nothing."""
        ...

    def put_back(self, removed: RemovedObject, replace: bool = False, expected_modified: str | None = None) -> None:
        """Restore exactly what :meth:`take_object` removed or :meth:`object_rows` read (the same id);
        a used id is refused (a :class:`~usvips.store.records.StaleEditError` naming who made it), or with
        ``replace`` its object replaced. ``expected_modified`` (an undo or redo of an edit: the version the
        editor left the object at): the object is replaced only when still stored at that version; changed
        or deleted since (by another annotator) is a ``StaleEditError`` naming the object and who made the
        last change, and nothing is changed — never a silent overwrite of someone's later edit."""
        ...

    def object(self, object_id: int) -> StoredObject:
        """One object with its vertices in order; an unknown id is a ``ProjectError``."""
        ...

    def objects(self) -> list[StoredObject]:
        """Every object, a consistent snapshot, by id."""
        ...

    def objects_with_ids(self, object_ids: Sequence[int]) -> list[StoredObject]:
        """The objects of ``object_ids`` that exist, by id, in one consistent read (an id no longer stored
        is simply absent)."""
        ...

    def objects_on(self, pair: str, first_frame: int | None = None, last_frame: int | None = None
                   ) -> list[StoredObject]:
        """The objects whose first vertex is on the image pair or video labelled ``pair`` — on a video, with
        ``first_frame``/``last_frame``, only those whose first vertex's left frame lies between them
        (inclusive) — by id, in one consistent read (what a detection run compares its proposals with,
        without reading a whole survey)."""
        ...

    def set_record(self, object_id: int, record: ObservationRecord | None,
                   expected_modified: str | None = None) -> None:
        """Store (None: remove) an object's observation record; its ``modified`` stamp moves forward, and a
        changed record returns an accepted object to unreviewed (as :meth:`update_object` says).
        ``expected_modified`` as for :meth:`update_object` (a stale record is a ``StaleEditError``)."""
        ...

    def records(self) -> dict[int, ObservationRecord]:
        """Every object's observation record, by object id (objects without one are absent)."""
        ...

    def record(self, object_id: int) -> ObservationRecord | None:
        """An object's observation record, None when none was entered."""
        ...

    def records_of(self, object_ids: Sequence[int]) -> dict[int, ObservationRecord]:
        """The observation records of ``object_ids`` (those without one absent): :meth:`records` restricted to
        them, without reading every record of a survey (what a view re-reads after a change to those objects)."""
        ...

    def provenance(self, object_id: int) -> Provenance:
        """Who made what of an object and when (a :class:`~usvips.store.records.Provenance`: the object's
        creator and times, who picked each vertex, who made its observation record)."""
        ...

    def history(self, object_id: int | None = None) -> list[HistoryEntry]:
        """The append-only history of changes (of one object when ``object_id`` is given, also after it
        was deleted), oldest first: one :class:`~usvips.store.records.HistoryEntry` per write — "add",
        "edit" (kind, attribute, notes: old and new of the fields given; or ``instant_of``: an instant
        linked to or unlinked from an object, :meth:`add_instant` / :meth:`remove_instant`, with
        ``tracked_from`` when it was tracked), "re-pick"
        (vertices replaced),
        "delete", "put back" (an undo), "record" (observation record set or removed), "review" (review state
        set: ``{"state", "reason", "reviewer"}`` before and after). Rows are never
        changed or removed (the schema refuses it)."""
        ...

    # ------------------------------------------------------------------------ the change feed (schema 14)
    def last_change_id(self) -> int:
        """The id of the newest history row (0 when the history is empty): where a reader that has just read
        the project's state starts following :meth:`changes_since`."""
        ...

    def changes_since(self, after: int, limit: int = 10000) -> list[HistoryEntry]:
        """The history rows with an id above ``after`` (an id from :meth:`last_change_id` or from the last
        entry read), oldest first, at most ``limit``: every add, edit, delete, review … committed since, by any
        handle or process, each naming its object and who made it. A reader given ``limit`` rows asks again
        from the last one's id."""
        ...

    def watch(self) -> ChangeWatch:
        """A :class:`~usvips.store.change_watch.ChangeWatch` on this project, made to be used from a
        background thread (it owns its own connection): ``wait(timeout_s)`` returns True as soon as another
        connection may have committed a change (False on timeout), then the reader asks
        :meth:`changes_since` (through a handle of its own thread). A file is watched through SQLite's change
        counter (``PRAGMA data_version``, read every 0.2 s), a server through LISTEN/NOTIFY (the history's
        trigger notifies at each commit). ``close()`` releases it (idempotent); no message names a password."""
        ...

    # ------------------------------------------------------------------------ reviews (schema 9)
    def set_review(self, object_id: int, state: str, reason: str = "", expected_modified: str | None = None) -> None:
        """Set an object's review state: "accepted" (``reason`` an optional remark), "flagged" (``reason``
        required: what is wrong, one line) or "unreviewed" (back in the queue; no reason), made by this
        handle's annotator now. One transaction: the review, the object's ``modified`` stamp moved forward
        (a review is a new version of the object), and one "review" row in the history (old and new state);
        the state and reason the object already has (accepted again, say) is no change: nothing is written
        (no history row, the same version, the first reviewer kept).
        An unknown id, an unknown state, a flag without a reason is a ``ProjectError`` naming the object;
        ``expected_modified`` as for :meth:`update_object` (a stale review is a ``StaleEditError``)."""
        ...

    def review(self, object_id: int) -> Review:
        """An object's :class:`~usvips.store.records.Review` (state "unreviewed" when none was made); an
        unknown id is a ``ProjectError``."""
        ...

    def reviews(self, state: str | None = None) -> list[Review]:
        """The review of every object, by object id (unreviewed ones included); with ``state`` only those in
        that state (an unknown state is a ``ProjectError``). One consistent read."""
        ...

    # ------------------------------------------------------------------------ objects over several instants
    def add_instant(self, object_id: int, instant_id: int, tracked_from: int | None = None,
                    expected_modified: str | None = None) -> None:
        """Make the stored object ``instant_id`` (of the same kind) a further instant of ``object_id``: one
        object measured on several instants, its first instant being itself. ``tracked_from``: how the
        instant was made — the left frame its track started from (its vertices carry that frame's picks,
        :func:`usvips.app.tracking.add_tracked_instants`), None when picked by hand; stored with the link
        (schema 10), kept by undo, push and pull, and in the history's link row. An unknown id, an object of
        another kind, a frame that is not a whole number >= 0, or a link that would chain instants (an
        instant of an instant, an object with instants of its own becoming an instant) is a ``ProjectError``.
        The link is a change of ``instant_id``: its ``modified`` stamp moves forward, and
        ``expected_modified`` (its version as read) is checked as for :meth:`update_object`."""
        ...

    def remove_instant(self, instant_id: int, expected_modified: str | None = None) -> None:
        """Unlink an instant (it stays, as an object of its own); one that is not an instant is an error.
        Its ``modified`` stamp moves forward; ``expected_modified`` as for :meth:`add_instant`."""
        ...

    def instants(self, object_id: int) -> list[int]:
        """The ids of the further instants of ``object_id``, by id (empty when it has one instant)."""
        ...

    def instant_links(self) -> dict[int, int]:
        """Every further instant's id → the id of the object it is an instant of."""
        ...

    def instant_links_of(self, object_ids: Sequence[int]) -> dict[int, int]:
        """The links (a further instant's id → the id of its object) in which any of ``object_ids`` takes part,
        as the instant or as the object: :meth:`instant_links` restricted to them, without reading every link
        of a survey (what a view re-reads after a change to those objects)."""
        ...

    def instant_sources(self, object_id: int | None = None) -> dict[int, int | None]:
        """How each further instant was made: its id → the left frame its track started from, None when
        picked by hand (what :meth:`add_instant` was given; never read from the notes); of ``object_id``, or
        of every object's further instants when None."""
        ...

    # ------------------------------------------------------------------------ deployment and georeference
    def set_deployment(self, deployment: Deployment | None, video: str | None = None,
                       expected: object = UNREAD) -> None:
        """Store (None: remove) the deployment metadata of the project, or of one stereo ``video``;
        ``expected``: that scope's own deployment as read (None: none)."""
        ...

    def deployments(self) -> dict[str, Deployment]:
        """Scope ('' for the project, else a video's label) → its deployment."""
        ...

    def deployment(self, video: str | None = None) -> Deployment | None:
        """The deployment of ``video`` when it has its own, else the project's; None when none was entered."""
        ...

    def set_georeference(self, georeference: Georeference | None, expected: object = UNREAD) -> None:
        """Store (None: remove) where the object frame lies on the Earth; ``expected``: as read."""
        ...

    def georeference(self) -> Georeference | None:
        """The object frame's georeference; None when none was entered."""
        ...

    # ------------------------------------------------------------------------ pointing estimates
    def set_pointing_estimates(self, estimates: list[dict], expected: object = UNREAD) -> None:
        """Store (an empty list: remove) the project's pointing estimates, JSON-able dicts (no schema of
        their own; see :mod:`usvips.app.pointing_settings`). ``expected``: the estimates as read."""
        ...

    def pointing_estimates(self) -> list[dict]:
        """The stored pointing estimates, oldest first ([] when none)."""
        ...

    # ------------------------------------------------------------------------ campaign (GlobalArchive)
    def set_campaign(self, campaign: Campaign | None, expected: object = UNREAD) -> None:
        """Store (None: remove) the campaign the project's deployments belong to (GlobalArchive's CampaignID,
        Project, method, sampling design, submitter, dates …; kept as JSON, no schema of its own);
        ``expected``: the campaign as read (None: none)."""
        ...

    def campaign(self) -> Campaign | None:
        """The stored campaign; None when none was entered."""
        ...

    # ------------------------------------------------------------------------ vocabularies, lists, settings
    def add_term(self, term: str, category: str = "attribute") -> None:
        """Add a term to a vocabulary (once)."""
        ...

    def vocabulary(self, category: str = "attribute") -> list[str]:
        """A vocabulary's terms, sorted."""
        ...

    def set_species_list(self, species: list[Species], expected: object = UNREAD) -> None:
        """Replace the species list; ``expected``: the list as read."""
        ...

    def species_list(self) -> list[Species]:
        """The species list, by genus and species."""
        ...

    def set_enhancement(self, image_key: str, pipeline_json: str, expected: object = UNREAD) -> None:
        """Keep an image's enhancement pipeline (JSON); ``expected``: the pipeline as read (None: none)."""
        ...

    def enhancement(self, image_key: str) -> str | None:
        """An image's enhancement pipeline (JSON), None when none was kept."""
        ...

    def set_draft(self, name: str, text: str | None, expected: object = UNREAD) -> None:
        """Keep (None: drop) a half-finished piece of work, e.g. a wizard's state; ``expected``: as read."""
        ...

    def draft(self, name: str) -> str | None:
        """A kept draft, None when there is none."""
        ...
