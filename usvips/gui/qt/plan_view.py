"""The plan view: the measured objects seen from above."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from PySide6 import QtWidgets

from usvips.core.errors import UsvipsError
from usvips.core.measurements import kind as measurement_kind
from usvips.gui.panel_registry import Panel, register
from usvips.gui.qt.on_screen import ScreenWatch, on_screen
from usvips.gui.workspace import Workspace

if TYPE_CHECKING:
    import pyqtgraph as pg


class PlanView(QtWidgets.QWidget):
    """Measured objects in plan (X–Y, seen from above) or in profile (X–Z, Y–Z), metres on both axes at
    the same scale, with their labels, 1σ error ellipses of the vertices, the pair's two cameras, the
    frame named, and the range fitted to what is drawn — a plot that runs offscreen, where a 3-D view
    might not."""

    VIEWS = {"plan (X–Y)": (0, 1), "profile (X–Z)": (0, 2), "profile (Y–Z)": (1, 2)}

    def __init__(self, workspace: Workspace, parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(parent)
        self.workspace = workspace
        self.view = QtWidgets.QComboBox()
        self.view.addItems(list(self.VIEWS))
        self.view.currentTextChanged.connect(self.refresh)
        self.frame = QtWidgets.QLabel("")
        self.frame.setWordWrap(True)
        #: the plot and its items, made when the view first comes on screen (:meth:`_build_plot`)
        self.plot: pg.PlotWidget | None = None
        self._added: list[int] = []
        self.labels: list[pg.TextItem] = []
        top = QtWidgets.QHBoxLayout()
        top.addWidget(self.view)
        top.addWidget(self.frame, 1)
        self._layout = QtWidgets.QVBoxLayout(self)
        self._layout.setContentsMargins(2, 2, 2, 2)
        self._layout.addLayout(top)
        self._parts: dict[int, tuple] = {}  # object id -> (label, label position, outline, 1σ rings) in this view
        self._dirty = True
        self._stale: set[int] = set()  # ids whose drawing is not computed yet (done when the view is shown)
        self._events = ((workspace.objects_reset, self.refresh), (workspace.pair_changed, self._on_pair),
                        (workspace.objects_added, self._on_added), (workspace.objects_updated, self._on_objects),
                        (workspace.objects_removed, self._on_objects),
                        (workspace.selection_changed, self._on_selection))
        for signal, slot in self._events:
            signal.connect(slot)
        self._watch = ScreenWatch(self, self._on_screen)  # a tab behind another is "visible" in Qt 6
        self.refresh()

    def _build_plot(self) -> None:
        """The plot and its items (once, when first drawn: a survey opened with the view behind another tab
        makes none of it)."""
        from usvips.gui.qt.plots import pg  # not on the window's start path

        if self.plot is not None:
            return
        self.plot = pg.PlotWidget(background=None)
        self.plot.setAspectLocked(True)
        for axis in ("bottom", "left"):
            self.plot.getAxis(axis).enableAutoSIPrefix(False)  # metres on both axes, never m against mm
        self.curve = self.plot.plot(pen=pg.mkPen((0, 200, 255), width=2), connect="finite", symbol="o",
                                    symbolSize=5)
        self.ellipses = self.plot.plot(pen=pg.mkPen((255, 140, 0), width=1), connect="finite")
        self.cameras = self.plot.plot(pen=None, symbol="t", symbolSize=12, symbolBrush=(60, 220, 120))
        # objects stored since the last whole drawing (at survey size): an item of their own, so that one more
        # fish among thousands does not rebuild the others' outlines
        self.added_curve = self.plot.plot(pen=pg.mkPen((0, 200, 255), width=1), connect="finite")
        self._layout.addWidget(self.plot)

    #: Above this many objects only the selected ones are labelled (thousands of labels hide the plot).
    MAX_LABELS = 300
    #: Objects drawn on their own after being added, before the whole plot is redrawn.
    MAX_ADDED = 200

    def cleanup(self) -> None:
        for signal, slot in self._events:
            signal.disconnect(slot)

    def _label(self, text: str, position, colour) -> None:
        from usvips.gui.qt.plots import pg  # not on the window's start path

        item = pg.TextItem(text, color=colour, anchor=(0, 1))
        item.setPos(float(position[0]), float(position[1]))
        self.plot.addItem(item, ignoreBounds=True)
        self.labels.append(item)

    def refresh(self, *_: object) -> None:
        """Every object again (another view or project)."""
        self._parts = {}
        self._on_objects(tuple(self.workspace.cache.ids()))

    def _on_pair(self) -> None:
        """Another pair: its cameras and frame (the objects stay as they are)."""
        self._dirty = True
        if on_screen(self):
            self.redraw()

    def _on_objects(self, ids: tuple[int, ...]) -> None:
        """Recompute the drawing of just ``ids``: now if the view is shown, else when it is shown (a hidden
        plan view costs nothing: labelling a few hundred objects takes seconds of the GUI thread)."""
        self._stale.update(ids)
        self._dirty = True
        if on_screen(self):
            self.redraw()

    def _on_added(self, ids: tuple[int, ...]) -> None:
        """New objects: shown, at survey size, unselected and after every object drawn, only they are drawn
        (on their own items); otherwise as any change."""
        alone = (on_screen(self) and not self._dirty and len(self._parts) > self.MAX_LABELS
                 and len(self._added) + len(ids) <= self.MAX_ADDED and min(ids, default=0) > self._last_id()
                 and not set(ids) & set(self.workspace.selection))
        if not alone:
            self._on_objects(ids)
            return
        self._stale.update(ids)
        self._update_parts()
        self._added.extend(i for i in ids if i in self._parts)
        parts = [self._parts[i] for i in self._added]
        data = np.vstack([p[1] for p in parts]) if parts else np.zeros((0, 2))
        self.added_curve.setData(data[:, 0], data[:, 1], connect="finite")
        self.plot.autoRange()

    def _last_id(self) -> int:
        """The highest id drawn (``_parts`` is kept in id order)."""
        return next(reversed(self._parts), 0)

    def _update_parts(self) -> None:
        a, b = self.VIEWS[self.view.currentText()]
        ids, self._stale = sorted(self._stale), set()
        ordered = not ids or ids[0] > self._last_id()  # new ids above all others keep the order
        objects = []
        for object_id in ids:
            try:
                objects.append(self.workspace.stored_object(object_id))
            except UsvipsError:
                self._parts.pop(object_id, None)
        for stored, part in zip(objects, self._parts_of(objects, a, b), strict=True):
            if part is None:
                self._parts.pop(stored.id, None)
            else:
                self._parts[stored.id] = part
        if not ordered:
            self._parts = dict(sorted(self._parts.items()))

    def _on_selection(self, _ids) -> None:
        """At survey size the selected objects are labelled: only the labels change."""
        if len(self._parts) > self.MAX_LABELS:
            if not on_screen(self):
                self._dirty = True
            elif self._dirty:
                self.redraw()
            else:
                self._draw_labels()

    def _on_screen(self) -> None:
        """The view came on screen (shown, or its tab brought to the front): drawn if anything changed."""
        if self._dirty:
            self.redraw()

    CIRCLE = np.column_stack([np.cos(np.linspace(0, 2 * np.pi, 49)), np.sin(np.linspace(0, 2 * np.pi, 49))])

    def _parts_of(self, objects: list, a: int, b: int) -> list[tuple | None]:
        """Each object's (label and its position, outline (K, 2) m ending in a NaN row, 1σ rings (M × 50, 2) m
        NaN-separated) in the view of axes ``a``, ``b``; None for an object with no 3-D point. Every vertex
        of every object in one array, the 2 × 2 covariance blocks in one eigen-decomposition (a survey's
        10,000 objects at once); only kinds whose outline is not their vertices are drawn one by one."""
        located = [[v for v in stored.vertices if v.xyz is not None] for stored in objects]
        counts = np.array([len(vs) for vs in located], int)
        ends = np.cumsum(counts)
        vertices = [v for vs in located for v in vs]
        xyz = np.array([v.xyz for v in vertices], float).reshape(-1, 3)
        # each object's vertices in the view followed by a NaN row: object i's outline is rows [start + i, end + i]
        separated = np.insert(xyz[:, [a, b]], ends, np.nan, axis=0)
        with_covariance = np.array([v.covariance is not None for v in vertices], bool)
        ring_rows = np.zeros((0, 50, 2))
        if with_covariance.any():  # (N, 49, 2) rings of every vertex at once, each followed by a NaN row
            blocks = np.array([v.covariance for v in vertices if v.covariance is not None], float)
            blocks = blocks.reshape(-1, 3, 3)[:, [a, b]][:, :, [a, b]]
            values, vectors = np.linalg.eigh(blocks)
            scaled = self.CIRCLE[None] * np.sqrt(np.clip(values, 0, None))[:, None, :]
            ring = xyz[with_covariance][:, None, [a, b]] + scaled @ vectors.transpose(0, 2, 1)
            ring_rows = np.concatenate([ring, np.full((len(ring), 1, 2), np.nan)], axis=1)
        before = np.concatenate([[0], np.cumsum(with_covariance)]).tolist()  # rings before each vertex
        plane = separated  # the vertices in the view; object i's first vertex is row start + i
        rings_flat = ring_rows.reshape(-1, 2)  # 50 rows a ring
        kinds: dict[str, tuple] = {}  # kind -> (its MeasurementKind, its own outline, closes) or None
        parts: list[tuple | None] = []
        for n, (stored, count, end) in enumerate(zip(objects, counts.tolist(), ends.tolist(), strict=True)):
            if not count:
                parts.append(None)
                continue
            start = end - count
            outline = separated[start + n:end + n + 1]
            if count == len(stored.vertices):
                drawn = kinds.get(stored.kind, False)
                if drawn is False:
                    try:
                        k = measurement_kind(stored.kind)
                        drawn = kinds[stored.kind] = (k, k.outline_fitted, k.closes)
                    except UsvipsError:
                        drawn = kinds[stored.kind] = None  # drawn through its vertices
                if drawn is not None and (drawn[1] or (drawn[2] and count > 2)):
                    try:
                        outline = np.vstack([drawn[0].outline(xyz[start:end])[:, [a, b]], [[np.nan, np.nan]]])
                    except UsvipsError:
                        pass
            rings = rings_flat[50 * before[start]:50 * before[end]]
            parts.append(((f"{stored.id} {stored.attribute}".strip(), plane[start + n]), outline, rings))
        return parts

    def redraw(self) -> None:
        from usvips.gui.qt.plots import pg  # not on the window's start path

        self._build_plot()
        self._update_parts()
        self._dirty = False
        self._added = []
        self.added_curve.setData([], [])
        a, b = self.VIEWS[self.view.currentText()]
        self.plot.setLabel("bottom", "XYZ"[a] + " (m)")
        self.plot.setLabel("left", "XYZ"[b] + " (m)")
        parts = [p[1] for p in self._parts.values()]
        data = np.vstack(parts) if parts else np.zeros((0, 2))
        # at survey size no vertex marks (20,000 of them cost pyqtgraph about half a second per drawing) and a
        # thin pen (a wide one costs Qt's stroker a quarter of a second per repaint of 10,000 outlines)
        survey = len(self._parts) > self.MAX_LABELS
        self.curve.setSymbol(None if survey else "o")
        self.curve.setPen(pg.mkPen((0, 200, 255), width=1 if survey else 2))
        self.curve.setData(data[:, 0], data[:, 1], connect="finite", antialias=not survey)
        self._draw_labels()
        geometry = self.workspace.geometry
        if geometry is not None:
            rig = geometry.calibration.rig(geometry.station, geometry.frame)
            cameras = np.array([rig.left.exterior.position, rig.right.exterior.position])[:, [a, b]]
            self.cameras.setData(cameras[:, 0], cameras[:, 1])
            self.frame.setText(f"{geometry.description}; orange: 1σ ellipses{self._which()}, green: the cameras")
        else:
            self.cameras.setData([], [])
            self.frame.setText(f"no calibrated pair shown: coordinates as measured; orange: 1σ ellipses{self._which()}")
        self.plot.enableAutoRange()
        self.plot.autoRange()

    def _which(self) -> str:
        return "" if len(self._parts) <= self.MAX_LABELS else " (of the selected objects)"

    def _draw_labels(self) -> None:
        """The objects' labels and 1σ ellipses (at survey size the selected ones only: 20,000 ellipses cost
        Qt half a second per repaint, and at that scale they are specks) and the cameras' labels."""
        for item in self.labels:
            self.plot.removeItem(item)
        self.labels = []
        labelled = (self._parts if len(self._parts) <= self.MAX_LABELS
                    else {i: self._parts[i] for i in self.workspace.selection if i in self._parts})
        for label, _, _ in labelled.values():
            self._label(label[0], label[1], (230, 230, 230))
        rings = [p[2] for p in labelled.values() if len(p[2])]
        ring_data = np.vstack(rings) if rings else np.zeros((0, 2))
        self.ellipses.setData(ring_data[:, 0], ring_data[:, 1], connect="finite")
        geometry = self.workspace.geometry
        if geometry is not None:
            a, b = self.VIEWS[self.view.currentText()]
            rig = geometry.calibration.rig(geometry.station, geometry.frame)
            for name, camera in zip(("L", "R"), rig.cameras, strict=True):
                self._label(name, camera.exterior.position[[a, b]], (60, 220, 120))


#: the panel's declaration (usvips.gui.panel_registry): the window builds its dock from it
PANEL = register(Panel("plan", "Plan view", "bottom", lambda context: PlanView(context.workspace), group="records",
                     order=60))
