"""Undo and redo, free of Qt: every pick and edit of the workstation is a :class:`Command` pushed on one
:class:`UndoStack`. A command that changes the project restores exactly what it changed (the stored
rows of an object, see :meth:`usvips.store.project.Project.object_rows`), never a look-alike.

Two scopes: a step on the project (store, edit, delete an object) stays undoable when another pair or
video frame is shown; a step on what is shown (a pick, a nudge, the images' enhancement) is
``pair_bound`` and forgotten then (:meth:`UndoStack.forget_pair_steps`): the picks are gone with their
images, and an enhancement undone on other images would change those.

On a shared survey a step is taken back only onto the object as this window left it: a step refused as
stale (:class:`~usvips.store.records.StaleEditError`, another annotator changed the object since) is
dropped from the stack, nothing changed (see :meth:`UndoStack._move`)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from usvips.gui.signals import Signal
from usvips.store.records import StaleEditError


@dataclass
class Command:
    """One undoable step: ``redo`` does it (again), ``undo`` takes it back. ``pair_bound``: a step on
    the pair shown (forgotten when another is shown), not on the project."""

    label: str
    redo: Callable[[], None]
    undo: Callable[[], None]
    pair_bound: bool = False


class UndoStack:
    """Undo and redo of every pick and edit; ``changed`` fires after each push, undo and redo."""

    def __init__(self) -> None:
        self._done: list[Command] = []
        self._undone: list[Command] = []
        self.changed = Signal()

    def push(self, command: Command) -> None:
        command.redo()
        self._done.append(command)
        self._undone.clear()
        self.changed.emit()

    def undo(self) -> str | None:
        """Take back the last step; returns its label (None when there is nothing to undo)."""
        return self._move(self._done, self._undone, "undo")

    def redo(self) -> str | None:
        """Do the last undone step again; returns its label (None when there is nothing to redo)."""
        return self._move(self._undone, self._done, "redo")

    def _move(self, source: list[Command], target: list[Command], action: str) -> str | None:
        """Undo or redo the step on top of ``source``. When it raises, its error goes to the caller and
        the stack stays usable: a step refused as stale (another annotator changed the object since: it can
        never be taken back over their edit) is dropped, and the next Ctrl+Z goes on with the one before;
        any other refusal (the store busy, say) leaves the step where it was, to try again."""
        if not source:
            return None
        command = source[-1]
        try:
            getattr(command, action)()
        except StaleEditError:
            source.pop()
            self.changed.emit()
            raise
        source.pop()
        target.append(command)
        self.changed.emit()
        return command.label

    def clear(self) -> None:
        self._done.clear()
        self._undone.clear()
        self.changed.emit()

    def forget_pair_steps(self) -> None:
        """Another pair or video frame is shown: forget the steps bound to the one before (picks,
        enhancement), keep those on the project (objects stored, edited, deleted) in their order."""
        done = [c for c in self._done if not c.pair_bound]
        undone = [c for c in self._undone if not c.pair_bound]
        if (len(done), len(undone)) != (len(self._done), len(self._undone)):
            self._done, self._undone = done, undone
            self.changed.emit()

    @property
    def undo_label(self) -> str | None:
        return self._done[-1].label if self._done else None

    @property
    def redo_label(self) -> str | None:
        return self._undone[-1].label if self._undone else None
