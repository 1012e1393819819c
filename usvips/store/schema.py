"""Schema of the project database and its forward migrations.

``PRAGMA user_version`` holds the schema version. Version 1 is the first release; every later version
is reached from the previous one by a migration below, so a project made by any older USVIPS opens.
"""

from __future__ import annotations

import sqlite3

VERSION_1 = """
CREATE TABLE meta (key TEXT PRIMARY KEY, value TEXT NOT NULL);
CREATE TABLE image_pairs (
    id INTEGER PRIMARY KEY, label TEXT NOT NULL UNIQUE, left_path TEXT, right_path TEXT,
    width INTEGER, height INTEGER, left_hash TEXT, right_hash TEXT, frame INTEGER,
    medium TEXT NOT NULL DEFAULT 'water' CHECK (medium IN ('air', 'water')));
CREATE TABLE calibrations (
    id INTEGER PRIMARY KEY, name TEXT NOT NULL, json TEXT NOT NULL, sigma0_px REAL, created TEXT NOT NULL);
CREATE TABLE active_calibrations (
    pair_id INTEGER PRIMARY KEY REFERENCES image_pairs(id) ON DELETE CASCADE,
    calibration_id INTEGER NOT NULL REFERENCES calibrations(id) ON DELETE RESTRICT);
CREATE TABLE control_points (
    id TEXT PRIMARY KEY, x REAL NOT NULL, y REAL NOT NULL, z REAL NOT NULL, sx REAL, sy REAL, sz REAL);
CREATE TABLE control_observations (
    id INTEGER PRIMARY KEY, pair_id INTEGER NOT NULL REFERENCES image_pairs(id) ON DELETE CASCADE,
    point_id TEXT NOT NULL, xl REAL NOT NULL, yl REAL NOT NULL, xr REAL NOT NULL, yr REAL NOT NULL,
    role TEXT NOT NULL, UNIQUE (pair_id, point_id, role));
CREATE TABLE objects (
    id INTEGER PRIMARY KEY, kind TEXT NOT NULL CHECK (kind IN ('point', 'line', 'polygon')),
    attribute TEXT NOT NULL DEFAULT '', notes TEXT NOT NULL DEFAULT '', creator TEXT NOT NULL DEFAULT '',
    created TEXT NOT NULL, modified TEXT NOT NULL);
CREATE TABLE vertices (
    object_id INTEGER NOT NULL REFERENCES objects(id) ON DELETE CASCADE, idx INTEGER NOT NULL,
    pair_id INTEGER REFERENCES image_pairs(id), xl REAL NOT NULL, yl REAL NOT NULL, xr REAL NOT NULL,
    yr REAL NOT NULL, x REAL, y REAL, z REAL, covariance TEXT, calibration_id INTEGER REFERENCES calibrations(id),
    PRIMARY KEY (object_id, idx));
CREATE TABLE vocabulary (term TEXT PRIMARY KEY, category TEXT NOT NULL DEFAULT 'attribute');
CREATE TABLE enhancements (image_key TEXT PRIMARY KEY, pipeline TEXT NOT NULL);
"""

# version 2: keep the 3-D values a vertex had before a recomputation (a calibration changed)
VERSION_2 = """
CREATE TABLE vertex_history (
    id INTEGER PRIMARY KEY, object_id INTEGER NOT NULL REFERENCES objects(id) ON DELETE CASCADE,
    idx INTEGER NOT NULL, x REAL, y REAL, z REAL, covariance TEXT, calibration_id INTEGER,
    replaced TEXT NOT NULL);
CREATE INDEX vertex_history_object ON vertex_history(object_id, idx);
"""

MIGRATIONS = {1: VERSION_1, 2: VERSION_2}

# version 5: the observation record (EventMeasure / CheckEM fields) of each object, and the project's
# species list it is typed from
VERSION_5 = """
CREATE TABLE species (
    family TEXT NOT NULL DEFAULT '', genus TEXT NOT NULL, species TEXT NOT NULL DEFAULT '',
    code TEXT NOT NULL DEFAULT '', PRIMARY KEY (genus, species));
CREATE TABLE observation_records (
    object_id INTEGER PRIMARY KEY REFERENCES objects(id) ON DELETE CASCADE,
    family TEXT NOT NULL DEFAULT '', genus TEXT NOT NULL DEFAULT '', species TEXT NOT NULL DEFAULT '',
    code TEXT NOT NULL DEFAULT '', number INTEGER NOT NULL DEFAULT 1 CHECK (number >= 1),
    stage TEXT NOT NULL DEFAULT '', activity TEXT NOT NULL DEFAULT '', comment TEXT NOT NULL DEFAULT '');
"""
# versions 3 and 4 come from other branches; until they are merged here they change nothing
MIGRATIONS.setdefault(3, "")
MIGRATIONS.setdefault(4, "")
MIGRATIONS[5] = VERSION_5
SCHEMA_VERSION = max(MIGRATIONS)


def migrate(connection: sqlite3.Connection, target: int = SCHEMA_VERSION) -> int:
    """Bring the schema from its ``user_version`` up to ``target``, each step one transaction."""
    current = connection.execute("PRAGMA user_version").fetchone()[0]
    for version in range(current + 1, target + 1):
        try:
            connection.executescript("BEGIN;" + MIGRATIONS[version] + f"PRAGMA user_version = {version};COMMIT;")
        except sqlite3.Error:
            if connection.in_transaction:
                connection.execute("ROLLBACK")
            raise
    return connection.execute("PRAGMA user_version").fetchone()[0]
