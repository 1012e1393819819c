"""The dock panels: enhancement with histograms, the object list, the geo-calculator, the plan view and
the log. Each takes the :class:`~usvips.gui.workspace.Workspace` in ``__init__``, listens to its events
and writes user input back through its methods; ``cleanup()`` disconnects."""

from __future__ import annotations

import bisect
import json

import numpy as np
import pyqtgraph as pg
from PySide6 import QtCore, QtGui, QtWidgets

from usvips.core.enhance import OPERATIONS, Operation, Pipeline, balance_pair
from usvips.core.errors import UsvipsError
from usvips.core.measurements import kind as measurement_kind
from usvips.core.observation_record import STAGES, ObservationRecord, Species
from usvips.gui.calculator import format_figure
from usvips.gui.video_model import video_frame_text
from usvips.gui.worker import Worker, start
from usvips.gui.workspace import SIDES, Workspace

#: Starting values for operations whose parameters have no default in core.
STARTING_PARAMETERS = {"piecewise": {"points": [[0, 0], [64, 32], [192, 224], [255, 255]]},
                       "convolve": {"kernel": [[0, -1, 0], [-1, 5, -1], [0, -1, 0]]}}


def default_operation(name: str) -> Operation:
    return Operation(name, dict(STARTING_PARAMETERS.get(name, {})))


class EnhancementPanel(QtWidgets.QWidget):
    """Build a pipeline for the left, right or both images; every change is previewed at once (the
    window recomputes the display off the GUI thread) and saved per image in the project."""

    def __init__(self, workspace: Workspace, parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(parent)
        self.workspace = workspace
        self.target = QtWidgets.QComboBox()
        self.target.addItems(["both", "left", "right"])
        self.operation = QtWidgets.QComboBox()
        self.operation.addItems(list(OPERATIONS))
        self.add_button = add = QtWidgets.QPushButton("Add")
        add.setToolTip("append the operation to the pipeline of the chosen image(s)")
        self.steps = QtWidgets.QListWidget()
        self.steps.setMaximumHeight(110)
        self.parameters = QtWidgets.QLineEdit()
        self.parameters.setPlaceholderText("parameters of the selected step, e.g. {\"clip_limit\": 2.0}")
        remove = QtWidgets.QPushButton("Remove")
        reset = QtWidgets.QPushButton("Reset")
        reset.setToolTip("back to the original image(s)")
        balance = QtWidgets.QPushButton("Balance right to left")
        balance.setToolTip("levels on the right image so that its mean and spread match the left (thesis 3.4.3)")
        self.histogram = pg.PlotWidget(background=None)
        self.histogram.setMinimumHeight(120)
        self.histogram.hideAxis("left")
        self.histogram.setMouseEnabled(False, False)
        self.histogram.addLegend(offset=(5, 5))
        self.original_curve = self.histogram.plot(pen=pg.mkPen((150, 150, 150), width=1), name="original")
        self.processed_curve = self.histogram.plot(pen=pg.mkPen((255, 140, 0), width=1.5), name="processed")
        self.status = QtWidgets.QLabel("")
        self.status.setWordWrap(True)
        row = QtWidgets.QHBoxLayout()
        row.addWidget(QtWidgets.QLabel("Image"))
        row.addWidget(self.target)
        row.addWidget(self.operation, 1)
        row.addWidget(add)
        buttons = QtWidgets.QGridLayout()  # two rows: the dock is about 330 px wide on a 1366 px screen
        buttons.addWidget(remove, 0, 0)
        buttons.addWidget(reset, 0, 1)
        buttons.addWidget(balance, 1, 0, 1, 2)
        layout = QtWidgets.QVBoxLayout(self)
        layout.addLayout(row)
        layout.addWidget(self.steps)
        layout.addWidget(self.parameters)
        layout.addLayout(buttons)
        layout.addWidget(self.histogram, 1)
        layout.addWidget(self.status)
        add.clicked.connect(self._on_add)
        remove.clicked.connect(self._on_remove)
        reset.clicked.connect(self._on_reset)
        balance.clicked.connect(self._on_balance)
        self.target.currentTextChanged.connect(self._refresh_steps)
        self.steps.currentRowChanged.connect(self._on_step_selected)
        self.parameters.editingFinished.connect(self._on_parameters_edited)
        workspace.pair_changed.connect(self._refresh_steps)
        workspace.enhancement_changed.connect(self._on_enhancement_changed)

    def cleanup(self) -> None:
        self.workspace.pair_changed.disconnect(self._refresh_steps)
        self.workspace.enhancement_changed.disconnect(self._on_enhancement_changed)

    def _sides(self) -> tuple[str, ...]:
        target = self.target.currentText()
        return SIDES if target == "both" else (target,)

    def _pipeline(self) -> Pipeline:
        return self.workspace.pipelines[self._sides()[0]]

    def _apply(self, pipeline: Pipeline) -> None:
        if not self.workspace.images:
            self.status.setText("open an image pair first")
            return
        self.workspace.set_pipelines(dict.fromkeys(self._sides(), pipeline))

    def _on_add(self) -> None:
        try:
            step = default_operation(self.operation.currentText())
        except UsvipsError as error:
            self.status.setText(str(error))
            return
        pipeline = self._pipeline()
        self._apply(Pipeline(pipeline.operations + (step,)))
        self.steps.setCurrentRow(self.steps.count() - 1)

    def _on_remove(self) -> None:
        row = self.steps.currentRow()
        operations = list(self._pipeline().operations)
        if 0 <= row < len(operations):
            del operations[row]
            self._apply(Pipeline(tuple(operations)))

    def _on_reset(self) -> None:
        self._apply(Pipeline())

    def _on_balance(self) -> None:
        if not self.workspace.images:
            return
        step = balance_pair(self.workspace.images["left"], self.workspace.images["right"])
        pipeline = self.workspace.pipelines["right"]
        self.workspace.set_pipeline("right", Pipeline(pipeline.operations + (step,)))

    def _on_step_selected(self, row: int) -> None:
        operations = self._pipeline().operations
        self.parameters.setText(json.dumps(operations[row].params) if 0 <= row < len(operations) else "")

    def _on_parameters_edited(self) -> None:
        row = self.steps.currentRow()
        operations = list(self._pipeline().operations)
        if not 0 <= row < len(operations):
            return
        try:
            params = json.loads(self.parameters.text() or "{}")
            if not isinstance(params, dict):
                raise UsvipsError("parameters must be a JSON object such as {\"gamma\": 0.8}")
            operations[row] = Operation(operations[row].name, params)
        except json.JSONDecodeError as error:
            self.status.setText(f"parameters: not valid JSON ({error.msg}); the step is unchanged")
            return
        except UsvipsError as error:
            self.status.setText(f"{error}; the step is unchanged")
            return
        self.status.setText("")
        self._apply(Pipeline(tuple(operations)))
        self.steps.setCurrentRow(row)

    def _refresh_steps(self, *_: object) -> None:
        row = self.steps.currentRow()
        self.steps.blockSignals(True)
        self.steps.clear()
        for operation in self._pipeline().operations:
            params = ", ".join(f"{k}={v}" for k, v in operation.params.items() if not isinstance(v, list))
            self.steps.addItem(f"{operation.name}" + (f" ({params})" if params else ""))
        self.steps.blockSignals(False)
        if self.steps.count():
            self.steps.setCurrentRow(min(max(row, 0), self.steps.count() - 1))
        else:
            self.parameters.clear()

    def _on_enhancement_changed(self, side: str) -> None:
        if side in self._sides():
            self._refresh_steps()

    def show_histograms(self, original: np.ndarray | None, processed: np.ndarray | None) -> None:
        """Luminance histograms (counts per grey level, normalised) of the original and processed image."""
        for curve, counts in ((self.original_curve, original), (self.processed_curve, processed)):
            if counts is None:
                curve.setData([], [])
            else:
                curve.setData(np.arange(len(counts)), counts / max(counts.max(), 1))


class ObjectList(QtWidgets.QWidget):
    """The measured objects: select (drives the geo-calculator and the highlight), edit attribute and
    notes in place, delete, zoom to."""

    zoom_requested = QtCore.Signal(int)
    selection_changed = QtCore.Signal(list)
    #: an object's row double-clicked (its id): the video goes to the frame it was measured on
    object_activated = QtCore.Signal(int)

    COLUMNS = ("id", "type", "attribute", "vertices", "figure", "quality", "notes", "frame")

    def __init__(self, workspace: Workspace, parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(parent)
        self.workspace = workspace
        self.table = QtWidgets.QTableWidget(0, len(self.COLUMNS))
        self.table.setHorizontalHeaderLabels([c.capitalize() for c in self.COLUMNS])
        self.table.setSelectionBehavior(QtWidgets.QAbstractItemView.SelectionBehavior.SelectRows)
        self.table.verticalHeader().hide()
        self.table.horizontalHeader().setStretchLastSection(True)
        self.table.setEditTriggers(QtWidgets.QAbstractItemView.EditTrigger.DoubleClicked
                                   | QtWidgets.QAbstractItemView.EditTrigger.EditKeyPressed)
        delete = QtWidgets.QPushButton("Delete")
        zoom = QtWidgets.QPushButton("Zoom to")
        buttons = QtWidgets.QHBoxLayout()
        buttons.addWidget(zoom)
        buttons.addWidget(delete)
        # editing a stored object's vertices (undoable): re-pick one, or delete it
        self.vertex = QtWidgets.QSpinBox()
        self.vertex.setRange(1, 1)
        self.vertex.setPrefix("vertex ")
        self.vertex.setToolTip("the vertex of the selected object to re-pick or delete (1 = the first measured)")
        repick = QtWidgets.QPushButton("Re-pick")
        repick.setToolTip("measure the chosen vertex again: click it in either image, then its partner")
        delete_vertex = QtWidgets.QPushButton("Delete vertex")
        self.repick_button, self.delete_vertex_button = repick, delete_vertex
        # changing the kind where the vertices allow it (an arc measured round a patch becomes a polygon)
        self.kind = QtWidgets.QComboBox()
        self.kind.setToolTip("the kinds the selected object's vertices can make")
        set_kind = QtWidgets.QPushButton("Set kind")
        set_kind.setToolTip("make the selected object the chosen kind, keeping its vertices (undoable)")
        self.set_kind_button = set_kind
        set_kind.clicked.connect(self._on_set_kind)
        buttons.addSpacing(12)
        for widget in (self.vertex, repick, delete_vertex, self.kind, set_kind):
            buttons.addWidget(widget)
        buttons.addStretch(1)
        repick.clicked.connect(lambda: self._edit_vertex(self.workspace.start_repick))
        delete_vertex.clicked.connect(lambda: self._edit_vertex(self.workspace.delete_vertex))
        self.table.itemSelectionChanged.connect(self._on_vertex_range)
        layout = QtWidgets.QVBoxLayout(self)
        layout.setContentsMargins(2, 2, 2, 2)
        layout.addWidget(self.table)
        layout.addLayout(buttons)
        delete.clicked.connect(self._on_delete)
        zoom.clicked.connect(self._on_zoom)
        delete.setToolTip("delete the selected objects (Delete in the list; Ctrl+Z undoes it)")
        # the Delete key in the list (not while a cell is being edited: the editor has the key then)
        self.delete_shortcut = QtGui.QShortcut(QtGui.QKeySequence(QtCore.Qt.Key.Key_Delete), self.table)
        self.delete_shortcut.setContext(QtCore.Qt.ShortcutContext.WidgetShortcut)
        self.delete_shortcut.activated.connect(self._on_delete)
        self.table.itemSelectionChanged.connect(self._on_table_selection)
        self.table.itemChanged.connect(self._on_item_changed)
        self.table.cellDoubleClicked.connect(
            lambda row, _: self.object_activated.emit(self._ids[row]) if row < len(self._ids) else None)
        self._filling = False
        self._ids: list[int] = []  # the object id of each row, ascending (rows are in id order)
        self._worker: Worker | None = None
        self._pending: list[int] = []  # the ids the running figures worker computes
        self._events = ((workspace.objects_reset, self.refresh), (workspace.objects_added, self._on_added),
                        (workspace.objects_updated, self._on_updated), (workspace.objects_removed, self._on_removed),
                        (workspace.rules_changed, self._on_rules_changed),
                        (workspace.selection_changed, self._on_model_selection))
        for signal, slot in self._events:
            signal.connect(slot)
        self.refresh()

    def cleanup(self) -> None:
        for signal, slot in self._events:
            signal.disconnect(slot)

    def selected_ids(self) -> list[int]:
        rows = sorted({index.row() for index in self.table.selectedIndexes()})
        return [self._ids[r] for r in rows if r < len(self._ids)]

    #: Objects whose figures are computed at once when they change; more go to a worker thread.
    SYNCHRONOUS = 2
    #: Up to this many rows the columns are fitted to their contents on every change.
    FIT_ROWS = 200

    def row_of(self, object_id: int) -> int | None:
        """The table row showing ``object_id`` (None when it has none)."""
        row = bisect.bisect_left(self._ids, object_id)
        return row if row < len(self._ids) and self._ids[row] == object_id else None

    # ------------------------------------------------------------------ the model's events
    def refresh(self, *_: object) -> None:
        """Every row again (another project, new rules): the objects come from the model's cache, the
        figures that are not known yet are computed (in a worker when many)."""
        objects = self.workspace.objects()
        self._filling = True
        self.table.setUpdatesEnabled(False)
        try:
            self.table.clearContents()
            self.table.setRowCount(len(objects))
            self._ids = [o.id for o in objects]
            for row, stored in enumerate(objects):
                self._set_row(row, stored)
        finally:
            self.table.setUpdatesEnabled(True)
            self._filling = False
        self._compute([o.id for o in objects])
        self._fit()
        self._on_model_selection(self.workspace.selection)

    def _on_added(self, ids: tuple[int, ...]) -> None:
        self._filling = True
        try:
            for object_id in ids:
                row = bisect.bisect_left(self._ids, object_id)
                self._ids.insert(row, object_id)
                self.table.insertRow(row)
                self._set_row(row, self.workspace.stored_object(object_id))
        finally:
            self._filling = False
        self._compute(list(ids))
        self._fit()

    def _on_updated(self, ids: tuple[int, ...]) -> None:
        self._filling = True
        try:
            for object_id in ids:
                row = self.row_of(object_id)
                if row is not None:
                    self._set_row(row, self.workspace.stored_object(object_id))
        finally:
            self._filling = False
        self._compute(list(ids))
        self._on_vertex_range()

    def _on_removed(self, ids: tuple[int, ...]) -> None:
        for object_id in ids:
            row = self.row_of(object_id)
            if row is not None:
                self.table.removeRow(row)
                del self._ids[row]

    def _on_rules_changed(self, _rules) -> None:
        self._compute(list(self._ids))

    def _on_model_selection(self, ids: tuple[int, ...]) -> None:
        """Show the model's selection (when the list did not make it)."""
        if set(ids) == set(self.selected_ids()):
            return
        self.table.blockSignals(True)
        try:
            self.table.clearSelection()
            for object_id in ids:
                row = self.row_of(object_id)
                if row is not None:
                    self.table.selectRow(row)
        finally:
            self.table.blockSignals(False)
        self.table.viewport().update()
        self._on_vertex_range()

    def _on_table_selection(self) -> None:
        ids = self.selected_ids()
        self.workspace.select(ids)
        self.selection_changed.emit(ids)

    # ------------------------------------------------------------------ rows and figures
    def _set_row(self, row: int, stored) -> None:
        values = (str(stored.id), stored.kind, stored.attribute, str(len(stored.vertices)), "", "",
                  stored.notes, video_frame_text(stored))
        for column, value in enumerate(values):
            item = QtWidgets.QTableWidgetItem(value)
            if self.COLUMNS[column] not in ("attribute", "notes"):
                item.setFlags(item.flags() & ~QtCore.Qt.ItemFlag.ItemIsEditable)
            self.table.setItem(row, column, item)
        self._show_figures(row, stored.id)

    def _show_figures(self, row: int, object_id: int) -> None:
        result = self.workspace.object_figures(object_id)
        if result is None:
            main, quality = "computing…", ""
        else:
            main = format_figure(result.figures[0]) if result.figures else result.reason
            quality = "; ".join(result.failures) or "ok"
        filling, self._filling = self._filling, True
        try:
            for column, value in (("figure", main), ("quality", quality)):
                item = self.table.item(row, self.COLUMNS.index(column))
                if item is not None and item.text() != value:
                    item.setText(value)
        finally:
            self._filling = filling

    def _compute(self, ids: list[int]) -> None:
        """Figures of ``ids`` not yet known: at once for a few, else in a worker (the newest job wins)."""
        missing = [i for i in ids if self.workspace.object_figures(i) is None]
        if 0 < len(missing) <= self.SYNCHRONOUS:
            for object_id in missing:
                self.workspace.figures([object_id])
                row = self.row_of(object_id)
                if row is not None:
                    self._show_figures(row, object_id)
        elif missing:
            if self._worker is not None:
                self._worker.cancel()
                missing = sorted(set(missing) | set(self._pending))
            self._pending = missing
            job = self.workspace.figures_job(missing)
            worker = self._worker = Worker(job, "computing the objects' figures")
            worker.signals.finished.connect(lambda results, j=job, w=worker: self._on_figures(j, w, results))
            start(worker)

    def _on_figures(self, job, worker: Worker, results: dict) -> None:
        if worker is self._worker:
            self._worker, self._pending = None, []
        for object_id in self.workspace.remember_figures(job, results):
            row = self.row_of(object_id)
            if row is not None:
                self._show_figures(row, object_id)
        self._fit()

    def _fit(self) -> None:
        if len(self._ids) <= self.FIT_ROWS:
            self.table.resizeColumnsToContents()

    def _on_item_changed(self, item: QtWidgets.QTableWidgetItem) -> None:
        if self._filling:
            return
        row = item.row()
        object_id = int(self.table.item(row, 0).text())
        attribute = self.table.item(row, self.COLUMNS.index("attribute")).text()
        notes = self.table.item(row, self.COLUMNS.index("notes")).text()
        self.workspace.edit_object(object_id, attribute, notes)

    def _on_vertex_range(self) -> None:
        ids = self.selected_ids()
        count = len(self.workspace.stored_object(ids[0]).vertices) if len(ids) == 1 else 1
        self.vertex.setRange(1, max(count, 1))
        self.kind.clear()
        if len(ids) == 1:
            self.kind.addItems(self.workspace.kinds_for(ids[0]))

    def _on_set_kind(self) -> None:
        ids = self.selected_ids()
        if len(ids) != 1 or not self.kind.currentText():
            self.workspace.message.emit("warning", "select one object in the list to change its kind")
            return
        try:
            self.workspace.change_kind(ids[0], self.kind.currentText())
        except UsvipsError as error:
            self.workspace.message.emit("error", str(error))

    def _edit_vertex(self, action) -> None:
        """Re-pick or delete the chosen vertex of the one selected object; errors go to the window."""
        ids = self.selected_ids()
        if len(ids) != 1:
            self.workspace.message.emit("warning", "select one object in the list to edit its vertices")
            return
        try:
            action(ids[0], self.vertex.value() - 1)
        except UsvipsError as error:
            self.workspace.message.emit("error", str(error))

    def _on_delete(self) -> None:
        for object_id in self.selected_ids():
            self.workspace.delete_object(object_id)

    def _on_zoom(self) -> None:
        ids = self.selected_ids()
        if ids:
            self.zoom_requested.emit(ids[0])


class CalculatorPanel(QtWidgets.QWidget):
    """The geo-calculator on the selected objects, with sigmas and the quality rules (editable)."""

    def __init__(self, workspace: Workspace, parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(parent)
        self.workspace = workspace
        self.selection: list[int] = []
        self.output = QtWidgets.QPlainTextEdit()
        self.output.setReadOnly(True)
        rules = workspace.rules
        self.max_rms = self._spin(rules.max_ray_rms_m * 1000, 0.1, 1000, " mm", "largest ray-intersection RMS")
        self.max_precision = self._spin(rules.max_relative_precision * 100, 0.1, 100, " %",
                                        "largest sigma relative to the length or area")
        self.max_range = self._spin(rules.max_range_m, 0.1, 1000, " m", "largest range from the left camera")
        form = QtWidgets.QGridLayout()  # two rows, so that the rules fit the dock on a 1366 px screen
        for k, (label, spin) in enumerate((("ray RMS ≤", self.max_rms), ("σ/value ≤", self.max_precision),
                                           ("range ≤", self.max_range))):
            form.addWidget(QtWidgets.QLabel(label), k // 2, 2 * (k % 2))
            form.addWidget(spin, k // 2, 2 * (k % 2) + 1)
        form.setColumnStretch(4, 1)
        layout = QtWidgets.QVBoxLayout(self)
        layout.setContentsMargins(2, 2, 2, 2)
        layout.addLayout(form)
        layout.addWidget(self.output)
        self._events = ((workspace.selection_changed, self.set_selection), (workspace.objects_reset, self.refresh),
                        (workspace.objects_updated, self._on_objects), (workspace.objects_removed, self._on_objects),
                        (workspace.rules_changed, self.refresh))
        for signal, slot in self._events:
            signal.connect(slot)

    def _spin(self, value: float, low: float, high: float, suffix: str, tip: str) -> QtWidgets.QDoubleSpinBox:
        spin = QtWidgets.QDoubleSpinBox()
        spin.setRange(low, high)
        spin.setDecimals(1)
        spin.setValue(value)
        spin.setSuffix(suffix)
        spin.setToolTip(tip)
        spin.valueChanged.connect(self._on_rules_changed)
        return spin

    def cleanup(self) -> None:
        for signal, slot in self._events:
            signal.disconnect(slot)

    def _on_rules_changed(self) -> None:
        from dataclasses import replace

        self.workspace.set_rules(replace(self.workspace.rules, max_ray_rms_m=self.max_rms.value() / 1000,
                                         max_relative_precision=self.max_precision.value() / 100,
                                         max_range_m=self.max_range.value()))

    def set_selection(self, object_ids) -> None:
        self.selection = list(object_ids)
        self.refresh()

    def _on_objects(self, ids: tuple[int, ...]) -> None:
        """Only a change of a shown object is redrawn."""
        if set(ids) & set(self.selection):
            self.refresh()

    def refresh(self, *_: object) -> None:
        existing = set(self.workspace.object_ids())
        self.selection = [i for i in self.selection if i in existing]
        if not self.selection:
            self.output.setPlainText("Select one object for its figures, or two for the figures between them "
                                     "(distance, point–line, point–plane, angle).")
            return
        result = self.workspace.figures(self.selection)
        head = "objects " + " and ".join(str(i) for i in self.selection)
        lines = [head, ""] + [format_figure(f) for f in result.figures]
        if result.reason:
            lines.append(result.reason)
        if result.figures and not result.reason:
            lines.append("")
            lines.append("quality: " + ("; ".join(result.failures) if result.failures else "passes the rules"))
        if any(f.name in ("bearing", "slope") for f in result.figures):
            lines.append(f"bearing (clockwise from +Y towards +X) and slope (above the X–Y plane) are in "
                         f"{self.workspace.frame_description(self.selection[0])}")
        self.output.setPlainText("\n".join(lines))


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
        self._added: list[int] = []
        self.labels: list[pg.TextItem] = []
        top = QtWidgets.QHBoxLayout()
        top.addWidget(self.view)
        top.addWidget(self.frame, 1)
        layout = QtWidgets.QVBoxLayout(self)
        layout.setContentsMargins(2, 2, 2, 2)
        layout.addLayout(top)
        layout.addWidget(self.plot)
        self._parts: dict[int, tuple] = {}  # object id -> (label, label position, outline, 1σ rings) in this view
        self._dirty = True
        self._stale: set[int] = set()  # ids whose drawing is not computed yet (done when the view is shown)
        self._events = ((workspace.objects_reset, self.refresh), (workspace.pair_changed, self._on_pair),
                        (workspace.objects_added, self._on_added), (workspace.objects_updated, self._on_objects),
                        (workspace.objects_removed, self._on_objects),
                        (workspace.selection_changed, self._on_selection))
        for signal, slot in self._events:
            signal.connect(slot)
        self.refresh()

    #: Above this many objects only the selected ones are labelled (thousands of labels hide the plot).
    MAX_LABELS = 300
    #: Objects drawn on their own after being added, before the whole plot is redrawn.
    MAX_ADDED = 200

    def cleanup(self) -> None:
        for signal, slot in self._events:
            signal.disconnect(slot)

    def _label(self, text: str, position, colour) -> None:
        item = pg.TextItem(text, color=colour, anchor=(0, 1))
        item.setPos(float(position[0]), float(position[1]))
        self.plot.addItem(item, ignoreBounds=True)
        self.labels.append(item)

    def refresh(self, *_: object) -> None:
        """Every object again (another view or project)."""
        self._parts = {}
        self._on_objects(tuple(self.workspace.object_ids()))

    def _on_pair(self) -> None:
        """Another pair: its cameras and frame (the objects stay as they are)."""
        self._dirty = True
        if self.isVisible():
            self.redraw()

    def _on_objects(self, ids: tuple[int, ...]) -> None:
        """Recompute the drawing of just ``ids``: now if the view is shown, else when it is shown (a hidden
        plan view costs nothing: labelling a few hundred objects takes seconds of the GUI thread)."""
        self._stale.update(ids)
        self._dirty = True
        if self.isVisible():
            self.redraw()

    def _on_added(self, ids: tuple[int, ...]) -> None:
        """New objects: shown, at survey size, unselected and after every object drawn, only they are drawn
        (on their own items); otherwise as any change."""
        alone = (self.isVisible() and not self._dirty and len(self._parts) > self.MAX_LABELS
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
        for object_id in ids:
            try:
                stored = self.workspace.stored_object(object_id)
            except UsvipsError:
                self._parts.pop(object_id, None)
                continue
            part = self._part(stored, a, b)
            if part is None:
                self._parts.pop(object_id, None)
            else:
                self._parts[object_id] = part
        if not ordered:
            self._parts = dict(sorted(self._parts.items()))

    def _on_selection(self, _ids) -> None:
        """At survey size the selected objects are labelled: only the labels change."""
        if len(self._parts) > self.MAX_LABELS:
            if not self.isVisible():
                self._dirty = True
            elif self._dirty:
                self.redraw()
            else:
                self._draw_labels()

    def showEvent(self, event) -> None:  # noqa: N802 (Qt's name)
        super().showEvent(event)
        if self._dirty:
            self.redraw()

    CIRCLE = np.column_stack([np.cos(np.linspace(0, 2 * np.pi, 49)), np.sin(np.linspace(0, 2 * np.pi, 49))])

    def _part(self, stored, a: int, b: int) -> tuple | None:
        vertices = [v for v in stored.vertices if v.xyz is not None]
        points = np.array([v.xyz for v in vertices], float).reshape(-1, 3)
        if not len(points):
            return None
        rings = np.zeros((0, 2))
        known = [i for i, v in enumerate(vertices) if v.covariance is not None]
        if known:  # the 2 x 2 blocks of every vertex at once: (M, 49, 2) rings, NaN-separated
            blocks = np.array([vertices[i].covariance for i in known], float)[:, [a, b]][:, :, [a, b]]
            values, vectors = np.linalg.eigh(blocks)
            scaled = self.CIRCLE[None] * np.sqrt(np.clip(values, 0, None))[:, None, :]
            ring = points[known][:, None, [a, b]] + np.einsum("mkj,mij->mki", scaled, vectors)
            rings = np.concatenate([ring, np.full((len(known), 1, 2), np.nan)], axis=1).reshape(-1, 2)
        label = (f"{stored.id} {stored.attribute}".strip(), points[0, [a, b]])
        if len(points) == len(stored.vertices):
            try:
                points = measurement_kind(stored.kind).outline(points)
            except UsvipsError:
                pass  # drawn through its vertices
        outline = np.vstack([points[:, [a, b]], [[np.nan, np.nan]]])
        return label, outline, rings

    def redraw(self) -> None:
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


class ObservationForm(QtWidgets.QWidget):
    """The observation record of the object just stored (or the one selected), typed from the keyboard:
    species with type-ahead from the project's species list, number, stage, activity, comment. Enter
    stores it and hands the keyboard back to the images, Esc leaves it blank; *Keep values* starts the
    next record with these values. ``finished()`` fires after either."""

    finished = QtCore.Signal()

    def __init__(self, workspace: Workspace, parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(parent)
        self.workspace = workspace
        self.object_id: int | None = None
        self.target = QtWidgets.QLabel("no object")
        self.species = QtWidgets.QComboBox()
        self.species.setEditable(True)
        self.species.setInsertPolicy(QtWidgets.QComboBox.InsertPolicy.NoInsert)
        self.species.setMinimumContentsLength(18)
        self.species.setToolTip("type part of the genus, species or code; the list is the project's "
                                "(File › Import species list…); blank: not identified")
        self.number = QtWidgets.QSpinBox()
        self.number.setRange(1, 100000)
        self.number.setToolTip("number of individuals")
        self.stage = QtWidgets.QComboBox()
        self.stage.setEditable(True)
        self.stage.addItems(["", *STAGES])
        self.stage.setToolTip("life stage: AD adult, J juvenile, F female, M male, U unknown (or type one)")
        self.activity = QtWidgets.QLineEdit()
        self.activity.setPlaceholderText("activity")
        self.comment = QtWidgets.QLineEdit()
        self.comment.setPlaceholderText("comment")
        self.keep = QtWidgets.QCheckBox("Keep values")
        self.keep.setToolTip("start the next record with these values")
        self.ask = QtWidgets.QCheckBox("Ask after each measurement")
        self.ask.setChecked(True)
        store = QtWidgets.QPushButton("Store (Enter)")
        store.clicked.connect(self.store)
        self.status = QtWidgets.QLabel("")
        row = QtWidgets.QHBoxLayout()
        for label, widget in (("", self.target), ("Species", self.species), ("No.", self.number),
                              ("Stage", self.stage), ("", self.activity), ("", self.comment)):
            if label:
                row.addWidget(QtWidgets.QLabel(label))
            row.addWidget(widget, 2 if widget in (self.species, self.comment) else 0)
        row.addWidget(store)
        options = QtWidgets.QHBoxLayout()
        options.addWidget(self.keep)
        options.addWidget(self.ask)
        options.addWidget(self.status, 1)
        layout = QtWidgets.QVBoxLayout(self)
        layout.setContentsMargins(2, 2, 2, 2)
        layout.addLayout(row)
        layout.addLayout(options)
        layout.addStretch(1)
        self.refresh_species()

    def refresh_species(self) -> None:
        """Reload the type-ahead list from the open project."""
        project = self.workspace.project
        self._species = {} if project is None else {s.name.lower(): s for s in project.species_list()}
        text = self.species.currentText()
        self.species.clear()
        self.species.addItems([""] + [self._label(s) for s in self._species.values()])
        completer = QtWidgets.QCompleter([self.species.itemText(i) for i in range(1, self.species.count())], self)
        completer.setCaseSensitivity(QtCore.Qt.CaseSensitivity.CaseInsensitive)
        completer.setFilterMode(QtCore.Qt.MatchFlag.MatchContains)
        self.species.setCompleter(completer)
        self.species.setEditText(text)

    @staticmethod
    def _label(species: Species) -> str:
        return f"{species.name} — {species.family}" + (f" ({species.code})" if species.code else "")

    def begin(self, object_id: int) -> None:
        """Show the record of ``object_id`` and take the keyboard (after a measurement)."""
        self.load(object_id)
        self.status.setText("type the species (type-ahead), Tab to the next field, Enter stores, Esc skips")
        self.species.setFocus(QtCore.Qt.FocusReason.OtherFocusReason)
        self.species.lineEdit().selectAll()

    def load(self, object_id: int) -> None:
        """Show the record of ``object_id`` (its stored one, else blank or the kept values)."""
        self.object_id = object_id
        stored = self.workspace.project.object(object_id)
        self.target.setText(f"{stored.kind} {object_id}")
        record = self.workspace.project.record(object_id)
        if record is not None:
            self._show(record)
        elif not self.keep.isChecked():
            self._show(ObservationRecord())
        self.status.setText("")

    def _show(self, record: ObservationRecord) -> None:
        match = self._species.get(record.name.lower())
        self.species.setEditText(self._label(match) if match else record.name)
        self.number.setValue(record.number)
        self.stage.setEditText(record.stage)
        self.activity.setText(record.activity)
        self.comment.setText(record.comment)

    def chosen_species(self) -> Species | None:
        """The species typed: its list entry (by 'Genus species', the list's text or its code); None when
        blank; an error naming the text when it is not in the project's list."""
        text = self.species.currentText().split(" — ")[0].strip()
        if not text:
            return None
        found = self._species.get(text.lower()) or next(
            (s for s in self._species.values() if s.code and s.code.lower() == text.lower()), None)
        if found is None:
            raise UsvipsError(f"species {text!r} is not in the project's species list (File › Import species "
                              "list…); leave it blank if not identified")
        return found

    def store(self) -> bool:
        if self.object_id is None or self.workspace.project is None:
            self.status.setText("measure an object first (or select one in the object list)")
            return False
        try:
            record = ObservationRecord.of(self.chosen_species(), number=self.number.value(),
                                          stage=self.stage.currentText(), activity=self.activity.text(),
                                          comment=self.comment.text())
            self.workspace.set_record(self.object_id, record)
        except UsvipsError as error:
            self.status.setText(str(error))  # nothing typed is lost: the fields keep it
            return False
        self.status.setText(f"stored for object {self.object_id}: {record.name or 'not identified'} × {record.number}")
        if not self.keep.isChecked():
            self._show(ObservationRecord())
        self.finished.emit()
        return True

    def keyPressEvent(self, event) -> None:  # noqa: N802 (Qt's name)
        if event.key() in (QtCore.Qt.Key.Key_Return, QtCore.Qt.Key.Key_Enter):
            event.accept()
            self.store()
            return
        if event.key() == QtCore.Qt.Key.Key_Escape:
            event.accept()
            self.status.setText(f"object {self.object_id} left without a record")
            self.finished.emit()
            return
        super().keyPressEvent(event)


class LogPanel(QtWidgets.QPlainTextEdit):
    """Every message of the session, newest last."""

    def __init__(self, parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(parent)
        self.setReadOnly(True)
        self.setMaximumBlockCount(2000)

    def add(self, level: str, text: str) -> None:
        stamp = QtCore.QTime.currentTime().toString("HH:mm:ss")
        self.appendPlainText(f"{stamp} {level:7s} {text}")
