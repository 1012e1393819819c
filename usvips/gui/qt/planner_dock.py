"""The precision planner in the window: the map of a length's expected sigma over the current pair's
common view and range (``usvips/core/planner.py``), computed off the GUI thread with progress and cancel.

The map is drawn with across position (metres, along the baseline from its middle) to the right and range
(metres from the middle of the baseline) upwards, in millimetres; positions the two cameras do not both
see are transparent.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from PySide6 import QtCore, QtWidgets

from usvips.gui.panel_registry import Panel, register
from usvips.gui.qt.worker import Cancelled, Worker, start
from usvips.gui.window_context import WindowContext
from usvips.gui.workspace import Workspace

if TYPE_CHECKING:  # the planner's computation is imported with the first map asked for
    from usvips.core.planner import PrecisionMap


class PlannerDock(QtWidgets.QWidget):
    """Length, orientations, Compute / Cancel, a progress bar, the map and a line of figures.

    ``workers``: the window's set of running workers (so that closing the window cancels this one too)."""

    def __init__(self, workspace: Workspace, pool: QtCore.QThreadPool | None = None,
                 workers: set[Worker] | None = None, parent: QtWidgets.QWidget | None = None) -> None:
        from usvips.gui.qt.plots import pg  # made when its dock is first shown: not on the window's start path

        super().__init__(parent)
        self.workspace = workspace
        self.pool = pool
        self.workers = workers if workers is not None else set()
        self.worker: Worker | None = None
        self.result: PrecisionMap | None = None
        self.length = QtWidgets.QDoubleSpinBox()
        self.length.setRange(0.01, 10.0)
        self.length.setDecimals(3)
        self.length.setSingleStep(0.05)
        self.length.setValue(0.3)
        self.length.setSuffix(" m")
        self.orientations = QtWidgets.QSpinBox()
        self.orientations.setRange(1, 60)
        self.orientations.setValue(8)
        self.compute_button = QtWidgets.QPushButton("Compute")
        self.cancel_button = QtWidgets.QPushButton("Cancel")
        self.cancel_button.setEnabled(False)
        self.progress = QtWidgets.QProgressBar()
        self.progress.setRange(0, 100)
        self.status = QtWidgets.QLabel()
        self.status.setWordWrap(True)
        self.plot = pg.PlotWidget(background=None)
        self.plot.setLabel("bottom", "across", units="m")
        self.plot.setLabel("left", "range", units="m")
        self.plot.setMinimumHeight(180)
        self.image = pg.ImageItem(axisOrder="row-major")
        self.image.setColorMap(pg.colormap.get("viridis"))
        self.plot.addItem(self.image)
        form = QtWidgets.QFormLayout()
        form.addRow("length", self.length)
        form.addRow("orientations", self.orientations)
        buttons = QtWidgets.QHBoxLayout()
        buttons.addWidget(self.compute_button)
        buttons.addWidget(self.cancel_button)
        layout = QtWidgets.QVBoxLayout(self)
        layout.setContentsMargins(2, 2, 2, 2)
        layout.addLayout(form)
        layout.addLayout(buttons)
        layout.addWidget(self.progress)
        layout.addWidget(self.plot, 1)
        layout.addWidget(self.status)
        self.compute_button.clicked.connect(self.compute)
        self.cancel_button.clicked.connect(self.cancel)
        workspace.pair_changed.connect(self._on_pair_changed)
        self._on_pair_changed()

    def cleanup(self) -> None:
        self.cancel()
        self.workspace.pair_changed.disconnect(self._on_pair_changed)

    def _on_pair_changed(self, *_: object) -> None:
        self.cancel()
        self.result = None
        self.image.clear()
        geometry = self.workspace.geometry
        self.compute_button.setEnabled(geometry is not None)
        self.status.setText("the pair has no calibration" if geometry is None and self.workspace.pair else
                            "" if geometry is None else
                            f"pair {self.workspace.pair}: {geometry.description}; Compute maps a length's sigma")

    def compute(self) -> None:
        geometry = self.workspace.geometry
        if geometry is None or self.worker is not None:
            return
        calibration, length, orientations = geometry.calibration, self.length.value(), self.orientations.value()

        def job(progress, cancelled):
            def on_row(done: int, total: int) -> None:
                progress(done / total)
                if cancelled():
                    raise Cancelled

            from usvips.core.planner import default_grid, precision_map  # with the first map asked for

            across, ranges = default_grid(calibration)
            return precision_map(calibration, across, ranges, length, orientations=orientations, on_row=on_row)

        self.worker = Worker(job, "precision planner")
        self.worker.signals.progress.connect(lambda f: self.progress.setValue(int(round(100 * f))))
        self.worker.signals.finished.connect(self._on_finished)
        self.worker.signals.failed.connect(lambda text: self._done(text))
        self.worker.signals.cancelled.connect(lambda: self._done("cancelled"))
        self.workers.add(self.worker)
        self.compute_button.setEnabled(False)
        self.cancel_button.setEnabled(True)
        self.progress.setValue(0)
        self.status.setText(f"computing the sigma of a {length:g} m length over the common view …")
        start(self.worker, self.pool)

    def cancel(self) -> None:
        if self.worker is not None:
            self.worker.cancel()

    def _done(self, text: str) -> None:
        self.workers.discard(self.worker)
        self.worker = None
        self.cancel_button.setEnabled(False)
        self.compute_button.setEnabled(self.workspace.geometry is not None)
        self.status.setText(text)

    def _on_finished(self, plan: PrecisionMap) -> None:
        self.result = plan
        values = np.where(plan.visible, plan.length_rms * 1e3, np.nan)
        finite = values[np.isfinite(values)]
        if finite.size:
            self.image.setImage(values, levels=(float(finite.min()), float(finite.max())))
            dx = plan.across[1] - plan.across[0] if len(plan.across) > 1 else 0.1
            dr = plan.ranges[1] - plan.ranges[0] if len(plan.ranges) > 1 else 0.1
            self.image.setRect(QtCore.QRectF(plan.across[0] - dx / 2, plan.ranges[0] - dr / 2,
                                             dx * len(plan.across), dr * len(plan.ranges)))
            self.plot.autoRange()
        best = [row for row in plan.summary()["ranges"] if row["length_sigma_rms_m"]]
        text = "; ".join(f"{row['range_m']:.1f} m: {row['length_sigma_rms_m'][0] * 1e3:.1f} mm" for row in best[::3])
        self._done(f"{plan.length:g} m length, RMS sigma over orientations (colour: {finite.min():.1f}–"
                   f"{finite.max():.1f} mm) — {text}" if finite.size else "no length fits in the common view")


def _planner(context: WindowContext) -> PlannerDock:
    """The planner, its maps computed by the window's jobs (closing the window cancels them)."""
    jobs = context.jobs
    return PlannerDock(context.workspace, None if jobs is None else jobs.pool, None if jobs is None else jobs.workers)


#: the panel's declaration (usvips.gui.panel_registry): the window builds its dock from it
PANEL = register(Panel("planner", "Precision planner", "right", _planner, group="figures", order=30))
