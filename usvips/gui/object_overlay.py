"""The stored objects drawn over both stereo panes, kept up to date by the workspace's events.

Each object's outline on the current pair (image pixels, x right, y down, origin at the centre of the
top-left pixel) is computed once and cached by object id; an event recomputes only the ids it names, and a
pick redraws only the object being digitised. With more than :data:`MAX_LABELS` objects on the pair only
the selected ones carry a label and vertex marks (ten thousand labels would hide the image, and the marks
of 20,000 vertices cost pyqtgraph about a second per change). The outlines are up to :data:`CHUNKS`
cached pictures (of at least :data:`CHUNK` outlines each), a chunk redrawn only when one of its outlines
changes or goes: a selection draws the selected outlines over them, and at survey size an object stored
(added, not selected) is drawn on its own beside them until the next change that needs a whole drawing (or
:data:`MAX_ADDED` additions).
"""

from __future__ import annotations

import numpy as np

from usvips.core.errors import UsvipsError
from usvips.gui.pick_tool import SIDES
from usvips.gui.wording import species_text
from usvips.gui.workspace import Workspace

#: Above this many objects on the pair, only the selected objects are labelled.
MAX_LABELS = 300
#: Objects drawn on their own after being added, before the whole picture is redrawn.
MAX_ADDED = 200
#: The outlines are drawn as at most this many cached pictures: a removal or an edit redraws the chunk
#: holding the object, not all of them (stroking 10,000 outlines in both panes took Qt about 60 ms), while
#: every repaint blits each chunk's cached picture (20 of them cost a pick about 50 ms).
CHUNKS = 4
#: ... of at least this many outlines each.
CHUNK = 500


class ObjectOverlay:
    """Draws the workspace's stored objects (and the one being digitised) on ``panes`` (side -> pane)."""

    def __init__(self, workspace: Workspace, panes: dict) -> None:
        self.workspace = workspace
        self.panes = panes
        #: id -> (label, left outline, right outline, closed, left vertex picks, right vertex picks)
        self.outlines: dict[int, tuple] = {}
        self._added: list[int] = []  # ids drawn on their own since the last whole drawing
        self._lines_drawn = False  # whether the panes' picture of all outlines is up to date
        self._chunks: list[list[int]] = []  # the ids drawn in each chunk of the picture
        self._chunk_of: dict[int, int] = {}
        self._events = ((workspace.objects_reset, self.refresh), (workspace.pair_changed, self.refresh),
                        (workspace.objects_added, self._on_added), (workspace.objects_updated, self._on_objects),
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
        self._chunks, self._chunk_of, self._lines_drawn = [], {}, False
        self._on_objects(tuple(self.workspace.cache.ids()))
        self.draw_digitising()

    def _on_added(self, ids: tuple[int, ...]) -> None:
        """New objects: at survey size, unselected and after every object drawn, only they are drawn."""
        last = max(self.outlines, default=0)
        alone = (len(self.outlines) > MAX_LABELS and len(self._added) + len(ids) <= MAX_ADDED
                 and min(ids, default=0) > last and not set(ids) & set(self.workspace.selection))
        if not alone:
            self._on_objects(ids)
            return
        self._outline(ids)
        self._added.extend(i for i in ids if i in self.outlines)
        for index, side in enumerate(SIDES):
            lines = [self.outlines[i][1][index] for i in self._added]
            self.panes[side].set_added_lines(np.concatenate(lines) if lines else np.zeros((0, 2)),
                                             len(self.outlines))

    def _on_objects(self, ids: tuple[int, ...]) -> None:
        self._outline(ids)
        drawn = self._lines_drawn and self._chunks and all(i in self._chunk_of for i in ids)
        if not drawn:
            self._lines_drawn = False
        else:  # changed or removed objects already drawn: only their chunks again
            for k in sorted({self._chunk_of[i] for i in ids}):
                self._chunks[k] = [i for i in self._chunks[k] if i in self.outlines]
                for index, side in enumerate(SIDES):
                    lines = [self.outlines[i][1][index] for i in self._chunks[k]]
                    self.panes[side].set_object_chunk(k, np.concatenate(lines) if lines else np.zeros((0, 2)),
                                                      len(self.outlines))
            for i in ids:
                if i not in self.outlines:
                    self._chunk_of.pop(i, None)
        self.draw()

    def _outline(self, ids: tuple[int, ...]) -> None:
        """Compute (or drop) the cached outlines of ``ids``."""
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
            paths = tuple(_path(pixels, drawn[2]) for pixels in drawn[:2])
            marks = (np.array([(v.xl, v.yl) for v in picks], float).reshape(-1, 2),
                     np.array([(v.xr, v.yr) for v in picks], float).reshape(-1, 2))
            record = self.workspace.cache.record(object_id)  # the species is the record's, when there is one
            name = species_text(record) if record is not None and record.name else stored.attribute
            whole = self.workspace.cache.instant_of(object_id)  # an instant is labelled as its object's
            label = f"{stored.id} {name}" if whole is None else f"{stored.id}: instant of {whole} {name}"
            mark = self.workspace.cache.marks.get(object_id)  # a colleague's change: by whom
            label = label if mark is None else f"{label.strip()} · {mark.who}"
            self.outlines[object_id] = (label.strip(), paths, marks)

    def draw(self, *_: object) -> None:
        """Hand the cached outlines to the panes, joined into one array per kind of mark: all of them (when
        one changed), and the selected ones highlighted over them."""
        selection = set(self.workspace.selection)
        labelled = len(self.outlines) <= MAX_LABELS
        shown = self.outlines if labelled else {i: self.outlines[i] for i in selection if i in self.outlines}
        empty = np.zeros((0, 2))
        if not self._lines_drawn:
            ids = list(self.outlines)
            size = max(CHUNK, -(-len(ids) // CHUNKS))
            self._chunks = [ids[k:k + size] for k in range(0, len(ids), size)]
            self._chunk_of = {i: k for k, chunk in enumerate(self._chunks) for i in chunk}
        for index, side in enumerate(SIDES):
            if not self._lines_drawn:
                chunks = [[self.outlines[i][1][index] for i in chunk] for chunk in self._chunks]
                self.panes[side].set_object_chunks([np.concatenate(c) if c else empty for c in chunks],
                                                   len(self.outlines))
            chosen, vertices, labels = [], [], []
            for object_id, (label, paths, marks) in shown.items():
                selected = object_id in selection
                if selected:
                    chosen.append(paths[index])
                vertices.append(marks[index])  # at survey size the outlines' ends show the vertices well enough
                if label:
                    labels.append((label, tuple(paths[index][0]), selected))
            self.panes[side].set_selection_marks(np.concatenate(chosen) if chosen else empty,
                                                 np.concatenate(vertices) if vertices else empty, labels,
                                                 len(self.outlines))
        if not self._lines_drawn:
            self._added, self._lines_drawn = [], True

    def draw_digitising(self, *_: object) -> None:
        current = self.workspace.pick_tool.digitising.vertices
        for side in SIDES:
            self.panes[side].set_digitising(np.array([getattr(v, side) for v in current]) if current else None)


def _path(pixels: np.ndarray, closed: bool) -> np.ndarray:
    """An outline's pixels (N, 2), back to the start when it closes, ended by a NaN row (the separator)."""
    pixels = np.asarray(pixels, float).reshape(-1, 2)
    if closed and len(pixels) > 2:
        pixels = np.vstack([pixels, pixels[:1]])
    return np.vstack([pixels, [[np.nan, np.nan]]])
