"""An object's instants in the window (issue 25): a dialog listing each instant — frame and time, its
figure ± σ, its weight in the combination, its residual and whether it is outlying — over the combined
figure ± σ with the between-instant share of σ², the agreement test's p-value and the outliers named.

Enter or a double-click on an instant goes to its frame (``frame_requested(object_id)``: the window's
video shows the frame that instant was measured on); **Remove** (or Delete) unlinks the chosen instant
from the object (it stays as an object of its own; one undoable step). The numbers come from
:mod:`usvips.gui.instants_model` (Qt-free); the view follows the workspace's object events.
"""

from __future__ import annotations

import numpy as np
from PySide6 import QtCore, QtGui, QtWidgets

from usvips.core.errors import UsvipsError
from usvips.gui.calculator import format_figure
from usvips.gui.instants_model import ObjectInstants, object_instants
from usvips.gui.undo import Command
from usvips.gui.workspace import Workspace


def residual_text(residual: float) -> str:
    """A standardised residual signed to two decimals ("+0.00", never "-0.00"); "—" when there is none."""
    if not np.isfinite(residual):
        return "—"
    return f"{round(float(residual), 2) + 0.0:+.2f}"  # + 0.0: a residual rounding to zero is +0.00


class InstantsView(QtWidgets.QDialog):
    """The instants of one object (see the module docstring); ``show_object(id)`` fills it."""

    frame_requested = QtCore.Signal(int)
    COLUMNS = ("object", "frame / time", "figure ± σ", "weight", "residual", "outlier")

    def __init__(self, workspace: Workspace, parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(parent)
        self.setObjectName("instants_view")
        self.setWindowTitle("Instants of the object")
        self.workspace = workspace
        self.object_id: int | None = None
        self.listed: ObjectInstants | None = None
        self.summary = QtWidgets.QLabel("")
        self.summary.setObjectName("instants_summary")
        self.summary.setWordWrap(True)
        self.summary.setTextInteractionFlags(QtCore.Qt.TextInteractionFlag.TextSelectableByMouse)
        self.table = QtWidgets.QTableWidget(0, len(self.COLUMNS))
        self.table.setHorizontalHeaderLabels([c.capitalize() for c in self.COLUMNS])
        for column, tip in (("weight", "the instant's share of the combination (weights 1/(σᵢ² + τ²), σᵢ its "
                                       "pointing part)"),
                            ("residual", "the instant's leave-one-out standardised residual (in σ; — with fewer "
                                         "than 3 instants)")):
            self.table.horizontalHeaderItem(self.COLUMNS.index(column)).setToolTip(tip)
        self.table.setSelectionBehavior(QtWidgets.QAbstractItemView.SelectionBehavior.SelectRows)
        self.table.setSelectionMode(QtWidgets.QAbstractItemView.SelectionMode.SingleSelection)
        self.table.setEditTriggers(QtWidgets.QAbstractItemView.EditTrigger.NoEditTriggers)
        self.table.verticalHeader().hide()
        self.table.horizontalHeader().setStretchLastSection(True)
        self.table.cellDoubleClicked.connect(lambda row, _: self.go_to(row))
        for key, slot in ((QtCore.Qt.Key.Key_Return, lambda: self.go_to(self.table.currentRow())),
                          (QtCore.Qt.Key.Key_Enter, lambda: self.go_to(self.table.currentRow())),
                          (QtCore.Qt.Key.Key_Delete, self.remove_current)):
            shortcut = QtGui.QShortcut(QtGui.QKeySequence(key), self.table)
            shortcut.setContext(QtCore.Qt.ShortcutContext.WidgetShortcut)
            shortcut.activated.connect(slot)
        self.go_button = QtWidgets.QPushButton("&Go to frame")
        self.go_button.setToolTip("show the frame the chosen instant was measured on (Enter, double-click)")
        self.go_button.clicked.connect(lambda: self.go_to(self.table.currentRow()))
        self.remove_button = QtWidgets.QPushButton("&Remove instant")
        self.remove_button.setToolTip("unlink the chosen instant from the object: it stays an object of its own "
                                      "(Delete; Ctrl+Z undoes it)")
        self.remove_button.clicked.connect(self.remove_current)
        close = QtWidgets.QPushButton("Close")
        close.clicked.connect(self.close)
        buttons = QtWidgets.QHBoxLayout()
        for widget in (self.go_button, self.remove_button):
            buttons.addWidget(widget)
        buttons.addStretch(1)
        buttons.addWidget(close)
        layout = QtWidgets.QVBoxLayout(self)
        layout.addWidget(self.summary)
        layout.addWidget(self.table, 1)
        layout.addLayout(buttons)
        self.resize(720, 320)
        self._events = ((workspace.objects_updated, self._on_changed), (workspace.objects_removed, self._on_changed),
                        (workspace.objects_added, self._on_changed), (workspace.objects_reset, self._on_reset))
        for signal, slot in self._events:
            signal.connect(slot)

    def cleanup(self) -> None:
        for signal, slot in self._events:
            signal.disconnect(slot)

    # ------------------------------------------------------------------ filling
    def show_object(self, object_id: int) -> bool:
        """List the instants of ``object_id`` (or of the object it is an instant of); False with the
        reason in the summary line when its figures cannot be computed."""
        self.object_id = int(object_id)
        return self.refresh()

    def refresh(self) -> bool:
        ws = self.workspace
        self.table.setRowCount(0)
        self.listed = None
        if self.object_id is None or ws.project is None:
            self.summary.setText("no object chosen")
            return False
        try:
            self.listed = object_instants(ws.project, self.object_id, ws.rules, ws.cache.calibrations)
        except UsvipsError as error:
            self.summary.setText(str(error))
            self.remove_button.setEnabled(False)
            return False
        self.object_id = self.listed.object_id
        self.setWindowTitle(f"Instants of object {self.object_id}")
        self.summary.setText(self.listed.summary())
        self.table.setRowCount(len(self.listed.rows))
        for row, instant in enumerate(self.listed.rows):
            residual = residual_text(instant.residual)
            own = " (the object)" if instant.object_id == self.object_id else ""
            values = (f"{instant.object_id}{own}", instant.where, format_figure(instant.figure),
                      f"{instant.weight:.0%}", residual, "OUTLYING" if instant.outlier else "")
            for column, value in enumerate(values):
                item = QtWidgets.QTableWidgetItem(value)
                if instant.outlier:
                    item.setForeground(QtGui.QColor(230, 60, 60))
                self.table.setItem(row, column, item)
        self.table.resizeColumnsToContents()
        self.remove_button.setEnabled(len(self.listed.rows) > 1)
        if self.listed.rows:
            self.table.setCurrentCell(0, 0)
        return True

    def _on_changed(self, ids) -> None:
        if self.object_id is not None and self.listed is not None:
            mine = {r.object_id for r in self.listed.rows}
            if mine & set(ids) and self.isVisible():
                if self.object_id not in self.workspace.cache:
                    self.close()
                else:
                    self.refresh()

    def _on_reset(self, *_: object) -> None:
        self.object_id, self.listed = None, None
        self.close()

    # ------------------------------------------------------------------ actions
    def go_to(self, row: int) -> None:
        """Show the frame of instant ``row``."""
        if self.listed is not None and 0 <= row < len(self.listed.rows):
            self.frame_requested.emit(self.listed.rows[row].object_id)

    def remove_current(self) -> bool:
        """Unlink the chosen instant from the object (undoable); the object's own first instant cannot be."""
        row = self.table.currentRow()
        ws = self.workspace
        if self.listed is None or not 0 <= row < len(self.listed.rows):
            return False
        instant_id, object_id = self.listed.rows[row].object_id, self.listed.object_id
        if instant_id == object_id:
            ws.message.emit("warning", f"object {object_id} is its own first instant: remove another instant, or "
                                       "delete the object in the object list")
            return False

        def redo() -> None:  # on the instant as this window last read it (see ProjectStore.remove_instant)
            ws.project.remove_instant(instant_id, expected_modified=ws.stored_object(instant_id).modified)
            ws.cache.changed_in_store(updated=(object_id, instant_id))

        def undo() -> None:
            ws.project.add_instant(object_id, instant_id, expected_modified=ws.stored_object(instant_id).modified)
            ws.cache.changed_in_store(updated=(object_id, instant_id))

        try:
            ws.undo.push(Command(f"remove instant {instant_id} from object {object_id}", redo, undo))
        except UsvipsError as error:
            ws.message.emit("error", str(error))
            return False
        ws.message.emit("info", f"object {instant_id} is no longer an instant of object {object_id} (Ctrl+Z undoes "
                                "it)")
        self.refresh()
        return True
