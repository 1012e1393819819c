"""The target path of the calibration wizards: calibrate phase 1, phase 2 or joint from views of a
calibration target (a board or a 3-D target field) found automatically, in image pairs or in a stereo video
of the project — one ``QWizard`` over a Qt-free :class:`~usvips.gui.target_session.TargetSession`.

Pages: the target and the source of views (and for phase 2 the phase-1 calibration and the housing); the
views — detection in a worker with progress and a Stop that stops it, the coverage maps per camera and the
advice, each view's detections drawn on its images, a tick per view; the computation in a worker with the
fit and the validation and a verdict; saving as the project's calibration. Nothing is stored before
Finish. Keyboard: every control has a mnemonic (Alt + the underlined letter), Space ticks a view, Enter
goes on.
"""

from __future__ import annotations

import datetime

import pyqtgraph as pg
from PySide6 import QtCore, QtWidgets

from usvips.core.calibration.phases import DEFAULT_HOUSING
from usvips.core.errors import UsvipsError
from usvips.gui import active_pairs
from usvips.gui.pane import StereoPane
from usvips.gui.target_session import TargetSession
from usvips.gui.worker import Cancelled, Worker, start

TITLES = {"air": "Phase 1 in air from target views", "water": "Phase 2 underwater from target views",
          "joint": "Joint underwater calibration from target views"}
ERROR_STYLE = "color: #c0392b;"


def _job(job):
    """A session job as a :class:`Worker` job: an :class:`InterruptedError` becomes :class:`Cancelled`."""

    def run(progress, cancelled):
        try:
            return job(progress, cancelled)
        except InterruptedError as error:
            raise Cancelled(str(error)) from None
    return run


class SourcePage(QtWidgets.QWizardPage):
    """The target, where the views come from, and for phase 2 the base calibration and the housing."""

    def __init__(self, session: TargetSession) -> None:
        super().__init__()
        self.session = session
        self.setTitle(TITLES[session.phase])
        self.setSubTitle("Choose the target you filmed (a file from `usvips target describe`, or a chessboard "
                         "described here) and the image pairs or the project's video that show it.")
        form = QtWidgets.QFormLayout(self)
        self.target_label = QtWidgets.QLabel("no target yet")
        open_target = QtWidgets.QPushButton("&Open target file…")
        open_target.clicked.connect(self._on_open_target)
        row = QtWidgets.QHBoxLayout()
        row.addWidget(self.target_label, 1)
        row.addWidget(open_target)
        form.addRow("Target", row)
        self.cols, self.rows = QtWidgets.QSpinBox(), QtWidgets.QSpinBox()
        for box, value in ((self.cols, 9), (self.rows, 6)):
            box.setRange(2, 99)
            box.setValue(value)
        self.square = QtWidgets.QDoubleSpinBox()
        self.square.setRange(0.1, 1000.0)
        self.square.setDecimals(2)
        self.square.setValue(30.0)
        self.square.setSuffix(" mm")
        use_board = QtWidgets.QPushButton("&Use this chessboard")
        use_board.clicked.connect(self.use_chessboard)
        board = QtWidgets.QHBoxLayout()
        for text, widget in (("inner corners", self.cols), ("×", self.rows), ("square", self.square)):
            board.addWidget(QtWidgets.QLabel(text))
            board.addWidget(widget)
        board.addWidget(use_board)
        board.addStretch(1)
        form.addRow("or a chessboard", board)
        self.from_images = QtWidgets.QRadioButton("&Image pairs")
        self.from_video = QtWidgets.QRadioButton("Project &video")
        self.from_images.setChecked(True)
        left, right = QtWidgets.QPushButton("&Left images…"), QtWidgets.QPushButton("&Right images…")
        left.clicked.connect(lambda: self._choose_images("left"))
        right.clicked.connect(lambda: self._choose_images("right"))
        self.chosen = {"left": [], "right": []}
        self.images_label = QtWidgets.QLabel("no images chosen")
        images = QtWidgets.QHBoxLayout()
        images.addWidget(self.from_images)
        images.addWidget(left)
        images.addWidget(right)
        images.addWidget(self.images_label, 1)
        form.addRow("Views from", images)
        self.video = QtWidgets.QComboBox()
        self.video.addItems(session.videos())
        self.every, self.max_views = QtWidgets.QSpinBox(), QtWidgets.QSpinBox()
        self.every.setRange(1, 1000)
        self.every.setValue(session.every)
        self.every.setPrefix("every ")
        self.every.setSuffix(" frames")
        self.max_views.setRange(3, 500)
        self.max_views.setValue(session.max_views)
        self.max_views.setPrefix("at most ")
        self.max_views.setSuffix(" views")
        video = QtWidgets.QHBoxLayout()
        video.addWidget(self.from_video)
        video.addWidget(self.video, 1)
        video.addWidget(self.every)
        video.addWidget(self.max_views)
        form.addRow("", video)
        self.video.currentIndexChanged.connect(lambda: self.from_video.setChecked(True))
        if not session.videos():
            self.from_video.setEnabled(False)
            self.video.setEnabled(False)
        if session.water:
            self.base = QtWidgets.QComboBox()
            for calibration in session.base_calibrations():
                self.base.addItem(f"{calibration['id']}: {calibration['name']}", calibration["id"])
            self.housing = QtWidgets.QComboBox()
            self.housing.addItems(list(DEFAULT_HOUSING))
            self.housing.setCurrentText(session.housing)
            form.addRow("&Phase-1 calibration", self.base)
            form.addRow("&Housing", self.housing)
        self.holdout = QtWidgets.QSpinBox()
        self.holdout.setRange(0, 50)
        self.holdout.setSuffix(" % of the views")
        self.holdout.setValue(int(round(100 * (session.holdout or 0))))
        self.holdout.setToolTip("views left out of the fit and measured with the calibration: the honest check "
                                "(0: none)")
        form.addRow("Hold ou&t for validation", self.holdout)
        self.message = QtWidgets.QLabel()
        self.message.setWordWrap(True)
        self.message.setStyleSheet(ERROR_STYLE)
        form.addRow(self.message)
        if session.water and not self.base.count():
            self.message.setText("the project has no phase-1 (in-air) calibration yet: calibrate the cameras in air "
                                 "first (the phase-1 wizard), then come back")

    def _on_open_target(self) -> None:
        path, _ = QtWidgets.QFileDialog.getOpenFileName(self, "Target description", "", "Target (*.json)")
        if path:
            self.load_target(path)

    def load_target(self, path: str) -> None:
        try:
            self.session.load_target(path)
        except UsvipsError as error:
            self.message.setText(str(error))
            return
        self._show_target()

    def use_chessboard(self) -> None:
        try:
            self.session.describe_target({"kind": "chessboard", "cols": self.cols.value(), "rows": self.rows.value(),
                                          "square": self.square.value() / 1000.0})
        except UsvipsError as error:
            self.message.setText(str(error))
            return
        self._show_target()

    def _show_target(self) -> None:
        target = self.session.target
        points = len(target.control_points().ids)
        self.target_label.setText(f"{target.kind}: {points} points ({self.session.target_source})")
        self.message.clear()

    def _choose_images(self, side: str) -> None:
        paths, _ = QtWidgets.QFileDialog.getOpenFileNames(self, f"The {side} images", "",
                                                          "Images (*.png *.jpg *.jpeg *.tif *.tiff *.bmp)")
        if paths:
            self.set_images(side, paths)

    def set_images(self, side: str, paths: list[str]) -> None:
        """The images of one camera (the other camera's are paired with them in name order)."""
        self.chosen[side] = list(paths)
        self.from_images.setChecked(True)
        self.images_label.setText(f"{len(self.chosen['left'])} left, {len(self.chosen['right'])} right images")

    def validatePage(self) -> bool:  # noqa: N802 (Qt's name)
        session = self.session
        try:
            if self.from_video.isChecked():
                session.set_video(self.video.currentText(), self.every.value(), self.max_views.value())
            else:
                session.set_images(self.chosen["left"], self.chosen["right"])
            if session.water:
                session.base_id = self.base.currentData()
                session.housing = self.housing.currentText()
            session.holdout = self.holdout.value() / 100.0 or None
        except UsvipsError as error:
            self.message.setText(str(error))
            return False
        ready, why = session.readiness()
        if not ready:
            self.message.setText(why)
        return ready


class ViewsPage(QtWidgets.QWizardPage):
    """Detection in a worker, the views with a tick each, their detections and the coverage."""

    def __init__(self, session: TargetSession, pool: QtCore.QThreadPool) -> None:
        super().__init__()
        self.session, self.pool = session, pool
        self.setTitle("The views")
        self.setSubTitle("The target is found in every view; untick the views you do not want (Space), look at "
                         "each view's points on its images, and read the coverage and its advice.")
        self.worker: Worker | None = None
        self.detect_button = QtWidgets.QPushButton("&Detect again")
        self.detect_button.clicked.connect(self.detect)
        self.stop_button = QtWidgets.QPushButton("&Stop")
        self.stop_button.clicked.connect(self.stop)
        self.stop_button.setEnabled(False)
        self.progress = QtWidgets.QProgressBar()
        self.progress.setRange(0, 1000)
        top = QtWidgets.QHBoxLayout()
        top.addWidget(self.detect_button)
        top.addWidget(self.stop_button)
        top.addWidget(self.progress, 1)
        self.list = QtWidgets.QListWidget()
        self.list.setObjectName("views")
        self.list.itemChanged.connect(self._on_ticked)
        self.list.currentItemChanged.connect(self._on_current)
        self.panes = {side: StereoPane(side) for side in ("left", "right")}
        for pane in self.panes.values():
            pane.set_loupe_enabled(False)
        self.maps = pg.GraphicsLayoutWidget()
        self.maps.setFixedHeight(110)
        self.map_items = {}
        for side in ("left", "right"):
            plot = self.maps.addViewBox(lockAspect=True, invertY=True, enableMouse=False)
            item = pg.ImageItem(axisOrder="row-major")
            plot.addItem(item)
            self.map_items[side] = item
        self.advice = QtWidgets.QLabel()
        self.advice.setWordWrap(True)
        self.tally = QtWidgets.QLabel()
        self.tally.setWordWrap(True)
        self.set_aside = QtWidgets.QLabel()
        self.set_aside.setWordWrap(True)
        self.set_aside.setStyleSheet(ERROR_STYLE)
        side_panel = QtWidgets.QVBoxLayout()
        label = QtWidgets.QLabel("&Views (ticked: used)")
        label.setBuddy(self.list)
        side_panel.addWidget(label)
        side_panel.addWidget(self.list, 1)
        side_panel.addWidget(QtWidgets.QLabel("Coverage (left, right: views per cell)"))
        side_panel.addWidget(self.maps)
        side_panel.addWidget(self.advice)
        images = QtWidgets.QHBoxLayout()
        images.addWidget(self.panes["left"])
        images.addWidget(self.panes["right"])
        body = QtWidgets.QHBoxLayout()
        body.addLayout(side_panel, 1)
        body.addLayout(images, 3)
        layout = QtWidgets.QVBoxLayout(self)
        layout.addLayout(top)
        layout.addLayout(body, 1)
        layout.addWidget(self.tally)
        layout.addWidget(self.set_aside)
        self.setTabOrder(self.list, self.detect_button)
        self.setTabOrder(self.detect_button, self.stop_button)

    # ------------------------------------------------------------------ detection
    def initializePage(self) -> None:  # noqa: N802 (Qt's name)
        if self.session.views is None:
            self.detect()
        else:
            self._fill()
        self.list.setFocus()

    @property
    def busy(self) -> bool:
        return self.worker is not None

    def detect(self) -> None:
        if self.busy:
            return
        try:
            job = self.session.detection_job()
        except UsvipsError as error:
            self.set_aside.setText(str(error))
            return
        self.list.clear()
        self.tally.setText("finding the target…")
        self.set_aside.clear()
        self.worker = Worker(_job(job), "target detection")
        self.worker.signals.progress.connect(lambda f: self.progress.setValue(int(1000 * f)))
        self.worker.signals.finished.connect(self._on_found)
        self.worker.signals.failed.connect(self._on_failed)
        self.worker.signals.cancelled.connect(self._on_cancelled)
        self.detect_button.setEnabled(False)
        self.stop_button.setEnabled(True)
        self.completeChanged.emit()
        start(self.worker, self.pool)

    def stop(self) -> None:
        if self.worker is not None:
            self.worker.cancel()

    def _done(self) -> None:
        self.worker = None
        self.detect_button.setEnabled(True)
        self.stop_button.setEnabled(False)
        self.completeChanged.emit()

    def _on_found(self, views) -> None:
        self._done()
        self.session.set_views(views)
        self.progress.setValue(1000)
        self._fill()
        self.completeChanged.emit()

    def _on_failed(self, message: str) -> None:
        self._done()
        self.set_aside.setText(message)

    def _on_cancelled(self) -> None:
        self._done()
        self.set_aside.setText("detection stopped: Detect again (Alt+D) to start over")

    # ------------------------------------------------------------------ views
    def _fill(self) -> None:
        views = self.session.views
        self.list.blockSignals(True)
        self.list.clear()
        for view in views.views:
            item = QtWidgets.QListWidgetItem(f"{view.label}  ({len(view.common_ids())} points)")
            item.setData(QtCore.Qt.ItemDataRole.UserRole, view.label)
            item.setFlags(item.flags() | QtCore.Qt.ItemFlag.ItemIsUserCheckable)
            item.setCheckState(QtCore.Qt.CheckState.Checked if self.session.ticked.get(view.label)
                               else QtCore.Qt.CheckState.Unchecked)
            self.list.addItem(item)
        self.list.blockSignals(False)
        self.tally.setText("\n".join(views.tally))
        self.set_aside.setText("\n".join(reason for _, reason in views.set_aside))
        self._show_coverage()
        if self.list.count():
            self.list.setCurrentRow(0)

    def _on_ticked(self, item: QtWidgets.QListWidgetItem) -> None:
        label = item.data(QtCore.Qt.ItemDataRole.UserRole)
        self.session.set_ticked(label, item.checkState() == QtCore.Qt.CheckState.Checked)
        self._show_coverage()
        self.completeChanged.emit()

    def _show_coverage(self) -> None:
        coverage = self.session.coverage()
        if coverage is None:
            self.advice.setText("no view ticked")
            for item in self.map_items.values():
                item.clear()
            return
        top = max(int(coverage.left.counts.max()), int(coverage.right.counts.max()), 1)
        for side in ("left", "right"):
            counts = getattr(coverage, side).counts.astype(float)
            item = self.map_items[side]
            item.setImage(counts, levels=(0, top))
            item.setLookupTable(pg.colormap.get("viridis").getLookupTable(nPts=64))
        self.advice.setText("\n".join(coverage.summary()))

    def _on_current(self, item: QtWidgets.QListWidgetItem | None, _previous=None) -> None:
        if item is None:
            return
        label = item.data(QtCore.Qt.ItemDataRole.UserRole)
        try:
            job = self.session.images_job(label)
        except UsvipsError as error:
            self.set_aside.setText(str(error))
            return
        worker = Worker(job, f"reading view {label}")
        worker.signals.finished.connect(self._show_view)
        worker.signals.failed.connect(self.set_aside.setText)
        start(worker, self.pool)

    def _show_view(self, read) -> None:
        label, images = read
        current = self.list.currentItem()
        if current is None or current.data(QtCore.Qt.ItemDataRole.UserRole) != label:
            return
        view = self.session.view(label)
        for side, image in zip(("left", "right"), images, strict=True):
            pane = self.panes[side]
            pane.set_image(image)
            detection = getattr(view, side)
            # a ring on every point; ids on at most about a dozen of them, so that they stay readable
            step = max(1, len(detection.ids) // 12)
            pane.set_control([(pid if k % step == 0 else "", tuple(px))
                              for k, (pid, px) in enumerate(zip(detection.ids, detection.pixels, strict=True))])
            pane.title.setText(f"{side.capitalize()} — {label}: {len(detection.ids)} points")
            pane.fit()

    def isComplete(self) -> bool:  # noqa: N802 (Qt's name)
        return not self.busy and len(self.session.kept()) >= 3


class ComputePage(QtWidgets.QWizardPage):
    """The calibration from the ticked views in a worker; the fit, the validation and a verdict."""

    def __init__(self, session: TargetSession, pool: QtCore.QThreadPool) -> None:
        super().__init__()
        self.session, self.pool = session, pool
        self.setTitle("Compute and judge")
        self.setSubTitle("RMS over the kept and over all observations; held-out views measured with the "
                         "calibration; for boards in air, OpenCV's solution of the same views beside ours.")
        self.worker: Worker | None = None
        self.compute_button = QtWidgets.QPushButton("&Compute again")
        self.compute_button.clicked.connect(self.compute)
        self.progress = QtWidgets.QProgressBar()
        self.progress.setRange(0, 0)
        self.progress.hide()
        self.text = QtWidgets.QPlainTextEdit()
        self.text.setReadOnly(True)
        self.text.setObjectName("results")
        self.verdict = QtWidgets.QLabel()
        self.verdict.setWordWrap(True)
        self.verdict.setStyleSheet("font-weight: bold;")
        top = QtWidgets.QHBoxLayout()
        top.addWidget(self.compute_button)
        top.addWidget(self.progress, 1)
        top.addStretch(1)
        layout = QtWidgets.QVBoxLayout(self)
        layout.addLayout(top)
        layout.addWidget(self.text, 1)
        layout.addWidget(self.verdict)

    def initializePage(self) -> None:  # noqa: N802 (Qt's name)
        if self.session.result is None:
            self.compute()
        else:
            self._show()

    @property
    def busy(self) -> bool:
        return self.worker is not None

    def compute(self) -> None:
        if self.busy:
            return
        try:
            job = self.session.calibration_job()
        except UsvipsError as error:
            self.verdict.setText(str(error))
            return
        self.text.setPlainText(f"calibrating from {len(self.session.kept())} views…")
        self.verdict.clear()
        self.worker = Worker(_job(job), "calibration from target views")
        self.worker.signals.finished.connect(self._on_finished)
        self.worker.signals.failed.connect(self._on_failed)
        self.worker.signals.cancelled.connect(self._on_failed)
        self.compute_button.setEnabled(False)
        self.progress.show()
        self.completeChanged.emit()
        start(self.worker, self.pool)

    def _done(self) -> None:
        self.worker = None
        self.compute_button.setEnabled(True)
        self.progress.hide()
        self.completeChanged.emit()

    def _on_finished(self, result) -> None:
        self._done()
        self.session.set_result(result)
        self._show()

    def _on_failed(self, message: str = "cancelled") -> None:
        self._done()
        self.text.setPlainText(message)
        self.verdict.setText("nothing is stored; change the views or the settings and compute again")

    def _show(self) -> None:
        self.text.setPlainText("\n".join(self.session.result.lines()))
        self.verdict.setText(self.session.verdict())
        self.completeChanged.emit()

    def isComplete(self) -> bool:  # noqa: N802 (Qt's name)
        return not self.busy and self.session.result is not None


class SavePage(QtWidgets.QWizardPage):
    """Name the calibration and the pairs it becomes active for; Finish stores it in the project."""

    def __init__(self, session: TargetSession) -> None:
        super().__init__()
        self.session = session
        self.setTitle("Save the calibration")
        self.setSubTitle("Finish stores it in the project; Cancel leaves the project as it was.")
        self.name = QtWidgets.QLineEdit()
        self.active = QtWidgets.QListWidget()
        self.message = QtWidgets.QLabel()
        self.message.setStyleSheet(ERROR_STYLE)
        form = QtWidgets.QFormLayout(self)
        name_label = QtWidgets.QLabel("&Name")
        name_label.setBuddy(self.name)
        active_label = QtWidgets.QLabel("&Active for")
        active_label.setBuddy(self.active)
        form.addRow(name_label, self.name)
        form.addRow(active_label, self.active)
        form.addRow(self.message)
        self.saved_id: int | None = None

    def initializePage(self) -> None:  # noqa: N802 (Qt's name)
        stamp = datetime.datetime.now().strftime("%Y-%m-%d %H:%M")
        sigma = self.session.result.calibration.sigma0_px
        self.name.setText(f"{self.session.default_name()} σ0 {sigma:.3f} px {stamp}")
        medium = "air" if self.session.phase == "air" else "water"
        self.message.setText("" if active_pairs.fill(self.active, self.session.project, medium) else
                             f"the project has no {medium} pairs yet: the calibration is stored, active for none; "
                             "choose it for a pair later")

    def active_for(self) -> list[str]:
        return active_pairs.ticked(self.active)

    def validatePage(self) -> bool:  # noqa: N802 (Qt's name)
        try:
            self.saved_id = self.session.save(self.name.text(), self.active_for())
        except UsvipsError as error:
            self.message.setText(str(error))
            return False
        self.wizard().saved.emit(self.saved_id)
        return True


class TargetWizard(QtWidgets.QWizard):
    """``saved(calibration_id)`` fires when Finish stored the calibration."""

    saved = QtCore.Signal(int)

    def __init__(self, session: TargetSession, parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(parent)
        self.session = session
        self.pool = QtCore.QThreadPool.globalInstance()
        self.setWindowTitle(f"USVIPS — {TITLES[session.phase]}")
        self.setWizardStyle(QtWidgets.QWizard.WizardStyle.ClassicStyle)
        self.source_page = SourcePage(session)
        self.views_page = ViewsPage(session, self.pool)
        self.compute_page = ComputePage(session, self.pool)
        self.save_page = SavePage(session)
        for page in (self.source_page, self.views_page, self.compute_page, self.save_page):
            self.addPage(page)
        self.resize(1280, 720)

    def reject(self) -> None:
        """Cancel: stop a running detection (its worker stops at the next image); nothing is stored."""
        self.views_page.stop()
        if self.compute_page.worker is not None:
            self.compute_page.worker.cancel()
        super().reject()


def open_target_wizard(project, phase: str, parent: QtWidgets.QWidget | None = None) -> TargetWizard:
    """The target wizard for ``phase`` over ``project``, shown (not modal)."""
    wizard = TargetWizard(TargetSession(project, phase), parent)
    wizard.setAttribute(QtCore.Qt.WidgetAttribute.WA_DeleteOnClose, True)
    wizard.show()
    return wizard

