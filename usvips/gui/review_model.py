"""Review mode's model (Qt-free): a second reader walks the objects of a survey that were unreviewed when
the walk began, accepts each one or flags it with a reason, and sees how far they are.

The queue is in a stable order: by where the object was measured (its video or image pair, by label), then
its left frame (objects of one video in time order), then its id. It holds the objects that were
unreviewed when it was loaded (and the objects measured since, appended as they come); reviewing an
object keeps it in the queue, so that Previous goes back to it and its review can be changed.

- :meth:`ReviewModel.next` / :meth:`ReviewModel.previous` move one place in the queue;
- :meth:`ReviewModel.accept` / :meth:`ReviewModel.flag` store the review (as the store's annotator, with
  the object's version as read: an object someone else changed meanwhile is refused by name, and its
  state read again), then move on to the next object still unreviewed;
- :meth:`ReviewModel.skip` moves on to the next unreviewed object without reviewing this one.

Review states stay current while several annotators review one survey: every move to another object
(next, previous, skip, go to) reads that object's review again — one query — so a review someone else made
meanwhile is shown (:meth:`ReviewModel.refresh_current` does the same on demand: the window calls it when
it regains the focus). A review made on a stale read is still refused by name (the store's optimistic
versions): reading the state again does not make the object's version current, a refused review does.

Events (:class:`usvips.gui.signals.Signal`): ``changed()`` after anything the view shows changed (the
queue, the current object, a state); ``reviewed(object_id, review)`` after a review was stored;
``read(object_id, review)`` when a review read again differs from the one shown (someone else's).
"""

from __future__ import annotations

from collections.abc import Iterable

from usvips.core.errors import UsvipsError
from usvips.gui.signals import Signal
from usvips.store.records import Review, StaleEditError, StoredObject


def queue_key(stored: StoredObject) -> tuple:
    """Where an object comes in the queue: its video or pair label, its left frame (-1 on an image
    pair), its id."""
    vertex = stored.vertices[0] if stored.vertices else None
    if vertex is None:
        return ("", -1, stored.id)
    if vertex.video is not None:
        return (vertex.video, int(vertex.frame_left if vertex.frame_left is not None else -1), stored.id)
    return (vertex.pair or "", -1, stored.id)


def progress_text(reviewed: int, total: int, flagged: int = 0) -> str:
    """``12 of 140 reviewed`` (``, 3 flagged`` when any were), or that there is nothing to review."""
    if total == 0:
        return "nothing to review: every object has been reviewed"
    return f"{reviewed} of {total} reviewed" + (f", {flagged} flagged" if flagged else "")


class ReviewModel:
    """The review queue of one store (a :class:`~usvips.store.interface.ProjectStore`); see the module
    docstring. ``load`` (re)reads it; without a store the queue is empty."""

    def __init__(self) -> None:
        self.changed = Signal()
        self.reviewed = Signal()
        self.read = Signal()
        self.store = None
        self.queue: list[int] = []
        self.position = 0
        self.reviews: dict[int, Review] = {}
        self._versions: dict[int, str] = {}
        self._made: dict[int, str] = {}  # the latest version of an object read here (the caller's may be older)

    # ------------------------------------------------------------------ loading
    def load(self, store, objects: Iterable[StoredObject] | None = None) -> None:
        """Read the reviews of ``store`` (None: no project) and queue its unreviewed objects; ``objects``:
        the store's objects when the caller has them (the window's cache), else they are read."""
        if store is not self.store:
            self._made = {}
        self.store = store
        self.reviews, self._versions, self.queue, self.position = {}, {}, [], 0
        if store is not None:
            stored = list(objects) if objects is not None else store.objects()
            self.reviews = {r.object_id: r for r in store.reviews()}
            self._versions = {o.id: max(o.modified, self._made.get(o.id, "")) for o in stored}
            self.queue = [o.id for o in sorted(stored, key=queue_key)
                          if self.reviews.get(o.id, Review(o.id)).state == "unreviewed"]
        self.changed.emit()

    def add(self, objects: Iterable[StoredObject]) -> None:
        """Objects measured since the queue was loaded: unreviewed, they join the end of the queue."""
        new = [o for o in objects if o.id not in self._versions]
        for stored in sorted(new, key=queue_key):
            self._versions[stored.id] = stored.modified
            self.reviews[stored.id] = Review(stored.id)
            self.queue.append(stored.id)
        if new:
            self.changed.emit()

    def updated(self, objects: Iterable[StoredObject]) -> None:
        """Objects changed in the window since they were read, as just read again from the store: their
        versions now (a review of them is not a stale one). Taken as they are, not the later of the two: an
        edit undone puts the object's rows back with their older stamp, which is then the stored one."""
        for stored in objects:
            if stored.id in self._versions:
                self._versions[stored.id] = self._made[stored.id] = stored.modified

    def reread(self, object_ids: Iterable[int]) -> list[int]:
        """Read the reviews of ``object_ids`` again — another annotator's reviews, or an edit that returned
        an accepted object to unreviewed — by one query (:meth:`ProjectStore.review` of one object, else
        :meth:`ProjectStore.reviews`); returns the ids whose review changed. An object now unreviewed that
        is not in the queue joins its end (it waits for a review again); ids not read here are left out.
        An object of one id that no longer exists is the store's ``ProjectError``."""
        if self.store is None:
            return []
        ids = [i for i in dict.fromkeys(object_ids) if i in self._versions]
        if len(ids) == 1:
            fresh = {ids[0]: self.store.review(ids[0])}
        elif ids:
            every = {r.object_id: r for r in self.store.reviews()}
            fresh = {i: every[i] for i in ids if i in every}
        else:
            return []
        changed = self._take(fresh)
        if changed:
            self.changed.emit()
        return changed

    def _take(self, fresh: dict[int, Review]) -> list[int]:
        """Keep the reviews read again; the ids whose review changed (each announced by ``read``)."""
        changed = [i for i, review in fresh.items() if review != self.state(i)]
        for object_id in changed:
            self.reviews[object_id] = fresh[object_id]
            if fresh[object_id].state == "unreviewed" and object_id not in self.queue:
                self.queue.append(object_id)
            self.read.emit(object_id, fresh[object_id])
        return changed

    def refresh_current(self) -> bool:
        """Read the current object's review again (one query); True when it changed (``changed`` then
        fires). An object deleted meanwhile is the store's ``ProjectError``."""
        object_id = self.current
        if object_id is None or self.store is None:
            return False
        changed = self._take({object_id: self.store.review(object_id)})
        if changed:
            self.changed.emit()
        return bool(changed)

    def forget(self, object_ids: Iterable[int]) -> None:
        """Objects deleted: out of the queue (the current place stays on the same object, or the next)."""
        gone = set(object_ids) & set(self._versions)
        if not gone:
            return
        before = sum(1 for i in self.queue[:self.position] if i in gone)
        self.queue = [i for i in self.queue if i not in gone]
        for object_id in gone:
            self._versions.pop(object_id, None)
            self.reviews.pop(object_id, None)
        self.position = max(0, min(self.position - before, len(self.queue) - 1))
        self.changed.emit()

    # ------------------------------------------------------------------ where we are
    @property
    def current(self) -> int | None:
        """The object under review (None when the queue is empty)."""
        return self.queue[self.position] if self.queue else None

    def state(self, object_id: int) -> Review:
        """An object's review as last read or made."""
        return self.reviews.get(object_id, Review(object_id))

    def _states(self, object_ids: Iterable[int]) -> list[str]:
        """The review states of ``object_ids`` (no review made: unreviewed), without making a review each."""
        reviews = self.reviews
        return [review.state if (review := reviews.get(i)) is not None else "unreviewed" for i in object_ids]

    def counts(self) -> tuple[int, int, int]:
        """(reviewed, total, flagged) over the queue."""
        states = self._states(self.queue)
        return len(states) - states.count("unreviewed"), len(states), states.count("flagged")

    def progress(self) -> str:
        return progress_text(*self.counts())

    def survey_counts(self, object_ids: Iterable[int]) -> tuple[int, int, int]:
        """(reviewed, total, flagged) over the survey's objects ``object_ids`` — not only the queue (which
        holds the objects unreviewed when it was loaded, and those measured since)."""
        states = self._states(object_ids)
        return len(states) - states.count("unreviewed"), len(states), states.count("flagged")

    def survey_progress(self, object_ids: Iterable[int]) -> str:
        """``survey: 138 of 140 reviewed, 2 flagged`` — or "" when the queue is the whole survey (the queue's
        own count says it all)."""
        ids = list(object_ids)
        if set(ids) <= set(self.queue):
            return ""
        reviewed, total, flagged = self.survey_counts(ids)
        return f"survey: {reviewed} of {total} reviewed" + (f", {flagged} flagged" if flagged else "")

    @property
    def finished(self) -> bool:
        """Every object of the queue has been reviewed."""
        reviewed, total, _ = self.counts()
        return reviewed == total

    # ------------------------------------------------------------------ moving
    def go_to(self, object_id: int) -> None:
        """Make ``object_id`` (in the queue) the current object (its review read again)."""
        if object_id in self.queue:
            self.position = self.queue.index(object_id)
            self._moved()

    def _moved(self) -> None:
        """After a move: the current object's review read again (one query), then ``changed``; a failed
        read is raised after the view was told of the move."""
        try:
            if self.current is not None and self.store is not None:
                self._take({self.current: self.store.review(self.current)})
        finally:
            self.changed.emit()

    def next(self) -> int | None:
        """One place on (stays at the end); returns the current object."""
        return self._move(1)

    def previous(self) -> int | None:
        """One place back (stays at the start); returns the current object."""
        return self._move(-1)

    def _move(self, step: int) -> int | None:
        if self.queue:
            self.position = max(0, min(self.position + step, len(self.queue) - 1))
        self._moved()
        return self.current

    def skip(self) -> int | None:
        """On to the next object still unreviewed after this one (round to the start; stays when none)."""
        count = len(self.queue)
        for step in range(1, count):
            index = (self.position + step) % count
            if self.state(self.queue[index]).state == "unreviewed":
                self.position = index
                break
        self._moved()
        return self.current

    # ------------------------------------------------------------------ reviewing
    def accept(self, reason: str = "") -> Review:
        """Accept the current object (``reason``: an optional remark), then on to the next unreviewed one."""
        return self._review("accepted", reason)

    def flag(self, reason: str) -> Review:
        """Flag the current object with ``reason`` (required, one line), then on to the next unreviewed one."""
        return self._review("flagged", reason)

    def unreview(self) -> Review:
        """Put the current object back to unreviewed (a review made by mistake); the place stays."""
        return self._review("unreviewed", "", advance=False)

    def _review(self, state: str, reason: str, advance: bool = True) -> Review:
        object_id = self.current
        if object_id is None or self.store is None:
            raise UsvipsError("nothing to review: the queue is empty")
        try:
            self.store.set_review(object_id, state, reason, expected_modified=self._versions.get(object_id))
        except StaleEditError:
            self._take({object_id: self.store.review(object_id)})  # the object as it now is: its state (shown
            self._reread(object_id)                                 # and announced) and version, to review again
            self.changed.emit()
            raise
        self._reread(object_id)
        review = self.state(object_id)
        self.reviewed.emit(object_id, review)
        if advance and not self.finished:
            try:
                self.skip()
            except UsvipsError:
                pass  # the review is stored; the next object's review could not be read again (deleted
                # meanwhile?): it is shown as last read, and a review of it is refused by name
        else:
            self.changed.emit()
        return review

    def _reread(self, object_id: int) -> None:
        self.reviews[object_id] = self.store.review(object_id)
        self._versions[object_id] = self._made[object_id] = self.store.object(object_id).modified
