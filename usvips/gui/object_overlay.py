"""The stored objects drawn over both stereo panes, kept up to date by the workspace's events.

Each object's outline on the current pair (image pixels, x right, y down, origin at the centre of the
top-left pixel) is computed once and cached by object id; an event recomputes only the ids it names, and a
pick redraws only the object being digitised. With more than :data:`MAX_LABELS` objects on the pair only
the selected ones carry a label (ten thousand labels would hide the image and cost a second a redraw).
"""

from __future__ import annotations

import numpy as np

from usvips.core.errors import UsvipsError
from usvips.gui.workspace import SIDES, Workspace

#: Above this many objects on the pair, only the selected objects are labelled.
MAX_LABELS = 300


class ObjectOverlay:
    """Draws the workspace's stored objects (and the one being digitised) on ``panes`` (side -> pane)."""

    def __init__(self, workspace: Workspace, panes: dict) -> None:
        self.workspace = workspace
        self.panes = panes
        #: id -> (label, left outline, right outline, closed, left vertex picks, right vertex picks)
        self.outlines: dict[int, tuple] = {}
        self._events = ((workspace.objects_reset, self.refresh), (workspace.pair_changed, self.refresh),
                        (workspace.objects_added, self._on_objects), (workspace.objects_updated, self._on_objects),
                        (workspace.objects_removed, self._on_objects), (workspace.selection_changed, self.draw),
                        (workspace.picks_changed, self.draw_digitising))
        for signal, slot in self._events:
            signal.connect(slot)

    def cleanup(self) -> None:
        for signal, slot in self._events:
            signal.disconnect(slot)

    def refresh(self, *_: object) -> None:
        """Every object's outline again (another project or pair)."""
        self.outlines = {}
        self._on_objects(tuple(self.workspace.object_ids()))
        self.draw_digitising()

    def _on_objects(self, ids: tuple[int, ...]) -> None:
        for object_id in ids:
            self.outlines.pop(object_id, None)
            if self.workspace.pair is None:
                continue
            try:
                stored = self.workspace.stored_object(object_id)
            except UsvipsError:
                continue  # removed
            drawn = self.workspace.outline(stored)
            if drawn is None:
                continue  # measured on another pair (or frame)
            picks = self.workspace.vertices_shown(stored)
            self.outlines[object_id] = (f"{stored.id} {stored.attribute}".strip(), drawn[0], drawn[1], drawn[2],
                                        [(v.xl, v.yl) for v in picks], [(v.xr, v.yr) for v in picks])
        self.draw()

    def draw(self, *_: object) -> None:
        """Hand the cached outlines to the panes, the selected ones highlighted."""
        selection = set(self.workspace.selection)
        labelled = len(self.outlines) <= MAX_LABELS
        for index, side in enumerate(SIDES):
            outlines = []
            for object_id, (label, left, right, closed, picks_left, picks_right) in self.outlines.items():
                selected = object_id in selection
                outlines.append((label if labelled or selected else "", (left, right)[index], closed, selected,
                                 (picks_left, picks_right)[index]))
            self.panes[side].set_objects(outlines)

    def draw_digitising(self, *_: object) -> None:
        current = self.workspace.digitising.vertices
        for side in SIDES:
            self.panes[side].set_digitising(np.array([getattr(v, side) for v in current]) if current else None)
