"""An object measured on several instants: linking a stored object as a further instant of another,
with the domain's checks (one kind, one calibration) made before anything is stored, and the survey's
objects listed once each (an instant belongs to its object, not to the list)."""

from __future__ import annotations

from usvips.core.errors import UsvipsError
from usvips.store.interface import ProjectStore
from usvips.store.project import StoredObject

#: how the notes of an instant made by tracking begin (:func:`usvips.app.tracking.add_tracked_instants`), for a
#: person reading them. Whether an instant was tracked is the stored fact ``tracked_from`` of its link
#: (:func:`is_tracked`), never these notes: its vertices carry the pick they were tracked from, pick error
#: included, so the figures combine its instants' pointing errors as one common error
#: (:func:`usvips.app.project_figures.evaluate`), and editing the notes changes none of that
TRACKED_NOTE = "tracked from frame"


def tracked_note(start: int) -> str:
    """The notes an instant tracked from the picks on left frame ``start`` is given (for a person)."""
    return f"{TRACKED_NOTE} {int(start)}"


def is_tracked(project: ProjectStore, instant_id: int) -> bool:
    """Whether the further instant ``instant_id`` was made by tracking: what its link stores
    (``ProjectStore.instant_sources``), never its notes; False for an object that is no further instant."""
    whole = project.instant_links().get(int(instant_id))
    return whole is not None and project.instant_sources(whole).get(int(instant_id)) is not None


def has_tracked_instants(project: ProjectStore, object_id: int) -> bool:
    """Whether any further instant of ``object_id`` was made by tracking (the stored fact, one query)."""
    return any(start is not None for start in project.instant_sources(object_id).values())


def _calibration_of(stored: StoredObject) -> int | None:
    ids = {v.calibration_id for v in stored.vertices}
    if len(ids) != 1:
        raise UsvipsError(f"object {stored.id}: its vertices were measured with "
                          f"{'no calibration' if not ids or ids == {None} else 'different calibrations'}; "
                          "re-measure it before making it an instant")
    return next(iter(ids))


def add_instant(project: ProjectStore, object_id: int, instant_id: int, tracked_from: int | None = None,
                expected_modified: str | None = None) -> None:
    """Make the stored object ``instant_id`` a further instant of ``object_id`` (``tracked_from``: the left
    frame its track started from, None when picked by hand; ``expected_modified``: the instant's version as
    the caller read it, a colleague's change since is refused by name): refused, naming both, when they were
    measured with different calibrations (their common error would not be one) or are of different kinds;
    nothing is stored then."""
    whole, instant = project.object(object_id), project.object(instant_id)
    if whole.kind != instant.kind:
        raise UsvipsError(f"object {instant_id} is a {instant.kind}, object {object_id} a {whole.kind}: the "
                          "instants of an object are of one kind")
    first, other = _calibration_of(whole), _calibration_of(instant)
    if first != other:
        raise UsvipsError(f"object {object_id} was measured with calibration {first} but object {instant_id} with "
                          f"calibration {other}: the instants of an object share one calibration")
    project.add_instant(object_id, instant_id, tracked_from, expected_modified)


def survey_objects(project: ProjectStore) -> list[StoredObject]:
    """Every stored object that is not a further instant of another (each object once), by id."""
    links = project.instant_links()
    return [o for o in project.objects() if o.id not in links]
