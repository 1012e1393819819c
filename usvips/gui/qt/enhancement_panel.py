"""The enhancement panel: each image's pipeline of operations (display only) with its histograms."""

from __future__ import annotations

import json

import numpy as np
from PySide6 import QtWidgets

from usvips.core.enhance import OPERATIONS, Operation, Pipeline, balance_pair
from usvips.core.errors import UsvipsError
from usvips.gui.panel_registry import Panel, register
from usvips.gui.pick_tool import SIDES
from usvips.gui.qt.histogram_view import HistogramView
from usvips.gui.workspace import Workspace

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
        self.histogram = HistogramView({"original": ((150, 150, 150), 1.0), "processed": ((255, 140, 0), 1.5)})
        self.histogram.setMinimumHeight(120)
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
        workspace.pair_changed.connect(self._on_pair_changed)
        workspace.enhancement_changed.connect(self._on_enhancement_changed)

    def cleanup(self) -> None:
        self.workspace.pair_changed.disconnect(self._on_pair_changed)
        self.workspace.enhancement_changed.disconnect(self._on_enhancement_changed)

    def _on_pair_changed(self) -> None:
        """Another pair: its steps; no pair (another project): no histograms of the last one either."""
        if not self.workspace.images:
            self.show_histograms(None, None)
        self._refresh_steps()

    def _sides(self) -> tuple[str, ...]:
        target = self.target.currentText()
        return SIDES if target == "both" else (target,)

    def _pipeline(self) -> Pipeline:
        return self.workspace.enhancement.pipelines[self._sides()[0]]

    def _apply(self, pipeline: Pipeline) -> None:
        if not self.workspace.images:
            self.status.setText("open an image pair first")
            return
        self.workspace.enhancement.set_pipelines(dict.fromkeys(self._sides(), pipeline))

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
        pipeline = self.workspace.enhancement.pipelines["right"]
        self.workspace.enhancement.set_pipelines({"right": Pipeline(pipeline.operations + (step,))})

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
        self.histogram.set_counts("original", original)
        self.histogram.set_counts("processed", processed)


#: the panel's declaration (usvips.gui.panel_registry): the window builds its dock from it
PANEL = register(Panel("enhancement", "Enhancement", "right", lambda context: EnhancementPanel(context.workspace),
                     group="enhancement", order=10, size=330,
                     length=400))  # (its steps, parameters, buttons and histogram without a scroll bar)
