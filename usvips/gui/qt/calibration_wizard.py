"""The calibration wizards (phase 1 in air, phase 2 underwater, joint): choose, measure, compute, judge,
save — one ``QWizard`` over a :class:`~usvips.gui.calibration_session.CalibrationSession`.

Pages: what to calibrate (pairs, control, housing with its known values), measuring the control (import,
the project's observations, or clicks in the two images with snapping and the epipolar help), the
computation in a worker thread with the results (parameters, correlations, residuals drawn on the
images, blunders to exclude, check points, comparison), and saving as the active calibration. Going
back never loses what was measured; "Save progress" keeps the wizard in the project to resume later.
"""

from __future__ import annotations

import json
import re

import numpy as np
from PySide6 import QtCore, QtGui, QtWidgets

from usvips.core.calibration.phases import DEFAULT_HOUSING
from usvips.core.calibration.report import CalibrationReport, ResidualRow
from usvips.core.errors import UsvipsError
from usvips.gui.calibration_session import PHASES, CalibrationSession, CheckPoint, ParameterChange
from usvips.gui.housing_values import known_label, read_known
from usvips.gui.pick_tool import OBSERVE, SIDES
from usvips.gui.qt import save_page
from usvips.gui.qt.exchange_dialogs import WizardReport
from usvips.gui.qt.field_errors import FormFields
from usvips.gui.qt.housing_value_form import fill_known_form
from usvips.gui.qt.marks import Lines
from usvips.gui.qt.pane import StereoPane, item_from_pixels
from usvips.gui.qt.worker import Worker, start
from usvips.gui.workspace import Workspace, pair_image_paths, read_pair

FLAG_COLOUR = QtGui.QColor(255, 170, 170)
CHECK_COLOUR = QtGui.QColor(200, 220, 255)
RESIDUAL_SCALE = 50.0


#: σ0 above this many times the a-priori pointing σ is not a calibration to keep without a confirmation:
#: the data or the model are wrong (blunders, the wrong control file or housing, a bad start).
ABSURD_SIGMA0_RATIO = 5.0

#: Unit and one-line meaning of each housing parameter (camera frame: x right, y up, the camera looking
#: along −z), as each housing kind states them (usvips/core/housing/kinds/).
def natural_key(text: str) -> tuple:
    """Sort key that puts target numbers in numeric order (1, 2, 15, 16) and names alphabetically."""
    parts = re.split(r"(\d+)", str(text))
    return tuple((0, int(p), "") if p.isdigit() else (1, 0, p) for p in parts if p)


def _item(text: str, editable: bool = False) -> QtWidgets.QTableWidgetItem:
    item = QtWidgets.QTableWidgetItem(text)
    if not editable:
        item.setFlags(item.flags() & ~QtCore.Qt.ItemFlag.ItemIsEditable)
    return item


def _split(first: QtWidgets.QLayout, second: QtWidgets.QLayout, ratio: tuple[int, int]) -> QtWidgets.QSplitter:
    """Two layouts side by side in a splitter, sized in ``ratio`` at first."""
    splitter = QtWidgets.QSplitter(QtCore.Qt.Orientation.Horizontal)
    for layout in (first, second):
        holder = QtWidgets.QWidget()
        layout.setContentsMargins(2, 2, 2, 2)
        holder.setLayout(layout)
        splitter.addWidget(holder)
    splitter.setStretchFactor(0, ratio[0])
    splitter.setStretchFactor(1, ratio[1])
    splitter.setChildrenCollapsible(False)
    return splitter


def _fill_height(page: QtWidgets.QWizardPage) -> None:
    """Let a page with images take the wizard's whole height (QWizard otherwise leaves the extra height
    to a spacer under the page, and the images stay small on a large screen)."""
    policy = QtWidgets.QSizePolicy(QtWidgets.QSizePolicy.Policy.Expanding, QtWidgets.QSizePolicy.Policy.Expanding)
    policy.setVerticalStretch(1)
    page.setSizePolicy(policy)


def _table(headers: list[str]) -> QtWidgets.QTableWidget:
    table = QtWidgets.QTableWidget(0, len(headers))
    table.setHorizontalHeaderLabels(headers)
    table.verticalHeader().hide()
    table.setSelectionBehavior(QtWidgets.QAbstractItemView.SelectionBehavior.SelectRows)
    table.horizontalHeader().setStretchLastSection(True)
    return table


class SetupPage(QtWidgets.QWizardPage):
    """What to calibrate: the pairs, the control, and for phase 2 the base calibration and the housing."""

    def __init__(self, session: CalibrationSession) -> None:
        super().__init__()
        self.session = session
        self.setTitle(PHASES[session.phase])
        water = session.phase != "air"
        self.setSubTitle("Choose the image pair(s) showing the calibration frame, and the control points' 3-D "
                         "coordinates." + (" Phase 2 starts from a phase-1 (in-air) calibration; give the housing "
                                           "values you know." if water else ""))
        self.pairs = QtWidgets.QListWidget()
        for label in session.candidate_pairs():
            item = QtWidgets.QListWidgetItem(label)
            item.setFlags(item.flags() | QtCore.Qt.ItemFlag.ItemIsUserCheckable)
            item.setCheckState(QtCore.Qt.CheckState.Checked if label in session.pairs
                               else QtCore.Qt.CheckState.Unchecked)
            self.pairs.addItem(item)
        self.pairs.itemChanged.connect(self._on_pair_checked)
        self.control_label = QtWidgets.QLabel()
        load = QtWidgets.QPushButton("Load control file…")
        load.clicked.connect(self._on_load_control)
        self.automatic = QtWidgets.QCheckBox("Handle blunders automatically (robust weights and data snooping, as "
                                             "the command line does)")
        self.automatic.setChecked(session.automatic_blunders)
        self.sigma = QtWidgets.QDoubleSpinBox()
        self.sigma.setRange(0.01, 20.0)
        self.sigma.setDecimals(2)
        self.sigma.setSuffix(" px")
        self.sigma.setValue(session.sigma_px)
        self.sigma.setToolTip("a-priori standard deviation of one measured pixel coordinate")
        form = QtWidgets.QFormLayout()
        form.addRow("Pairs", self.pairs)
        row = QtWidgets.QHBoxLayout()
        row.addWidget(self.control_label, 1)
        row.addWidget(load)
        form.addRow("Control", row)
        form.addRow("Pointing σ", self.sigma)
        form.addRow("", self.automatic)
        # the target path (usvips/gui/qt/target_pages.py): views of a board or target field found automatically
        from_target = QtWidgets.QPushButton("From a &target: a board or field in images or video…")
        from_target.setToolTip("find a calibration target in image pairs or a video and calibrate from all views")
        from_target.clicked.connect(self._on_from_target)
        form.addRow("Or", from_target)
        self.known: dict[str, QtWidgets.QLineEdit] = {}
        self._known_housing = session.housing
        if water:
            self.base = QtWidgets.QComboBox()
            for calibration in session.base_calibrations():
                self.base.addItem(f"{calibration.id}: {calibration.name} (σ0 "
                                  f"{calibration.sigma0_px or float('nan'):.3f} px)", calibration.id)
            if session.base_id is not None:
                self.base.setCurrentIndex(max(self.base.findData(session.base_id), 0))
            self.housing = QtWidgets.QComboBox()
            self.housing.addItems(list(DEFAULT_HOUSING))
            self.housing.setCurrentText(session.housing)
            self.housing.currentTextChanged.connect(self._fill_known)
            self.housing_source = QtWidgets.QLabel(session.housing_source())
            housing_row = QtWidgets.QHBoxLayout()
            housing_row.addWidget(self.housing)
            housing_row.addWidget(self.housing_source, 1)
            form.addRow("Phase-1 calibration", self.base)
            form.addRow("Housing", housing_row)
            self.known_box = QtWidgets.QGroupBox("Known housing values: a value holds it fixed, 'value ± sigma' "
                                                 "weights it; blank keeps the default shown")
            self.known_form = QtWidgets.QFormLayout(self.known_box)
            form.addRow(self.known_box)
            self._fill_known(session.housing)
        self.message = QtWidgets.QLabel()
        self.message.setStyleSheet("color: #c0392b;")
        form.addRow(self.message)
        #: the page's fields by the parameter an error names: each housing value by its symbol
        self.field_errors = FormFields(lambda: {name: (edit, known_label(self._known_housing, name))
                                                for name, edit in self.known.items()}, self.message.setText)
        self.setLayout(form)
        self._refresh_control()

    def _on_from_target(self) -> None:
        from usvips.gui.qt.target_pages import open_target_wizard

        wizard = self.wizard()
        target = open_target_wizard(self.session.project, self.session.phase, wizard)
        target.saved.connect(wizard.saved)
        # Finish there stored the calibration: this wizard closes too (it stayed open behind it), unless
        # it holds measured work of its own
        target.accepted.connect(lambda: QtCore.QTimer.singleShot(0, lambda: self._close_after_target(wizard)))

    @staticmethod
    def _close_after_target(wizard: QtWidgets.QWizard) -> None:
        if not wizard.has_unsaved_work():
            wizard.done(QtWidgets.QDialog.DialogCode.Accepted)

    def _fill_known(self, housing: str) -> None:
        known = self.session.known if housing == self.session.housing else {}
        self.known = fill_known_form(self.known_form, housing, known)
        self._known_housing = housing

    def _refresh_control(self) -> None:
        control = self.session.control
        self.control_label.setText("none: load a control file" if control is None else
                                   f"{len(control.ids)} points from {self.session.control_source}")

    def _on_load_control(self) -> None:
        path, _ = QtWidgets.QFileDialog.getOpenFileName(self, "Control points", "", "CSV (*.csv *.txt)")
        if path:
            try:
                self.session.load_control(path)
            except UsvipsError as error:
                self.message.setText(str(error))
            self._refresh_control()
            self.completeChanged.emit()

    def _on_pair_checked(self, item: QtWidgets.QListWidgetItem) -> None:
        if self.session.phase == "water" and item.checkState() == QtCore.Qt.CheckState.Checked:
            self.pairs.blockSignals(True)
            for i in range(self.pairs.count()):  # phase 2 on one pair: the others are unchecked
                if self.pairs.item(i) is not item:
                    self.pairs.item(i).setCheckState(QtCore.Qt.CheckState.Unchecked)
            self.pairs.blockSignals(False)
        self.completeChanged.emit()

    def checked_pairs(self) -> list[str]:
        return [self.pairs.item(i).text() for i in range(self.pairs.count())
                if self.pairs.item(i).checkState() == QtCore.Qt.CheckState.Checked]

    def set_checked_pairs(self, labels: list[str]) -> None:
        for i in range(self.pairs.count()):
            item = self.pairs.item(i)
            item.setCheckState(QtCore.Qt.CheckState.Checked if item.text() in labels
                               else QtCore.Qt.CheckState.Unchecked)

    def isComplete(self) -> bool:  # noqa: N802 (Qt's name)
        return bool(self.checked_pairs()) and self.session.control is not None

    def validatePage(self) -> bool:  # noqa: N802 (Qt's name)
        session = self.session
        try:
            session.set_pairs(self.checked_pairs())
            session.sigma_px = self.sigma.value()
            session.automatic_blunders = self.automatic.isChecked()
            if session.phase != "air":
                if self.base.currentData() is None:
                    raise UsvipsError("the project has no phase-1 (in-air) calibration: run phase 1 first")
                session.base_id = int(self.base.currentData())
                if self.housing.currentText() != session.housing:
                    session.known = {}
                session.housing = self.housing.currentText()
                typed = read_known(session.housing, {name: edit.text() for name, edit in self.known.items()})
                for name in self.known:
                    if name in typed:
                        session.set_known(name, *typed[name])
                    else:
                        session.known.pop(name, None)
        except UsvipsError as error:
            self.field_errors.show(error)  # a housing value at fault: its field outlined and named
            return False
        self.field_errors.clear()
        self.message.setText("")
        return True


class MeasurePage(QtWidgets.QWizardPage):
    """Measure the control: import, take the project's observations, or point at targets in both images."""

    COLUMNS = ["pair", "id", "X", "Y", "Z", "xl", "yl", "xr", "yr", "check"]

    def __init__(self, session: CalibrationSession, pool: QtCore.QThreadPool) -> None:
        super().__init__()
        self.session = session
        self.pool = pool
        self.setTitle("Measure the control points")
        self.setSubTitle("Import observations or take the project's, or measure: type the target's number, click "
                         "its centre in the left image, then in the right (snapping finds the centre; after a first "
                         "calibration the epipolar curve helps). Tick 'check' to hold a point out as a check point.")
        self.table = _table(self.COLUMNS)
        self.table.itemChanged.connect(self._on_item_changed)
        project_button = QtWidgets.QPushButton("Take the project's observations")
        project_button.clicked.connect(self._on_project)
        import_button = QtWidgets.QPushButton("Import CSV…")
        import_button.clicked.connect(self._on_import)
        remove_button = QtWidgets.QPushButton("Remove selected")
        remove_button.clicked.connect(self._on_remove)
        self.spread = QtWidgets.QLabel()
        self.spread.setWordWrap(True)
        self.message = QtWidgets.QLabel()
        self.message.setWordWrap(True)
        buttons = QtWidgets.QHBoxLayout()
        for button in (project_button, import_button, remove_button):
            buttons.addWidget(button)
        buttons.addStretch(1)
        left = QtWidgets.QVBoxLayout()
        left.addLayout(buttons)
        left.addWidget(self.table, 1)
        left.addWidget(self.spread)
        # the measuring area: a pair chooser, the target number, both images
        self.pair = QtWidgets.QComboBox()
        self.pair.currentTextChanged.connect(self._load_images)
        self.target = QtWidgets.QComboBox()
        self.target.setEditable(True)
        self.target.setToolTip("the number printed on the target you are about to click")
        self.snap = QtWidgets.QCheckBox("Snap to target centres")
        self.snap.setChecked(True)
        top = QtWidgets.QHBoxLayout()
        for widget in (QtWidgets.QLabel("Pair"), self.pair, QtWidgets.QLabel("Target"), self.target, self.snap):
            top.addWidget(widget)
        top.addStretch(1)
        self.panes = {side: StereoPane(side) for side in SIDES}
        images = QtWidgets.QSplitter(QtCore.Qt.Orientation.Horizontal)
        for side in SIDES:
            images.addWidget(self.panes[side])
            self.panes[side].setMinimumSize(240, 200)
            self.panes[side].clicked.connect(lambda x, y, s=side: self._on_clicked(s, x, y))
        right = QtWidgets.QVBoxLayout()
        right.addLayout(top)
        right.addWidget(images, 1)
        right.addWidget(self.message)
        # the table and the images share the page in a splitter the user can move (images get most of it)
        self.splitter = _split(left, right, (1, 2))
        _fill_height(self)
        layout = QtWidgets.QHBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.addWidget(self.splitter)
        self.workspace = Workspace(project=session.project)
        self.workspace.pick_tool.set_tool(OBSERVE)
        self.workspace.observed.connect(self._on_observed)
        self.workspace.picks_changed.connect(self._on_picks_changed)
        self.workspace.message.connect(lambda level, text: self.message.setText(text))
        self._filling = False
        session.data_changed.connect(self._on_data)  # the table follows the session, whoever changed it
        self.table.itemSelectionChanged.connect(self._on_row_selected)

    #: the session's data the table and the spread show
    SHOWN = frozenset({"pairs", "control", "observations", "check", "exclusions"})

    def _on_data(self, what: str, _keys: tuple) -> None:
        if what in self.SHOWN:
            self.refresh()

    def initializePage(self) -> None:  # noqa: N802 (Qt's name)
        session = self.session
        width = max(self.wizard().width() if self.wizard() is not None else 0, 600)
        self.splitter.setSizes([width // 3, width - width // 3])  # the images get two thirds
        if not session.observations:
            session.load_project_observations()
        self.pair.blockSignals(True)
        self.pair.clear()
        self.pair.addItems(session.pairs)
        self.pair.blockSignals(False)
        self.target.clear()
        if session.control is not None:
            self.target.addItems(list(session.control.ids))
        self.refresh()
        self._load_images(self.pair.currentText())

    def _load_images(self, label: str) -> None:
        if not label:
            return
        try:
            paths = pair_image_paths(self.session.project, label)
        except UsvipsError as error:
            self.message.setText(f"{error}: import the observations instead")
            return
        worker = Worker(lambda progress, cancelled: (label, read_pair(paths)), f"reading pair {label}")
        # bound methods of this page: Qt drops the connection if the page goes before the worker reports
        worker.signals.finished.connect(self._show_images)
        worker.signals.failed.connect(self.message.setText)
        start(worker, self.pool)

    def _show_images(self, read) -> None:
        label, images = read
        if label != self.pair.currentText():
            return
        self.workspace.set_pair(label, *images)
        self.workspace.pick_tool.set_tool(OBSERVE)
        if self.session.image_size == (None, None):
            self.session.image_size = (images[0].shape[1], images[0].shape[0])
        for side, image in zip(SIDES, images, strict=True):
            self.panes[side].set_image(image)
        self.draw_targets()
        self.message.setText(f"pair {label}: type a target number, then click it left and right")

    def selected_target(self) -> tuple[str, str] | None:
        """(pair, target) of the table row selected, or None."""
        rows = sorted({index.row() for index in self.table.selectedIndexes()})
        if not rows or self.table.item(rows[0], 1) is None:
            return None
        return self.table.item(rows[0], 0).text(), self.table.item(rows[0], 1).text()

    def draw_targets(self) -> None:
        """The shown pair's measured targets, each labelled with its number on both images; the one whose
        row is selected in the table highlighted."""
        pair = self.pair.currentText()
        chosen = self.selected_target()
        selected = chosen[1] if chosen is not None and chosen[0] == pair else None
        measured = [(pid, values) for (p, pid), values in self.session.observations.items() if p == pair]
        self.panes["left"].set_control([(pid, (v[0], v[1])) for pid, v in measured], selected)
        self.panes["right"].set_control([(pid, (v[2], v[3])) for pid, v in measured], selected)

    def _on_row_selected(self) -> None:
        """A row chosen in the table: its pair shown (loaded when another), its target highlighted and
        centred in both images."""
        chosen = self.selected_target()
        if chosen is None or self._filling:
            self.draw_targets()
            return
        pair, pid = chosen
        if pair != self.pair.currentText() and self.pair.findText(pair) >= 0:
            self.pair.setCurrentText(pair)  # loads its images; they are drawn with the highlight
            return
        self.draw_targets()
        values = self.session.observations.get((pair, pid))
        if values is not None and self.workspace.images:
            self.panes["left"].centre_on((values[0], values[1]))
            self.panes["right"].centre_on((values[2], values[3]))

    def _on_clicked(self, side: str, x: float, y: float) -> None:
        self.workspace.settings.snap = self.snap.isChecked()
        try:
            self.workspace.pick_tool.pick(side, (x, y))
        except UsvipsError as error:
            self.message.setText(str(error))

    def _on_picks_changed(self) -> None:
        state = self.workspace.pick_tool.state
        for side in SIDES:
            opposite = state.source is not None and state.source != side
            self.panes[side].set_picks(state.pick(side), state.proposal if opposite else None,
                                       state.curve if opposite else None, weak=state.weak)
        if state.note:
            self.message.setText(state.note)

    def _on_observed(self, left, right) -> None:
        point = self.target.currentText().strip()
        try:
            self.session.set_observation(self.pair.currentText(), point, left, right)
        except UsvipsError as error:
            self.message.setText(str(error))
            return
        self.message.setText(f"target {point} measured in pair {self.pair.currentText()}")
        index = self.target.findText(point)
        if 0 <= index < self.target.count() - 1:
            self.target.setCurrentIndex(index + 1)  # the next target, as the operator works through them

    def keyPressEvent(self, event: QtGui.QKeyEvent) -> None:  # noqa: N802 (Qt's name)
        """Enter on this page accepts the proposed match and never advances the wizard (Next does)."""
        if event.key() in (QtCore.Qt.Key.Key_Return, QtCore.Qt.Key.Key_Enter):
            event.accept()
            self.accept_pick()
            return
        super().keyPressEvent(event)

    def accept_pick(self) -> None:
        """Take the proposed match as the second pick of the target; without one, say what to do."""
        state = self.workspace.pick_tool.state
        if state.proposal is not None:
            try:
                self.workspace.pick_tool.accept_proposal()
            except UsvipsError as error:
                self.message.setText(str(error))
        elif state.source is not None:
            opposite = "right" if state.source == "left" else "left"
            self.message.setText(f"no proposed match to accept: click the target in the {opposite} image")
        else:
            self.message.setText("Enter accepts a proposed match: click a target first. Next (below) goes on "
                                 "to the computation.")

    def _on_project(self) -> None:
        count = self.session.load_project_observations()
        self.message.setText(f"{count} observations taken from the project")

    def _on_import(self) -> None:
        path, _ = QtWidgets.QFileDialog.getOpenFileName(self, "Observations", "", "CSV (*.csv *.txt)")
        if path:
            self.import_file(path)

    def import_file(self, path: str) -> None:
        try:
            count = self.session.import_observations(path, self.pair.currentText() or None)
        except UsvipsError as error:
            self.message.setText(str(error))
            return
        self.message.setText(f"{count} observations imported from {path}")

    def _on_remove(self) -> None:
        rows = sorted({index.row() for index in self.table.selectedIndexes()})
        keys = [(self.table.item(row, 0).text(), self.table.item(row, 1).text()) for row in rows]
        for pair, point in keys:
            self.session.remove_observation(pair, point)

    def _on_item_changed(self, item: QtWidgets.QTableWidgetItem) -> None:
        if self._filling or item.column() != self.COLUMNS.index("check"):
            return
        pair, point = self.table.item(item.row(), 0).text(), self.table.item(item.row(), 1).text()
        self.session.set_check(pair, point, item.checkState() == QtCore.Qt.CheckState.Checked)

    def refresh(self) -> None:
        session = self.session
        self._filling = True
        self.table.setRowCount(0)
        index = {pid: i for i, pid in enumerate(session.control.ids)} if session.control is not None else {}
        for (pair, pid), values in sorted(session.observations.items(),
                                          key=lambda item: (natural_key(item[0][0]), natural_key(item[0][1]))):
            if pair not in session.pairs:
                continue
            row = self.table.rowCount()
            self.table.insertRow(row)
            xyz = session.control.xyz[index[pid]] if pid in index else (np.nan,) * 3
            cells = [pair, pid, *(f"{v:.4f}" for v in xyz), *(f"{v:.2f}" for v in values)]
            for column, text in enumerate(cells):
                self.table.setItem(row, column, _item(text))
            check = _item("")
            check.setFlags(check.flags() | QtCore.Qt.ItemFlag.ItemIsUserCheckable)
            check.setCheckState(QtCore.Qt.CheckState.Checked if (pair, pid) in session.check
                                else QtCore.Qt.CheckState.Unchecked)
            self.table.setItem(row, len(cells), check)
            if (pair, pid) in session.excluded:
                for column in range(self.table.columnCount()):
                    self.table.item(row, column).setBackground(FLAG_COLOUR)
                    self.table.item(row, column).setToolTip("excluded as a blunder")
        self.table.resizeColumnsToContents()
        self._filling = False
        lines = []
        for pair in session.pairs:
            spread = session.spread(pair)
            mark = "✓" if spread.ok else "✗"
            left = [pid for pid in (session.control.ids if session.control is not None else ())
                    if pid not in session.measured(pair)]
            more = f"; not measured: {', '.join(left[:12])}{' …' if len(left) > 12 else ''}" if left else ""
            lines.append(f"{mark} {pair}: {spread.message}{more}")
        ok, reason = session.readiness()
        if not ok and not any(pair in reason for pair in session.pairs):
            lines.append(f"✗ {reason}")
        self.spread.setText("\n".join(lines))
        self.draw_targets()
        self.completeChanged.emit()

    def isComplete(self) -> bool:  # noqa: N802 (Qt's name)
        return self.session.readiness()[0]


class ResultsPage(QtWidgets.QWizardPage):
    """Compute (worker thread, progress, cancel) and judge the result."""

    def __init__(self, session: CalibrationSession, pool: QtCore.QThreadPool) -> None:
        super().__init__()
        self.session = session
        self.pool = pool
        self.worker: Worker | None = None
        self.setTitle("Compute and judge the calibration")
        self.setSubTitle("DLT start, then the least-squares adjustment. Rows in red are likely blunders "
                         f"(w-test above 3.29); exclude the worst with one click and compute again. Residual vectors "
                         f"are drawn ×{RESIDUAL_SCALE:g} on the first pair's images.")
        self.progress = QtWidgets.QProgressBar()
        self.progress.setRange(0, 0)
        self.progress.hide()
        self.compute_button = QtWidgets.QPushButton("Compute")
        self.compute_button.clicked.connect(self.compute)
        self.cancel_button = QtWidgets.QPushButton("Cancel computation")
        self.cancel_button.clicked.connect(self.cancel)
        self.cancel_button.hide()
        self.exclude_button = QtWidgets.QPushButton("Exclude the worst and compute again")
        self.exclude_button.setToolTip("leave out the observation with the largest w-test (one at a time, as "
                                       "data snooping does) and adjust again")
        self.exclude_button.clicked.connect(self.exclude_and_rerun)
        self.exclude_button.setEnabled(False)
        self.summary = QtWidgets.QLabel("Not computed yet.")
        self.summary.setWordWrap(True)
        self.summary.setTextInteractionFlags(QtCore.Qt.TextInteractionFlag.TextSelectableByMouse)
        self.parameters = _table(["parameter", "value", "sigma", "status"])
        self.residuals = _table(["pair", "id", "side", "vx px", "vy px", "w x", "w y", "used"])
        self.checks = _table(["pair", "id", "dX mm", "dY mm", "dZ mm"])
        self.comparison = _table(["parameter", "before", "now", "change / sigma"])
        tabs = QtWidgets.QTabWidget()
        tabs.addTab(self.parameters, "Parameters")
        tabs.addTab(self.residuals, "Residuals")
        tabs.addTab(self.checks, "Check points")
        tabs.addTab(self.comparison, "Comparison")
        self.tabs = tabs
        self.panes = {side: StereoPane(side) for side in SIDES}
        self.vectors = {}
        images = QtWidgets.QSplitter(QtCore.Qt.Orientation.Horizontal)
        for side in SIDES:
            self.panes[side].setMinimumSize(220, 180)
            self.panes[side].set_loupe_enabled(False)
            images.addWidget(self.panes[side])
            self.vectors[side] = Lines((255, 60, 60), width=2, connect="pairs")
            self.panes[side].add_mark(self.vectors[side])
        self.legend = QtWidgets.QLabel(f"red: residual vectors ×{RESIDUAL_SCALE:g} (a 0.5 px residual is drawn "
                                       f"{0.5 * RESIDUAL_SCALE:g} image pixels long)")
        buttons = QtWidgets.QHBoxLayout()
        for widget in (self.compute_button, self.cancel_button, self.progress, self.exclude_button):
            buttons.addWidget(widget)
        buttons.addStretch(1)
        left = QtWidgets.QVBoxLayout()
        left.addLayout(buttons)
        left.addWidget(self.summary)
        left.addWidget(tabs, 1)
        self.accept_anyway = QtWidgets.QCheckBox("Keep this calibration anyway (σ0 is implausible)")
        self.accept_anyway.hide()
        self.accept_anyway.toggled.connect(lambda _: self.completeChanged.emit())
        left.addWidget(self.accept_anyway)
        right = QtWidgets.QVBoxLayout()
        right.addWidget(images, 1)
        right.addWidget(self.legend)
        self.splitter = _split(left, right, (3, 2))
        _fill_height(self)
        layout = QtWidgets.QHBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.addWidget(self.splitter)
        session.result_changed.connect(self._on_result)

    def _on_result(self) -> None:
        """The session's result was set (show it) or dropped because its data changed (say so)."""
        if self.session.result is not None:
            self.show_result()
        elif self.worker is None:
            self.summary.setText("The observations changed since the last computation: compute again.")
            self.completeChanged.emit()

    def initializePage(self) -> None:  # noqa: N802 (Qt's name)
        measure = self.wizard().measure_page
        for side in SIDES:
            self.panes[side].set_image(measure.panes[side].display)
        if self.session.result is None:
            self.compute()
        else:
            self.show_result()

    @property
    def busy(self) -> bool:
        return self.worker is not None

    def compute(self) -> None:
        if self.worker is not None:
            return
        try:
            job = self.session.job()
        except UsvipsError as error:
            self.summary.setText(f"Cannot compute: {error}")
            return
        self.worker = worker = Worker(job, "calibration")
        worker.signals.finished.connect(self._on_finished)
        worker.signals.failed.connect(self._on_failed)
        worker.signals.cancelled.connect(self._on_cancelled)
        self.progress.show()
        self.cancel_button.show()
        self.compute_button.setEnabled(False)
        self.summary.setText("Computing: DLT start, then the adjustment …")
        start(worker, self.pool)

    def cancel(self) -> None:
        """Stop waiting for the computation: its result, when it comes, is dropped."""
        if self.worker is not None:
            self.worker.cancel()
            self._done()
            self.summary.setText("Cancelled: nothing was computed. Compute again, or go back.")

    def _done(self) -> None:
        self.worker = None
        self.progress.hide()
        self.cancel_button.hide()
        self.compute_button.setEnabled(True)

    def _on_finished(self, result) -> None:
        if self.sender() is not None and self.worker is None:
            return
        self._done()
        self.session.set_result(result)  # shown by the session's result event

    def _on_failed(self, message: str) -> None:
        self._done()
        self.summary.setText(f"The computation failed: {message}")
        self.completeChanged.emit()

    def _on_cancelled(self) -> None:
        self._done()

    def exclude_and_rerun(self) -> None:
        if self.session.exclude_flagged():  # the measure page follows by the session's data event
            self.compute()

    def show_result(self) -> None:
        session = self.session
        result = session.result
        report = result.report
        adjustment = result.adjustment
        flagged = session.flagged()
        words = [f"<b>{'Converged' if adjustment.converged else 'Did not converge: ' + adjustment.reason}</b>",
                 f"σ0 = {result.calibration.sigma0_px:.3f} px, RMS = {adjustment.rms:.3f}, redundancy "
                 f"{adjustment.redundancy}, condition number {adjustment.condition_number:.3g}, "
                 f"{adjustment.iterations} iterations."]
        if report.correlations:
            pairs = ", ".join(f"{c.a}–{c.b} ({c.r:.3f})" for c in report.correlations[:6])
            words.append(f"<span style='color:#b9770e'>Correlations above 0.95: {pairs}"
                         f"{' …' if len(report.correlations) > 6 else ''} — their separate values are "
                         "not determined by these data.</span>")
        words.append(self.verdict())
        if flagged:
            words.append(f"<span style='color:#c0392b'>{len(flagged)} observation(s) look like blunders (red in "
                         "Residuals).</span>")
        left_out = session.left_out()
        if left_out or session.excluded:
            words.append(f"Left out: {len(session.excluded)} by you, {len(left_out)} by the adjustment's robust "
                         "weights (not counted as blunders above).")
        rows, rms = session.check_points()
        if rms is not None:
            words.append(f"Check points: {len(rows)}, RMS of the 3-D differences {rms * 1000:.1f} mm.")
        self.summary.setText("<br>".join(words))
        self.accept_anyway.setChecked(False)
        self.accept_anyway.setVisible(self.implausible())
        self.exclude_button.setEnabled(bool(flagged))
        self._fill_parameters(report)
        self._fill_residuals(report, flagged)
        self._fill_checks(rows)
        self._fill_comparison(session.comparison())
        self._draw_vectors(report)
        self.completeChanged.emit()

    def _fill_parameters(self, report: CalibrationReport) -> None:
        self.parameters.setRowCount(0)
        order = sorted(report.parameters.items(), key=lambda item: item[1].status == "fixed")
        for name, p in order:  # estimated parameters first, the fixed ones after
            if "@" in name and p.status == "fixed":
                continue
            row = self.parameters.rowCount()
            self.parameters.insertRow(row)
            sigma = "" if p.sigma is None else f"{p.sigma:.3g}"
            for column, text in enumerate([name, f"{p.value:.6g}", sigma, p.status]):
                self.parameters.setItem(row, column, _item(text))
        self.parameters.resizeColumnsToContents()

    def _fill_residuals(self, report: CalibrationReport, flagged: list[ResidualRow]) -> None:
        self.residuals.setRowCount(0)
        bad = {(r.station, r.id, r.side) for r in flagged}
        for r in sorted(report.residuals, key=lambda r: -max(abs(r.wx), abs(r.wy))):
            row = self.residuals.rowCount()
            self.residuals.insertRow(row)
            # a set-aside observation's residual is its prediction residual (None where no ray reaches it)
            cells = [r.station, r.id, r.side, *("—" if v is None else f"{v:.3f}" for v in (r.vx, r.vy)),
                     f"{r.wx:.2f}", f"{r.wy:.2f}", "yes" if r.used else "no"]
            for column, text in enumerate(cells):
                item = _item(text)
                if (r.station, r.id, r.side) in bad:
                    item.setBackground(FLAG_COLOUR)
                self.residuals.setItem(row, column, item)
        self.residuals.resizeColumnsToContents()

    def _fill_checks(self, rows: list[CheckPoint]) -> None:
        self.checks.setRowCount(0)
        for r in rows:
            row = self.checks.rowCount()
            self.checks.insertRow(row)
            for column, text in enumerate([r.pair, r.id, *(f"{d * 1000:.1f}" for d in r.difference)]):
                self.checks.setItem(row, column, _item(text))

    def _fill_comparison(self, rows: list[ParameterChange]) -> None:
        self.comparison.setRowCount(0)
        for r in rows[:40]:
            row = self.comparison.rowCount()
            self.comparison.insertRow(row)
            change = "" if r.change_sigmas is None else f"{r.change_sigmas:.2f}"
            for column, text in enumerate([r.name, f"{r.old:.6g}", f"{r.new:.6g}", change]):
                self.comparison.setItem(row, column, _item(text))

    def _draw_vectors(self, report: CalibrationReport) -> None:
        first = self.session.pairs[0] if self.session.pairs else None
        for side, letter in (("left", "l"), ("right", "r")):
            segments = []
            for r in report.residuals:
                key = (r.station, r.id)
                if (r.station != first or r.side != letter or key not in self.session.observations
                        or r.vx is None or r.vy is None):
                    continue
                values = self.session.observations[key]
                start = np.array(values[:2] if side == "left" else values[2:])
                segments += [start, start + RESIDUAL_SCALE * np.array([r.vx, r.vy])]
            data = item_from_pixels(np.array(segments)) if segments else np.zeros((0, 2))
            self.vectors[side].set_points(data)

    def sigma0_ratio(self) -> float | None:
        """σ0 in units of the a-priori pointing σ (1: residuals as large as assumed), None before a result."""
        result = self.session.result
        return None if result is None else float(result.calibration.sigma0_px / self.session.sigma_px)

    def implausible(self) -> bool:
        """σ0 over :data:`ABSURD_SIGMA0_RATIO` times the pointing σ: Next needs a confirmation."""
        ratio = self.sigma0_ratio()
        return ratio is not None and ratio > ABSURD_SIGMA0_RATIO

    def verdict(self) -> str:
        """The global (χ², 95 %) test of the adjustment in one line, with what to do when it fails."""
        test = self.session.result.report.global_test
        ratio = self.sigma0_ratio()
        scale = f"σ0 is {ratio:.2f} × the a-priori pointing σ of {self.session.sigma_px:g} px (1 expected)"
        if self.implausible():
            return (f"<span style='color:#c0392b'><b>Global test failed badly:</b> {scale}. The measurements or the "
                    "model are wrong (blunders, wrong control file, wrong housing kind or start): fix them and "
                    "compute again; Next needs 'Keep this calibration anyway'.</span>")
        if test.get("accepted_95", True):
            return f"<b>Global test passed</b> (χ², 95 %): {scale}."
        hint = ("the pointing is better than assumed: lower the pointing σ" if ratio < 1 else
                "residuals larger than assumed: look for blunders, or raise the pointing σ if it was optimistic")
        return f"<span style='color:#b9770e'><b>Global test rejected</b> (χ², 95 %): {scale}; {hint}.</span>"

    def isComplete(self) -> bool:  # noqa: N802 (Qt's name)
        result = self.session.result
        return (result is not None and bool(result.adjustment.converged) and self.worker is None
                and (not self.implausible() or self.accept_anyway.isChecked()))


class SavePage(save_page.SavePage):
    """Name the calibration and choose the pairs it becomes active for; Finish stores it
    (:class:`usvips.gui.qt.save_page.SavePage`, with the classic session's report)."""

    def __init__(self, session: CalibrationSession) -> None:
        super().__init__(session, lambda page: WizardReport(page, session),
                         "It is stored in the project with the observations it used, and becomes the active "
                         "calibration of the pairs ticked below. Cancel discards it; the project stays as it was.")


class CalibrationWizard(QtWidgets.QWizard):
    """``saved(calibration_id)`` fires when Finish stored a calibration."""

    saved = QtCore.Signal(int)

    def __init__(self, session: CalibrationSession, parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(parent)
        self.session = session
        # the global pool, not one owned by the wizard: closing must not wait for a running adjustment
        # (its result is dropped; the pages' connections go with them)
        self.pool = QtCore.QThreadPool.globalInstance()
        self.setWindowTitle(f"USVIPS — {PHASES[session.phase]}")
        self.setWizardStyle(QtWidgets.QWizard.WizardStyle.ClassicStyle)
        self.setOption(QtWidgets.QWizard.WizardOption.HaveCustomButton1, True)
        self.setButtonText(QtWidgets.QWizard.WizardButton.CustomButton1, "Save progress")
        self.customButtonClicked.connect(self._on_custom)
        self.setup_page = SetupPage(session)
        self.measure_page = MeasurePage(session, self.pool)
        self.results_page = ResultsPage(session, self.pool)
        self.save_page = SavePage(session)
        for page in (self.setup_page, self.measure_page, self.results_page, self.save_page):
            self.addPage(page)
        self._baseline: str | None = None
        self.currentIdChanged.connect(self._on_page_changed)
        self._listening = ((session.step_changed, self._on_step), (session.data_changed, self.measure_page._on_data),
                           (session.result_changed, self.results_page._on_result))
        session.step_changed.connect(self._on_step)
        screen = self.screen().availableGeometry() if self.screen() is not None else None
        if screen is not None:  # most of the screen: the measure page needs room for two images
            self.resize(min(1500, int(screen.width() * 0.95)), min(950, int(screen.height() * 0.92)))
        else:
            self.resize(1200, 760)

    def _on_custom(self, which: int) -> None:
        if self.currentPage() is self.setup_page:
            self.setup_page.validatePage()
        self.session.save_draft()
        box = QtWidgets.QMessageBox(QtWidgets.QMessageBox.Icon.Information, "Progress saved",
                                    "The wizard's state is kept in the project: choose the same calibration again "
                                    "later to resume it.", QtWidgets.QMessageBox.StandardButton.Ok, self)
        box.setModal(False)
        box.show()
        self._saved_box = box

    def measured_state(self) -> str:
        """What the user measured and decided in this wizard (observations, check points, exclusions)."""
        data = json.loads(self.session.to_json())
        return json.dumps([data["observations"], data["check"], data["excluded"]], sort_keys=True)

    def has_unsaved_work(self) -> bool:
        """Measured work or a computed result that Cancel would discard."""
        if self._baseline is None:
            return False
        return self.session.result is not None or self.measured_state() != self._baseline

    #: the wizard's steps (the session's ``step``), page by page, and how the title names them
    STEPS = {"setup": "set-up", "measure": "measure the targets", "results": "compute and judge", "save": "save"}

    def _on_page_changed(self, _id: int) -> None:
        if self._baseline is None and self.currentPage() is self.measure_page:
            self._baseline = self.measured_state()  # what the project already had when measuring began
        pages = (self.setup_page, self.measure_page, self.results_page, self.save_page)
        if self.currentPage() in pages:
            self.session.set_step(list(self.STEPS)[pages.index(self.currentPage())])

    def _on_step(self, step: str) -> None:
        """The session is at another step: the title says which."""
        self.setWindowTitle(f"USVIPS — {PHASES[self.session.phase]} — {self.STEPS.get(step, step)}")

    def ask_discard(self) -> str:
        """Ask what to do with unsaved work: ``"save"`` (keep a draft), ``"discard"`` or ``"stay"``."""
        buttons = QtWidgets.QMessageBox.StandardButton
        box = QtWidgets.QMessageBox(QtWidgets.QMessageBox.Icon.Question, "Discard the calibration?",
                                    "What you measured or computed in this wizard is not saved. Keep it as a draft "
                                    "in the project (resume it later), discard it, or go back to the wizard?",
                                    buttons.Save | buttons.Discard | buttons.Cancel, self)
        box.setDefaultButton(buttons.Cancel)
        answer = box.exec()
        return {buttons.Save: "save", buttons.Discard: "discard"}.get(answer, "stay")

    def reject(self) -> None:
        """Cancel, Esc and the window's close button: ask before discarding measured work."""
        if self.has_unsaved_work():
            answer = self.ask_discard()
            if answer == "stay":
                return
            if answer == "save":
                self.session.save_draft()
        super().reject()

    def done(self, result: int) -> None:
        self.results_page.cancel()
        for signal, slot in self._listening:  # the session may outlive this wizard
            signal.disconnect(slot)
        super().done(result)
