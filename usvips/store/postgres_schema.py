"""What copying a project between a file and a server moves (:mod:`usvips.store.transfer`,
:mod:`usvips.store.file_copy`): every table of the schema with its columns, in an order in which rows can be
inserted. The schema itself — for both backends — is the one list of :mod:`usvips.store.schema`; a server's
tables have the same names, columns and column order (plus ``control_points.ord``, the order SQLite's rowid
keeps, and the counters of schema 13).
"""

from __future__ import annotations

from usvips.store.schema import SCHEMA_VERSION

#: a survey's schema version: the one numbering of :mod:`usvips.store.schema` (a copy refuses a mismatch)
SERVER_SCHEMA_VERSION = SCHEMA_VERSION

# every table in an order in which its rows can be inserted (what a row refers to comes first), with the
# columns a copy moves (all but control_points.ord, which follows the order of insertion)
TABLES: dict[str, tuple[str, ...]] = {
    "meta": ("key", "value"),
    "image_pairs": ("id", "label", "left_path", "right_path", "width", "height", "left_hash", "right_hash", "frame",
                    "medium"),
    "calibrations": ("id", "name", "json", "sigma0_px", "created"),
    "active_calibrations": ("pair_id", "calibration_id"),
    "control_points": ("id", "x", "y", "z", "sx", "sy", "sz"),
    "control_observations": ("id", "pair_id", "point_id", "xl", "yl", "xr", "yr", "role"),
    "objects": ("id", "kind", "attribute", "notes", "creator", "created", "modified"),
    "vertices": ("object_id", "idx", "pair_id", "xl", "yl", "xr", "yr", "x", "y", "z", "covariance",
                 "calibration_id", "creator", "created", "pointing_source", "sigma_left_px", "sigma_right_px",
                 "pointing_origin", "weak_score", "weak_reason"),
    "vertex_history": ("id", "object_id", "idx", "x", "y", "z", "covariance", "calibration_id", "replaced"),
    "vocabulary": ("term", "category"),
    "enhancements": ("image_key", "pipeline"),
    "media": ("path", "size", "sha256"),
    "videos": ("id", "label", "fps", "frame_count", "width", "height", "offset_frames", "offset_estimate", "report",
               "created"),
    "video_files": ("video_id", "camera", "idx", "path", "frame_count", "fps"),
    "periods": ("id", "video_id", "name", "start_frame", "end_frame"),
    "vertex_frames": ("object_id", "idx", "video_id", "frame_left", "frame_right", "time_s"),
    "species": ("family", "genus", "species", "code", "max_length_m"),
    "observation_records": ("object_id", "family", "genus", "species", "code", "number", "stage", "activity",
                            "comment", "creator", "created"),
    "deployments": ("scope", "opcode", "date", "time", "latitude", "longitude", "depth_m", "site", "location",
                    "status", "successful_count", "successful_length", "observer", "comment"),
    "georeference": ("id", "latitude", "longitude", "depth_m", "heading_deg"),
    "object_instants": ("object_id", "of_object", "tracked_from"),
    "history": ("id", "at", "annotator", "object_id", "change", "old", "new"),
    "reviews": ("object_id", "state", "reason", "reviewer", "reviewed"),
}
