"""The survey's rules, once, for every backend: what a USVIPS project means — pairs and media, videos,
control, calibrations, measured objects with who made them and when, the append-only history, reviews,
the stale-write rule (:mod:`usvips.store.versions`), instants, media identity, deployments, the campaign —
written against the small :class:`~usvips.store.backend.Backend` interface (SQL in the dialect SQLite and
PostgreSQL share, transactions, the schema version, where media are). :class:`Survey` is the
:class:`~usvips.store.interface.ProjectStore`; a backend module opens one on its database
(:class:`usvips.store.project.Project`: an SQLite file; :class:`usvips.store.postgres.ServerProject`: a
survey on a PostgreSQL server) and adds nothing to its rules.

Every user edit is one transaction (a crash loses at most the edit in progress); :meth:`Survey.transaction`
groups several edits into one (an import either completes or changes nothing). Paths of media are stored
relative to the backend's media folder where possible and resolved through the survey
(:meth:`Survey.image_path`, :meth:`Survey.media_path`).

Who and when (schema 8): every handle has an ``annotator`` (``usvips.store.annotator``); objects, vertices
and observation records are stamped with who made them and when, and every write to an object appends one
row to the ``history`` table in the same transaction (see :meth:`Survey.history`). The survey only ever
INSERTs into the history, and the schema's triggers refuse any UPDATE or DELETE of it.

Every failure of the database (locked by another program or annotator, disk full, a damaged file, a server
gone) is a :class:`ProjectError` whose one line names the project and what to do; nothing is half-written.
"""

from __future__ import annotations

import contextlib
import dataclasses
import json
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from datetime import UTC, datetime, timedelta
from numbers import Integral
from pathlib import Path

import numpy as np

from usvips.core.campaign import Campaign
from usvips.core.deployment import DEPLOYMENT_FIELDS, Deployment, Georeference
from usvips.core.errors import InvalidParameterError, UsvipsError
from usvips.core.observation_record import ObservationRecord, Species
from usvips.core.observations import ControlPoints, StereoObservations
from usvips.core.pointing import MIGRATED_SOURCE, PointingSigma, WeakMatch, per_vertex, source_from_label
from usvips.store import checks, versions
from usvips.store.annotator import current_annotator
from usvips.store.backend import PUT_META, Backend, BackendError, ConstraintError, Result, Statement, upsert
from usvips.store.change_watch import ChangeWatch
from usvips.store.records import (
    REVIEW_STATES,
    HistoryEntry,
    Pair,
    ProjectError,
    Provenance,
    RemovedObject,
    Review,
    StaleEditError,
    StoredCalibration,
    StoredObject,
    Vertex,
    Video,
    VideoFile,
)
from usvips.store.versions import UNREAD

FORMAT = "usvips-project"
#: a pair's (or video's) active calibration stored or replaced: (pair id, calibration id)
ACTIVATE = upsert("active_calibrations", ("pair_id", "calibration_id"), ("pair_id",))
#: an observation record's columns after its object's id
RECORD_FIELDS = ("family", "genus", "species", "code", "number", "stage", "activity", "comment")
#: a vertex row stored (:meth:`Survey._vertex_rows`)
INSERT_VERTEX = ("INSERT INTO vertices (object_id, idx, pair_id, xl, yl, xr, yr, x, y, z, covariance, calibration_id, "
                 "creator, created, pointing_source, sigma_left_px, sigma_right_px, pointing_origin, weak_score, "
                 f"weak_reason) VALUES ({', '.join('?' * 20)})")
#: a video vertex's frames stored: (object id, vertex index, video id, left frame, right frame, time s)
INSERT_VERTEX_FRAMES = "INSERT INTO vertex_frames VALUES (?, ?, ?, ?, ?, ?)"
#: a history row appended (:meth:`Survey._history_row`)
INSERT_HISTORY = "INSERT INTO history (at, annotator, object_id, change, old, new) VALUES (?, ?, ?, ?, ?, ?)"
#: the ``meta`` key holding the campaign (JSON of :class:`~usvips.core.campaign.Campaign`)
CAMPAIGN_KEY = "campaign"
#: the ``meta`` key holding the project's pointing estimates (a JSON list, see :meth:`Project.pointing_estimates`)
POINTING_KEY = "pointing_estimates"


def _now() -> str:
    """The time now, UTC, ISO 8601 to the microsecond (an object's ``modified`` is also its version)."""
    return datetime.now(UTC).isoformat(timespec="microseconds")


def _later(stamp: str) -> str:
    """A ``modified`` stamp after ``stamp``: now, or ``stamp`` plus a microsecond when the clock has not
    moved past it (two edits in one tick, or a clock set back) — every edit makes a new version."""
    now = _now()
    if now > stamp:
        return now
    try:
        return (datetime.fromisoformat(stamp) + timedelta(microseconds=1)).isoformat(timespec="microseconds")
    except ValueError:
        return now


def refuse_stale(where: object, stored: StoredObject, expected_modified: str | None, by: str = "") -> None:
    """An edit made on an object as read at ``expected_modified`` is refused when it has changed since.
    ``by``: who made the last change and what (from the history), named in the refusal."""
    if expected_modified is not None and stored.modified != expected_modified:
        versions.refuse_stale_object(where, stored.id, stored.modified, expected_modified, by)


def _pick_key(vertex: Vertex) -> tuple:
    """What makes a vertex's pick: its pixels, pair, video and frames (not its 3-D values, which a
    recomputation replaces without anyone picking again)."""
    return (vertex.xl, vertex.yl, vertex.xr, vertex.yr, vertex.pair, vertex.video, vertex.frame_left,
            vertex.frame_right)


#: the pointing columns of a vertex (schema 11), as :func:`_pointing_row` writes and :func:`_pointing_fields`
#: reads them; a project older than schema 11 (read-only) reads its vertices as hand clicks of unknown source
POINTING_COLUMNS = ("v.pointing_source, v.sigma_left_px, v.sigma_right_px, v.pointing_origin, v.weak_score, "
                    "v.weak_reason")
POINTING_BEFORE_11 = f"'{MIGRATED_SOURCE}', NULL, NULL, NULL, NULL, NULL"


def _pointing_row(vertex: Vertex, path) -> tuple:
    """A vertex's pointing as its schema-11 columns; a source label or pointing sigma that is not one is a
    :class:`ProjectError` naming the project."""
    try:
        source_from_label(vertex.source)
        sigma = None if vertex.pointing_px is None else per_vertex(np.asarray(vertex.pointing_px, float)[None], 1)[0]
        origin = None if sigma is None else PointingSigma(float(sigma[0]), origin=vertex.pointing_origin).origin
    except UsvipsError as error:
        raise ProjectError(f"{path}: cannot store the vertex: {error}") from None
    weak = vertex.weak
    score = None if weak is None or weak.score is None else float(weak.score)
    return (vertex.source, *(sigma.tolist() if sigma is not None else (None, None)), origin, score,
            None if weak is None else str(weak.reason))


def _pointing_fields(row: tuple) -> dict:
    """The :class:`Vertex` fields of its pointing columns (source, sigma left, sigma right, origin, weak
    score, weak reason)."""
    source, left, right, origin, score, reason = row
    return {"source": source or MIGRATED_SOURCE,
            "pointing_px": None if left is None or right is None else (float(left), float(right)),
            "pointing_origin": origin or "default",
            "weak": None if reason is None else WeakMatch(None if score is None else float(score), reason)}


def _kept_pointing(vertex: Vertex, stored: Vertex) -> Vertex:
    """A re-picked vertex whose picks are those of ``stored`` keeps what ``stored`` knew of its pointing that
    the new one does not say (its source, sigmas, and above all a weak match's flag: no edit that leaves the
    picks where they were removes it)."""
    if _pick_key(vertex) != _pick_key(stored):
        return vertex
    changes = {}
    if vertex.weak is None and stored.weak is not None:
        changes["weak"] = stored.weak
    if vertex.source == "hand click" and vertex.pointing_px is None:
        changes.update(source=stored.source, pointing_px=stored.pointing_px, pointing_origin=stored.pointing_origin)
    return dataclasses.replace(vertex, **changes) if changes else vertex


def _vertex_state(vertex: Vertex) -> dict:
    """A vertex as the history shows it: picks (pixels), and where given pair, video and frames, X Y Z (m)."""
    state: dict = {"xl": vertex.xl, "yl": vertex.yl, "xr": vertex.xr, "yr": vertex.yr}
    if vertex.pair is not None:
        state["pair"] = vertex.pair
    if vertex.video is not None:
        state.update(video=vertex.video, frame_left=vertex.frame_left, frame_right=vertex.frame_right)
    if vertex.xyz is not None:
        state["xyz"] = [float(c) for c in vertex.xyz]
    if vertex.source != "hand click":
        state["source"] = vertex.source
    if vertex.pointing_px is not None:
        state.update(pointing_px=[float(c) for c in vertex.pointing_px], pointing_origin=vertex.pointing_origin)
    if vertex.weak is not None:
        state["weak"] = {"score": vertex.weak.score, "reason": vertex.weak.reason}
    return state


def _object_state(kind: str, attribute: str, notes: str, vertices: list[Vertex]) -> dict:
    return {"kind": kind, "attribute": attribute, "notes": notes, "vertices": [_vertex_state(v) for v in vertices]}


#: why an accepted object went back to unreviewed without a reviewer: the reason of the history's 'review' row
EDITED_AFTER_REVIEW = "edited after review"
#: what of an object a review looks at: an edit of any of these (its observation record too) undoes an
#: acceptance; its notes and its instant links do not
REVIEWED_FIELDS = ("kind", "attribute", "vertices")


def _review_state(review: Review) -> dict:
    """A review as the history shows it: its state, and when reviewed the reason and the reviewer."""
    if review.state == "unreviewed":
        return {"state": "unreviewed"}
    return {"state": review.state, "reason": review.reason, "reviewer": review.reviewer}


def _history_json(value: dict | None) -> str | None:
    """A history value as JSON text (numbers that are not finite written as null: JSON has no NaN)."""
    if value is None:
        return None

    def finite(item):
        if isinstance(item, float) and not np.isfinite(item):
            return None
        if isinstance(item, dict):
            return {k: finite(v) for k, v in item.items()}
        if isinstance(item, list):
            return [finite(v) for v in item]
        if isinstance(item, np.generic):
            return finite(item.item())
        return item

    return json.dumps(finite(value), allow_nan=False, ensure_ascii=False)


def file_hash(path: Path) -> str:
    import hashlib  # here, not at the top: OpenSSL's binding is not loaded by every start of the window

    digest = hashlib.sha256()
    with open(path, "rb") as stream:
        for chunk in iter(lambda: stream.read(1 << 20), b""):
            digest.update(chunk)
    return digest.hexdigest()


#: the sampled hash of a media file reads this many blocks …
SAMPLE_BLOCKS = 16
#: … of this many bytes, evenly spaced from the file's start to its end (the whole of a small file)
SAMPLE_BLOCK_BYTES = 1 << 16


def sampled_hash(path: Path) -> str:
    """A fast fingerprint of a media file: SHA-256 of its size and :data:`SAMPLE_BLOCKS` blocks of
    :data:`SAMPLE_BLOCK_BYTES` spread evenly over it, first and last included (about 1 MiB read however
    large the file; the whole file when smaller). Another recording of the same name and size differs
    in its first block already (its own header, time stamps and pictures)."""
    import hashlib  # here, not at the top (see file_hash)

    size = path.stat().st_size
    digest = hashlib.sha256(str(size).encode())
    with open(path, "rb") as stream:
        if size <= SAMPLE_BLOCKS * SAMPLE_BLOCK_BYTES:
            digest.update(stream.read())
        else:
            for start in np.linspace(0, size - SAMPLE_BLOCK_BYTES, SAMPLE_BLOCKS).astype(np.int64).tolist():
                stream.seek(start)
                digest.update(stream.read(SAMPLE_BLOCK_BYTES))
    return digest.hexdigest()


def _sample_key(stored: str) -> str:
    """The ``meta`` key holding a media file's sampled hash (no schema change: older projects lack it)."""
    return f"media-sample:{stored}"


#: found by the key column; its instant links both ways (an instant of another, or the first of its own)
_OBJECT_TABLES = (("objects", "id"), ("vertices", "object_id"), ("vertex_frames", "object_id"),
                  ("vertex_history", "object_id"), ("observation_records", "object_id"),
                  ("object_instants", "object_id"), ("object_instants", "of_object"), ("reviews", "object_id"))


def _link(object_id: int, tracked_from: int | None) -> dict:
    """An instant's link as the history keeps it: the object it is an instant of, and the frame its track
    started from when it was tracked (a hand-picked instant's link is ``{"instant_of": id}`` alone)."""
    link: dict = {"instant_of": int(object_id)}
    if tracked_from is not None:
        link["tracked_from"] = int(tracked_from)
    return link


class Survey:
    """A project's rules over a :class:`~usvips.store.backend.Backend` (see the module docstring); made by
    a backend module's opener (``Project.open``, ``ServerProject.open``), used as a context manager or
    closed with :meth:`close`."""

    def __init__(self, path: Path, backend: Backend, read_only: bool = False):
        self.path = path
        self.read_only = read_only
        self._db = backend
        self._depth = 0
        self._pointing = False
        #: who is annotating: stamped on what this handle writes and on every history row it adds. A bad
        #: name (``$USVIPS_ANNOTATOR`` with a line break …) refuses a writing open in one line naming it; a
        #: read-only open, which writes nothing, goes ahead
        try:
            self.annotator = current_annotator()
        except UsvipsError:
            if not read_only:
                backend.close()
                raise
            self.annotator = ""

    def close(self) -> None:
        self._db.close()

    def __enter__(self) -> Survey:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    @property
    def version(self) -> int:
        return self._db.schema_version()

    def watch(self) -> ChangeWatch:
        """A :class:`~usvips.store.change_watch.ChangeWatch` on the survey (its own connection, for a
        background thread): ``wait`` returns True as soon as another connection committed a change."""
        return self._db.watch()

    def derived_media_folder(self) -> Path:
        """Where seek proxies and exported frames are kept: beside a project file, a cache for a server."""
        return self._db.derived_media_folder()

    def copy_to(self, path: str | Path) -> Path:
        """A consistent copy of the whole survey as a new project file at ``path`` (each backend's own)."""
        raise ProjectError(f"{self.path}: this store cannot be copied to a file")

    # ---------------------------------------------------------------------------- transactions
    @contextmanager
    def transaction(self) -> Iterator[None]:
        """Group edits into one transaction: all of them are stored, or (on any error) none.

        Nested uses join the outermost one. Errors of the database become :class:`ProjectError`.
        """
        if self.read_only:
            raise ProjectError(f"{self.path}: opened read-only; nothing can be changed")
        if self._depth:
            self._depth += 1
            try:
                yield
            finally:
                self._depth -= 1
            return
        try:
            self._db.begin(write=True)
        except BackendError as error:
            raise ProjectError(f"{self.path}: cannot write the project: {error.problem} "
                               "(nothing was changed)") from None
        self._depth = 1
        try:
            yield
            self._db.commit()
        except BaseException as error:
            if self._db.in_transaction:
                with contextlib.suppress(ProjectError):
                    self._db.rollback()
            if isinstance(error, BackendError):
                raise ProjectError(f"{self.path}: cannot write the project: {error.problem} "
                                   "(nothing was changed)") from None
            raise
        finally:
            self._depth = 0

    @contextmanager
    def _reading(self) -> Iterator[None]:
        """One read transaction (a consistent snapshot while other programs write)."""
        own = not self._db.in_transaction
        try:
            if own:
                self._db.begin(write=False)
            yield
        except BackendError as error:
            raise ProjectError(f"{self.path}: cannot read the project: {error.problem}") from None
        finally:
            if own and self._db.in_transaction:
                with contextlib.suppress(ProjectError):
                    self._db.commit()

    def _query(self, sql: str, parameters=()) -> list[tuple]:
        """All rows of one query, with errors a person can act on."""
        try:
            return self._db.execute(sql, parameters).fetchall()
        except BackendError as error:
            raise ProjectError(f"{self.path}: cannot read the project: {error.problem}") from None

    def _edit(self, sql: str, parameters=()) -> Result:
        """One statement as one transaction (or part of the one in progress)."""
        with self.transaction():
            try:
                return self._db.execute(sql, parameters)
            except ConstraintError as error:
                raise ProjectError(f"{self.path}: {error.problem}") from None

    def _json(self, text: str, what: str):
        try:
            return json.loads(text)
        except (json.JSONDecodeError, TypeError, RecursionError):
            raise ProjectError(f"{self.path}: {what} is damaged (not valid JSON)") from None

    # ---------------------------------------------------------------------------- pairs
    def _relative(self, path: str | Path | None) -> str | None:
        if path is None:
            return None
        path = Path(path).resolve()
        try:
            return str(path.relative_to(self._db.media_folder.resolve()))
        except ValueError:
            return str(path)

    def add_pair(self, label: str, left: str | Path | None = None, right: str | Path | None = None,
                 medium: str = "water", frame: int | None = None, size: tuple[int, int] | None = None) -> int:
        checks.pair_images(label, left, right)
        try:
            hashes = [file_hash(Path(p)) if p is not None else None for p in (left, right)]
        except OSError as error:
            raise ProjectError(f"pair {label!r}: cannot read the image {error.filename}: "
                               f"{error.strerror or error}") from None
        width, height = size if size else (None, None)
        cursor = self._edit("INSERT INTO image_pairs (label, left_path, right_path, width, height, left_hash, "
                            "right_hash, frame, medium) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?) RETURNING id",
                            (label, self._relative(left), self._relative(right), width, height, *hashes, frame, medium))
        return int(cursor.fetchone()[0])

    def pairs(self) -> list[Pair]:
        rows = self._query("SELECT id, label, left_path, right_path, width, height, frame, medium "
                           "FROM image_pairs ORDER BY id")
        return [Pair(*row) for row in rows]

    def pair_id(self, label: str) -> int:
        rows = self._query("SELECT id FROM image_pairs WHERE label = ?", (label,))
        if not rows:
            raise ProjectError(f"{self.path}: no image pair {label!r}")
        return int(rows[0][0])

    def media_location(self, stored: str) -> Path:
        """Where a recorded media path should be, absolute, whether or not a file is there: a relative one
        resolved against the backend's media folder (a file project's folder; a server's media folder)."""
        return (self._db.media_folder / stored).resolve()

    def image_path(self, relative: str) -> Path:
        """The absolute path of a stored image path; raises if the image has gone missing."""
        path = (self._db.media_folder / relative).resolve()
        if not path.is_file():
            raise ProjectError(f"{self.path}: the image {relative} is missing (moved or deleted?)")
        return path

    # ---------------------------------------------------------------------------- calibrations
    def add_calibration(self, name: str, calibration: dict, active_for: tuple[str, ...] = ()) -> int:
        try:
            text = json.dumps(calibration, allow_nan=False)
        except (TypeError, ValueError) as error:
            raise ProjectError(f"{self.path}: cannot store the calibration {name!r}: {error}") from None
        sigma0 = calibration.get("sigma0_px")
        if not (isinstance(sigma0, int | float) and not isinstance(sigma0, bool)):
            sigma0 = None
        with self.transaction():
            try:
                cursor = self._db.execute("INSERT INTO calibrations (name, json, sigma0_px, created) "
                                          "VALUES (?, ?, ?, ?) RETURNING id", (name, text, sigma0, _now()))
            except ConstraintError as error:
                raise ProjectError(f"{self.path}: cannot store the calibration: {error.problem}") from None
            calibration_id = int(cursor.fetchone()[0])
            for label in active_for:
                self._db.execute(ACTIVATE,
                                 (self.pair_id(label), calibration_id))
        return calibration_id

    def calibration(self, calibration_id: int) -> dict:
        rows = self._query("SELECT json FROM calibrations WHERE id = ?", (calibration_id,))
        if not rows:
            raise ProjectError(f"{self.path}: no calibration {calibration_id}")
        data = self._json(rows[0][0], f"the stored calibration {calibration_id}")
        if not isinstance(data, dict):
            raise ProjectError(f"{self.path}: the stored calibration {calibration_id} is damaged (not an object)")
        return data

    def active_calibration(self, label: str) -> int | None:
        rows = self._query("SELECT calibration_id FROM active_calibrations WHERE pair_id = ?",
                           (self.pair_id(label),))
        return None if not rows else int(rows[0][0])

    # ---------------------------------------------------------------------------- control
    def set_control(self, control: ControlPoints, expected: object = UNREAD) -> None:
        sig = control.sigmas if control.sigmas is not None else np.full((len(control), 3), np.nan)
        rows = [(pid, *map(float, control.xyz[i]), *(None if np.isnan(v) else float(v) for v in sig[i]))
                for i, pid in enumerate(control.ids)]
        with self.transaction():
            self._refuse_changed("control points", self.control(), expected)
            self._db.execute("DELETE FROM control_points")
            try:
                self._db.executemany("INSERT INTO control_points (id, x, y, z, sx, sy, sz) "
                                     "VALUES (?, ?, ?, ?, ?, ?, ?)", rows)
            except ConstraintError as error:
                raise ProjectError(f"{self.path}: cannot store the control points: {error.problem}") from None

    def control(self) -> ControlPoints:
        rows = self._query(f"SELECT id, x, y, z, sx, sy, sz FROM control_points ORDER BY {self._db.insertion_order}")
        sigmas = None
        if rows and all(r[4] is not None for r in rows):
            sigmas = np.array([r[4:] for r in rows], dtype=float)
        return ControlPoints(tuple(r[0] for r in rows), np.array([r[1:4] for r in rows], float).reshape(-1, 3),
                             sigmas, str(self.path))

    def add_control_observations(self, observations: StereoObservations, role: str, pair: str,
                                 replace: bool = False, expected: object = UNREAD) -> None:
        """Store a pair's control observations for a role; ``replace`` swaps the stored set for this one
        in the same transaction (a calibration wizard saving what it used)."""
        with self.transaction():
            pair_id = self.pair_id(pair)
            self._refuse_changed(f"{role} observations of pair {pair!r}", self.control_observations(role, pair),
                                 expected)
            rows = [(pair_id, pid, *map(float, observations.left[i]), *map(float, observations.right[i]), role)
                    for i, pid in enumerate(observations.ids)]
            if replace:
                self._db.execute("DELETE FROM control_observations WHERE pair_id = ? AND role = ?",
                                 (pair_id, role))
            try:
                self._db.executemany("INSERT INTO control_observations (pair_id, point_id, xl, yl, xr, yr, role) "
                                     "VALUES (?, ?, ?, ?, ?, ?, ?)", rows)
            except ConstraintError as error:
                raise ProjectError(f"{self.path}: pair {pair!r}, role {role!r}: an observation of a point is "
                                   f"already stored ({error.problem}); nothing was imported") from None

    def control_observations(self, role: str, pair: str) -> StereoObservations:
        rows = self._query("SELECT point_id, xl, yl, xr, yr FROM control_observations WHERE role = ? AND "
                           "pair_id = ? ORDER BY id", (role, self.pair_id(pair)))
        return StereoObservations(tuple(r[0] for r in rows), np.array([r[1:3] for r in rows], float).reshape(-1, 2),
                                  np.array([r[3:5] for r in rows], float).reshape(-1, 2), (pair,) * len(rows))

    # ---------------------------------------------------------------------------- objects
    def add_object(self, kind: str, vertices: list[Vertex], attribute: str = "", notes: str = "",
                   creator: str = "") -> int:
        """Store one object (one transaction). ``kind`` is a registered measurement kind (or the legacy
        ``line``, stored as ``length`` or ``arc`` by its vertex count); its vertex count is checked."""
        return self.add_objects([(kind, vertices, attribute, notes, creator)])[0]

    def add_objects(self, objects: list[tuple[str, list[Vertex], str, str, str]]) -> list[int]:
        """Store several objects, each (kind, vertices, attribute, notes, creator), in ONE transaction:
        all of them or, on any error, none."""
        checked = []
        for kind, vertices, attribute, notes, creator in objects:
            checked.append((checks.object_kind(kind, vertices, self.path), vertices, attribute, notes,
                            creator or self.annotator))
        now = _now()
        with self.transaction():
            try:
                first = self._reserve_object_ids(len(checked))
                ids = list(range(first, first + len(checked)))
                # every row of every object as one batch, parents first (nothing of it is read back: a server
                # sends it with the next statement or the commit, in the same round trip)
                vertex_rows: list[tuple] = []
                frame_rows: list[tuple] = []
                known: dict[tuple[str, str], int] = {}
                for object_id, (_, vertices, _, _, _) in zip(ids, checked, strict=True):
                    rows, frames = self._vertex_rows(object_id, vertices, now, known=known)
                    vertex_rows += rows
                    frame_rows += frames
                self._db.write_later([
                    Statement("INSERT INTO objects (id, kind, attribute, notes, creator, created, modified) "
                              "VALUES (?, ?, ?, ?, ?, ?, ?)",
                              [(object_id, kind, attribute, notes, creator, now, now) for object_id,
                               (kind, _, attribute, notes, creator) in zip(ids, checked, strict=True)], many=True),
                    Statement(INSERT_VERTEX, vertex_rows, many=True),
                    Statement(INSERT_VERTEX_FRAMES, frame_rows, many=True),
                    Statement(INSERT_HISTORY, [self._history_row(object_id, "add", None,
                                                                 _object_state(kind, attribute, notes, vertices))
                                               for object_id, (kind, vertices, attribute, notes, _) in
                                               zip(ids, checked, strict=True)], many=True)])
            except ConstraintError as error:
                raise ProjectError(f"{self.path}: cannot store the object: {error.problem}") from None
        return ids

    def _reserve_object_ids(self, count: int) -> int:
        """The first of ``count`` new object ids, reserved from the counter (inside the caller's
        transaction): past every id an object or a history row ever held, so no id is ever used twice
        (a copied or pulled survey whose counter lags is caught up here)."""
        # the counter row's own ``next`` (not a subquery of it): a server re-reads the row it updates after
        # waiting for a concurrent writer's lock, so two writers never reserve the same ids
        floor = ("(SELECT max(v) FROM (SELECT coalesce(max(id), 0) + 1 AS v FROM objects "
                 "UNION ALL SELECT coalesce(max(object_id), 0) + 1 FROM history) AS floor)")
        row = self._db.execute(
            f"UPDATE id_counters SET next = ? + CASE WHEN next >= {floor} THEN next ELSE {floor} END "
            "WHERE name = 'objects' RETURNING next - ?", (int(count), int(count))).fetchone()
        if row is None:
            raise ProjectError(f"{self.path}: the project has no object counter; open it with this version "
                               "of USVIPS for writing once, so that it is brought up to date")
        return int(row[0])

    def _vertex_rows(self, object_id: int, vertices: list[Vertex], now: str,
                     kept: dict[tuple, tuple[str, str]] | None = None,
                     known: dict[tuple[str, str], int] | None = None) -> tuple[list[tuple], list[tuple]]:
        """The object's rows of ``vertices`` (:data:`INSERT_VERTEX`) and of their frames on a video
        (:data:`INSERT_VERTEX_FRAMES`). Each vertex is stamped with who picked it and when: this handle's
        annotator and ``now``, or for a vertex whose picks are unchanged (``kept``: its pick key → (creator,
        created)) the stamps it had. ``known``: the ids of pairs and videos already looked up (by ("pair",
        label) or ("video", label)), so that each is read once."""
        known = {} if known is None else known

        def id_of(what: str, label: str) -> int:
            if (what, label) not in known:
                known[(what, label)] = self.pair_id(label) if what == "pair" else int(self._video_row(label)[0])
            return known[(what, label)]

        rows, frames = [], []
        for i, v in enumerate(vertices):
            xyz = v.xyz if v.xyz is not None else (None, None, None)
            cov = json.dumps(np.asarray(v.covariance, float).reshape(9).tolist()) if v.covariance is not None else None
            pair_id = id_of("pair", v.pair) if v.pair else None
            creator, created = (kept or {}).get((i, *_pick_key(v)), (self.annotator, now))
            rows.append((object_id, i, pair_id, v.xl, v.yl, v.xr, v.yr, *xyz, cov, v.calibration_id, creator, created,
                         *_pointing_row(v, self.path)))
            if v.video is None:
                continue
            if v.frame_left is None or v.frame_right is None or v.time_s is None:
                raise ProjectError(f"vertex {i}: a vertex on video {v.video!r} needs its left and right frames "
                                   "and time")
            frames.append((object_id, i, id_of("video", v.video), int(v.frame_left), int(v.frame_right),
                           float(v.time_s)))
        return rows, frames

    # ---------------------------------------------------------------------------- who and when (schema 8)
    def _log(self, object_id: int, change: str, old: dict | None, new: dict | None) -> None:
        """Append one row to the history (inside the caller's transaction): never updated or deleted
        afterwards (the schema's triggers refuse it; the store only ever INSERTs here)."""
        self._db.execute(INSERT_HISTORY, self._history_row(object_id, change, old, new))

    def _history_row(self, object_id: int, change: str, old: dict | None, new: dict | None) -> tuple:
        """One history row (:data:`INSERT_HISTORY`): now, this handle's annotator, the object, the change and
        its old and new value."""
        return (_now(), self.annotator, int(object_id), change, _history_json(old), _history_json(new))

    def _last_change(self, object_id: int) -> str:
        """Who last changed an object, what and when, from the history ('' before schema 8)."""
        if not self._has_table("history"):
            return ""
        row = self._db.execute("SELECT annotator, change, at FROM history WHERE object_id = ? ORDER BY id DESC "
                               "LIMIT 1", (int(object_id),)).fetchone()
        return "" if row is None else f"last change: {row[1]} by {row[0] or 'an unnamed annotator'} at {row[2]}"

    def _refuse_stale(self, stored: StoredObject, expected_modified: str | None) -> None:
        """:func:`refuse_stale` naming who made the last change (inside the caller's transaction)."""
        self._refuse_stale_version(stored.id, stored.modified, expected_modified)

    def _refuse_stale_version(self, object_id: int, modified: str, expected_modified: str | None) -> None:
        """An edit of the object ``object_id``, now at version ``modified``, made on it as read at
        ``expected_modified`` is refused when they differ, naming who made the last change."""
        if expected_modified is not None and modified != expected_modified:
            versions.refuse_stale_object(self.path, int(object_id), modified, expected_modified,
                                         self._last_change(object_id))

    def _refuse_changed(self, item: str, stored: object, expected: object) -> None:
        """Inside the caller's write transaction: a project-wide ``item`` (the campaign, a deployment …)
        whose ``stored`` value is not the one the writer read (``expected``) is refused by name (who last
        wrote it and when); else this write is stamped as the last one of ``item``. See
        :mod:`usvips.store.versions`."""
        key = versions.stamp_key(item)
        if not versions.same_version(stored, expected):
            row = self._db.execute("SELECT value FROM meta WHERE key = ?", (key,)).fetchone()
            versions.refuse_changed(self.path, item, None if row is None else row[0])
        self._db.execute(PUT_META, (key, versions.stamp_value(self.annotator,
                                                                                                 _now())))

    def history(self, object_id: int | None = None) -> list[HistoryEntry]:
        """Every recorded change (of one object when ``object_id`` is given, also after it was deleted),
        oldest first; empty for a project older than schema 8 opened read-only."""
        if not self._has_table("history"):
            return []
        where, parameters = ("WHERE object_id = ?", (int(object_id),)) if object_id is not None else ("", ())
        rows = self._query(f"SELECT id, at, annotator, object_id, change, old, new FROM history {where} ORDER BY id",
                           parameters)
        return self._history_entries(rows)

    def last_change_id(self) -> int:
        """The id of the newest history row (0 when there is none, or before schema 8)."""
        if not self._has_table("history"):
            return 0
        return int(self._query("SELECT COALESCE(MAX(id), 0) FROM history")[0][0])

    def changes_since(self, after: int, limit: int = 10000) -> list[HistoryEntry]:
        """The history rows with an id above ``after``, oldest first, at most ``limit`` of them (the change
        feed: a reader keeps the last id it has seen; see :meth:`watch`)."""
        if not self._has_table("history"):
            return []
        rows = self._query("SELECT id, at, annotator, object_id, change, old, new FROM history WHERE id > ? "
                           "ORDER BY id LIMIT ?", (int(after), max(0, int(limit))))
        return self._history_entries(rows)

    def _history_entries(self, rows: list[tuple]) -> list[HistoryEntry]:
        return [HistoryEntry(int(r[0]), r[1], r[2], int(r[3]), r[4],
                             None if r[5] is None else self._json(r[5], f"history entry {r[0]}"),
                             None if r[6] is None else self._json(r[6], f"history entry {r[0]}")) for r in rows]

    def provenance(self, object_id: int) -> Provenance:
        """Who made what of an object and when: ``object`` (creator, created, modified), ``vertices`` (one
        (creator, created) per vertex, in order: who picked it) and ``record`` ((creator, created) of the
        observation record as it stands, None when there is none). Times are ISO 8601 UTC text."""
        if not self._has_table("history"):  # before schema 8 (read-only): only the object was stamped
            stored = self.object(object_id)
            return Provenance((stored.creator, stored.created, stored.modified), [("", "")] * len(stored.vertices),
                              None)
        with self._reading():
            stored = self.object(object_id)
            vertices = [tuple(r) for r in self._db.execute(
                "SELECT creator, created FROM vertices WHERE object_id = ? ORDER BY idx", (object_id,)).fetchall()]
            record = self._db.execute("SELECT creator, created FROM observation_records WHERE object_id = ?",
                                      (object_id,)).fetchone()
        return Provenance((stored.creator, stored.created, stored.modified), vertices,
                          None if record is None else tuple(record))

    def _full_state(self, object_id: int) -> dict:
        """An object as the history shows it: kind, attribute, notes, vertices, observation record."""
        stored = self.object(object_id)
        state = _object_state(stored.kind, stored.attribute, stored.notes, list(stored.vertices))
        state["creator"] = stored.creator
        record = self.record(object_id)
        if record is not None:
            state["record"] = dataclasses.asdict(record)
        review = self.review(object_id)
        if review.state != "unreviewed":
            state["review"] = _review_state(review)
        return state

    # ---------------------------------------------------------------------------- reviews (schema 9)
    def set_review(self, object_id: int, state: str, reason: str = "", expected_modified: str | None = None) -> None:
        """Set an object's review state (see :meth:`ProjectStore.set_review`): one transaction that stores
        the review with this handle's annotator and the time, moves the object's ``modified`` stamp forward
        and appends one 'review' row (old and new state) to the history. The state and reason it already
        has (an accepted object accepted again): nothing is written."""
        state, reason = checks.review(object_id, state, reason, self.path)
        with self.transaction():
            stored = self.object(object_id)
            self._refuse_stale(stored, expected_modified)
            old = self.review(object_id)
            if (old.state, old.reason) == (state, reason):  # already so: no history row, no new version
                return
            now = _later(stored.modified)
            if state == "unreviewed":
                self._db.execute("DELETE FROM reviews WHERE object_id = ?", (object_id,))
            else:
                self._db.execute(upsert("reviews", ("object_id", "state", "reason", "reviewer", "reviewed"),
                                        ("object_id",)), (object_id, state, reason, self.annotator, now))
            self._db.execute("UPDATE objects SET modified = ? WHERE id = ?", (now, object_id))
            self._log(object_id, "review", _review_state(old), _review_state(self.review(object_id)))

    def _unaccepted(self, object_id: int, old: Review) -> list[Statement]:
        """Inside the caller's transaction, after an edit of what a review looked at (:data:`REVIEWED_FIELDS`, the
        observation record) of an object whose review is ``old``: an accepted object goes back to unreviewed, and
        the history gains a 'review' row by the editor, accepted → unreviewed with the reason
        :data:`EDITED_AFTER_REVIEW`; the statements that write it. A flagged object stays flagged (its reason
        still stands until a reviewer looks again): nothing."""
        if old.state != "accepted":
            return []
        return [Statement("DELETE FROM reviews WHERE object_id = ?", (object_id,)),
                Statement(INSERT_HISTORY, self._history_row(object_id, "review", _review_state(old),
                                                            {"state": "unreviewed", "reason": EDITED_AFTER_REVIEW}))]

    def review(self, object_id: int) -> Review:
        """An object's review (unreviewed when none was made, or before schema 9); an unknown id is a
        ``ProjectError``."""
        if self.read_only and not self._has_table("reviews"):  # a writing handle is of the current schema
            self.object(object_id)
            return Review(int(object_id))
        rows = self._query("SELECT o.id, r.state, r.reason, r.reviewer, r.reviewed FROM objects o LEFT JOIN reviews r "
                           "ON r.object_id = o.id WHERE o.id = ?", (int(object_id),))  # one query: the window
        if not rows:                                                                   # re-reads it often
            raise ProjectError(f"{self.path}: no object {object_id}")
        return Review(int(object_id)) if rows[0][1] is None else Review(int(object_id), *rows[0][1:])

    def reviews(self, state: str | None = None) -> list[Review]:
        """The review of every object (unreviewed ones included), by object id; with ``state`` only the
        objects in that state. One consistent read."""
        if state is not None and state not in REVIEW_STATES:
            raise ProjectError(f"{self.path}: unknown review state {state!r} (one of {', '.join(REVIEW_STATES)})")
        with self._reading():
            ids = [int(r[0]) for r in self._db.execute("SELECT id FROM objects ORDER BY id").fetchall()]
            rows = {} if not self._has_table("reviews") else {
                int(r[0]): r[1:] for r in self._db.execute(
                    "SELECT object_id, state, reason, reviewer, reviewed FROM reviews").fetchall()}
        found = [Review(i, *rows[i]) if i in rows else Review(i) for i in ids]
        return found if state is None else [r for r in found if r.state == state]

    def update_object(self, object_id: int, attribute: str | None = None, notes: str | None = None,
                      vertices: list[Vertex] | None = None, kind: str | None = None,
                      expected_modified: str | None = None) -> None:
        """Change an object in one transaction; replaced 3-D values go to the vertex history. ``kind``: a
        registered measurement kind that suits the (new) vertex count. ``expected_modified``: see
        :meth:`ProjectStore.update_object` (a stale edit is refused). An accepted object whose kind,
        attribute or vertices changed goes back to unreviewed in the same transaction (a second history
        row, 'review', see :meth:`_unaccepted`); notes alone do not.

        Few round trips on a server: what the edit needs is read at once (the object, its vertices' stamps,
        its review, the pairs and videos the new vertices name), the writes are held and go with the
        re-read of the object as changed, and its history rows with the commit."""
        with self.transaction():
            stored, kept, review, known = self._edit_reads(object_id, vertices)
            self._refuse_stale(stored, expected_modified)
            before = _object_state(stored.kind, stored.attribute, stored.notes, list(stored.vertices))
            if kind is not None:
                count = len(vertices) if vertices is not None else len(stored.vertices)
                try:
                    kind = checks.kind_for_count(kind, count)
                except UsvipsError as error:
                    raise ProjectError(f"{self.path}: object {object_id}: {error}") from None
            changes = [(name, value) for name, value in (("kind", kind), ("attribute", attribute), ("notes", notes))
                       if value is not None] + [("modified", _later(stored.modified))]
            writes = [Statement(f"UPDATE objects SET {', '.join(f'{name} = ?' for name, _ in changes)} WHERE id = ?",
                                (*(value for _, value in changes), object_id))]
            if vertices is not None:
                vertices = [_kept_pointing(v, stored.vertices[i]) if i < len(stored.vertices) else v
                            for i, v in enumerate(vertices)]
                rows, frames = self._vertex_rows(object_id, vertices, _now(), kept, known)
                writes += [Statement("INSERT INTO vertex_history (object_id, idx, x, y, z, covariance, calibration_id, "
                                     "replaced) SELECT object_id, idx, x, y, z, covariance, calibration_id, ? "
                                     "FROM vertices WHERE object_id = ? AND x IS NOT NULL", (_now(), object_id)),
                           Statement("DELETE FROM vertices WHERE object_id = ?", (object_id,)),
                           Statement(INSERT_VERTEX, rows, many=True),
                           Statement(INSERT_VERTEX_FRAMES, frames, many=True)]
            self._db.write_later(writes)
            changed = self.object(object_id)
            after = _object_state(changed.kind, changed.attribute, changed.notes, list(changed.vertices))
            given = [name for name, value in (("kind", kind), ("attribute", attribute), ("notes", notes),
                                              ("vertices", vertices)) if value is not None]
            history = [Statement(INSERT_HISTORY, self._history_row(
                object_id, "re-pick" if vertices is not None else "edit", {name: before[name] for name in given},
                {name: after[name] for name in given}))]
            if any(before[name] != after[name] for name in given if name in REVIEWED_FIELDS):
                history += self._unaccepted(object_id, review)
            self._db.write_later(history)

    def _edit_reads(self, object_id: int, vertices: list[Vertex] | None
                    ) -> tuple[StoredObject, dict[tuple, tuple[str, str]] | None, Review, dict[tuple[str, str], int]]:
        """What :meth:`update_object` reads before it writes, in one batch (one round trip on a server): the
        object as stored, its vertices' stamps by pick (when ``vertices`` are given: see :meth:`_vertex_rows`),
        its review, and the ids of the pairs and videos ``vertices`` name (by ("pair" or "video", label);
        one that does not exist is left out, for :meth:`_vertex_rows` to refuse by name)."""
        queries = self._object_queries("WHERE id = ?", (int(object_id),))
        queries.append(Statement("SELECT o.id, r.state, r.reason, r.reviewer, r.reviewed FROM objects o LEFT JOIN "
                                 "reviews r ON r.object_id = o.id WHERE o.id = ?", (int(object_id),)))
        looked_up = []
        if vertices is not None:
            queries.append(Statement("SELECT creator, created FROM vertices WHERE object_id = ? ORDER BY idx",
                                     (int(object_id),)))
            for what, table in (("pair", "image_pairs"), ("video", "videos")):
                labels = sorted({getattr(v, what) for v in vertices if getattr(v, what)})
                if labels:
                    queries.append(Statement(f"SELECT label, id FROM {table} WHERE label IN "
                                             f"({', '.join('?' * len(labels))})", tuple(labels)))
                    looked_up.append(what)
        results = self._db.batch(queries)
        count = len(queries) - len(looked_up) - (2 if vertices is not None else 1)
        found = self._stored_objects(results[:count])
        if not found:
            raise ProjectError(f"{self.path}: no object {object_id}")
        stored = found[0]
        review_row = results[count].fetchone()
        review = Review(int(object_id)) if review_row[1] is None else Review(int(object_id), *review_row[1:])
        kept = None
        if vertices is not None:
            kept = {(i, *_pick_key(v)): (row[0], row[1])
                    for i, (v, row) in enumerate(zip(stored.vertices, results[count + 1].fetchall(), strict=True))}
        known = {(what, label): int(identifier) for what, result in zip(looked_up, results[count + 2:], strict=True)
                 for label, identifier in result.fetchall()}
        return stored, kept, review, known

    def delete_object(self, object_id: int, expected_modified: str | None = None) -> None:
        with self.transaction():
            self._refuse_stale(self.object(object_id), expected_modified)
            old = self._full_state(object_id)
            self._edit("DELETE FROM objects WHERE id = ?", (object_id,))
            self._log(object_id, "delete", old, None)

    def object_rows(self, object_id: int) -> RemovedObject:
        """Everything stored of one object, row for row (read only), for :meth:`put_back` to restore: an
        undo of an edit puts back exactly what was there (no history row is added by the undo)."""
        with self._reading():
            self.object(object_id)
            rows = []
            for table, key in _OBJECT_TABLES:
                if self._has_table(table):
                    cursor = self._db.execute(f"SELECT * FROM {table} WHERE {key} = ?", (object_id,))
                    rows.append((table, cursor.columns, tuple(cursor.fetchall())))
        return RemovedObject(object_id, tuple(rows))

    def _remove_rows(self, object_id: int) -> None:
        self._db.execute("DELETE FROM objects WHERE id = ?", (object_id,))
        for table, key in _OBJECT_TABLES[1:]:  # also where foreign keys are not enforced
            if self._has_table(table):
                self._db.execute(f"DELETE FROM {table} WHERE {key} = ?", (object_id,))

    def take_object(self, object_id: int, expected_modified: str | None = None) -> RemovedObject:
        """Delete an object (one transaction) and return everything that went with it, for
        :meth:`put_back` (undo of a delete gives back the same id, record and history).
        ``expected_modified``: as for :meth:`update_object` (a stale take is a ``StaleEditError``)."""
        with self.transaction():
            self._refuse_stale(self.object(object_id), expected_modified)
            removed = self.object_rows(object_id)
            old = self._full_state(object_id)
            self._remove_rows(object_id)
            self._log(object_id, "delete", old, None)
        return removed

    def put_back(self, removed: RemovedObject, replace: bool = False, expected_modified: str | None = None) -> None:
        """Restore an object as :meth:`take_object` or :meth:`object_rows` found it, row for row (same id).
        With ``replace`` whatever is stored under that id now is replaced; without, a used id is refused
        (a ``StaleEditError`` naming who made it). ``expected_modified`` (an undo or redo of an edit): the
        object must still be stored at that version — it is then replaced; changed or deleted since by
        someone else is a ``StaleEditError`` naming the object and who, and nothing is changed."""
        with self.transaction():
            old = None
            exists = self._db.execute("SELECT 1 FROM objects WHERE id = ?", (removed.object_id,)).fetchone()
            if expected_modified is not None:
                if not exists:
                    raise StaleEditError(f"{self.path}: object {removed.object_id} was deleted by someone else "
                                         f"since it was read ({self._last_change(removed.object_id)}); nothing "
                                         "was changed")
                self._refuse_stale(self.object(removed.object_id), expected_modified)
                replace = True
            if exists:
                if not replace:
                    raise StaleEditError(f"{self.path}: object {removed.object_id} exists again "
                                         f"({self._last_change(removed.object_id)}); it cannot be put back "
                                         "(nothing was changed)")
                old = self._full_state(removed.object_id)
                self._remove_rows(removed.object_id)
            try:
                for table, columns, values in removed.rows:
                    if values:
                        self._db.executemany(f"INSERT INTO {table} ({', '.join(columns)}) VALUES "
                                             f"({', '.join('?' * len(columns))})", values)
            except BackendError as error:
                raise ProjectError(f"{self.path}: object {removed.object_id} cannot be put back: "
                                   f"{error.problem} (nothing was changed)") from None
            self._log(removed.object_id, "put back", old, self._full_state(removed.object_id))

    def object(self, object_id: int) -> StoredObject:
        found = self._objects("WHERE id = ?", (object_id,))
        if not found:
            raise ProjectError(f"{self.path}: no object {object_id}")
        return found[0]

    def objects(self) -> list[StoredObject]:
        """Every object, read in one transaction (a consistent snapshot while another program edits)."""
        return self._objects("", ())

    def objects_with_ids(self, object_ids: Sequence[int]) -> list[StoredObject]:
        """The objects of ``object_ids`` that exist, by id, read by one query in one transaction (the
        window re-reads just what an edit changed; an id no longer stored is simply absent)."""
        ids = sorted({int(i) for i in object_ids})
        found: list[StoredObject] = []
        for start in range(0, len(ids), 500):  # SQLite's limit on bound parameters
            chunk = tuple(ids[start:start + 500])
            found.extend(self._objects(f"WHERE id IN ({', '.join('?' * len(chunk))})", chunk))
        return found

    def objects_on(self, pair: str, first_frame: int | None = None, last_frame: int | None = None
                   ) -> list[StoredObject]:
        where = ("WHERE id IN (SELECT v.object_id FROM vertices v JOIN image_pairs p ON p.id = v.pair_id "
                 "WHERE v.idx = 0 AND p.label = ?)")
        parameters: tuple = (str(pair),)
        if (first_frame is None) != (last_frame is None):
            raise InvalidParameterError("last_frame" if last_frame is None else "first_frame",
                                        "give both the first and the last frame, or neither")
        if first_frame is not None:
            if not self._has_table("vertex_frames"):
                return []
            where += (" AND id IN (SELECT object_id FROM vertex_frames WHERE idx = 0 AND frame_left >= ? "
                      "AND frame_left <= ?)")
            parameters += (int(first_frame), int(last_frame))
        return self._objects(where, parameters)

    def _objects(self, where: str, parameters: tuple) -> list[StoredObject]:
        with self._reading():
            return self._stored_objects(self._db.batch(self._object_queries(where, parameters)))

    def _object_queries(self, where: str, parameters: tuple) -> list[Statement]:
        """The reads of the objects ``where`` selects (their rows, vertices and — on a video — frames), for
        one :meth:`Backend.batch` (one round trip on a server); :meth:`_stored_objects` makes the objects."""
        wanted = f"WHERE v.object_id IN (SELECT id FROM objects {where})" if where else ""
        pointing = POINTING_COLUMNS if self._has_pointing() else POINTING_BEFORE_11
        queries = [Statement("SELECT id, kind, attribute, notes, creator, created, modified FROM objects "
                             f"{where} ORDER BY id", parameters),
                   Statement("SELECT v.object_id, v.xl, v.yl, v.xr, v.yr, v.x, v.y, v.z, v.covariance, "
                             f"v.calibration_id, p.label, {pointing} FROM vertices v LEFT JOIN image_pairs p "
                             f"ON p.id = v.pair_id {wanted} ORDER BY v.object_id, v.idx", parameters)]
        if self._has_table("vertex_frames"):  # (none in a project older than schema 4, opened read-only)
            frames = f"WHERE f.object_id IN (SELECT id FROM objects {where})" if where else ""
            queries.append(Statement("SELECT f.object_id, f.idx, v.label, f.frame_left, f.frame_right, f.time_s "
                                     f"FROM vertex_frames f JOIN videos v ON v.id = f.video_id {frames}", parameters))
        return queries

    def _stored_objects(self, results: Sequence[Result]) -> list[StoredObject]:
        """The objects read by the results of :meth:`_object_queries` (the rows, vertices and frames)."""
        rows, vertex_rows = results[0].fetchall(), results[1].fetchall()
        frame_rows = results[2].fetchall() if len(results) > 2 else []
        frames = {(r[0], r[1]): dict(zip(("video", "frame_left", "frame_right", "time_s"), r[2:], strict=True))
                  for r in frame_rows}
        covariances = self._covariances(vertex_rows)
        vertices: dict[int, list[Vertex]] = {}
        for v, cov in zip(vertex_rows, covariances, strict=True):
            own = vertices.setdefault(v[0], [])
            on_video = frames.get((v[0], len(own)), {}) if frames else {}
            own.append(Vertex(v[1], v[2], v[3], v[4], None if v[5] is None else (v[5], v[6], v[7]), cov, v[9], v[10],
                              **_pointing_fields(v[11:]), **on_video))
        return [StoredObject(*row, vertices=tuple(vertices.get(row[0], ()))) for row in rows]

    def _covariances(self, vertex_rows: list[tuple]) -> list[np.ndarray | None]:
        """Each vertex row's covariance (its column 8: the JSON of 9 numbers, m²) as a 3 × 3 array, None where
        none is stored. All are parsed at once — one ``json.loads`` and one array for the lot, each vertex
        given its own 3 × 3 block of it (20,000 parses were most of reading a survey) — and, when that
        fails, one by one, so that a damaged covariance is named by its object."""
        texts = [v[8] for v in vertex_rows if v[8] is not None]
        blocks = None
        if texts:
            try:
                block = np.array(json.loads(f"[{','.join(texts)}]"), dtype=float)
                if block.ndim >= 2 and block.shape[0] == len(texts) and block.size == 9 * len(texts):
                    blocks = iter(block.reshape(len(texts), 3, 3))
            except (ValueError, TypeError, RecursionError):
                blocks = None  # a damaged one among them: found below
        if blocks is None:
            blocks = iter([self._covariance(v[0], v[8]) for v in vertex_rows if v[8] is not None])
        return [None if v[8] is None else next(blocks) for v in vertex_rows]

    def _covariance(self, object_id: int, text: str) -> np.ndarray:
        """One stored covariance (JSON of 9 numbers) as a 3 × 3 array; damaged: a ``ProjectError`` naming
        the object."""
        values = self._json(text, f"object {object_id}: a stored covariance")
        try:
            return np.array(values, dtype=float).reshape(3, 3)
        except (TypeError, ValueError):
            raise ProjectError(f"{self.path}: object {object_id}: a stored covariance is damaged "
                               "(not 9 numbers)") from None

    # ---------------------------------------------------------------------------- instants (schema 7)
    def add_instant(self, object_id: int, instant_id: int, tracked_from: int | None = None,
                    expected_modified: str | None = None) -> None:
        """Make the stored object ``instant_id`` a further instant of ``object_id`` (see
        :meth:`ProjectStore.add_instant`)."""
        if tracked_from is not None and (isinstance(tracked_from, bool) or not isinstance(tracked_from, Integral)
                                         or tracked_from < 0):
            raise ProjectError(f"{self.path}: object {instant_id}: tracked from frame {tracked_from!r}; the frame a "
                               "track started from is a whole number >= 0")
        with self.transaction():
            whole, instant = self.object(object_id), self.object(instant_id)
            self._refuse_stale(instant, expected_modified)
            if object_id == instant_id:
                raise ProjectError(f"{self.path}: object {object_id} cannot be an instant of itself")
            if whole.kind != instant.kind:
                raise ProjectError(f"{self.path}: object {instant_id} is a {instant.kind}, object {object_id} a "
                                   f"{whole.kind}: the instants of an object are of one kind")
            links = self.instant_links_of((object_id, instant_id))  # (these ids' links, not a survey's)
            if object_id in links:
                raise ProjectError(f"{self.path}: object {object_id} is itself an instant of object "
                                   f"{links[object_id]}; add the instant to that object")
            if instant_id in links:
                raise ProjectError(f"{self.path}: object {instant_id} is already an instant of object "
                                   f"{links[instant_id]}")
            if any(of == instant_id for of in links.values()):
                raise ProjectError(f"{self.path}: object {instant_id} has instants of its own; add them to "
                                   f"object {object_id} one by one")
            tracked = None if tracked_from is None else int(tracked_from)
            self._edit("INSERT INTO object_instants (object_id, of_object, tracked_from) VALUES (?, ?, ?)",
                       (instant_id, object_id, tracked))
            self._db.execute("UPDATE objects SET modified = ? WHERE id = ?", (_later(instant.modified), instant_id))
            self._log(instant_id, "edit", {"instant_of": None}, _link(object_id, tracked))

    def remove_instant(self, instant_id: int, expected_modified: str | None = None) -> None:
        """Unlink an instant: it stays, as an object of its own (its ``modified`` stamp moves forward;
        ``expected_modified`` as for :meth:`update_object`)."""
        with self.transaction():
            instant = self.object(instant_id)
            self._refuse_stale(instant, expected_modified)
            of = self.instant_links().get(int(instant_id))
            tracked = self.instant_sources(of).get(int(instant_id)) if of is not None else None
            if of is None or self._edit("DELETE FROM object_instants WHERE object_id = ?", (instant_id,)).rowcount == 0:
                raise ProjectError(f"{self.path}: object {instant_id} is not an instant of another object")
            self._db.execute("UPDATE objects SET modified = ? WHERE id = ?", (_later(instant.modified), instant_id))
            self._log(instant_id, "edit", _link(of, tracked), {"instant_of": None})

    def instants(self, object_id: int) -> list[int]:
        """The ids of the further instants of ``object_id`` (its first instant is itself), by id."""
        if not self._has_table("object_instants"):
            return []
        return [r[0] for r in self._query("SELECT object_id FROM object_instants WHERE of_object = ? "
                                          "ORDER BY object_id", (int(object_id),))]

    def instant_links_of(self, object_ids: Sequence[int]) -> dict[int, int]:
        ids = sorted({int(i) for i in object_ids})
        if not ids or not self._has_table("object_instants"):
            return {}
        links: dict[int, int] = {}
        for start in range(0, len(ids), 250):  # (SQLite's limit on bound parameters: each id is bound twice)
            chunk = tuple(ids[start:start + 250])
            marks = ", ".join("?" * len(chunk))
            links.update(self._query(f"SELECT object_id, of_object FROM object_instants WHERE object_id IN ({marks}) "
                                     f"OR of_object IN ({marks})", chunk + chunk))
        return dict(sorted(links.items()))

    def instant_links(self) -> dict[int, int]:
        """Every further instant's id → the id of the object it is an instant of (none before schema 7)."""
        if not self._has_table("object_instants"):
            return {}
        return dict(self._query("SELECT object_id, of_object FROM object_instants ORDER BY object_id"))

    def instant_sources(self, object_id: int | None = None) -> dict[int, int | None]:
        """How each further instant was made (schema 10): its id → the left frame its track started from,
        None when picked by hand; of ``object_id``, or of every object when None (one query)."""
        if not self._has_table("object_instants"):
            return {}
        source = "i.tracked_from"
        if self.version < 10:  # a read-only open of an older project: what its migration will store
            source = ("CASE WHEN o.notes GLOB 'tracked from frame [0-9]*' THEN CAST(substr(o.notes, 20) AS INTEGER) "
                      "END")
        where, parameters = ("", ()) if object_id is None else ("WHERE i.of_object = ? ", (int(object_id),))
        return dict(self._query(f"SELECT i.object_id, {source} FROM object_instants i LEFT JOIN objects o "
                                f"ON o.id = i.object_id {where}ORDER BY i.object_id", parameters))

    def vertex_history(self, object_id: int) -> list[tuple]:
        return self._query("SELECT idx, x, y, z, calibration_id, replaced FROM vertex_history "
                           "WHERE object_id = ? ORDER BY id", (object_id,))

    # ---------------------------------------------------------------------------- vocabulary, settings
    def add_term(self, term: str, category: str = "attribute") -> None:
        self._edit("INSERT INTO vocabulary (term, category) VALUES (?, ?) ON CONFLICT DO NOTHING", (term, category))

    def vocabulary(self, category: str = "attribute") -> list[str]:
        return [r[0] for r in self._query("SELECT term FROM vocabulary WHERE category = ? ORDER BY term",
                                          (category,))]

    def set_enhancement(self, image_key: str, pipeline_json: str, expected: object = UNREAD) -> None:
        with self.transaction():
            self._refuse_changed(f"enhancement of {image_key!r}", self.enhancement(image_key), expected)
            self._edit(upsert("enhancements", ("image_key", "pipeline"), ("image_key",)), (image_key, pipeline_json))

    def set_draft(self, name: str, text: str | None, expected: object = UNREAD) -> None:
        """Keep (or, with None, drop) a half-finished piece of work, e.g. a calibration wizard's state."""
        with self.transaction():
            self._refuse_changed(f"draft {name!r}", self.draft(name), expected)
            if text is None:
                self._edit("DELETE FROM meta WHERE key = ?", (f"draft:{name}",))
            else:
                self._edit(PUT_META, (f"draft:{name}", text))

    def draft(self, name: str) -> str | None:
        rows = self._query("SELECT value FROM meta WHERE key = ?", (f"draft:{name}",))
        return None if not rows else rows[0][0]

    def calibrations(self) -> list[StoredCalibration]:
        """id, name, phase, sigma0_px and created of every stored calibration, oldest first."""
        rows = self._query("SELECT id, name, json, sigma0_px, created FROM calibrations ORDER BY id")
        result = []
        for r in rows:
            data = self._json(r[2], f"the stored calibration {r[0]}")
            result.append(StoredCalibration(int(r[0]), r[1], data.get("phase") if isinstance(data, dict) else None,
                                            r[3], r[4]))
        return result

    def enhancement(self, image_key: str) -> str | None:
        rows = self._query("SELECT pipeline FROM enhancements WHERE image_key = ?", (image_key,))
        return None if not rows else rows[0][0]


    # ---------------------------------------------------------------------------- media (schema 4)
    def _media(self, path: str | Path) -> str:
        """Record a media file's size and SHA-256 (inside the caller's transaction); returns the stored
        (relative when inside the project's folder) path."""
        path = Path(path)
        if not path.is_file():
            raise ProjectError(f"{path}: no such media file")
        stored = self._relative(path)
        self._db.execute(upsert("media", ("path", "size", "sha256"), ("path",)),
                         (stored, path.stat().st_size, file_hash(path)))
        self._db.execute(PUT_META, (_sample_key(stored), sampled_hash(path)))
        return stored

    def media_identity(self, stored: str, full: bool = False) -> str | None:
        """Why the file at a recorded media path is not the one added — missing, another size, other
        content — or None when it is. The fast check (``full`` False) compares the size and the sampled
        hash (:func:`sampled_hash`; a project from before sampled hashes compares the full SHA-256 once
        and, when writable, records the sample); ``full`` compares the whole file's SHA-256."""
        row = self._db.execute("SELECT size, sha256 FROM media WHERE path = ?", (stored,)).fetchone()
        path = self._db.media_folder / stored
        if not path.is_file():
            return "missing (moved or deleted?)"
        if row is None:
            return None  # not a recorded media file (nothing to compare with)
        size, sha = row
        now = path.stat().st_size
        if now != size:
            return f"{now} bytes, but {size} when it was added"
        sample = self._db.execute("SELECT value FROM meta WHERE key = ?", (_sample_key(stored),)).fetchone()
        if sample is not None and sampled_hash(path) != sample[0]:
            return "its contents differ from the file added (sampled hash; same size)"
        if full or sample is None:
            if file_hash(path) != sha:
                return "its contents differ from the file added (SHA-256; same size)"
            if sample is None and not self.read_only:
                with contextlib.suppress(ProjectError):
                    self._edit(PUT_META, (_sample_key(stored), sampled_hash(path)))
        return None

    def media_records(self) -> list[tuple[str, Path, int, str]]:
        """(stored path, where it should be, size in bytes, SHA-256) of every recorded media file: what a
        worker needs to compare whole files away from the project's connection
        (:func:`usvips.app.video_project.verify_media`)."""
        if not self._has_table("media"):
            return []
        rows = self._query("SELECT path, size, sha256 FROM media ORDER BY path")
        return [(stored, self._db.media_folder / stored, int(size), sha) for stored, size, sha in rows]

    def _refuse_changed_media(self, stored: str, expected_sha256: str | None) -> None:
        """Inside the caller's write transaction: a recorded media file gone (relocated) or accepted anew
        since the writer read its SHA-256 ``expected_sha256`` is refused by name; else this write is
        stamped as the file's last change."""
        row = self._db.execute("SELECT sha256 FROM media WHERE path = ?", (stored,)).fetchone()
        if row is None:
            stamp = self._db.execute("SELECT value FROM meta WHERE key = ?",
                                     (versions.stamp_key(f"media file {stored}"),)).fetchone()
            if stamp is not None:
                versions.refuse_changed(self.path, f"media file {stored}", stamp[0])
            raise ProjectError(f"{self.path}: no media file {stored!r} in the project")
        self._refuse_changed(f"media file {stored}", row[0], UNREAD if expected_sha256 is None else expected_sha256)

    def accept_media(self, stored: str, expected_sha256: str | None = None,
                     hashed: tuple[int, str, str] | None = None) -> None:
        """Take the file now at a recorded media path as the one the project means (after the user has
        looked at it): its size, SHA-256 and sampled hash are recorded anew. ``expected_sha256``: the
        SHA-256 recorded when the caller read it (:meth:`media_records`); accepted or relocated since by
        someone else is a ``StaleEditError`` naming who and when. ``hashed``: (size in bytes, SHA-256,
        sampled hash) of the file as the caller read it (a worker hashes a large file away from the window);
        the file is then not read whole again, and one whose size or sampled hash differs from those is
        refused as changed since it was read; None: the file is hashed here."""
        if self._db.execute("SELECT 1 FROM media WHERE path = ?", (stored,)).fetchone() is None:
            with self.transaction():
                self._refuse_changed_media(stored, expected_sha256)
        path = self._db.media_folder / stored
        if not path.is_file():
            raise ProjectError(f"{self.path}: the media file {stored} is missing; relocate it instead")
        sample = sampled_hash(path)
        if hashed is None:
            size, sha = path.stat().st_size, file_hash(path)
        else:
            size, sha = hashed[0], hashed[1]
            if path.stat().st_size != size or sample != hashed[2]:
                raise ProjectError(f"{path}: changed again since it was read for accepting; look at it and "
                                   "accept it again")
        with self.transaction():
            self._refuse_changed_media(stored, expected_sha256)
            self._db.execute("UPDATE media SET size = ?, sha256 = ? WHERE path = ?", (size, sha, stored))
            self._db.execute(PUT_META, (_sample_key(stored), sample))
            self._db.execute("UPDATE image_pairs SET left_hash = ? WHERE left_path = ?", (sha, stored))
            self._db.execute("UPDATE image_pairs SET right_hash = ? WHERE right_path = ?", (sha, stored))

    def media_problems(self, check_hash: bool = True) -> list[tuple[str, str]]:
        """(stored path, problem) for every recorded media file that is missing, has changed size or
        content, or now holds what another recorded file held (swapped). ``check_hash``: compare every
        file's full SHA-256; else the fast check of :meth:`media_identity` (size and sampled hash), the
        full hash read only of the files found changed."""
        if not self._has_table("media"):
            return []
        rows = self._query("SELECT path, size, sha256 FROM media ORDER BY path")
        owners = {sha: path for path, _, sha in rows}
        problems = []
        for stored, size, sha in rows:
            path = self._db.media_folder / stored
            if not path.is_file():
                problems.append((stored, "missing (moved or deleted?)"))
                continue
            if self.media_identity(stored, full=check_hash) is None:
                continue
            now = file_hash(path)
            if now == sha:
                continue  # only its sampled hash was stale (recorded anew by accept_media)
            other = owners.get(now)
            problems.append((stored, f"holds what {other} held when added (swapped?)" if other else
                             f"changed since it was added ({path.stat().st_size} bytes, {size} then; "
                             "its SHA-256 differs)"))
        return problems

    def relocate_media(self, stored: str, new_path: str | Path, expected_sha256: str | None = None) -> str:
        """Point a recorded media file at its new place; the file there must be the same (size and SHA-256).
        ``expected_sha256`` as for :meth:`accept_media` (relocated by someone else since: refused by name)."""
        row = self._db.execute("SELECT size, sha256 FROM media WHERE path = ?", (stored,)).fetchone()
        if row is None:
            with self.transaction():
                self._refuse_changed_media(stored, expected_sha256)
        new_path = Path(new_path)
        if not new_path.is_file():
            raise ProjectError(f"{new_path}: no such file")
        if new_path.stat().st_size != row[0] or file_hash(new_path) != row[1]:
            raise ProjectError(f"{new_path}: not the file that was added as {stored} (size or SHA-256 differs)")
        new = self._relative(new_path)
        with self.transaction():
            self._refuse_changed_media(stored, expected_sha256)
            self._refuse_changed(f"media file {new}", None, UNREAD)
            try:
                self._db.execute("UPDATE media SET path = ? WHERE path = ?", (new, stored))
                self._db.execute("DELETE FROM meta WHERE key = ?", (_sample_key(stored),))
                self._db.execute(PUT_META,
                                 (_sample_key(new), sampled_hash(new_path)))
                self._db.execute("UPDATE image_pairs SET left_path = ? WHERE left_path = ?", (new, stored))
                self._db.execute("UPDATE image_pairs SET right_path = ? WHERE right_path = ?", (new, stored))
            except ConstraintError as error:
                raise ProjectError(f"{self.path}: cannot relocate {stored}: {error.problem}") from None
        return new

    def _refuse_unusable_pairs(self, pairs: Sequence[tuple[str, Path, Path]]) -> None:
        """A label already in the project or given twice, or one file as both left and right: one line
        naming the pair (nothing is added)."""
        checks.image_pairs(pairs, {row[0] for row in self._db.execute("SELECT label FROM image_pairs")}, self.path)

    def add_image_pairs(self, pairs: Sequence[tuple[str, Path, Path]], medium: str = "water",
                        sizes: Sequence[tuple[int, int]] | None = None) -> list[int]:
        """Add (label, left image, right image) pairs in one transaction (all or none), recording the
        media's size and SHA-256; ``sizes``: (width, height) pixels per pair."""
        self._refuse_unusable_pairs(pairs)
        ids = []
        with self.transaction():
            try:
                for k, (label, left, right) in enumerate(pairs):
                    stored = [self._media(left), self._media(right)]
                    hashes = [self._db.execute("SELECT sha256 FROM media WHERE path = ?", (p,)).fetchone()[0]
                              for p in stored]
                    width, height = sizes[k] if sizes else (None, None)
                    cursor = self._db.execute(
                        "INSERT INTO image_pairs (label, left_path, right_path, width, height, left_hash, right_hash, "
                        "medium) VALUES (?, ?, ?, ?, ?, ?, ?, ?) RETURNING id",
                        (label, *stored, width, height, *hashes, medium))
                    ids.append(int(cursor.fetchone()[0]))
            except ConstraintError as error:
                raise ProjectError(f"{self.path}: cannot add the pairs: {error.problem} (is a label already "
                                   "used?)") from None
        return ids

    # ---------------------------------------------------------------------------- videos (schema 4)
    def add_video(self, label: str, left: Sequence[tuple[Path, int, float]], right: Sequence[tuple[Path, int, float]],
                  fps: float, frame_count: int, size: tuple[int, int], report: str = "", medium: str = "water") -> int:
        """A stereo video: ``left``/``right`` the chapter files of each camera in order, each as (path,
        frames, fps); ``fps`` and ``frame_count`` of the pair (the left stream's), ``size`` (width,
        height) px, ``report`` what was found when the streams were read (frame-rate problems), ``medium``
        "air" or "water" (stored as its pair's medium: an in-air calibration video is not water)."""
        if not label:
            raise ProjectError("a video needs a label")
        if medium not in ("air", "water"):
            raise ProjectError(f"a video's medium is 'air' or 'water', got {medium!r}")
        with self.transaction():
            try:
                cursor = self._db.execute(
                    "INSERT INTO videos (label, fps, frame_count, width, height, report, created) "
                    "VALUES (?, ?, ?, ?, ?, ?, ?) RETURNING id",
                    (label, float(fps), int(frame_count), *map(int, size), report, _now()))
                video_id = int(cursor.fetchone()[0])
                # the video is also a pair (no image files): its calibration is made active for it as for
                # any pair, and its vertices refer to it
                self._db.execute("INSERT INTO image_pairs (label, medium) VALUES (?, ?)", (label, medium))
                for camera, files in (("left", left), ("right", right)):
                    for idx, (path, frames, file_fps) in enumerate(files):
                        self._db.execute("INSERT INTO video_files VALUES (?, ?, ?, ?, ?, ?)",
                                         (video_id, camera, idx, self._media(path), int(frames), float(file_fps)))
            except ConstraintError as error:
                raise ProjectError(f"{self.path}: cannot add video {label!r}: {error.problem} "
                                   "(is the label already used?)") from None
        return video_id

    def activate_calibration(self, label: str, calibration_id: int, expected: object = UNREAD) -> None:
        """Make a stored calibration the active one of a pair (or video); ``expected``: the id active when
        read (None: none was), a stale write is refused (:mod:`usvips.store.versions`)."""
        self.calibration(calibration_id)
        with self.transaction():
            self._refuse_changed(f"active calibration of {label!r}", self.active_calibration(label), expected)
            self._edit(ACTIVATE,
                       (self.pair_id(label), calibration_id))

    def _video_row(self, label: str) -> tuple:
        found = self._query("SELECT id, label, fps, frame_count, width, height, offset_frames, offset_estimate, "
                            "report FROM videos WHERE label = ?", (label,))
        row = found[0] if found else None
        if row is None:
            known = [r[0] for r in self._query("SELECT label FROM videos ORDER BY id")]
            raise ProjectError(f"{self.path}: no video pair {label!r}" + (f" (there are: {', '.join(known)})"
                                                                          if known else " (the project has no videos)"))
        return row

    def video(self, label: str) -> Video:
        """The stored video ``label`` (:class:`~usvips.store.records.Video`)."""
        row = self._video_row(label)
        files = {}
        for camera in ("left", "right"):
            files[camera] = tuple(VideoFile(r[0], int(r[1]), float(r[2])) for r in self._query(
                "SELECT path, frame_count, fps FROM video_files WHERE video_id = ? AND camera = ? ORDER BY idx",
                (row[0], camera)))
        return Video(id=int(row[0]), label=row[1], fps=float(row[2]), frame_count=int(row[3]), width=int(row[4]),
                     height=int(row[5]), offset_frames=int(row[6]),
                     offset_estimate=json.loads(row[7]) if row[7] else None, report=row[8],
                     left=files["left"], right=files["right"])

    def videos(self) -> list[Video]:
        """Every stereo video (none in a project older than schema 4, opened read-only)."""
        if not self._has_table("videos"):
            return []
        return [self.video(r[0]) for r in self._query("SELECT label FROM videos ORDER BY id")]

    def _has_table(self, name: str) -> bool:
        return self._db.has_table(name)

    def _has_pointing(self) -> bool:
        """Whether the vertices have their pointing columns (schema 11; not in an older project read-only).
        Once they have, they keep them: asked of the backend until then."""
        if not self._pointing:
            self._pointing = self.version >= 11
        return self._pointing

    def set_video_offset(self, label: str, frames: int, estimate: dict | None = None,
                         expected: object = UNREAD) -> None:
        """Left frame i and right frame i + ``frames`` show the same instant; ``estimate``: how it was found."""
        row = self._video_row(label)
        if not isinstance(frames, (int, np.integer)) or abs(int(frames)) >= row[3]:
            raise ProjectError(f"video {label!r}: offset {frames} frames is not a whole number smaller than the "
                               f"video ({row[3]} frames)")
        with self.transaction():
            self._refuse_changed(f"offset of video {label!r}", self._video_row(label)[6], expected)
            self._edit("UPDATE videos SET offset_frames = ?, offset_estimate = ? WHERE id = ?",
                       (int(frames), json.dumps(estimate) if estimate else None, row[0]))

    def media_path(self, stored: str) -> Path:
        """The absolute path of a stored media path; raises (naming it) if it has gone missing or is not
        the file that was added (the fast check of :meth:`media_identity`: size and sampled hash)."""
        path = (self._db.media_folder / stored).resolve()
        if not path.is_file():
            raise ProjectError(f"{self.path}: the media file {stored} is missing (moved or deleted?); relocate it")
        problem = self.media_identity(stored)
        if problem is not None:
            raise ProjectError(f"{self.path}: the media file {stored} is not the file that was added: {problem}; "
                               "relocate the right file, or accept this one (usvips project accept-media)")
        return path

    def add_period(self, video: str, name: str, start: int, end: int) -> int:
        """A named period of a video from frame ``start`` to ``end`` (left frames, inclusive)."""
        row = self._video_row(video)
        if not name:
            raise ProjectError("a period needs a name")
        if not (0 <= int(start) <= int(end) < row[3]):
            raise ProjectError(f"period {name!r}: frames {start} to {end} are not an interval within the video "
                               f"(0 to {row[3] - 1})")
        return int(self._edit("INSERT INTO periods (video_id, name, start_frame, end_frame) VALUES (?, ?, ?, ?) "
                              "RETURNING id", (row[0], name, int(start), int(end))).fetchone()[0])

    def periods(self, video: str) -> list[tuple[str, int, int]]:
        row = self._video_row(video)
        return [tuple(r) for r in self._db.execute("SELECT name, start_frame, end_frame FROM periods WHERE "
                                                   "video_id = ? ORDER BY start_frame, id", (row[0],))]

    # ---------------------------------------------------------------------------- species and records
    def set_species_list(self, species: list[Species], expected: object = UNREAD) -> None:
        """Replace the project's species list (one transaction); ``expected``: the list as read."""
        with self.transaction():
            self._refuse_changed("species list", self.species_list(), expected)
            try:
                self._db.execute("DELETE FROM species")
                self._db.executemany("INSERT INTO species (family, genus, species, code, max_length_m) "
                                     "VALUES (?, ?, ?, ?, ?)",
                                     [(s.family, s.genus, s.species, s.code, s.max_length_m) for s in species])
            except ConstraintError as error:
                raise ProjectError(f"{self.path}: cannot store the species list: {error.problem}") from None

    def species_list(self) -> list[Species]:
        """The project's species list, sorted by genus and species (none before schema 5)."""
        if not self._has_table("species"):
            return []
        maximum = "max_length_m" if self.version >= 7 else "NULL"  # before schema 7 (read-only)
        rows = self._db.execute(f"SELECT family, genus, species, code, {maximum} FROM species ORDER BY genus, species")
        return [Species(*row) for row in rows.fetchall()]

    def set_record(self, object_id: int, record: ObservationRecord | None,
                   expected_modified: str | None = None) -> None:
        """Store (or with None remove) an object's observation record, stamped with this handle's annotator
        and the time; the object's ``modified`` stamp moves forward and the history keeps the record before
        and after; an accepted object whose record changed goes back to unreviewed (a second 'review' row,
        see :meth:`_unaccepted`). One transaction."""
        with self.transaction():
            # what the write needs to know, by one query: the object's version, its record and its review
            found = self._db.execute(
                f"SELECT o.modified, r.object_id, {', '.join('r.' + name for name in RECORD_FIELDS)}, v.state, "
                "v.reason, v.reviewer, v.reviewed FROM objects o LEFT JOIN observation_records r ON r.object_id = o.id "
                "LEFT JOIN reviews v ON v.object_id = o.id WHERE o.id = ?", (object_id,)).fetchone()
            if found is None:
                raise ProjectError(f"{self.path}: no object {object_id}")
            modified, old, review = found[0], found[2:10], found[10:]
            self._refuse_stale_version(object_id, modified, expected_modified)
            old = None if found[1] is None else ObservationRecord(*old)
            review = Review(object_id) if review[0] is None else Review(object_id, *review)
            if record is None:
                written = Statement("DELETE FROM observation_records WHERE object_id = ?", (object_id,))
            else:
                written = Statement(upsert("observation_records", ("object_id", *RECORD_FIELDS, "creator", "created"),
                                           ("object_id",)),
                                    (object_id, *(getattr(record, name) for name in RECORD_FIELDS), self.annotator,
                                     _now()))
            try:  # one batch, read by nobody (a server sends it with the next statement or the commit)
                self._db.write_later([
                    written, Statement("UPDATE objects SET modified = ? WHERE id = ?", (_later(modified), object_id)),
                    Statement(INSERT_HISTORY, self._history_row(
                        object_id, "record", None if old is None else dataclasses.asdict(old),
                        None if record is None else dataclasses.asdict(record))),
                    *(self._unaccepted(object_id, review) if old != record else ())])
            except ConstraintError as error:
                raise ProjectError(f"{self.path}: {error.problem}") from None

    def records(self) -> dict[int, ObservationRecord]:
        """Every object's observation record by object id, by one query (none before schema 5)."""
        if not self._has_table("observation_records"):
            return {}
        rows = self._query("SELECT object_id, family, genus, species, code, number, stage, activity, comment FROM "
                           "observation_records ORDER BY object_id")
        return {int(row[0]): ObservationRecord(*row[1:]) for row in rows}

    def records_of(self, object_ids: Sequence[int]) -> dict[int, ObservationRecord]:
        ids = sorted({int(i) for i in object_ids})
        if not ids or not self._has_table("observation_records"):
            return {}
        records: dict[int, ObservationRecord] = {}
        for start in range(0, len(ids), 500):  # (SQLite's limit on bound parameters)
            chunk = tuple(ids[start:start + 500])
            rows = self._query("SELECT object_id, family, genus, species, code, number, stage, activity, comment "
                               f"FROM observation_records WHERE object_id IN ({', '.join('?' * len(chunk))})", chunk)
            records.update((int(row[0]), ObservationRecord(*row[1:])) for row in rows)
        return dict(sorted(records.items()))

    def record(self, object_id: int) -> ObservationRecord | None:
        """An object's observation record, None when none was entered (or before schema 5)."""
        if not self._has_table("observation_records"):
            return None
        row = self._db.execute("SELECT family, genus, species, code, number, stage, activity, comment FROM "
                               "observation_records WHERE object_id = ?", (object_id,)).fetchone()
        return None if row is None else ObservationRecord(*row)

    # ---------------------------------------------------------------------------- deployment and georeference
    def set_deployment(self, deployment: Deployment | None, video: str | None = None,
                       expected: object = UNREAD) -> None:
        """Store (or with None remove) the deployment metadata of the whole project, or of one stereo
        ``video`` (its label) when the project holds several deployments. ``expected``: that scope's own
        deployment as read (None: none), :mod:`usvips.store.versions`."""
        if video is not None:
            self._video_row(video)
        scope = video or ""
        with self.transaction():
            self._refuse_changed(f"deployment of video {video!r}" if video else "deployment",
                                 self.deployments().get(scope), expected)
            if deployment is None:
                self._edit("DELETE FROM deployments WHERE scope = ?", (scope,))
                return
            values = [getattr(deployment, name) for name in DEPLOYMENT_FIELDS]
            self._edit(upsert("deployments", ("scope", *DEPLOYMENT_FIELDS), ("scope",)),
                       (scope, *[int(v) if isinstance(v, bool) else v for v in values]))

    def deployments(self) -> dict[str, Deployment]:
        """Scope ('' for the project, else a video's label) → its deployment; none before schema 6."""
        if not self._has_table("deployments"):
            return {}
        rows = self._query(f"SELECT scope, {', '.join(DEPLOYMENT_FIELDS)} FROM deployments ORDER BY scope")
        out = {}
        for scope, *values in rows:
            record = dict(zip(DEPLOYMENT_FIELDS, values, strict=True))
            record["successful_count"] = bool(record["successful_count"])
            record["successful_length"] = bool(record["successful_length"])
            out[scope] = Deployment(**record)
        return out

    def deployment(self, video: str | None = None) -> Deployment | None:
        """The deployment of ``video`` when it has its own, else the project's; None when none was entered."""
        stored = self.deployments()
        return stored.get(video or "", stored.get(""))

    def set_georeference(self, georeference: Georeference | None, expected: object = UNREAD) -> None:
        """Store (or with None remove) where the object frame lies on the Earth; ``expected``: as read."""
        with self.transaction():
            self._refuse_changed("georeference", self.georeference(), expected)
            self._set_georeference(georeference)

    def _set_georeference(self, georeference: Georeference | None) -> None:
        if georeference is None:
            self._edit("DELETE FROM georeference")
            return
        g = georeference
        self._edit(upsert("georeference", ("id", "latitude", "longitude", "depth_m", "heading_deg"), ("id",)),
                   (1, g.latitude, g.longitude, g.depth_m, g.heading_deg))

    def georeference(self) -> Georeference | None:
        """The object frame's georeference; None when none was entered (or before schema 6)."""
        if not self._has_table("georeference"):
            return None
        rows = self._query("SELECT latitude, longitude, depth_m, heading_deg FROM georeference")
        return Georeference(*rows[0]) if rows else None

    # ---------------------------------------------------------------------------- pointing estimates
    def set_pointing_estimates(self, estimates: list[dict], expected: object = UNREAD) -> None:
        """Store the project's pointing estimates (each a JSON-able dict, see
        :mod:`usvips.app.pointing_settings`) as JSON in the ``meta`` table (key ``pointing_estimates``: no
        schema change, every backend and a push/pull carry it); an empty list removes them. ``expected``:
        the estimates as read (:meth:`pointing_estimates`), :mod:`usvips.store.versions`."""
        with self.transaction():
            rows = self._db.execute("SELECT value FROM meta WHERE key = ?", (POINTING_KEY,)).fetchall()
            stored = json.loads(rows[0][0]) if rows else []
            self._refuse_changed("pointing estimates", stored, expected)
            if not estimates:
                self._db.execute("DELETE FROM meta WHERE key = ?", (POINTING_KEY,))
            else:
                self._db.execute(PUT_META,
                                 (POINTING_KEY, json.dumps(list(estimates), ensure_ascii=False, sort_keys=True)))

    def pointing_estimates(self) -> list[dict]:
        """The stored pointing estimates, oldest first ([] when none). A damaged record is a
        :class:`ProjectError`."""
        rows = self._query("SELECT value FROM meta WHERE key = ?", (POINTING_KEY,))
        if not rows:
            return []
        try:
            value = json.loads(rows[0][0])
            if not isinstance(value, list) or not all(isinstance(v, dict) for v in value):
                raise ValueError("not a list of records")
            return value
        except ValueError as error:
            raise ProjectError(f"{self.path}: the stored pointing estimates cannot be read ({error}); estimate "
                               "them again") from None

    # ---------------------------------------------------------------------------- campaign (GlobalArchive)
    def set_campaign(self, campaign: Campaign | None, expected: object = UNREAD) -> None:
        """Store (or with None remove) the campaign the project's deployments belong to, as JSON in the
        ``meta`` table (key ``campaign``: no schema change, every backend and a push/pull carry it).
        ``expected``: the campaign as read (None: none), :mod:`usvips.store.versions`."""
        with self.transaction():
            self._refuse_changed("campaign", self._stored_campaign_text(), UNREAD if expected is UNREAD else
                                 (None if expected is None else
                                  json.dumps(expected.to_dict(), ensure_ascii=False, sort_keys=True)))
            self._set_campaign(campaign)

    def _stored_campaign_text(self) -> str | None:
        rows = self._db.execute("SELECT value FROM meta WHERE key = ?", (CAMPAIGN_KEY,)).fetchall()
        return rows[0][0] if rows else None

    def _set_campaign(self, campaign: Campaign | None) -> None:
        if campaign is None:
            self._edit("DELETE FROM meta WHERE key = ?", (CAMPAIGN_KEY,))
        else:
            self._edit(PUT_META,
                       (CAMPAIGN_KEY, json.dumps(campaign.to_dict(), ensure_ascii=False, sort_keys=True)))

    def campaign(self) -> Campaign | None:
        """The stored campaign; None when none was entered. A damaged record is a :class:`ProjectError`."""
        rows = self._query("SELECT value FROM meta WHERE key = ?", (CAMPAIGN_KEY,))
        if not rows:
            return None
        try:
            return Campaign.from_dict(json.loads(rows[0][0]))
        except (ValueError, TypeError) as error:  # bad JSON, or values a Campaign refuses
            raise ProjectError(f"{self.path}: the stored campaign cannot be read ({error}); set it again "
                               "(usvips project set-campaign)") from None
