"""The stored objects drawn over both stereo panes, kept up to date by the workspace's events.

Each object's outline on the current pair (image pixels, x right, y down, origin at the centre of the
top-left pixel) is computed once and held in an :class:`~usvips.gui.outline_set.OutlineSet` (flat arrays,
both images) that the panes draw at their own level of detail (the outlines near the view stroked, or one
raster of all of them); an event recomputes only the ids it names, and a selection or a pick changes no
outline: a selection draws the selected outlines, labels and vertex marks over the others, a pick only the
object being digitised. With more than :data:`MAX_LABELS` objects on the pair only the selected ones carry
a label and vertex marks (ten thousand labels would hide the image, and the marks of 20,000 vertices cost
pyqtgraph about a second per change). Labels are worded when drawn, for the few objects labelled.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from usvips.core.errors import UsvipsError
from usvips.core.measurements import kind as measurement_kind
from usvips.gui.outline_set import OutlineSet
from usvips.gui.pick_tool import SIDES
from usvips.gui.wording import species_text
from usvips.gui.workspace import Workspace

#: Above this many objects on the pair, only the selected objects are labelled.
MAX_LABELS = 300
#: Objects whose outlines are computed at a time when all of them are (another project or pair), when the
#: window lets the rest wait for the events pending (10,000 take about 50 ms; 100,000 at once froze the
#: window for 0.75 s).
SLICE = 10_000


class ObjectOverlay:
    """Draws the workspace's stored objects (and the one being digitised) on ``panes`` (side -> pane).
    ``later(call)``, when given, runs ``call`` once the events pending are handled (the window's event
    loop): every outline is then computed :data:`SLICE` objects at a time, the panes drawing each slice as
    it comes; without it, at once."""

    def __init__(self, workspace: Workspace, panes: dict,
                 later: Callable[[Callable[[], None]], None] | None = None) -> None:
        self.workspace = workspace
        self.panes = panes
        self.later = later
        self._waiting: tuple[int, ...] = ()  # objects of the last refresh whose outlines are still to be computed
        #: every stored object's outline on the current pair (the panes draw it)
        self.outlines = OutlineSet()
        self._drawings: dict[str, tuple[str, bool]] = {}  # measurement kind -> how it is drawn, whether it closes
        self._events = ((workspace.objects_reset, self.refresh), (workspace.pair_changed, self.refresh),
                        (workspace.objects_added, self._on_objects), (workspace.objects_updated, self._on_objects),
                        (workspace.objects_removed, self._on_objects), (workspace.selection_changed, self.draw),
                        (workspace.picks_changed, self.draw_digitising))
        for signal, slot in self._events:
            signal.connect(slot)

    def cleanup(self) -> None:
        self._waiting = ()  # no slice of a refresh runs after
        for signal, slot in self._events:
            signal.disconnect(slot)

    def refresh(self, *_: object) -> None:
        """Every object's outline again (another project or pair): in slices when the overlay may wait."""
        self.outlines.clear()
        self._waiting = tuple(self.workspace.cache.ids())
        self._next_slice()
        self.draw_digitising()

    def _next_slice(self) -> None:
        """Compute the outlines of the next objects of the last refresh (all of them when the overlay may not
        wait), and ask for the slice after."""
        if not self._waiting:
            return
        size = len(self._waiting) if self.later is None else SLICE
        ids, self._waiting = self._waiting[:size], self._waiting[size:]
        self._on_objects(ids, marks=not self._waiting)  # labels and vertex marks once, for the whole set
        if self._waiting:
            self.later(self._next_slice)

    @property
    def refreshing(self) -> bool:
        """Whether outlines of the last refresh are still to be computed (the overlay waits between slices)."""
        return bool(self._waiting)

    def _on_objects(self, ids: tuple[int, ...], marks: bool = True) -> None:
        """Objects added, changed or gone: their outlines again, handed to the panes (which draw what is in
        view), and (``marks``) the selection's marks."""
        self._outline(ids)
        for index, side in enumerate(SIDES):
            self.panes[side].set_outlines(self.outlines, index)
        if marks:
            self.draw()

    def _outline(self, ids: tuple[int, ...]) -> None:
        """Compute (or drop) the outlines of ``ids``: the picks on the current pair (and frame) in one pass,
        a circle's projected ellipse by :meth:`Workspace.outline`."""
        ws = self.workspace
        self.outlines.drop(ids)
        if ws.pair is None or not ids:
            return
        pair, frame = ws.pair, None if ws.video_frame is None else ws.video_frame[1]
        kept, counts, closed, points = [], [], [], []
        for object_id in ids:
            try:
                stored = ws.stored_object(object_id)
            except UsvipsError:
                continue  # removed
            drawing, closes = self._drawing(stored.kind)
            if drawing == "circle":
                drawn = ws.outline(stored)
                if drawn is None:
                    continue
                outline = np.column_stack([np.asarray(drawn[0], float).reshape(-1, 2),
                                           np.asarray(drawn[1], float).reshape(-1, 2)])
                points.extend(map(tuple, outline))
                kept.append(object_id), counts.append(len(outline)), closed.append(drawn[2])
                continue
            shown = [(v.xl, v.yl, v.xr, v.yr) for v in stored.vertices
                     if v.pair == pair and (frame is None or v.frame_left == frame)]
            if shown:  # none: measured on another pair (or frame)
                points.extend(shown)
                kept.append(object_id), counts.append(len(shown)), closed.append(closes)
        if kept:
            self.outlines.put(np.array(kept), np.array(counts), np.array(closed), np.array(points, float))

    def _drawing(self, kind: str) -> tuple[str, bool]:
        """How objects of ``kind`` are drawn and whether the outline closes (the kind's own words; an open
        polyline for a kind not registered)."""
        if kind not in self._drawings:
            try:
                registered = measurement_kind(kind)
                self._drawings[kind] = registered.drawing, registered.closes
            except UsvipsError:
                self._drawings[kind] = "polyline", False
        return self._drawings[kind]

    def label(self, object_id: int) -> str:
        """The text an object's label shows: its id and species (an instant as its object's), and by whom a
        colleague's change was made."""
        cache = self.workspace.cache
        stored = self.workspace.stored_object(object_id)
        record = cache.record(object_id)  # the species is the record's, when there is one
        name = species_text(record) if record is not None and record.name else stored.attribute
        whole = cache.instant_of(object_id)  # an instant is labelled as its object's
        label = f"{stored.id} {name}" if whole is None else f"{stored.id}: instant of {whole} {name}"
        mark = cache.marks.get(object_id)  # a colleague's change: by whom
        return (label if mark is None else f"{label.strip()} · {mark.who}").strip()

    def draw(self, *_: object) -> None:
        """The selection's marks over the outlines: the selected outlines highlighted, and the labels and
        vertex marks of every object (at most :data:`MAX_LABELS` on the pair) or of the selected ones."""
        outlines, ws = self.outlines, self.workspace
        selected = np.isin(outlines.ids, np.array(ws.selection, np.int64))
        marked = np.arange(len(outlines)) if len(outlines) <= MAX_LABELS else np.flatnonzero(selected)
        labels, vertices = {}, {}
        for k in marked:
            object_id = int(outlines.ids[k])
            try:
                labels[k] = self.label(object_id)
                picks = ws.vertices_shown(ws.stored_object(object_id))
            except UsvipsError:
                continue
            vertices[k] = np.array([(v.xl, v.yl, v.xr, v.yr) for v in picks], float).reshape(-1, 4)
        starts = outlines.starts()
        for index, side in enumerate(SIDES):
            marks = [v[:, 2 * index:2 * index + 2] for v in vertices.values()]
            shown = [(text, tuple(outlines.side_points(index)[starts[k]]), bool(selected[k]))
                     for k, text in labels.items() if text]
            self.panes[side].set_selection_marks(outlines.lines(index, np.flatnonzero(selected)),
                                                 np.concatenate(marks) if marks else np.zeros((0, 2)), shown,
                                                 len(outlines))

    def draw_digitising(self, *_: object) -> None:
        current = self.workspace.pick_tool.digitising.vertices
        for side in SIDES:
            self.panes[side].set_digitising(np.array([getattr(v, side) for v in current]) if current else None)

