"""Edits of the stored objects, free of Qt: delete a vertex or an object, change an object's kind, its
attribute and notes, its observation record. Each is ONE command on the workspace's undo stack that
restores exactly what it changed: undo puts back the object's stored rows as they were (vertices, video
frames, kind, texts, record, history; a deleted object under its own id), redo the rows the edit made —
never a look-alike. On a shared survey an undo or redo is made only onto the object as this window left
it: when another annotator changed (or deleted) it since, the step is refused by name
(:class:`~usvips.store.records.StaleEditError`, nothing changes) — never a silent overwrite of their edit.
A refusal (too few vertices, a kind the vertices cannot make) is one line naming the
object, and nothing changes.

Every first save names the version this window read (the cache's ``modified`` stamp): an edit or delete
from an out-of-date window is refused by name, never written over a colleague's edit. A save that fails
(the server unreachable, a colleague's change, the store busy) is never shown as saved: the object is
shown again as stored (the list's cell reverts) and the edit is kept (:attr:`ObjectEdits.unsaved`) for
:meth:`ObjectEdits.retry_unsaved` or :meth:`ObjectEdits.discard_unsaved`; the message says so in plain
words.

The edits work on an :class:`EditScene` (the workspace: the open project, its object cache, the undo stack
and ``message``); a vertex edit also calls ``vertices_changed`` (the pick tool drops the vertex being
picked, which may have pointed at the old vertices).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

from usvips.core.errors import UsvipsError
from usvips.core.measurements import kind as measurement_kind
from usvips.core.measurements import registered_kinds, resolve
from usvips.core.observation_record import ObservationRecord
from usvips.gui.signals import Signal
from usvips.gui.undo import Command, UndoStack
from usvips.gui.wording import article, plural
from usvips.store.interface import ProjectStore
from usvips.store.project import Vertex
from usvips.store.records import ServerUnreachableError, StaleEditError


class EditScene(Protocol):
    """What the edits need: the open project, the one undo stack, ``message(level, text)``, a stored
    object by id (from the cache) and the cache told what was written."""

    project: ProjectStore | None
    undo: UndoStack
    message: Signal

    def stored_object(self, object_id: int): ...

    def objects_changed_in_store(self, added: tuple[int, ...] = (), updated: tuple[int, ...] = (),
                                 removed: tuple[int, ...] = ()) -> None: ...

    def show_as_cached(self, object_ids: tuple[int, ...]) -> None: ...


@dataclass(frozen=True)
class UnsavedEdit:
    """An edit the store did not take: what it was (``label``), of which object, why (one line), and how to
    make it again (``retry``: the same edit, on the object as the window now has it)."""

    label: str
    object_id: int
    reason: str
    retry: Callable[[], None]


def why_not_saved(error: UsvipsError) -> str:
    """A failed save in plain words: the server unreachable, a colleague's change (by name), or the
    store's own line."""
    if isinstance(error, ServerUnreachableError):
        return "the server is unreachable"
    return str(error)


class ObjectEdits:
    """The undoable edits of the stored objects of ``scene``'s project."""

    def __init__(self, scene: EditScene, vertices_changed: Callable[[], None] | None = None) -> None:
        self.scene = scene
        self.vertices_changed = vertices_changed
        #: the edits not saved, by (object id, what): kept for :meth:`retry_unsaved` or :meth:`discard_unsaved`
        self.unsaved: dict[tuple[int, str], UnsavedEdit] = {}

    def delete_vertex(self, object_id: int, index: int) -> None:
        """Remove vertex ``index`` (0-based) of a stored object (undoable); an object keeps at least the
        vertices its kind needs (delete the object instead)."""
        stored = self.scene.stored_object(object_id)
        if not 0 <= index < len(stored.vertices):
            raise UsvipsError(f"{stored.kind} {object_id} has vertices 1 to {len(stored.vertices)}, not {index + 1}")
        least = measurement_kind(resolve(stored.kind, len(stored.vertices))).minimum_vertices
        if len(stored.vertices) - 1 < least:
            raise UsvipsError(f"{article(stored.kind)} needs at least {plural(least, 'vertex')}: delete the object "
                              "instead")
        saved = list(stored.vertices)
        self._set_vertices(f"delete vertex {index + 1} of object {object_id}", object_id, saved,
                           saved[:index] + saved[index + 1:])

    def _set_vertices(self, label: str, object_id: int, before: list[Vertex], after: list[Vertex]) -> None:
        project = self.scene.project
        self.edit_stored(label, object_id,
                         lambda version: project.update_object(object_id, vertices=after, expected_modified=version),
                         self.vertices_changed)
        self.scene.message.emit("info", f"{label}: done (Ctrl+Z undoes it)")

    def edit_stored(self, label: str, object_id: int, edit: Callable[[str], None],
                    then: Callable[[], None] | None = None) -> None:
        """Run ``edit(version)`` of a stored object as one undoable command; ``version`` is the object's
        ``modified`` stamp as this window read it (its cache), which ``edit`` hands to the store
        (``expected_modified``): an object a colleague changed since is refused by name, never
        overwritten. Undo puts back the object's stored rows as they were before (vertices, kind, texts,
        record, history: exactly, nothing added); redo puts back the rows the edit made."""
        project = self.scene.project
        read = self.scene.stored_object(object_id).modified
        before: list = []  # the rows as they were (read with the first save, for undo)
        after: list = []

        def redo() -> None:
            if after:  # only onto the object as the undo left it: not over someone's edit made since
                self._unless_stale(object_id, lambda: project.put_back(after[0], expected_modified=before[0].modified))
            else:
                before[:] = [project.object_rows(object_id)]
                self._unless_stale(object_id, lambda: edit(read))
                after.append(project.object_rows(object_id))
            self.scene.objects_changed_in_store(updated=(object_id,))
            if then is not None:
                then()

        def undo() -> None:  # only when nobody (another annotator on a shared survey) changed it since
            self._unless_stale(object_id, lambda: project.put_back(before[0], expected_modified=after[0].modified))
            self.scene.objects_changed_in_store(updated=(object_id,))
            if then is not None:
                then()

        self._save(Command(label, redo, undo), object_id,
                   lambda: self.edit_stored(label, object_id, edit, then))

    def _save(self, command: Command, object_id: int, retry: Callable[[], None]) -> None:
        """Do ``command`` (pushed on the undo stack when it succeeds). When the store does not take it, it
        is never shown as saved: the object is shown as stored, the edit kept for retry or discard, the
        window told why in one line, and the error raised on (to a caller that keeps the typed text)."""
        key = (object_id, command.label)
        try:
            self.scene.undo.push(command)
        except UsvipsError as error:
            self.unsaved[key] = UnsavedEdit(command.label, object_id, why_not_saved(error), retry)
            self.scene.show_as_cached((object_id,))
            self.scene.message.emit("error", f"{command.label}: not saved — {why_not_saved(error)}; the edit is "
                                             "kept: Edit ▸ Retry unsaved edits, or Discard unsaved edits")
            raise
        self.unsaved.pop(key, None)

    def retry_unsaved(self) -> int:
        """Make every kept edit again (on the objects as the window now has them); returns how many were
        saved. One failing again is kept again (and said)."""
        saved = 0
        for key, kept in list(self.unsaved.items()):
            self.unsaved.pop(key, None)
            try:
                kept.retry()
            except UsvipsError:
                continue
            saved += 1
        return saved

    def discard_unsaved(self) -> int:
        """Forget every kept edit (the objects stay as stored); returns how many were dropped."""
        dropped = len(self.unsaved)
        ids = tuple(sorted({kept.object_id for kept in self.unsaved.values()}))
        self.unsaved.clear()
        if ids:
            self.scene.show_as_cached(ids)
        return dropped

    def _unless_stale(self, object_id: int, step: Callable[[], object]) -> object:
        """Run an undo or redo ``step`` of a stored object; refused as stale (another annotator changed or
        deleted it since), the window re-reads the object as it now is and the refusal goes on to the
        undo stack (which drops the step) and the status bar."""
        try:
            return step()
        except StaleEditError:
            self.scene.objects_changed_in_store(updated=(object_id,))
            raise

    def delete_object(self, object_id: int) -> None:
        """Delete a stored object (undoable: undo gives back the same id with its vertices, video frames,
        observation record and history)."""
        saved = self.scene.stored_object(object_id)
        removed: list = []
        project = self.scene.project

        def delete() -> None:  # only the object as this window read it (or the undo put it back)
            version = removed[0].modified if removed else saved.modified
            removed[:] = [self._unless_stale(object_id, lambda: project.take_object(object_id, version))]
            self.scene.objects_changed_in_store(removed=(object_id,))

        def restore() -> None:  # refused by name when the id was used again meanwhile
            project.put_back(removed[0])
            self.scene.objects_changed_in_store(added=(object_id,))

        try:
            self._save(Command(f"delete {saved.kind} {object_id}", delete, restore), object_id,
                       lambda: self.delete_object(object_id))
        except UsvipsError:
            return  # said and kept (see _save); the list's delete goes on with the next selected object

    def kinds_for(self, object_id: int) -> list[str]:
        """The registered measurement kinds a stored object's vertices can make (its own first)."""
        stored = self.scene.stored_object(object_id)
        count = len(stored.vertices)
        fitting = [k.name for k in registered_kinds() if k.minimum_vertices <= count
                   and (k.maximum_vertices is None or count <= k.maximum_vertices)]
        return sorted(fitting, key=lambda name: name != stored.kind)

    def change_kind(self, object_id: int, kind: str) -> None:
        """Make a stored object another measurement kind (an arc a polygon, say), keeping its vertices;
        undoable. Refused by name when the vertices cannot make that kind."""
        stored = self.scene.stored_object(object_id)
        if kind == stored.kind:
            return
        if kind not in self.kinds_for(object_id):
            raise UsvipsError(f"{stored.kind} {object_id} has {plural(len(stored.vertices), 'vertex')}: it cannot be "
                              f"{article(kind)} (it can be {', '.join(self.kinds_for(object_id))})")

        self.edit_stored(f"make object {object_id} {article(kind)}", object_id,
                         lambda version: self.scene.project.update_object(object_id, kind=kind,
                                                                          expected_modified=version))
        self.scene.message.emit("info", f"object {object_id} is now {article(kind)} (Ctrl+Z undoes it)")

    def edit_object(self, object_id: int, attribute: str, notes: str) -> None:
        """Change a stored object's attribute (kept as a term of the project's vocabulary) and notes;
        undoable. Only what differs from the object as this window read it is written (a colleague's
        notes are not written back by an edit of the attribute); nothing differing, nothing is done."""
        read = self.scene.stored_object(object_id)
        changed = {name: value for name, value in (("attribute", attribute), ("notes", notes))
                   if value != getattr(read, name)}
        if not changed:
            return

        def edit(version: str) -> None:
            with self.scene.project.transaction():
                self.scene.project.update_object(object_id, **changed, expected_modified=version)
                if changed.get("attribute"):
                    self.scene.project.add_term(changed["attribute"])

        try:
            self.edit_stored(f"edit object {object_id}", object_id, edit)
        except UsvipsError:
            return  # said and kept (see _save): the list's cell shows the object as stored

    def set_record(self, object_id: int, record: ObservationRecord | None) -> None:
        """Store an object's observation record (species, number, stage, activity, comment); undoable."""
        self.edit_stored(f"observation record of object {object_id}", object_id,
                         lambda version: self.scene.project.set_record(object_id, record, expected_modified=version))
