"""Edits of the stored objects, free of Qt: delete a vertex or an object, change an object's kind, its
attribute and notes, its observation record. Each is ONE command on the workspace's undo stack that
restores exactly what it changed: undo puts back the object's stored rows as they were (vertices, video
frames, kind, texts, record, history; a deleted object under its own id), redo the rows the edit made —
never a look-alike. On a shared survey an undo or redo is made only onto the object as this window left
it: when another annotator changed (or deleted) it since, the step is refused by name
(:class:`~usvips.store.records.StaleEditError`, nothing changes) — never a silent overwrite of their edit.
A refusal (too few vertices, a kind the vertices cannot make) is one line naming the
object, and nothing changes.

The edits work on an :class:`EditScene` (the workspace: the open project, its object cache, the undo stack
and ``message``); a vertex edit also calls ``vertices_changed`` (the pick tool drops the vertex being
picked, which may have pointed at the old vertices).
"""

from __future__ import annotations

from collections.abc import Callable
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
from usvips.store.records import StaleEditError


class EditScene(Protocol):
    """What the edits need: the open project, the one undo stack, ``message(level, text)``, a stored
    object by id (from the cache) and the cache told what was written."""

    project: ProjectStore | None
    undo: UndoStack
    message: Signal

    def stored_object(self, object_id: int): ...

    def objects_changed_in_store(self, added: tuple[int, ...] = (), updated: tuple[int, ...] = (),
                                 removed: tuple[int, ...] = ()) -> None: ...


class ObjectEdits:
    """The undoable edits of the stored objects of ``scene``'s project."""

    def __init__(self, scene: EditScene, vertices_changed: Callable[[], None] | None = None) -> None:
        self.scene = scene
        self.vertices_changed = vertices_changed

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
        self.edit_stored(label, object_id, lambda: project.update_object(object_id, vertices=after),
                         self.vertices_changed)
        self.scene.message.emit("info", f"{label}: done (Ctrl+Z undoes it)")

    def edit_stored(self, label: str, object_id: int, edit: Callable[[], None],
                    then: Callable[[], None] | None = None) -> None:
        """Run ``edit`` of a stored object as one undoable command. Undo puts back the object's stored rows
        as they were before (vertices, kind, texts, record, history: exactly, nothing added); redo puts
        back the rows the edit made."""
        project = self.scene.project
        before = project.object_rows(object_id)
        after: list = []

        def redo() -> None:
            if after:  # only onto the object as the undo left it: not over someone's edit made since
                self._unless_stale(object_id, lambda: project.put_back(after[0], expected_modified=before.modified))
            else:
                edit()
                after.append(project.object_rows(object_id))
            self.scene.objects_changed_in_store(updated=(object_id,))
            if then is not None:
                then()

        def undo() -> None:  # only when nobody (another annotator on a shared survey) changed it since
            self._unless_stale(object_id, lambda: project.put_back(before, expected_modified=after[0].modified))
            self.scene.objects_changed_in_store(updated=(object_id,))
            if then is not None:
                then()

        self.scene.undo.push(Command(label, redo, undo))

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

        def delete() -> None:  # a redo: only the object as the undo put it back, not someone's later edit
            version = removed[0].modified if removed else None
            removed[:] = [self._unless_stale(object_id, lambda: project.take_object(object_id, version))]
            self.scene.objects_changed_in_store(removed=(object_id,))

        def restore() -> None:  # refused by name when the id was used again meanwhile
            project.put_back(removed[0])
            self.scene.objects_changed_in_store(added=(object_id,))

        self.scene.undo.push(Command(f"delete {saved.kind} {object_id}", delete, restore))

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
                         lambda: self.scene.project.update_object(object_id, kind=kind))
        self.scene.message.emit("info", f"object {object_id} is now {article(kind)} (Ctrl+Z undoes it)")

    def edit_object(self, object_id: int, attribute: str, notes: str) -> None:
        """Change a stored object's attribute (kept as a term of the project's vocabulary) and notes;
        undoable."""
        self.scene.stored_object(object_id)

        def edit() -> None:
            self.scene.project.update_object(object_id, attribute=attribute, notes=notes)
            if attribute:
                self.scene.project.add_term(attribute)

        self.edit_stored(f"edit object {object_id}", object_id, edit)

    def set_record(self, object_id: int, record: ObservationRecord | None) -> None:
        """Store an object's observation record (species, number, stage, activity, comment); undoable."""
        self.edit_stored(f"observation record of object {object_id}", object_id,
                         lambda: self.scene.project.set_record(object_id, record))
