"""The display enhancement of the two images shown, free of Qt: one :class:`~usvips.core.enhance.Pipeline`
per side, read from the project when a pair is shown (by the image's stored path, its key) and written
back on every change, each change one undoable command. Display only: picks and coordinates always use
the original pixels."""

from __future__ import annotations

from usvips.core.enhance import Pipeline
from usvips.core.errors import UsvipsError
from usvips.gui.signals import Signal
from usvips.gui.undo import Command, UndoStack
from usvips.store.interface import ProjectStore

SIDES = ("left", "right")


class Enhancement:
    """The pipelines of the left and right image. Events: ``changed(side)`` after a side's pipeline
    changed (shown again), ``message(level, text)`` for a saved pipeline that cannot be read."""

    def __init__(self, undo: UndoStack, changed: Signal, message: Signal) -> None:
        self.undo = undo
        self.changed = changed
        self.message = message
        self.pipelines: dict[str, Pipeline] = {side: Pipeline() for side in SIDES}
        self.project: ProjectStore | None = None
        self.keys: dict[str, str] = {}  # side -> the project's key of the image shown there

    def load(self, project: ProjectStore | None, keys: dict[str, str]) -> None:
        """Show the saved pipelines of the images ``keys`` (side -> stored path) of ``project``."""
        self.project, self.keys = project, dict(keys)
        for side in SIDES:
            self.pipelines[side] = self._stored(side)

    def clear(self) -> None:
        """No images: no pipelines, nothing saved anywhere."""
        self.project, self.keys = None, {}
        self.pipelines = {side: Pipeline() for side in SIDES}

    def _stored(self, side: str) -> Pipeline:
        text = self.project.enhancement(self.keys[side]) if self.project is not None and side in self.keys else None
        if not text:
            return Pipeline()
        try:
            return Pipeline.from_json(text)
        except UsvipsError as error:
            self.message.emit("warning", f"the saved enhancement of the {side} image is ignored: {error}")
            return Pipeline()

    def set_pipelines(self, changes: dict[str, Pipeline]) -> None:
        """Change the enhancement of one or both images as one undoable step (saved in the project)."""
        unknown = [side for side in changes if side not in SIDES]
        if unknown:
            raise UsvipsError(f"side must be 'left' or 'right', got {unknown[0]!r}")
        before = {side: self.pipelines[side] for side in changes}
        if all(before[side] == changes[side] for side in changes):
            return
        label = "enhancement (" + " and ".join(changes) + ")"
        self.undo.push(Command(label, lambda: self._apply(changes), lambda: self._apply(before), pair_bound=True))

    def _apply(self, pipelines: dict[str, Pipeline]) -> None:
        for side, pipeline in pipelines.items():
            self.pipelines[side] = pipeline
            if self.project is not None and side in self.keys:
                self.project.set_enhancement(self.keys[side], pipeline.to_json())
            self.changed.emit(side)
