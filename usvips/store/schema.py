"""Schema of the project database and its forward migrations.

``PRAGMA user_version`` holds the schema version. Version 1 is the first release; every later version
is reached from the previous one by a migration below, so a project made by any older USVIPS opens.
A new version is one new entry of ``MIGRATIONS`` (SQL statements, no BEGIN/COMMIT of their own): the
store copies an older project aside and runs all pending entries in one transaction (see
``usvips.store.project``); read-only opens never migrate.
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

# version 3: measurement kinds are validated by the registry (usvips.core.measurements), not by a CHECK,
# so that a new kind needs no schema change; the old 'line' becomes 'length' (two vertices) or 'arc'
# (more), as usvips.core.measurements.registry.LEGACY says. SQLite drops a CHECK only by rebuilding the
# table; dropping `objects` would cascade into the vertices and their history, so both are kept aside in
# temporary tables and put back (explicitly emptied first, whether or not foreign keys are enforced).
VERSION_3 = """
CREATE TABLE objects_v3 (
    id INTEGER PRIMARY KEY, kind TEXT NOT NULL,
    attribute TEXT NOT NULL DEFAULT '', notes TEXT NOT NULL DEFAULT '', creator TEXT NOT NULL DEFAULT '',
    created TEXT NOT NULL, modified TEXT NOT NULL);
INSERT INTO objects_v3 SELECT o.id,
    CASE WHEN o.kind = 'line' THEN
        (CASE WHEN (SELECT count(*) FROM vertices v WHERE v.object_id = o.id) = 2 THEN 'length' ELSE 'arc' END)
    ELSE o.kind END, o.attribute, o.notes, o.creator, o.created, o.modified FROM objects o;
CREATE TEMP TABLE vertices_v3 AS SELECT * FROM vertices;
CREATE TEMP TABLE vertex_history_v3 AS SELECT * FROM vertex_history;
DROP TABLE objects;
ALTER TABLE objects_v3 RENAME TO objects;
DELETE FROM vertices;
DELETE FROM vertex_history;
INSERT INTO vertices SELECT * FROM temp.vertices_v3;
INSERT INTO vertex_history SELECT * FROM temp.vertex_history_v3;
DROP TABLE temp.vertices_v3;
DROP TABLE temp.vertex_history_v3;
"""

MIGRATIONS = {1: VERSION_1, 2: VERSION_2, 3: VERSION_3}

# version 4 (video): every media file's size and SHA-256 (moved, changed or swapped files are detected);
# stereo videos (a pair of recordings, each one or more chapter files in order) with their left/right
# offset (left frame i and right frame i + offset_frames show the same instant); periods; and the video
# frames and time of each vertex
VERSION_4 = """
CREATE TABLE media (path TEXT PRIMARY KEY, size INTEGER NOT NULL, sha256 TEXT NOT NULL);
CREATE TABLE videos (
    id INTEGER PRIMARY KEY, label TEXT NOT NULL UNIQUE, fps REAL NOT NULL CHECK (fps > 0),
    frame_count INTEGER NOT NULL CHECK (frame_count > 0), width INTEGER NOT NULL, height INTEGER NOT NULL,
    offset_frames INTEGER NOT NULL DEFAULT 0, offset_estimate TEXT, report TEXT NOT NULL DEFAULT '',
    created TEXT NOT NULL);
CREATE TABLE video_files (
    video_id INTEGER NOT NULL REFERENCES videos(id) ON DELETE CASCADE,
    camera TEXT NOT NULL CHECK (camera IN ('left', 'right')), idx INTEGER NOT NULL,
    path TEXT NOT NULL REFERENCES media(path) ON UPDATE CASCADE, frame_count INTEGER NOT NULL, fps REAL NOT NULL,
    PRIMARY KEY (video_id, camera, idx));
CREATE TABLE periods (
    id INTEGER PRIMARY KEY, video_id INTEGER NOT NULL REFERENCES videos(id) ON DELETE CASCADE,
    name TEXT NOT NULL, start_frame INTEGER NOT NULL, end_frame INTEGER NOT NULL,
    CHECK (start_frame >= 0 AND end_frame >= start_frame), UNIQUE (video_id, name));
CREATE TABLE vertex_frames (
    object_id INTEGER NOT NULL, idx INTEGER NOT NULL, video_id INTEGER NOT NULL REFERENCES videos(id),
    frame_left INTEGER NOT NULL, frame_right INTEGER NOT NULL, time_s REAL NOT NULL,
    PRIMARY KEY (object_id, idx), FOREIGN KEY (object_id, idx) REFERENCES vertices(object_id, idx) ON DELETE CASCADE);
"""
MIGRATIONS[4] = VERSION_4

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
MIGRATIONS[5] = VERSION_5

# version 6: deployment metadata (usvips.core.deployment.Deployment; the sample of CheckEM's _Metadata.csv)
# for the whole project (scope '') or for one stereo video (scope = its label), and the georeference of
# the object frame (origin latitude / longitude in degrees WGS 84, depth in m, heading of +X in degrees
# clockwise from north; one row)
VERSION_6 = """
CREATE TABLE deployments (
    scope TEXT PRIMARY KEY, opcode TEXT NOT NULL CHECK (opcode <> ''), date TEXT NOT NULL DEFAULT '',
    time TEXT NOT NULL DEFAULT '', latitude REAL, longitude REAL, depth_m REAL, site TEXT NOT NULL DEFAULT '',
    location TEXT NOT NULL DEFAULT '', status TEXT NOT NULL DEFAULT '',
    successful_count INTEGER NOT NULL DEFAULT 1, successful_length INTEGER NOT NULL DEFAULT 1,
    observer TEXT NOT NULL DEFAULT '', comment TEXT NOT NULL DEFAULT '');
CREATE TABLE georeference (
    id INTEGER PRIMARY KEY CHECK (id = 1), latitude REAL NOT NULL, longitude REAL NOT NULL,
    depth_m REAL NOT NULL, heading_deg REAL NOT NULL);
"""
MIGRATIONS[6] = VERSION_6

# version 7: an object measured on several instants (a fish on several video frames or pairs). The object
# is its first instant; each further instant is an object of its own (same kind, its own vertices, pair or
# frames) linked here to the object it is an instant of. Deleting the object unlinks its instants (they
# stay, as objects of their own); deleting an instant removes its link. And each species' maximum length
# (m, NULL when the list gives none), that a survey's lengths are checked against.
VERSION_7 = """
ALTER TABLE species ADD COLUMN max_length_m REAL CHECK (max_length_m IS NULL OR max_length_m > 0);
CREATE TABLE object_instants (
    object_id INTEGER PRIMARY KEY REFERENCES objects(id) ON DELETE CASCADE,
    of_object INTEGER NOT NULL REFERENCES objects(id) ON DELETE CASCADE,
    CHECK (object_id <> of_object));
CREATE INDEX object_instants_of ON object_instants(of_object);
"""
MIGRATIONS[7] = VERSION_7

# version 8: who made each vertex and observation record and when (objects have creator/created/modified
# since version 1; the vertices and records of older projects take their object's creator and last
# modification), and the append-only history of every change to an object (usvips.store.records.CHANGES):
# when, by whom, which object (no foreign key: the history of a deleted object stays), old and new value
# as JSON. Triggers refuse any UPDATE or DELETE of a history row, whoever asks.
VERSION_8 = """
ALTER TABLE vertices ADD COLUMN creator TEXT NOT NULL DEFAULT '';
ALTER TABLE vertices ADD COLUMN created TEXT NOT NULL DEFAULT '';
UPDATE vertices SET creator = (SELECT o.creator FROM objects o WHERE o.id = vertices.object_id),
    created = (SELECT o.modified FROM objects o WHERE o.id = vertices.object_id)
    WHERE object_id IN (SELECT id FROM objects);
ALTER TABLE observation_records ADD COLUMN creator TEXT NOT NULL DEFAULT '';
ALTER TABLE observation_records ADD COLUMN created TEXT NOT NULL DEFAULT '';
UPDATE observation_records SET creator = (SELECT o.creator FROM objects o WHERE o.id = observation_records.object_id),
    created = (SELECT o.modified FROM objects o WHERE o.id = observation_records.object_id)
    WHERE object_id IN (SELECT id FROM objects);
CREATE TABLE history (
    id INTEGER PRIMARY KEY, at TEXT NOT NULL, annotator TEXT NOT NULL, object_id INTEGER NOT NULL,
    change TEXT NOT NULL CHECK (change IN ('add', 'edit', 're-pick', 'delete', 'put back', 'record')),
    old TEXT, new TEXT);
CREATE INDEX history_object ON history(object_id, id);
CREATE TRIGGER history_kept_unchanged BEFORE UPDATE ON history
    BEGIN SELECT RAISE(ABORT, 'the history is append-only: a change once recorded is never altered'); END;
CREATE TRIGGER history_kept_whole BEFORE DELETE ON history
    BEGIN SELECT RAISE(ABORT, 'the history is append-only: a change once recorded is never removed'); END;
"""
MIGRATIONS[8] = VERSION_8

# version 9: the review of each object by a second reader (usvips.store.records.REVIEW_STATES): accepted, or
# flagged with a reason, by whom and when; an unreviewed object has no row. A review is a change the
# history keeps ('review'): SQLite changes a CHECK only by rebuilding the table, so the history is copied
# row for row into one whose CHECK also allows 'review' (DROP TABLE fires no trigger; the append-only
# triggers and the index are made again on the new table).
VERSION_9 = """
CREATE TABLE reviews (
    object_id INTEGER PRIMARY KEY REFERENCES objects(id) ON DELETE CASCADE,
    state TEXT NOT NULL CHECK (state IN ('accepted', 'flagged')), reason TEXT NOT NULL DEFAULT '',
    reviewer TEXT NOT NULL, reviewed TEXT NOT NULL, CHECK (state <> 'flagged' OR reason <> ''));
CREATE INDEX reviews_state ON reviews(state, object_id);
CREATE TABLE history_v9 (
    id INTEGER PRIMARY KEY, at TEXT NOT NULL, annotator TEXT NOT NULL, object_id INTEGER NOT NULL,
    change TEXT NOT NULL CHECK (change IN ('add', 'edit', 're-pick', 'delete', 'put back', 'record', 'review')),
    old TEXT, new TEXT);
INSERT INTO history_v9 (id, at, annotator, object_id, change, old, new)
    SELECT id, at, annotator, object_id, change, old, new FROM history ORDER BY id;
DROP TABLE history;
ALTER TABLE history_v9 RENAME TO history;
CREATE INDEX history_object ON history(object_id, id);
CREATE TRIGGER history_kept_unchanged BEFORE UPDATE ON history
    BEGIN SELECT RAISE(ABORT, 'the history is append-only: a change once recorded is never altered'); END;
CREATE TRIGGER history_kept_whole BEFORE DELETE ON history
    BEGIN SELECT RAISE(ABORT, 'the history is append-only: a change once recorded is never removed'); END;
"""
MIGRATIONS[9] = VERSION_9

# version 10: how each further instant was made, a stored fact rather than a reading of its notes: the left
# frame its track started from (usvips.app.tracking.add_tracked_instants), NULL when picked by hand. The
# instants of older projects that USVIPS tracked say so in their notes ("tracked from frame N",
# usvips.app.object_instants.tracked_note), which is copied here once, so their combined sigma is unchanged
VERSION_10 = """
ALTER TABLE object_instants ADD COLUMN tracked_from INTEGER CHECK (tracked_from IS NULL OR tracked_from >= 0);
UPDATE object_instants SET tracked_from = (SELECT CAST(substr(o.notes, 20) AS INTEGER) FROM objects o
    WHERE o.id = object_instants.object_id)
    WHERE object_id IN (SELECT id FROM objects WHERE notes GLOB 'tracked from frame [0-9]*');
"""
MIGRATIONS[10] = VERSION_10

# version 11: each vertex's pointing (usvips.core.pointing): where its pixels come from (a source label), its
# pointing sigmas left and right (px per image coordinate; NULL: the source's documented default) with their
# origin, and an accepted weak auto-match's reason and score (when known; a fact of the vertex: no edit of the object's
# notes removes it). Vertices stored before say 'hand click (unknown)' with the default sigma.
VERSION_11 = """
ALTER TABLE vertices ADD COLUMN pointing_source TEXT NOT NULL DEFAULT 'hand click';
ALTER TABLE vertices ADD COLUMN sigma_left_px REAL CHECK (sigma_left_px IS NULL OR sigma_left_px > 0);
ALTER TABLE vertices ADD COLUMN sigma_right_px REAL CHECK (sigma_right_px IS NULL OR sigma_right_px > 0);
ALTER TABLE vertices ADD COLUMN pointing_origin TEXT CHECK (pointing_origin IS NULL OR pointing_origin IN
    ('default', 'given', 'estimated'));
ALTER TABLE vertices ADD COLUMN weak_score REAL;
ALTER TABLE vertices ADD COLUMN weak_reason TEXT CHECK (weak_score IS NULL OR weak_reason IS NOT NULL);
UPDATE vertices SET pointing_source = 'hand click (unknown)';
"""
MIGRATIONS[11] = VERSION_11
# version 12: not used.
# version 13: nothing changes in a file. The server's schema 13 (usvips.store.postgres_schema) gives ids from a
# counter kept in the transaction (a sequence jumped after a crash) and records the database login in the
# history; a file's ids are already the highest plus one, and a file has no logins. The step keeps both
# backends at one schema number.
MIGRATIONS[13] = ""
# version 14: nothing changes in a file either. The server's schema 14 notifies listeners when the history
# grows (the change feed, usvips.store.change_watch); a file's watchers read SQLite's own change counter.
MIGRATIONS[14] = ""
SCHEMA_VERSION = max(MIGRATIONS)


def migrate(connection: sqlite3.Connection, target: int = SCHEMA_VERSION) -> int:
    """Bring the schema from its ``user_version`` up to ``target`` in ONE transaction: every step is
    applied, or (on any error) none and the file is as it was. ``connection`` must be in autocommit
    mode (``isolation_level=None``) with no transaction open."""
    current = connection.execute("PRAGMA user_version").fetchone()[0]
    if current >= target:
        return current
    script = "".join(MIGRATIONS.get(version, "") for version in range(current + 1, target + 1))  # numbers
    # other branches hold may be missing on this one: the lead renumbers at merge
    try:
        connection.executescript(f"BEGIN IMMEDIATE;{script}PRAGMA user_version = {target};COMMIT;")
    except sqlite3.Error:
        if connection.in_transaction:
            connection.execute("ROLLBACK")
        raise
    return connection.execute("PRAGMA user_version").fetchone()[0]
