"""The stale-write rule, in one place for every backend: a write names the version of what it read, and a
write made on something changed since (by another annotator, another window, another process) is refused
by name — who changed it and when — and changes nothing. Never a silent overwrite.

What "the version" is, per kind of thing written:

- an object (edit, delete, observation record, review, instant link/unlink, undo/redo): its ``modified``
  stamp as read (``expected_modified``; every write to an object moves it forward); who changed it and
  when comes from the object's history;
- a media file (accept, relocate): the SHA-256 recorded for it when read (``expected_sha256``);
- a project-wide value (campaign, deployment, georeference, species list, control, a video's offset, a
  pair's active calibration, an enhancement, a draft): the value as read (``expected``; :data:`UNREAD`,
  the default, checks nothing). Who last wrote it and when is kept beside it (:func:`stamp_key`).

Writes that only make something new (a pair, an object, a calibration …) have no version to read: a used
label or id is refused on its own. The storage protocol's operations are sorted into reads, creations
and versioned writes by :data:`READS` and :data:`CREATIONS`; ``tests/store/test_storage_contract.py``
fails for any other write that takes no version.
"""

from __future__ import annotations

import dataclasses
import json

import numpy as np

from usvips.store.records import StaleEditError

#: operations of :class:`~usvips.store.interface.ProjectStore` that change nothing
READS = frozenset({
    "version", "close", "__enter__", "__exit__", "transaction", "copy_to", "pairs", "derived_media_folder",
    "image_path", "media_location", "media_path", "media_problems", "media_identity", "media_records", "video",
    "videos",
    "periods", "control", "control_observations", "calibration", "calibrations", "active_calibration",
    "object", "objects", "objects_with_ids", "objects_on", "object_rows", "records", "record", "records_of",
    "provenance", "history",
    "review", "reviews", "instants", "instant_links", "instant_links_of", "instant_sources", "deployments",
    "deployment", "georeference", "campaign", "vocabulary", "species_list", "enhancement", "draft",
    "pointing_estimates", "last_change_id", "changes_since", "watch"})

#: writes that only add something new (a used label, id or term is refused or ignored on its own): there
#: is no version to read
CREATIONS = frozenset({"add_pair", "add_image_pairs", "add_video", "add_period", "add_calibration", "add_object",
                       "add_objects", "add_term"})

#: the names a versioned write's parameter may have (see the module docstring)
VERSION_PARAMETERS = ("expected_modified", "expected_sha256", "expected")


class _Unread:
    """The default of an ``expected`` value: the writer read nothing, nothing is checked."""

    def __repr__(self) -> str:
        return "UNREAD"


UNREAD = _Unread()


def _plain(value: object) -> object:
    """``value`` as JSON-able data (dataclasses, numpy arrays, tuples), for comparing versions."""
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return {f.name: _plain(getattr(value, f.name)) for f in dataclasses.fields(value)}
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, (np.integer, np.floating)):
        return value.item()
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    return value


def same_version(stored: object, expected: object) -> bool:
    """Whether a stored value is the one a writer read (:data:`UNREAD`: always)."""
    if expected is UNREAD:
        return True
    return json.dumps(_plain(stored), sort_keys=True, default=str) == json.dumps(_plain(expected), sort_keys=True,
                                                                                 default=str)


def stamp_key(item: str) -> str:
    """The ``meta`` key that keeps who last wrote ``item`` (a project-wide value) and when."""
    return f"changed:{item}"


def stamp_value(annotator: str, at: str) -> str:
    """What :func:`stamp_key` holds: who and when, as JSON."""
    return json.dumps({"by": annotator, "at": at}, ensure_ascii=False)


def who_and_when(stamp: str | None) -> str:
    """'by NAME at TIME' from a stamp (:func:`stamp_value`), 'by someone else' without one."""
    try:
        found = json.loads(stamp) if stamp else None
    except (TypeError, ValueError):
        found = None
    if not isinstance(found, dict) or not found.get("by"):
        return "by someone else"
    return f"by {found['by']} at {found.get('at', '?')}"


def refuse_changed(where: object, item: str, stamp: str | None) -> None:
    """A write made on ``item`` as it was read, now changed: refused by name (nothing is changed)."""
    raise StaleEditError(f"{where}: the {item} was changed {who_and_when(stamp)} since it was read; read it "
                         "again and make the change anew (nothing was changed)")


def refuse_stale_object(where: object, object_id: int, now_modified: str, expected_modified: str,
                        last_change: str = "") -> None:
    """A write made on object ``object_id`` as read at ``expected_modified``, now at ``now_modified``:
    refused naming the last change (``last_change``: who, what and when from the history)."""
    raise StaleEditError(f"{where}: object {object_id} was changed by someone else since it was read "
                         f"({last_change + ', ' if last_change else ''}now modified {now_modified}, read at "
                         f"{expected_modified}); reload it and edit again (nothing was changed)")
