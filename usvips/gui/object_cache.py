"""The open project's stored objects and their figures, kept in memory, free of Qt.

One :class:`ObjectCache` per open project (a new project gets a new cache: nothing of the previous one
can survive). It reads every object by ONE query when made (or, made ``deferred``, is empty and
:attr:`ObjectCache.loading` until the read made off the GUI thread on a handle of its own,
:func:`read_stored_objects`, arrives whole through :meth:`ObjectCache.arrived`), then is kept up to date
by id as edits are written (:meth:`ObjectCache.changed_in_store`); each object's figures are computed once
per change of the object or of the quality rules, here or in a worker (:meth:`ObjectCache.figures_job`),
and a worker's results for an object changed since are dropped.

Its events live in :class:`ObjectEvents`, owned by the workspace and handed to each new cache, so a view
connects once and hears every project's objects.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from usvips.app.live_changes import ColleagueChange
from usvips.app.pointing_settings import pointing_in_use
from usvips.app.project_figures import MeasurementInput, evaluate, joint_vertices, measurement_input
from usvips.core.errors import UsvipsError
from usvips.core.measurements import QualityRules
from usvips.core.observation_record import ObservationRecord
from usvips.core.stereo_calibration import StereoCalibration
from usvips.gui.calculator import Geometry, Result, pair_figures, result_of
from usvips.gui.figures_process import shared_process
from usvips.gui.signals import Signal
from usvips.store.interface import ProjectStore
from usvips.store.opening import open_project


@dataclass
class ObjectEvents:
    """``added(ids)``, ``updated(ids)``, ``removed(ids)`` (tuples of object ids, after the cache holds the
    change), ``reset()`` (every object is new: another project, or all read again) and ``changed()`` after
    any of these, for views that only recount."""

    added: Signal = field(default_factory=Signal)
    updated: Signal = field(default_factory=Signal)
    removed: Signal = field(default_factory=Signal)
    reset: Signal = field(default_factory=Signal)
    changed: Signal = field(default_factory=Signal)


@dataclass(frozen=True)
class StoredObjects:
    """Every stored object of a project by id (id order), their observation records and instant links:
    what a cache holds, read at once."""

    objects: dict[int, object]
    records: dict[int, ObservationRecord]
    links: dict[int, int]


def project_location(project: ProjectStore) -> str | Path:
    """Where the open ``project`` is, to open another handle on it: a server survey's URL, else its file."""
    return getattr(project, "url", None) or project.path


def read_stored_objects(location: str | Path, cancelled: Callable[[], bool] = lambda: False,
                        opener: Callable[..., ProjectStore] = open_project) -> StoredObjects | None:
    """Every stored object of the project at ``location``, read on a read-only handle of its own (any
    thread: a SQLite connection is never shared between threads); None when ``cancelled()`` turned True
    between the queries."""
    with opener(location, read_only=True) as store:
        objects = {o.id: o for o in store.objects()}
        if cancelled():
            return None
        records = store.records()
        if cancelled():
            return None
        return StoredObjects(objects, records, store.instant_links())


#: objects whose figures a worker computes together (``project_figures.evaluate_many``: one intersection with
#: the calibration's derivatives for all): 0.45 ms a fish against 4.5 ms one at a time, 0.58 ms in batches of
#: 16 and 0.34 ms of 128; 32 is ~15 ms of work, so a cancel is still heard at once
FIGURES_BATCH = 32


def _figures_of(source: MeasurementInput, rules: QualityRules) -> Result:
    """The object's figures through the one figure path (``project_figures.evaluate``); a reason when
    there are none. Pure: any thread."""
    try:
        return result_of(evaluate(source, rules))
    except UsvipsError as error:
        return Result((), (), str(error))


class ObjectCache:
    """The stored objects of ``project`` (None: no project, no objects) by id, and their figures under
    the rules ``rules()`` gives (the workspace's current quality rules)."""

    def __init__(self, project: ProjectStore | None, events: ObjectEvents,
                 rules: Callable[[], QualityRules], deferred: bool = False) -> None:
        self.project = project
        self.events = events
        self._rules = rules
        #: True until the objects read elsewhere arrive (``deferred``): the cache holds none meanwhile
        self.loading = bool(deferred and project is not None)
        #: ids written while loading: read again by id once the objects arrive (the read may predate them)
        self._pending: set[int] = set()
        read = self.loading or project is None
        self._objects: dict[int, object] = {} if read else {o.id: o for o in project.objects()}
        #: each object's observation record (the species is there, and only there)
        self._records: dict[int, ObservationRecord] = {} if read else project.records()
        self._figures: dict[int, tuple[QualityRules, Result]] = {}  # id -> the rules and its figures under them
        # id -> its main figure's value (NaN: it has none) for the figures held under ``_main_rules``: a sort of a
        # survey by the figure reads them at C speed (:meth:`main_figures`), not an object at a time in Python
        self._main: dict[int, float] = {}
        self._main_rules: QualityRules | None = None
        self._versions: dict[int, int] = {}  # id -> how often it changed (stale worker results are dropped)
        #: calibrations read for figures and picks, by id (read once per project)
        self.calibrations: dict[int, StereoCalibration | None] = {}
        #: a further instant's id -> the id of the object it is an instant of (read again on every change)
        self._links: dict[int, int] = {} if read else project.instant_links()
        #: the store's count of connections made again (a server that went away): when it moves, every
        #: object is read afresh (what colleagues wrote meanwhile)
        self._reconnections = getattr(project, "reconnections", 0)
        #: the project's pointing estimates in use (usvips.app.pointing_settings), read when first needed
        self._pointing: dict | None = None
        #: object id -> the colleague's change it was last read again for (usvips.gui.qt.live_updates): the views
        #: mark it with who changed it and when
        self.marks: dict[int, ColleagueChange] = {}

    # ------------------------------------------------------------------ the objects
    def objects(self) -> list:
        """The stored objects in id order (no query)."""
        return list(self._objects.values())

    def ids(self) -> list[int]:
        return list(self._objects)

    def __contains__(self, object_id: object) -> bool:
        return object_id in self._objects

    def get(self, object_id: int):
        """One stored object (raises by name when there is none)."""
        try:
            return self._objects[object_id]
        except KeyError:
            raise UsvipsError(f"there is no object {object_id} in the project") from None

    def instant_links(self) -> dict[int, int]:
        """Every further instant's id -> the id of the object it is an instant of (no query)."""
        return dict(self._links)

    def instant_of(self, object_id: int) -> int | None:
        """The id of the object ``object_id`` is a further instant of (None: it is no instant of another)."""
        return self._links.get(object_id)

    def record(self, object_id: int) -> ObservationRecord | None:
        """An object's observation record (None: none entered), from the cache."""
        return self._records.get(object_id)

    def changed_in_store(self, added: tuple[int, ...] = (), updated: tuple[int, ...] = (),
                         removed: tuple[int, ...] = ()) -> tuple[int, ...]:
        """Bring the cache up to date with what was just written (re-reading only those ids, by one query)
        and announce it by id; returns the ids now gone. An object whose instants changed (one of them
        edited, deleted, linked or unlinked) is announced as updated too: its combined figure changed; so
        is an instant linked or unlinked (it is shown as its object's). After the store connected again
        (a server that went away and came back) every object is read afresh instead. While the cache is
        :attr:`loading` the ids are only kept (read again, quietly, when the objects arrive)."""
        if self.loading:
            self._pending.update(added + updated + removed)
            return ()
        if getattr(self.project, "reconnections", 0) != self._reconnections:
            before = set(self._objects)
            self.reload()
            return tuple(sorted(before - set(self._objects)))
        named = added + updated + removed
        old, self._links = self._links, self._links_after(named)
        moved = set(old.items()) ^ set(self._links.items())
        touched = {i for link in moved for i in link} | {links.get(i) for links in (old, self._links) for i in named}
        updated = updated + tuple(sorted(i for i in touched if i is not None and i not in named and i in self._objects))
        fresh = {o.id: o for o in self.project.objects_with_ids(added + updated)} if added + updated else {}
        gone = tuple(i for i in removed + updated if i not in fresh and i in self._objects)
        for object_id in gone:
            del self._objects[object_id]
            self._records.pop(object_id, None)
        records = self.project.records_of(list(fresh)) if fresh else {}  # one query, not one an object
        for object_id in fresh:
            record = records.get(object_id)
            if record is None:
                self._records.pop(object_id, None)
            else:
                self._records[object_id] = record
        for object_id in (*added, *updated, *removed):
            self._figures.pop(object_id, None)
            self._main.pop(object_id, None)
            self._versions[object_id] = self._versions.get(object_id, 0) + 1
        new = tuple(i for i in added if i in fresh)
        changed = tuple(i for i in updated if i in fresh)
        highest = max(self._objects, default=0)
        for object_id in new:
            self._objects[object_id] = fresh[object_id]
        if any(i <= highest for i in new):  # keep id order (an undone delete comes back below the highest)
            self._objects = dict(sorted(self._objects.items()))
        for object_id in changed:
            self._objects[object_id] = fresh[object_id]
        if gone:
            self.events.removed.emit(gone)
        if new:
            self.events.added.emit(new)
        if changed:
            self.events.updated.emit(changed)
        self.events.changed.emit()
        return gone

    def _links_after(self, named: tuple[int, ...]) -> dict[int, int]:
        """The project's instant links after a write to the objects ``named``: the links held here, those in
        which a named object takes part (as instant or as object: a deleted object's instants are unlinked
        with it) read again — not every link of a survey, on the window's thread after each write."""
        if not named:
            return self._links
        ids = set(named)
        kept = {i: whole for i, whole in self._links.items() if i not in ids and whole not in ids}
        return dict(sorted({**kept, **self.project.instant_links_of(sorted(ids))}.items()))

    def arrived(self, read: StoredObjects) -> None:
        """The objects read elsewhere (:func:`read_stored_objects`) held at once, those written meanwhile
        read again by id (their records by one query, and only the links they take part in); then announced as
        every object new (``reset``, ``changed``). Ignored unless :attr:`loading` (a :meth:`reload` since holds
        newer objects)."""
        if not self.loading:
            return
        self._objects, self._records, self._links = dict(read.objects), dict(read.records), dict(read.links)
        self.loading, pending, self._pending = False, self._pending, set()
        if pending:
            named = tuple(sorted(pending))
            self._links = self._links_after(named)
            fresh = {o.id: o for o in self.project.objects_with_ids(named)}
            records = self.project.records_of(list(fresh)) if fresh else {}  # one query, not one an object
            for object_id in named:
                self._records.pop(object_id, None)
                if object_id in fresh:
                    self._objects[object_id] = fresh[object_id]
                    if object_id in records:
                        self._records[object_id] = records[object_id]
                else:
                    self._objects.pop(object_id, None)
            self._objects = dict(sorted(self._objects.items()))
        self._figures, self._versions, self._main = {}, {}, {}
        self.events.reset.emit()
        self.events.changed.emit()

    def reload(self) -> None:
        """Read every stored object again (by one query), e.g. after another program changed the project."""
        self.loading, self._pending = False, set()
        self._objects = {} if self.project is None else {o.id: o for o in self.project.objects()}
        self._records = {} if self.project is None else self.project.records()
        self._links = {} if self.project is None else self.project.instant_links()
        self._figures, self._versions, self._pointing, self._main = {}, {}, None, {}
        self._reconnections = getattr(self.project, "reconnections", 0)
        self.events.reset.emit()
        self.events.changed.emit()

    # ------------------------------------------------------------------ figures
    def forget_figures(self, object_ids: Iterable[int] | None = None) -> None:
        """Drop the computed figures of ``object_ids`` (they are computed again when asked for); with none given,
        every object's, and the project's pointing estimates in use read for them (read again: a change of
        estimate changes every figure)."""
        if object_ids is not None:
            for object_id in object_ids:
                self._figures.pop(object_id, None)
                self._main.pop(object_id, None)
            return
        self._figures, self._main = {}, {}
        self._pointing = None

    def _keep(self, object_id: int, rules: QualityRules, result: Result) -> None:
        """Hold ``result`` as the object's figures under ``rules``."""
        self._figures[object_id] = (rules, result)
        if self._main_rules is None and not self._main:
            self._main_rules = rules  # the table starts with the first figures held (no pass at the first sort)
        if rules is self._main_rules or rules == self._main_rules:
            self._main[object_id] = result.figures[0].value if result.figures else math.nan
        else:
            self._main.pop(object_id, None)

    def known_figures(self, object_id: int) -> Result | None:
        """An object's figures when known under the current rules (None: not yet computed)."""
        known = self._figures.get(object_id)
        if known is None:
            return None
        rules = self._rules()
        return known[1] if known[0] is rules or known[0] == rules else None

    def figures_known(self, object_ids: Iterable[int]) -> dict[int, Result | None]:
        """:meth:`known_figures` of many objects (the rules asked for once: a sort of a survey asks for all)."""
        rules, get = self._rules(), self._figures.get
        known = dict.fromkeys(object_ids)  # None: not known (most of a survey just opened: one lookup each)
        for object_id in known:
            held = get(object_id)
            if held is not None and (held[0] is rules or held[0] == rules):
                known[object_id] = held[1]
        return known

    def main_figures(self, object_ids: Iterable[int]) -> tuple[np.ndarray, np.ndarray, list[int]]:
        """The values of the main figure (m, m², …) and the ids of those of ``object_ids`` whose figures are known
        under the current rules and hold one, and the ids of the others, each in the order given: what a sort by
        the figure needs (a sort of a 20,000-object survey arranges them on the window's thread: ~3 ms, where
        a lookup an object in Python took ~40 ms)."""
        self._main_under_rules()
        listed = object_ids if isinstance(object_ids, list) else list(object_ids)
        values = np.fromiter(map(self._main.get, listed, itertools.repeat(math.nan)), dtype=np.float64,
                             count=len(listed))
        ids, valued = np.array(listed, dtype=np.int64), ~np.isnan(values)
        return values[valued], ids[valued], ids[~valued].tolist()

    def missing_figures(self) -> int:
        """How many held objects have no figures known under the current rules (no look at each object)."""
        self._main_under_rules()
        return len(self._objects) - len(self._main)

    def _main_under_rules(self) -> None:
        """The table of main figures made anew from the figures held when the rules are other than its own."""
        rules = self._rules()
        if not (self._main_rules is rules or self._main_rules == rules):  # other rules: what they hold, once
            self._main_rules = rules
            self._main = {i: (held[1].figures[0].value if held[1].figures else math.nan)
                          for i, held in self._figures.items() if held[0] is rules or held[0] == rules}

    def input(self, stored, instants: dict[int, list[int]] | None = None) -> MeasurementInput:
        """What the figures of a stored object need, read from the project now (GUI thread); ``instants``:
        every object's further instants (:meth:`instants_by_object`) when reading many."""
        if self._pointing is None:
            self._pointing = {} if self.project is None else pointing_in_use(self.project)
        return measurement_input(self.project, stored, self.calibrations,
                                 instants=self.instants_by_object() if instants is None else instants,
                                 pointing=self._pointing)

    def instants_by_object(self) -> dict[int, list[int]]:
        """Object id → the ids of its further instants, from the links held here (no query)."""
        grouped: dict[int, list[int]] = {}
        for instant, whole in sorted(self._links.items()):
            grouped.setdefault(whole, []).append(instant)
        return grouped

    def figures_job(self, object_ids: list[int]) -> Callable[..., dict[int, Result]]:
        """The figures of many objects as a function of copied inputs (run it off the GUI thread); give its
        result to :meth:`remember`. The inputs are copied with no query an object (the instants from the
        links held here, each calibration read once); the job computes them, :data:`FIGURES_BATCH` at a time,
        in the window process's figures child (:mod:`usvips.gui.figures_process`: the window's thread never
        waits on it for the GIL), or in its own thread while the child starts or when it cannot."""
        instants = self.instants_by_object()
        inputs = [(i, self.input(self.get(i), instants)) for i in object_ids]
        rules = self._rules()

        def run(progress=None, cancelled=None) -> dict[int, Result]:
            out = {}
            process = shared_process()
            for begin in range(0, len(inputs), FIGURES_BATCH):
                if cancelled is not None and cancelled():
                    break
                batch = inputs[begin:begin + FIGURES_BATCH]
                out.update(zip((i for i, _ in batch), process.figures([s for _, s in batch], rules), strict=True))
                if progress is not None:
                    progress((begin + len(batch)) / len(inputs))
            return out

        run.versions = {i: self._versions.get(i, 0) for i in object_ids}  # what the results are of
        run.rules = rules
        return run

    def remember(self, job: Callable[..., dict[int, Result]], results: dict[int, Result]) -> list[int]:
        """Keep what :meth:`figures_job`'s ``job`` computed, except for objects changed (or rules changed)
        since it was made; returns the ids kept."""
        if job.rules != self._rules():
            return []
        kept = [i for i in results if i in self._objects and self._versions.get(i, 0) == job.versions.get(i)]
        for object_id in kept:
            self._keep(object_id, job.rules, results[object_id])
        return kept

    def figures(self, object_ids: list[int]) -> Result:
        """The geo-calculator on one object (its figures, computed once per change and kept) or two (the
        figures between them, with their common covariance)."""
        if self.project is None or not object_ids:
            return Result((), (), "select one or two objects")
        rules = self._rules()
        if len(object_ids) == 1:
            object_id = object_ids[0]
            known = self.known_figures(object_id)
            if known is None:
                known = _figures_of(self.input(self.get(object_id)), rules)
                self._keep(object_id, rules, known)
            return known
        if len(object_ids) != 2:
            return Result((), (), "select one object (its own figures) or two (figures between them)")
        first, second = (self.get(i) for i in object_ids)
        both = replace(first, vertices=first.vertices + second.vertices)
        points, covariance, _ = joint_vertices(self.input(both))
        n = 3 * len(first.vertices)
        a = Geometry(first.kind, points[: n // 3], covariance[:n, :n])
        b = Geometry(second.kind, points[n // 3:], covariance[n:, n:])
        return pair_figures(a, b, covariance)
