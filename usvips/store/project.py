"""A USVIPS project: images, calibrations, control, picks and measured objects in one SQLite file.

WAL journal, foreign keys on, every user edit one transaction (a crash loses at most the edit in
progress). Paths of images are stored relative to the project file. A project made by an older USVIPS
is migrated forward on opening; one made by a newer USVIPS is refused.
"""

from __future__ import annotations

import hashlib
import json
import sqlite3
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path

import numpy as np

from usvips.core.errors import UsvipsError
from usvips.core.observation_record import ObservationRecord, Species
from usvips.core.observations import ControlPoints, StereoObservations
from usvips.store.schema import SCHEMA_VERSION, migrate

FORMAT = "usvips-project"


class ProjectError(UsvipsError):
    """A project file that cannot be opened or written; the message names the file."""


def _now() -> str:
    return datetime.now(UTC).isoformat(timespec="seconds")


def file_hash(path: Path) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as stream:
        for chunk in iter(lambda: stream.read(1 << 20), b""):
            digest.update(chunk)
    return digest.hexdigest()


@dataclass(frozen=True)
class Vertex:
    """One vertex of a measured object: its picks (pixels) and, once intersected, X, Y, Z (m) and the
    3 × 3 covariance (m²) with the calibration used."""

    xl: float
    yl: float
    xr: float
    yr: float
    xyz: tuple[float, float, float] | None = None
    covariance: np.ndarray | None = None
    calibration_id: int | None = None
    pair: str | None = None


@dataclass(frozen=True)
class StoredObject:
    id: int
    kind: str
    attribute: str
    notes: str
    creator: str
    created: str
    modified: str
    vertices: tuple[Vertex, ...]


class Project:
    """Open with :meth:`open` or :meth:`create`; use as a context manager or call :meth:`close`."""

    def __init__(self, path: Path, connection: sqlite3.Connection):
        self.path = path
        self._db = connection

    # ---------------------------------------------------------------------------- opening
    @classmethod
    def create(cls, path: str | Path) -> Project:
        path = Path(path)
        if path.exists():
            raise ProjectError(f"{path}: already exists; open it instead")
        if not path.parent.exists():
            raise ProjectError(f"{path}: the folder {path.parent} does not exist")
        project = cls(path, cls._connect(path))
        migrate(project._db)
        with project._db:
            project._db.executemany("INSERT INTO meta VALUES (?, ?)",
                                    [("format", FORMAT), ("created", _now())])
        return project

    @classmethod
    def open(cls, path: str | Path) -> Project:
        path = Path(path)
        if not path.is_file():
            raise ProjectError(f"{path}: no such project file")
        with open(path, "rb") as stream:
            if stream.read(16) != b"SQLite format 3\x00":
                raise ProjectError(f"{path}: not a USVIPS project (not an SQLite database)")
        connection = cls._connect(path)
        try:
            version = connection.execute("PRAGMA user_version").fetchone()[0]
            if version > SCHEMA_VERSION:
                raise ProjectError(f"{path}: made by a newer USVIPS (schema {version}; this one reads up to "
                                   f"{SCHEMA_VERSION}); update USVIPS to open it")
            tables = {r[0] for r in connection.execute("SELECT name FROM sqlite_master WHERE type='table'")}
            if "meta" not in tables or connection.execute(
                    "SELECT value FROM meta WHERE key='format'").fetchone() != (FORMAT,):
                raise ProjectError(f"{path}: not a USVIPS project (an SQLite database of something else)")
            if version < SCHEMA_VERSION:
                migrate(connection)
        except sqlite3.OperationalError as error:
            connection.close()
            raise ProjectError(f"{path}: cannot open the project: {error}") from None
        except ProjectError:
            connection.close()
            raise
        return cls(path, connection)

    @staticmethod
    def _connect(path: Path) -> sqlite3.Connection:
        try:
            connection = sqlite3.connect(str(path), timeout=2.0, isolation_level=None)
            connection.execute("PRAGMA foreign_keys = ON")
            mode = connection.execute("PRAGMA journal_mode = WAL").fetchone()[0]
            if mode.lower() != "wal":
                connection.execute("PRAGMA journal_mode = DELETE")
            connection.isolation_level = "DEFERRED"
            return connection
        except sqlite3.OperationalError as error:
            message = str(error)
            if "readonly" in message or "read-only" in message or "unable to open" in message:
                raise ProjectError(f"{path}: cannot write the project ({message}); is the file or its folder "
                                   "read-only?") from None
            if "locked" in message:
                raise ProjectError(f"{path}: the project is locked by another program; close it there") from None
            raise ProjectError(f"{path}: {message}") from None

    def close(self) -> None:
        self._db.close()

    def __enter__(self) -> Project:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    @property
    def version(self) -> int:
        return self._db.execute("PRAGMA user_version").fetchone()[0]

    def _edit(self, sql: str, parameters=()) -> sqlite3.Cursor:
        """One statement as one transaction, with errors a person can act on."""
        try:
            with self._db:
                return self._db.execute(sql, parameters)
        except sqlite3.IntegrityError as error:
            raise ProjectError(f"{self.path}: {error}") from None
        except sqlite3.OperationalError as error:
            if "locked" in str(error):
                raise ProjectError(f"{self.path}: cannot write the project: it is locked by another program; "
                                   "close it there and try again (nothing was changed)") from None
            raise ProjectError(f"{self.path}: cannot write the project: {error}") from None

    # ---------------------------------------------------------------------------- pairs
    def _relative(self, path: str | Path | None) -> str | None:
        if path is None:
            return None
        path = Path(path).resolve()
        try:
            return str(path.relative_to(self.path.resolve().parent))
        except ValueError:
            return str(path)

    def add_pair(self, label: str, left: str | Path | None = None, right: str | Path | None = None,
                 medium: str = "water", frame: int | None = None, size: tuple[int, int] | None = None) -> int:
        for side, image in (("left", left), ("right", right)):
            if image is not None and not Path(image).is_file():
                raise ProjectError(f"pair {label!r}: the {side} image {image} does not exist")
        hashes = [file_hash(Path(p)) if p is not None else None for p in (left, right)]
        width, height = size if size else (None, None)
        cursor = self._edit("INSERT INTO image_pairs (label, left_path, right_path, width, height, left_hash, "
                            "right_hash, frame, medium) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?)",
                            (label, self._relative(left), self._relative(right), width, height, *hashes, frame, medium))
        return int(cursor.lastrowid)

    def pairs(self) -> list[dict]:
        rows = self._db.execute("SELECT id, label, left_path, right_path, width, height, frame, medium "
                                "FROM image_pairs ORDER BY id").fetchall()
        keys = ("id", "label", "left", "right", "width", "height", "frame", "medium")
        return [dict(zip(keys, row, strict=True)) for row in rows]

    def pair_id(self, label: str) -> int:
        row = self._db.execute("SELECT id FROM image_pairs WHERE label = ?", (label,)).fetchone()
        if row is None:
            raise ProjectError(f"{self.path}: no image pair {label!r}")
        return int(row[0])

    def image_path(self, relative: str) -> Path:
        """The absolute path of a stored image path; raises if the image has gone missing."""
        path = (self.path.parent / relative).resolve()
        if not path.is_file():
            raise ProjectError(f"{self.path}: the image {relative} is missing (moved or deleted?)")
        return path

    # ---------------------------------------------------------------------------- calibrations
    def add_calibration(self, name: str, calibration: dict, active_for: tuple[str, ...] = ()) -> int:
        try:
            with self._db:
                cursor = self._db.execute(
                    "INSERT INTO calibrations (name, json, sigma0_px, created) VALUES (?, ?, ?, ?)",
                    (name, json.dumps(calibration, allow_nan=False), calibration.get("sigma0_px"), _now()))
                calibration_id = int(cursor.lastrowid)
                for label in active_for:
                    self._db.execute("INSERT OR REPLACE INTO active_calibrations VALUES (?, ?)",
                                     (self.pair_id(label), calibration_id))
            return calibration_id
        except sqlite3.Error as error:
            raise ProjectError(f"{self.path}: cannot store the calibration: {error}") from None

    def calibration(self, calibration_id: int) -> dict:
        row = self._db.execute("SELECT json FROM calibrations WHERE id = ?", (calibration_id,)).fetchone()
        if row is None:
            raise ProjectError(f"{self.path}: no calibration {calibration_id}")
        return json.loads(row[0])

    def active_calibration(self, label: str) -> int | None:
        row = self._db.execute("SELECT calibration_id FROM active_calibrations WHERE pair_id = ?",
                               (self.pair_id(label),)).fetchone()
        return None if row is None else int(row[0])

    # ---------------------------------------------------------------------------- control
    def set_control(self, control: ControlPoints) -> None:
        sig = control.sigmas if control.sigmas is not None else np.full((len(control), 3), np.nan)
        rows = [(pid, *map(float, control.xyz[i]), *(None if np.isnan(v) else float(v) for v in sig[i]))
                for i, pid in enumerate(control.ids)]
        with self._db:
            self._db.execute("DELETE FROM control_points")
            self._db.executemany("INSERT INTO control_points VALUES (?, ?, ?, ?, ?, ?, ?)", rows)

    def control(self) -> ControlPoints:
        rows = self._db.execute("SELECT id, x, y, z, sx, sy, sz FROM control_points ORDER BY rowid").fetchall()
        sigmas = None
        if rows and all(r[4] is not None for r in rows):
            sigmas = np.array([r[4:] for r in rows], dtype=float)
        return ControlPoints(tuple(r[0] for r in rows), np.array([r[1:4] for r in rows], float).reshape(-1, 3),
                             sigmas, str(self.path))

    def add_control_observations(self, observations: StereoObservations, role: str, pair: str,
                                 replace: bool = False) -> None:
        """Store a pair's control observations for a role; ``replace`` swaps the stored set for this one
        in the same transaction (a calibration wizard saving what it used)."""
        pair_id = self.pair_id(pair)
        rows = [(pair_id, pid, *map(float, observations.left[i]), *map(float, observations.right[i]), role)
                for i, pid in enumerate(observations.ids)]
        try:
            with self._db:
                if replace:
                    self._db.execute("DELETE FROM control_observations WHERE pair_id = ? AND role = ?",
                                     (pair_id, role))
                self._db.executemany("INSERT INTO control_observations (pair_id, point_id, xl, yl, xr, yr, role) "
                                     "VALUES (?, ?, ?, ?, ?, ?, ?)", rows)
        except sqlite3.IntegrityError as error:
            raise ProjectError(f"{self.path}: {error} (an observation is already stored)") from None

    def control_observations(self, role: str, pair: str) -> StereoObservations:
        rows = self._db.execute("SELECT point_id, xl, yl, xr, yr FROM control_observations WHERE role = ? AND "
                                "pair_id = ? ORDER BY id", (role, self.pair_id(pair))).fetchall()
        return StereoObservations(tuple(r[0] for r in rows), np.array([r[1:3] for r in rows], float).reshape(-1, 2),
                                  np.array([r[3:5] for r in rows], float).reshape(-1, 2), (pair,) * len(rows))

    # ---------------------------------------------------------------------------- objects
    def add_object(self, kind: str, vertices: list[Vertex], attribute: str = "", notes: str = "",
                   creator: str = "") -> int:
        for i, vertex in enumerate(vertices):
            values = (vertex.xl, vertex.yl, vertex.xr, vertex.yr)
            if any(v is None or not np.isfinite(v) for v in values):
                raise ProjectError(f"vertex {i}: a vertex needs both picks (left and right pixel)")
        now = _now()
        try:
            with self._db:
                cursor = self._db.execute("INSERT INTO objects (kind, attribute, notes, creator, created, modified) "
                                          "VALUES (?, ?, ?, ?, ?, ?)", (kind, attribute, notes, creator, now, now))
                object_id = int(cursor.lastrowid)
                self._insert_vertices(object_id, vertices)
            return object_id
        except sqlite3.IntegrityError as error:
            raise ProjectError(f"{self.path}: cannot store the object: {error}") from None

    def _insert_vertices(self, object_id: int, vertices: list[Vertex]) -> None:
        rows = []
        for i, v in enumerate(vertices):
            xyz = v.xyz if v.xyz is not None else (None, None, None)
            cov = json.dumps(np.asarray(v.covariance, float).reshape(9).tolist()) if v.covariance is not None else None
            pair_id = self.pair_id(v.pair) if v.pair else None
            rows.append((object_id, i, pair_id, v.xl, v.yl, v.xr, v.yr, *xyz, cov, v.calibration_id))
        self._db.executemany("INSERT INTO vertices VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)", rows)

    def update_object(self, object_id: int, attribute: str | None = None, notes: str | None = None,
                      vertices: list[Vertex] | None = None) -> None:
        """Change an object in one transaction; replaced 3-D values go to the vertex history."""
        self.object(object_id)
        with self._db:
            if attribute is not None:
                self._db.execute("UPDATE objects SET attribute = ? WHERE id = ?", (attribute, object_id))
            if notes is not None:
                self._db.execute("UPDATE objects SET notes = ? WHERE id = ?", (notes, object_id))
            if vertices is not None:
                self._db.execute("INSERT INTO vertex_history (object_id, idx, x, y, z, covariance, calibration_id, "
                                 "replaced) SELECT object_id, idx, x, y, z, covariance, calibration_id, ? "
                                 "FROM vertices WHERE object_id = ? AND x IS NOT NULL", (_now(), object_id))
                self._db.execute("DELETE FROM vertices WHERE object_id = ?", (object_id,))
                self._insert_vertices(object_id, vertices)
            self._db.execute("UPDATE objects SET modified = ? WHERE id = ?", (_now(), object_id))

    def delete_object(self, object_id: int) -> None:
        self.object(object_id)
        self._edit("DELETE FROM objects WHERE id = ?", (object_id,))

    def object(self, object_id: int) -> StoredObject:
        row = self._db.execute("SELECT id, kind, attribute, notes, creator, created, modified FROM objects "
                               "WHERE id = ?", (object_id,)).fetchone()
        if row is None:
            raise ProjectError(f"{self.path}: no object {object_id}")
        vertices = []
        for v in self._db.execute("SELECT v.xl, v.yl, v.xr, v.yr, v.x, v.y, v.z, v.covariance, v.calibration_id, "
                                  "p.label FROM vertices v LEFT JOIN image_pairs p ON p.id = v.pair_id "
                                  "WHERE v.object_id = ? ORDER BY v.idx", (object_id,)):
            xyz = None if v[4] is None else (v[4], v[5], v[6])
            cov = None if v[7] is None else np.array(json.loads(v[7])).reshape(3, 3)
            vertices.append(Vertex(v[0], v[1], v[2], v[3], xyz, cov, v[8], v[9]))
        return StoredObject(*row, vertices=tuple(vertices))

    def objects(self) -> list[StoredObject]:
        return [self.object(r[0]) for r in self._db.execute("SELECT id FROM objects ORDER BY id").fetchall()]

    def vertex_history(self, object_id: int) -> list[tuple]:
        return self._db.execute("SELECT idx, x, y, z, calibration_id, replaced FROM vertex_history "
                                "WHERE object_id = ? ORDER BY id", (object_id,)).fetchall()

    # ---------------------------------------------------------------------------- vocabulary, settings
    def add_term(self, term: str, category: str = "attribute") -> None:
        self._edit("INSERT OR IGNORE INTO vocabulary VALUES (?, ?)", (term, category))

    def vocabulary(self, category: str = "attribute") -> list[str]:
        return [r[0] for r in self._db.execute("SELECT term FROM vocabulary WHERE category = ? ORDER BY term",
                                               (category,))]

    def set_enhancement(self, image_key: str, pipeline_json: str) -> None:
        self._edit("INSERT OR REPLACE INTO enhancements VALUES (?, ?)", (image_key, pipeline_json))

    def set_draft(self, name: str, text: str | None) -> None:
        """Keep (or, with None, drop) a half-finished piece of work, e.g. a calibration wizard's state."""
        if text is None:
            self._edit("DELETE FROM meta WHERE key = ?", (f"draft:{name}",))
        else:
            self._edit("INSERT OR REPLACE INTO meta VALUES (?, ?)", (f"draft:{name}", text))

    def draft(self, name: str) -> str | None:
        row = self._db.execute("SELECT value FROM meta WHERE key = ?", (f"draft:{name}",)).fetchone()
        return None if row is None else row[0]

    def calibrations(self) -> list[dict]:
        """id, name, phase, sigma0_px and created of every stored calibration, oldest first."""
        rows = self._db.execute("SELECT id, name, json, sigma0_px, created FROM calibrations ORDER BY id").fetchall()
        return [{"id": r[0], "name": r[1], "phase": json.loads(r[2]).get("phase"), "sigma0_px": r[3],
                 "created": r[4]} for r in rows]

    def enhancement(self, image_key: str) -> str | None:
        row = self._db.execute("SELECT pipeline FROM enhancements WHERE image_key = ?", (image_key,)).fetchone()
        return None if row is None else row[0]


    def copy_to(self, path: str | Path) -> Path:
        """Write a consistent copy of the project to the new file ``path`` (SQLite's online backup, whole
        even while the project is open). Image paths stored relative to this project's folder are
        rewritten relative to the copy's folder (absolute where that is not possible), so the copy finds
        its images. Written to ``<path>.part`` and renamed: a failure leaves nothing half-written."""
        target = Path(path)
        if target.exists():
            raise ProjectError(f"{target}: already exists; choose a new file name for the copy")
        if not target.parent.is_dir():
            raise ProjectError(f"{target}: the folder {target.parent} does not exist")
        part = target.with_name(target.name + ".part")
        old_folder, new_folder = self.path.resolve().parent, target.resolve().parent

        def moved(stored: str | None) -> str | None:
            if stored is None:
                return None
            absolute = (old_folder / stored).resolve()
            try:
                return str(absolute.relative_to(new_folder))
            except ValueError:
                return str(absolute)

        try:
            copy = sqlite3.connect(str(part))
            try:
                self._db.backup(copy)
                rows = copy.execute("SELECT id, left_path, right_path FROM image_pairs").fetchall()
                with copy:
                    copy.executemany("UPDATE image_pairs SET left_path = ?, right_path = ? WHERE id = ?",
                                     [(moved(left), moved(right), pair_id) for pair_id, left, right in rows])
                copy.execute("PRAGMA journal_mode = DELETE")
            finally:
                copy.close()
            part.replace(target)
        except (sqlite3.Error, OSError) as error:
            part.unlink(missing_ok=True)
            raise ProjectError(f"{target}: cannot write the copy of the project: {error}") from None
        return target

    # ---------------------------------------------------------------------------- species and records
    def set_species_list(self, species: list[Species]) -> None:
        """Replace the project's species list (one transaction)."""
        try:
            with self._db:
                self._db.execute("DELETE FROM species")
                self._db.executemany("INSERT INTO species (family, genus, species, code) VALUES (?, ?, ?, ?)",
                                     [(s.family, s.genus, s.species, s.code) for s in species])
        except sqlite3.Error as error:
            raise ProjectError(f"{self.path}: cannot store the species list: {error}") from None

    def species_list(self) -> list[Species]:
        """The project's species list, sorted by genus and species."""
        rows = self._db.execute("SELECT family, genus, species, code FROM species ORDER BY genus, species")
        return [Species(*row) for row in rows.fetchall()]

    def set_record(self, object_id: int, record: ObservationRecord | None) -> None:
        """Store (or with None remove) an object's observation record."""
        self.object(object_id)
        if record is None:
            self._edit("DELETE FROM observation_records WHERE object_id = ?", (object_id,))
            return
        self._edit("INSERT OR REPLACE INTO observation_records (object_id, family, genus, species, code, number, "
                   "stage, activity, comment) VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?)",
                   (object_id, record.family, record.genus, record.species, record.code, record.number,
                    record.stage, record.activity, record.comment))

    def record(self, object_id: int) -> ObservationRecord | None:
        """An object's observation record, None when none was entered."""
        row = self._db.execute("SELECT family, genus, species, code, number, stage, activity, comment FROM "
                               "observation_records WHERE object_id = ?", (object_id,)).fetchone()
        return None if row is None else ObservationRecord(*row)
