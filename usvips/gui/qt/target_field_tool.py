"""Calibration › *Find a target field…*: identify six or more targets of a 3-D field in each image of a
pair by clicking and naming them, find the rest through the model, look at what was found (green),
doubtful (amber) or missing (listed), accept, reject or place the doubtful ones (drag them, or select
one and click), and confirm: the targets are stored as the pair's control observations, which the
classic calibration wizards read.

The view over :class:`usvips.gui.target_field_model.FieldModel`; the search runs on the worker with
progress and Stop. Keys: click a target, type its id, Enter; F5 finds the rest; in the list, A accepts,
R rejects, Delete forgets a click; Ctrl+Enter confirms.
"""

from __future__ import annotations

import numpy as np
from PySide6 import QtCore, QtGui, QtWidgets

from usvips.core.errors import UsvipsError
from usvips.gui.qt.marks import Handle, MarkLabel, Points
from usvips.gui.qt.pane import StereoPane, item_from_pixels, pixel_from_item
from usvips.gui.qt.worker import Worker, start
from usvips.gui.target_field_model import SIDES, STATES, FieldModel
from usvips.gui.window_context import WindowContext
from usvips.io.tables import read_control

#: colour (RGB) and symbol of each mark's state; the pending click and the selection
STYLE = {"clicked": ((0, 200, 255), "+"), "found": ((60, 220, 120), "o"), "doubtful": ((255, 176, 0), "o"),
         "accepted": ((255, 176, 0), "s")}
PENDING = (255, 255, 255)
SELECTED = (255, 0, 255)
#: list colours by status
ROW_COLOURS = {"found": "#2e8b57", "doubtful": "#b9770e", "missing": "#c0392b", "clicked": "#1f77b4"}


#: states drawn as handles the user can drag (the doubtful targets, accepted or not)
DRAGGED = ("doubtful", "accepted")


class FieldOverlay:
    """The marks of one pane: a scatter per state, a handle for each doubtful target (dragged to place
    it: ``moved(id, pixel)`` is called when the drag ends), the ids beside them, the pending click, the
    selection."""

    def __init__(self, pane: StereoPane, moved=None) -> None:
        self.pane = pane
        self.moved = moved
        self.handles: dict[str, Handle] = {}
        self.items = {}
        for state in STATES:
            colour, symbol = STYLE[state]
            self.items[state] = Points(15, colour, width=2, symbol=symbol)
            pane.add_mark(self.items[state])
        self.predicted = Points(11, STYLE["doubtful"][0], width=1.5, symbol="x")
        pane.add_mark(self.predicted)
        self.pending = Points(19, PENDING, width=2, symbol="+")
        self.selected = Points(25, SELECTED, width=2.5, symbol="o")
        for item in (self.pending, self.selected):
            pane.add_mark(item)
        self.labels: list[MarkLabel] = []

    def show(self, marks: list[tuple[str, tuple[float, float], str]], pending, selected: str | None,
             predicted: list[tuple[str, tuple[float, float]]] = ()) -> None:
        """``marks`` (id, pixel, state); the ``pending`` click (a pixel or None); the ``selected`` id; where
        the model ``predicted`` the doubtful targets (small amber crosses)."""
        guesses = np.array([p for _, p in predicted], float).reshape(-1, 2)
        self.predicted.set_points(item_from_pixels(guesses))
        for label in self.labels:
            self.pane.remove_mark(label)
        self.labels = []
        for state in STATES:
            pixels = np.array([p for _, p, s in marks if s == state and s not in DRAGGED], float).reshape(-1, 2)
            self.items[state].set_points(item_from_pixels(pixels))
        self._handles([(pid, pixel, state) for pid, pixel, state in marks if state in DRAGGED])
        for pid, pixel, state in marks:
            text = MarkLabel(pid, SELECTED if pid == selected else STYLE[state][0], (-0.25, 1.1), boxed=False)
            x, y = item_from_pixels(np.array(pixel))[0]
            text.setPos(float(x), float(y))
            self.pane.add_mark(text)
            self.labels.append(text)
        for pid, pixel in predicted:  # "T05?": where the model puts a doubtful target
            text = MarkLabel(f"{pid}?", STYLE["doubtful"][0], (-0.25, -0.1), boxed=False)
            x, y = item_from_pixels(np.array(pixel))[0]
            text.setPos(float(x), float(y))
            self.pane.add_mark(text)
            self.labels.append(text)
        self.pending.set_points(item_from_pixels(np.array(pending)) if pending is not None else None)
        chosen = [p for pid, p, _ in marks if pid == selected]
        self.selected.set_points(item_from_pixels(np.array(chosen[0])) if chosen else None)


    def _handles(self, marks: list[tuple[str, tuple[float, float], str]]) -> None:
        for handle in self.handles.values():
            self.pane.remove_mark(handle)
        self.handles = {}
        for pid, pixel, state in marks:
            colour, symbol = STYLE[state]
            x, y = item_from_pixels(np.array(pixel))[0]
            handle = Handle((float(x), float(y)), 15, symbol, colour, 2, SELECTED)
            handle.setToolTip(f"{pid}: drag to where the target is")
            handle.dropped.connect(lambda item, p=pid: self._dropped(p, item))
            self.pane.add_mark(handle)
            self.handles[pid] = handle

    def _dropped(self, pid: str, handle) -> None:
        if self.moved is not None:
            position = handle.pos()
            pixel = pixel_from_item(position.x(), position.y())
            # after the drag's own event: the handles are redrawn by the change it makes
            QtCore.QTimer.singleShot(0, lambda: self.moved(pid, pixel))


class TargetFieldTool(QtWidgets.QDialog):
    """The tool's dialog on a project (its image pairs, control and calibrations). ``confirmed(text)`` is
    emitted after the targets were stored."""

    confirmed = QtCore.Signal(str)

    def __init__(self, project, pair: str | None = None, parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(parent)
        self.setObjectName("target_field_tool")
        self.setWindowTitle("Find a target field")
        self.project = project
        self.control = None  # a control file's points, when the project holds none
        self.model: FieldModel | None = None
        self.worker: Worker | None = None
        self._build()
        labels = [p.label for p in project.pairs() if p.left and p.right]
        if not labels:
            raise UsvipsError("the project has no image pair: add the pair that shows the target field first")
        self.pair_box.addItems(labels)
        self.pair_box.setCurrentIndex(labels.index(pair) if pair in labels else 0)
        self.calibration_box.addItem("none: a DLT (in air)", None)
        for row in project.calibrations():
            self.calibration_box.addItem(f"{row['id']}: {row['name']} ({row['phase']})", row["id"])
        self.load_pair(self.pair_box.currentText())

    # ------------------------------------------------------------------ building
    def _build(self) -> None:
        top = QtWidgets.QHBoxLayout()
        self.pair_box = QtWidgets.QComboBox(objectName="field_pair")
        self.pair_box.activated.connect(lambda _: self.load_pair(self.pair_box.currentText()))
        self.calibration_box = QtWidgets.QComboBox(objectName="field_calibration")
        self.calibration_box.setToolTip("an earlier calibration: its interior and housing are used and the pose "
                                        "resected (needed underwater); none: a DLT from the clicks, in air")
        self.calibration_box.activated.connect(lambda _: self._on_calibration())
        self.shape_box = QtWidgets.QComboBox(objectName="field_shape")
        self.shape_box.addItems(["disc", "cross"])
        self.shape_box.activated.connect(lambda _: self.load_pair(self.pair_box.currentText()))
        for text, widget in (("&Pair", self.pair_box), ("Ca&libration", self.calibration_box),
                             ("Tar&gets", self.shape_box)):
            label = QtWidgets.QLabel(text)
            label.setBuddy(widget)
            top.addWidget(label)
            top.addWidget(widget)
        self.control_button = QtWidgets.QPushButton("C&ontrol file…", objectName="field_control")
        self.control_button.setToolTip("the field's control (id,X,Y,Z in metres) when the project holds none; "
                                       "stored with the targets on Confirm")
        self.control_button.clicked.connect(self._choose_control)
        top.addWidget(self.control_button)
        top.addStretch(1)

        self.panes = {side: StereoPane(side) for side in SIDES}
        self.overlays = {side: FieldOverlay(self.panes[side], lambda pid, pixel, s=side: self.drag(s, pid, pixel))
                         for side in SIDES}
        images = QtWidgets.QSplitter(QtCore.Qt.Orientation.Horizontal)
        for side in SIDES:
            self.panes[side].setObjectName(f"field_{side}_pane")
            self.panes[side].clicked.connect(lambda x, y, s=side: self.on_click(s, (x, y)))
            images.addWidget(self.panes[side])

        panel = QtWidgets.QWidget()
        panel.setMinimumWidth(300)
        panel.setMaximumWidth(420)
        side_layout = QtWidgets.QVBoxLayout(panel)
        side_layout.setContentsMargins(4, 0, 0, 0)
        self.count_label = QtWidgets.QLabel(objectName="field_count")
        self.count_label.setWordWrap(True)
        side_layout.addWidget(self.count_label)
        name_row = QtWidgets.QHBoxLayout()
        self.id_box = QtWidgets.QComboBox(objectName="field_id")
        self.id_box.setEditable(True)
        self.id_box.setInsertPolicy(QtWidgets.QComboBox.InsertPolicy.NoInsert)
        self.id_box.lineEdit().setPlaceholderText("target id")
        self.id_box.lineEdit().returnPressed.connect(self.name_click)
        self.name_button = QtWidgets.QPushButton("&Name", objectName="field_name")
        self.name_button.clicked.connect(self.name_click)
        id_label = QtWidgets.QLabel("&Id")
        id_label.setBuddy(self.id_box)
        name_row.addWidget(id_label)
        name_row.addWidget(self.id_box, 1)
        name_row.addWidget(self.name_button)
        side_layout.addLayout(name_row)
        self.hint = QtWidgets.QLabel(objectName="field_hint")
        self.hint.setWordWrap(True)
        side_layout.addWidget(self.hint)
        find_row = QtWidgets.QHBoxLayout()
        self.find_button = QtWidgets.QPushButton("&Find the rest", objectName="field_find")
        self.find_button.setToolTip("find every other target through the model (F5)")
        self.find_button.clicked.connect(self.find_rest)
        self.stop_button = QtWidgets.QPushButton("&Stop", objectName="field_stop")
        self.stop_button.clicked.connect(self.stop)
        self.stop_button.setEnabled(False)
        find_row.addWidget(self.find_button, 1)
        find_row.addWidget(self.stop_button)
        side_layout.addLayout(find_row)
        self.progress = QtWidgets.QProgressBar(objectName="field_progress")
        self.progress.setRange(0, 100)
        self.progress.hide()
        side_layout.addWidget(self.progress)
        self.summary = QtWidgets.QLabel(objectName="field_summary")
        self.summary.setWordWrap(True)
        self.summary.setTextInteractionFlags(QtCore.Qt.TextInteractionFlag.TextSelectableByMouse)
        side_layout.addWidget(self.summary)
        self.table = QtWidgets.QTreeWidget(objectName="field_table")
        self.table.setHeaderLabels(["Image", "Target", "Status", "Why"])
        self.table.setRootIsDecorated(False)
        self.table.setUniformRowHeights(True)
        self.table.currentItemChanged.connect(lambda item, _: self._on_row(item))
        side_layout.addWidget(self.table, 1)
        decide = QtWidgets.QHBoxLayout()
        self.accept_button = QtWidgets.QPushButton("&Accept", objectName="field_accept")
        self.accept_button.setToolTip("keep the selected doubtful target where it was located (A)")
        self.accept_button.clicked.connect(lambda: self.decide("accept"))
        self.reject_button = QtWidgets.QPushButton("&Reject", objectName="field_reject")
        self.reject_button.setToolTip("leave the selected doubtful target out (R)")
        self.reject_button.clicked.connect(lambda: self.decide("reject"))
        self.remove_button = QtWidgets.QPushButton("Forget clic&k", objectName="field_remove")
        self.remove_button.setToolTip("forget the selected click (Delete)")
        self.remove_button.clicked.connect(self.remove_click)
        for button in (self.accept_button, self.reject_button, self.remove_button):
            decide.addWidget(button)
        side_layout.addLayout(decide)
        self.confirm_button = QtWidgets.QPushButton("&Confirm: store them", objectName="field_confirm")
        self.confirm_button.setToolTip("store the targets found in both images as the pair's control observations "
                                       "(Ctrl+Enter)")
        self.confirm_button.clicked.connect(self.confirm)
        side_layout.addWidget(self.confirm_button)
        close = QtWidgets.QPushButton("Close", objectName="field_close")
        close.clicked.connect(self.close)
        side_layout.addWidget(close)

        body = QtWidgets.QSplitter(QtCore.Qt.Orientation.Horizontal)
        body.addWidget(images)
        body.addWidget(panel)
        body.setStretchFactor(0, 1)
        layout = QtWidgets.QVBoxLayout(self)
        layout.addLayout(top)
        layout.addWidget(body, 1)
        for keys, slot in (("F5", self.find_rest), ("Ctrl+Return", self.confirm), ("Ctrl+Enter", self.confirm)):
            QtGui.QShortcut(QtGui.QKeySequence(keys), self, slot)
        for keys, slot in (("A", lambda: self.decide("accept")), ("R", lambda: self.decide("reject")),
                           ("Delete", self.remove_click)):
            shortcut = QtGui.QShortcut(QtGui.QKeySequence(keys), self.table, slot)
            shortcut.setContext(QtCore.Qt.ShortcutContext.WidgetShortcut)
        # Enter belongs to the id box (it names the click): no button of the dialog takes it as its default
        for button in self.findChildren(QtWidgets.QPushButton):
            button.setAutoDefault(False)
            button.setDefault(False)
        self.resize(1200, 700)

    # ------------------------------------------------------------------ the pair
    def load_pair(self, pair: str) -> None:
        """Start afresh on ``pair`` (its images, the project's control, the chosen calibration)."""
        self.stop()
        try:
            model = FieldModel(self.project, pair, self.calibration_box.currentData(), self.shape_box.currentText(),
                               self.control)
        except UsvipsError as error:
            self.model = None
            self.summary.setText(f"Cannot search pair {pair}: {error}")
            self.refresh()
            return
        self.model = model
        model.changed.connect(self.refresh)
        for side in SIDES:
            self.panes[side].set_image(model.job.images[side])
        self.id_box.clear()
        self.id_box.addItems(list(model.ids()))
        self.id_box.setCurrentIndex(-1)
        self.id_box.setCompleter(QtWidgets.QCompleter(list(model.ids()), self))
        self.hint.setText(f"Click a target in either image, then give its id (typed or chosen) and press Enter. "
                          f"At least {model.needed()} per image.")
        self.summary.setText("")
        self.refresh()

    def _choose_control(self) -> None:
        path, _ = QtWidgets.QFileDialog.getOpenFileName(self, "The field's control (id,X,Y,Z in metres)", "",
                                                        "CSV (*.csv *.txt)")
        if path:
            self.use_control(path)

    def use_control(self, path: str) -> None:
        """Search with the control file at ``path`` (the project holds none, or the same); starts afresh."""
        try:
            self.control = read_control(path)
        except UsvipsError as error:
            self.summary.setText(str(error))
            return
        self.load_pair(self.pair_box.currentText())

    def _on_calibration(self) -> None:
        if self.model is None:
            return
        try:
            self.model.set_calibration(self.calibration_box.currentData())
        except UsvipsError as error:
            self.summary.setText(f"Cannot use that calibration: {error}")

    # ------------------------------------------------------------------ identifying
    def on_click(self, side: str, pixel: tuple[float, float]) -> None:
        if self.model is None or self.worker is not None:
            return
        self.hint.setText(self.model.click(side, pixel))
        if self.model.pending is not None:
            self.id_box.setFocus(QtCore.Qt.FocusReason.OtherFocusReason)
            self.id_box.lineEdit().selectAll()

    def name_click(self) -> None:
        if self.model is None:
            return
        try:
            self.model.name(self.id_box.currentText())
        except UsvipsError as error:
            self.hint.setText(str(error))
            return
        self.id_box.setCurrentIndex(-1)
        self.id_box.clearEditText()
        more = [f"{self.model.more_needed(s)} more in the {s} image" for s in SIDES if self.model.more_needed(s)]
        self.hint.setText(("Named. " + ", ".join(more) + ".") if more else
                          "Enough targets identified: press Find the rest (F5).")

    def remove_click(self) -> None:
        key = self._current()
        if self.model is not None and key is not None and key[1] in self.model.clicks[key[0]]:
            self.model.remove(*key)

    # ------------------------------------------------------------------ searching
    def find_rest(self) -> None:
        if self.model is None or self.worker is not None:
            return
        try:
            job = self.model.search_job()
        except UsvipsError as error:
            self.summary.setText(str(error))
            return
        worker = self.worker = Worker(job, "finding the target field")
        worker.signals.progress.connect(lambda f, w=worker: self.progress.setValue(int(100 * f))
                                        if w is self.worker else None)
        worker.signals.finished.connect(lambda result, w=worker: self._on_found(w, result))
        worker.signals.failed.connect(lambda message, w=worker: self._on_ended(w, message))
        worker.signals.cancelled.connect(lambda w=worker: self._on_ended(w, "Stopped: nothing was found."))
        self.progress.setValue(0)
        self.progress.show()
        self.stop_button.setEnabled(True)
        self.find_button.setEnabled(False)
        self.summary.setText("Finding the rest of the field …")
        start(worker)

    def stop(self) -> None:
        """Stop a search under way: its result, if it still comes, is dropped."""
        if self.worker is not None:
            self.worker.cancel()
            self._on_ended(self.worker, "Stopped: nothing was found.")

    def _on_found(self, worker: Worker, result) -> None:
        if worker is not self.worker:
            return
        self._idle()
        self.model.set_result(result)

    def _on_ended(self, worker: Worker, message: str) -> None:
        if worker is not self.worker:
            return
        self._idle()
        self.summary.setText(message)

    def _idle(self) -> None:
        self.worker = None
        self.progress.hide()
        self.stop_button.setEnabled(False)
        self.find_button.setEnabled(True)

    @property
    def busy(self) -> bool:
        return self.worker is not None

    # ------------------------------------------------------------------ deciding
    def _current(self) -> tuple[str, str] | None:
        item = self.table.currentItem()
        return None if item is None else (item.text(0), item.text(1))

    def _on_row(self, item) -> None:
        if self.model is None or item is None:
            return
        self.model.selected = (item.text(0), item.text(1))
        side, pid = self.model.selected
        marks = {m[0]: m[1] for m in self.model.marks(side)}
        if pid in marks:
            self.panes[side].bring_into_view(marks[pid])
        if self.model.status(side, pid) == "doubtful":
            self.hint.setText(f"{side} {pid} is doubtful ({item.text(3)}): Accept (A) keeps it where it was "
                              f"located, Reject (R) leaves it out; drag it, or click in the {side} image, to place "
                              f"it (an amber {pid}? marks where the other targets put it).")
        else:
            self.hint.setText(f"{side} {pid}: {item.text(2)} ({item.text(3)})")
        self._draw()

    def drag(self, side: str, pid: str, pixel: tuple[float, float]) -> None:
        """A doubtful target's handle dropped at ``pixel``: placed there (accepted)."""
        if self.model is None or self.worker is not None:
            return
        try:
            self.hint.setText(self.model.move(side, pid, pixel))
        except UsvipsError as error:
            self.hint.setText(str(error))

    def decide(self, how: str) -> None:
        key = self._current()
        if self.model is None or key is None:
            return
        try:
            (self.model.accept if how == "accept" else self.model.reject)(*key)
        except UsvipsError as error:
            self.hint.setText(str(error))

    def confirm(self) -> None:
        if self.model is None or self.worker is not None:
            return
        try:
            confirmed = self.model.confirm()
        except UsvipsError as error:
            self.summary.setText(f"Nothing stored: {error}")
            return
        text = (f"Stored {confirmed.count} targets as the {confirmed.role} observations of pair {confirmed.pair}"
                + (" and the control" if confirmed.control_stored else "") + ".")
        if confirmed.one_sided:
            text += f" Usable in one image only (not stored): {', '.join(confirmed.one_sided)}."
        self.summary.setText(text)
        self.confirmed.emit(text)

    # ------------------------------------------------------------------ showing
    def refresh(self) -> None:
        model = self.model
        ready = model is not None
        self.count_label.setText(model.count_line() if ready else "")
        self.find_button.setEnabled(ready and model.ready() and self.worker is None)
        self.confirm_button.setEnabled(ready and model.result is not None)
        if ready and model.result is not None:
            self.summary.setText(model.summary())
        current = self._current()
        self.table.blockSignals(True)
        self.table.clear()
        for side, pid, status, words in (model.rows() if ready else []):
            item = QtWidgets.QTreeWidgetItem([side, pid, status, words])
            item.setForeground(2, QtGui.QBrush(QtGui.QColor(ROW_COLOURS[status])))
            item.setToolTip(3, words)
            self.table.addTopLevelItem(item)
            if (side, pid) == current:
                self.table.setCurrentItem(item)
        self.table.blockSignals(False)
        for column in range(3):
            self.table.resizeColumnToContents(column)
        self._draw()

    def _draw(self) -> None:
        model = self.model
        for side in SIDES:
            if model is None:
                self.overlays[side].show([], None, None)
                continue
            pending = model.pending[1] if model.pending and model.pending[0] == side else None
            selected = model.selected[1] if model.selected and model.selected[0] == side else None
            self.overlays[side].show(model.marks(side), pending, selected, model.predictions(side))

    def closeEvent(self, event) -> None:  # noqa: N802 (Qt's name)
        self.stop()
        super().closeEvent(event)


def open_tool(context: WindowContext, parent: QtWidgets.QWidget) -> TargetFieldTool | None:
    """Open the tool on ``context``'s project and pair (an error said when it cannot); what it stores is
    said through ``context.messages``."""
    project = context.workspace.project
    if project is None:
        context.messages.error("open a project first: the target field is found in its image pairs")
        return None
    try:
        tool = TargetFieldTool(project, context.workspace.pair, parent)
    except UsvipsError as error:
        context.messages.error(str(error))
        return None
    tool.confirmed.connect(context.messages.info)
    tool.show()
    return tool
