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

import html

import numpy as np
from PySide6 import QtCore, QtGui, QtWidgets

from usvips.app.target_words import target_words
from usvips.core.calibration.figures import parameter_table
from usvips.core.calibration.phases import DEFAULT_HOUSING
from usvips.core.errors import UsvipsError
from usvips.gui import target_views_model as detail_model
from usvips.gui.housing_values import known_label, read_known
from usvips.gui.qt import save_page
from usvips.gui.qt.field_errors import FormFields
from usvips.gui.qt.housing_value_form import fill_known_form
from usvips.gui.qt.marks import Lines
from usvips.gui.qt.pane import StereoPane, item_from_pixels
from usvips.gui.qt.plots import pg
from usvips.gui.qt.worker import Cancelled, Worker, start
from usvips.gui.target_session import TargetSession

TITLES = {"air": "Phase 1 in air from target views", "water": "Phase 2 underwater from target views",
          "joint": "Joint underwater calibration from target views"}
ERROR_STYLE = "color: #c0392b;"
#: the views list's role holding whether the target was found in a view (False: set aside)
FOUND_ROLE = QtCore.Qt.ItemDataRole.UserRole + 1
#: the verdict's colour per level (usvips.app.board_verdict)
VERDICT_STYLE = {"good": "color: #1e7b34;", "short": "color: #9a6700;", "poor": "color: #c0392b;"}


def _job(job):
    """A session job as a :class:`Worker` job: an :class:`InterruptedError` becomes :class:`Cancelled`."""

    def run(progress, cancelled):
        try:
            return job(progress, cancelled)
        except InterruptedError as error:
            raise Cancelled(str(error)) from None
    return run


class PageJob:
    """One job at a time of a wizard page, in a worker of ``pool``: while it runs, the page's ``start``
    button is off, its ``stop`` button on (it stops the job) and ``busy`` (a progress bar, if any) shown; the
    page's completeness is told again when the job starts and ends. ``finished(result)``,
    ``failed(message)`` and ``cancelled()`` are the page's own, called once the job is over;
    ``progress(fraction)`` (optional) follows the job."""

    def __init__(self, page: QtWidgets.QWizardPage, start_button: QtWidgets.QAbstractButton,
                 stop_button: QtWidgets.QAbstractButton, pool: QtCore.QThreadPool, finished, failed, cancelled,
                 busy: QtWidgets.QWidget | None = None, progress=None) -> None:
        self.page, self.start_button, self.stop_button, self.pool = page, start_button, stop_button, pool
        self.finished, self.failed, self.cancelled = finished, failed, cancelled
        self.busy, self.progress = busy, progress
        self.worker: Worker | None = None
        stop_button.clicked.connect(self.stop)
        stop_button.setEnabled(False)

    @property
    def running(self) -> bool:
        return self.worker is not None

    def run(self, job, label: str) -> None:
        """Run the session's ``job(progress, cancelled)`` (an :class:`InterruptedError` is a cancel)."""
        worker = self.worker = Worker(_job(job), label)
        if self.progress is not None:
            worker.signals.progress.connect(self.progress)
        worker.signals.finished.connect(lambda result: self._over(self.finished, result))
        worker.signals.failed.connect(lambda message: self._over(self.failed, message))
        worker.signals.cancelled.connect(lambda: self._over(self.cancelled))
        self.start_button.setEnabled(False)
        self.stop_button.setEnabled(True)
        if self.busy is not None:
            self.busy.show()
        self.page.completeChanged.emit()
        start(worker, self.pool)

    def stop(self) -> None:
        if self.worker is not None:
            self.worker.cancel()

    def _over(self, then, *args) -> None:
        self.worker = None
        self.start_button.setEnabled(True)
        self.stop_button.setEnabled(False)
        if self.busy is not None:
            self.busy.hide()
        self.page.completeChanged.emit()
        then(*args)


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
        for box in (self.cols, self.rows, self.square):
            box.valueChanged.connect(self._on_board_changed)
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
                self.base.addItem(f"{calibration.id}: {calibration.name}", calibration.id)
            self.housing = QtWidgets.QComboBox()
            self.housing.addItems(list(DEFAULT_HOUSING))
            self.housing.setCurrentText(session.housing)
            form.addRow("&Phase-1 calibration", self.base)
            form.addRow("&Housing", self.housing)
            self.unmoved = QtWidgets.QCheckBox("The &cameras did not move since the phase-1 images (a tank or a "
                                               "pool: each view's poses held at phase 1's; one view will do)")
            self.unmoved.setChecked(session.cameras_unmoved)
            form.addRow("", self.unmoved)
            self.known_box = QtWidgets.QGroupBox("Known housing values: a value holds it fixed, 'value ± sigma' "
                                                 "weights it; blank keeps the default shown")
            self.known_form = QtWidgets.QFormLayout(self.known_box)
            self.known: dict[str, QtWidgets.QLineEdit] = {}
            form.addRow(self.known_box)
            self.housing.currentTextChanged.connect(self._fill_known)
            self._fill_known(self.housing.currentText())
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
        #: the page's fields by the parameter an error names (the described chessboard's, the video's, each
        #: housing value's by its symbol): a bad value is said with the field's label, the field outlined
        self.field_errors = FormFields(self._fields_by_parameter, self.message.setText)
        if session.water and not self.base.count():
            self.message.setText("the project has no phase-1 (in-air) calibration yet: calibrate the cameras in air "
                                 "first (the phase-1 wizard), then come back")

    def _fields_by_parameter(self) -> dict[str, tuple[QtWidgets.QWidget, str]]:
        fields = {"cols": (self.cols, "inner corners across"), "rows": (self.rows, "inner corners down"),
                  "square": (self.square, "square"), "upright": (self.cols, "inner corners"),
                  "video": (self.video, "project video"),
                  "every": (self.every, "every … frames"), "max_views": (self.max_views, "at most … views")}
        if self.session.water:
            housing = self.housing.currentText()
            fields.update({name: (edit, known_label(housing, name)) for name, edit in self.known.items()})
        return fields

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
            self.field_errors.show(error)
            return
        self._show_target()

    def _on_board_changed(self) -> None:
        """A value of the described chessboard changed: the target in use is rebuilt from the fields (a
        target from a file stays as it is until the chessboard is used)."""
        if self.session.target is not None and self.session.target_source == "described in the window":
            self.use_chessboard()

    def _show_target(self) -> None:
        self.target_label.setText(f"{target_words(self.session.target)} — {self.session.target_source}")
        self.message.clear()

    def _fill_known(self, housing: str) -> None:
        """One field per parameter of the housing kind: blank (the default shown), a value (held fixed) or
        'value ± sigma' (weighted)."""
        known = self.session.known if housing == self.session.housing else {}
        self.known = fill_known_form(self.known_form, housing, known)

    def known_values(self) -> dict[str, tuple[float, float | None]]:
        """The housing values typed: symbol → (value, σ or None); a bad one names its symbol."""
        return read_known(self.housing.currentText(), {name: edit.text() for name, edit in self.known.items()})

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
                session.known = self.known_values()
                session.cameras_unmoved = self.unmoved.isChecked()
            session.holdout = self.holdout.value() / 100.0 or None
        except UsvipsError as error:
            self.field_errors.show(error)  # a value at fault: its field outlined and named
            return False
        self.field_errors.clear()
        ready, why = session.readiness()
        if not ready:
            self.message.setText(why)
        return ready


class ViewsPage(QtWidgets.QWizardPage):
    """Detection in a worker; every view listed (found ones with a tick, those set aside with why), each
    opened on its images with its points (and its residual vectors once computed); the coverage maps with
    their scale, the advice and where to hold the board next."""

    def __init__(self, session: TargetSession, pool: QtCore.QThreadPool) -> None:
        super().__init__()
        self.session, self.pool = session, pool
        self.setTitle("The views")
        self.setSubTitle("The target is found in every view; untick the views you do not want (Space), open a "
                         "view to see its points (and why a view was set aside), and read the coverage and its "
                         "advice.")
        self.detect_button = QtWidgets.QPushButton("&Detect again")
        self.detect_button.clicked.connect(self.detect)
        self.stop_button = QtWidgets.QPushButton("&Stop")
        self.progress = QtWidgets.QProgressBar()
        self.progress.setRange(0, 1000)
        self.work = PageJob(self, self.detect_button, self.stop_button, pool, self._on_found, self._on_failed,
                            self._on_cancelled, progress=lambda f: self.progress.setValue(int(1000 * f)))
        top = QtWidgets.QHBoxLayout()
        top.addWidget(self.detect_button)
        top.addWidget(self.stop_button)
        top.addWidget(self.progress, 1)
        self.target_label = QtWidgets.QLabel()
        self.list = QtWidgets.QListWidget()
        self.list.setObjectName("views")
        self.list.setVerticalScrollBarPolicy(QtCore.Qt.ScrollBarPolicy.ScrollBarAsNeeded)
        self.list.itemChanged.connect(self._on_ticked)
        self.list.currentItemChanged.connect(self._on_current)
        self.panes = {side: StereoPane(side) for side in ("left", "right")}
        self.vectors = {}
        for side, pane in self.panes.items():
            pane.set_loupe_enabled(False)
            self.vectors[side] = Lines((255, 60, 60), width=2, connect="pairs")
            pane.add_mark(self.vectors[side])
        self.maps = pg.GraphicsLayoutWidget()
        self.maps.setFixedHeight(150)
        self.map_items = {}
        for column, side in enumerate(("left", "right")):
            plot = self.maps.addPlot(row=0, col=column, title=side)
            plot.setAspectLocked(True)
            plot.invertY(True)
            plot.setMouseEnabled(False, False)
            plot.hideButtons()
            item = pg.ImageItem(axisOrder="row-major")
            plot.addItem(item)
            self.map_items[side] = item
        self.colour_bar = pg.ColorBarItem(values=(0, 1), colorMap=pg.colormap.get("viridis"), interactive=False,
                                          width=10, label="views per cell")
        self.colour_bar.setImageItem(list(self.map_items.values()), insert_in=None)
        self.maps.addItem(self.colour_bar, row=0, col=2)
        self.notes = QtWidgets.QTextBrowser()  # the maps' scale, the coverage and its advice, the next pose
        self.notes.setObjectName("coverage notes")
        self.scale_label = QtWidgets.QLabel()
        self.advice = QtWidgets.QLabel()
        self.next_pose = QtWidgets.QLabel()
        self.tally = QtWidgets.QLabel()
        self.tally.setWordWrap(True)
        self.view_text = QtWidgets.QLabel()
        self.view_text.setWordWrap(True)
        self.set_aside = QtWidgets.QLabel()  # errors and a stopped detection (one line)
        self.set_aside.setWordWrap(True)
        self.set_aside.setStyleSheet(ERROR_STYLE)
        side_panel = QtWidgets.QVBoxLayout()
        side_panel.setContentsMargins(0, 0, 0, 0)
        label = QtWidgets.QLabel("&Views (ticked: used; red: set aside — open one to see why)")
        label.setWordWrap(True)
        label.setBuddy(self.list)
        side_panel.addWidget(label)
        side_panel.addWidget(self.list, 3)
        side_panel.addWidget(QtWidgets.QLabel("Coverage of the left and right images (pixels)"))
        side_panel.addWidget(self.maps)
        side_panel.addWidget(self.notes, 2)
        side = QtWidgets.QWidget()
        side.setLayout(side_panel)
        images = QtWidgets.QHBoxLayout()
        images.addWidget(self.panes["left"])
        images.addWidget(self.panes["right"])
        right = QtWidgets.QVBoxLayout()
        right.addLayout(images, 1)
        right.addWidget(self.view_text)
        right_widget = QtWidgets.QWidget()
        right_widget.setLayout(right)
        body = QtWidgets.QSplitter()
        body.addWidget(side)
        body.addWidget(right_widget)
        body.setStretchFactor(0, 0)
        body.setStretchFactor(1, 1)
        body.setSizes([400, 900])
        layout = QtWidgets.QVBoxLayout(self)
        layout.addLayout(top)
        layout.addWidget(self.target_label)
        layout.addWidget(body, 1)
        layout.addWidget(self.tally)
        layout.addWidget(self.set_aside)
        self.setTabOrder(self.list, self.detect_button)
        self.setTabOrder(self.detect_button, self.stop_button)

    # ------------------------------------------------------------------ detection
    def initializePage(self) -> None:  # noqa: N802 (Qt's name)
        if self.session.target is not None:
            self.target_label.setText(f"Target: {target_words(self.session.target)}")
        if self.session.views is None:
            self.detect()
        else:
            self._fill()
        self.list.setFocus()

    @property
    def busy(self) -> bool:
        return self.work.running

    def stop(self) -> None:
        self.work.stop()

    def detect(self) -> None:
        if self.busy:
            return
        try:
            job = self.session.detection_job()
        except UsvipsError as error:
            self.set_aside.setText(str(error))
            return
        self.session.forget_views()  # a stopped or failed detection leaves nothing to compute from
        self.list.clear()
        self._show_coverage()
        self.tally.setText("finding the target…")
        self.set_aside.clear()
        self.work.run(job, "target detection")

    def _on_found(self, views) -> None:
        self.session.set_views(views)
        self.progress.setValue(1000)
        self._fill()
        self.completeChanged.emit()

    def _on_failed(self, message: str) -> None:
        self.tally.clear()
        self.set_aside.setText(message)

    def _on_cancelled(self) -> None:
        self.tally.clear()
        self.set_aside.setText("detection stopped: no views; Detect again (Alt+D) to start over")

    # ------------------------------------------------------------------ views
    def _fill(self) -> None:
        views = self.session.views
        self.list.blockSignals(True)
        self.list.clear()
        for entry in detail_model.entries(self.session):
            item = QtWidgets.QListWidgetItem(entry.text)
            item.setData(QtCore.Qt.ItemDataRole.UserRole, entry.label)
            item.setData(FOUND_ROLE, entry.found)
            if entry.found:
                item.setFlags(item.flags() | QtCore.Qt.ItemFlag.ItemIsUserCheckable)
                item.setCheckState(QtCore.Qt.CheckState.Checked if self.session.ticked.get(entry.label)
                                   else QtCore.Qt.CheckState.Unchecked)
            else:
                item.setFlags(item.flags() & ~QtCore.Qt.ItemFlag.ItemIsUserCheckable)
                item.setForeground(QtGui.QColor("#c0392b"))
                item.setToolTip(entry.why)
            self.list.addItem(item)
        self.list.blockSignals(False)
        self.tally.setText("\n".join(views.tally) + (" (red in the list)" if views.set_aside else ""))
        self.set_aside.clear()
        self._show_coverage()
        if self.list.count():
            self.list.setCurrentRow(0)

    def _on_ticked(self, item: QtWidgets.QListWidgetItem) -> None:
        label = item.data(QtCore.Qt.ItemDataRole.UserRole)
        if not item.data(FOUND_ROLE):
            return
        self.session.set_ticked(label, item.checkState() == QtCore.Qt.CheckState.Checked)
        self._show_coverage()
        self._show_detail(label)
        self.completeChanged.emit()

    def _show_coverage(self) -> None:
        coverage = self.session.coverage()
        if coverage is None:
            self.advice.setText("no view ticked")
            self.scale_label.clear()
            self.next_pose.clear()
            self._show_notes()
            for item in self.map_items.values():
                item.clear()
            return
        top = max(int(coverage.left.counts.max()), int(coverage.right.counts.max()), 1)
        rows, cols = coverage.left.counts.shape
        width, height = self.session.views.image_size() if self.session.views and self.session.views.views \
            else (cols, rows)
        for side in ("left", "right"):
            item = self.map_items[side]
            item.setImage(getattr(coverage, side).counts.astype(float), levels=(0, top))
            item.setRect(QtCore.QRectF(0, 0, width, height))  # axes in the image's pixels
        self.colour_bar.setLevels((0, top))
        self.scale_label.setText(f"{cols} × {rows} cells over each image ({width} × {height} px: a cell is "
                                 f"{width / cols:.0f} × {height / rows:.0f} px); colour: views covering a cell, "
                                 f"dark 0 to yellow {top}")
        self.advice.setText("\n".join(coverage.summary()))
        self.next_pose.setText(self.session_next_pose())
        self._show_notes()

    def _show_notes(self) -> None:
        """The next pose first (bold), the coverage and its advice, then the maps' scale."""
        parts = []
        if self.next_pose.text():
            parts.append(f"<p><b>{html.escape(self.next_pose.text())}</b></p>")
        if self.advice.text():
            parts.append("<p>" + "<br>".join(html.escape(line) for line in self.advice.text().split("\n")) + "</p>")
        if self.scale_label.text():
            parts.append(f"<p style='color:#555'>{html.escape(self.scale_label.text())}</p>")
        self.notes.setHtml("".join(parts))

    def session_next_pose(self) -> str:
        """Where to hold the board next, in words (empty when nothing is missing or no view is kept)."""
        from usvips.core.next_pose import suggest

        kept = self.session.kept()
        if not kept or self.session.target is None:
            return ""
        try:
            suggestion = suggest(kept, self.session.target.control_points())
        except UsvipsError:
            return ""
        return f"Next: {suggestion.text()}" if suggestion is not None else ""

    def _on_current(self, item: QtWidgets.QListWidgetItem | None, _previous=None) -> None:
        if item is None:
            return
        label = item.data(QtCore.Qt.ItemDataRole.UserRole)
        self._show_detail(label)
        found = bool(item.data(FOUND_ROLE))
        try:
            if found:
                job = self.session.images_job(label)
            else:
                files = detail_model.set_aside_images(self.session, label)
                if files is None:
                    self._clear_panes(label)
                    return
                from usvips.io.images import read_image

                def job(progress=None, cancelled=None, files=files):
                    return label, (read_image(files[0]), read_image(files[1]))
        except UsvipsError as error:
            self.set_aside.setText(str(error))
            return
        worker = Worker(job, f"reading view {label}")
        worker.signals.finished.connect(self._show_view)
        worker.signals.failed.connect(self.view_text.setText)
        start(worker, self.pool)

    def _show_detail(self, label: str) -> None:
        self.view_text.setText(detail_model.detail(self.session, label))

    def _clear_panes(self, label: str) -> None:
        for side, pane in self.panes.items():
            pane.set_image(None)
            pane.set_control([])
            self.vectors[side].set_points(None)
            pane.title.setText(f"{side.capitalize()} — {label}: images not available")

    def refresh_view(self) -> None:
        """Draw the current view again (after a calibration: with its residual vectors)."""
        item = self.list.currentItem()
        if item is not None:
            self._on_current(item)

    def _show_view(self, read) -> None:
        label, images = read
        current = self.list.currentItem()
        if current is None or current.data(QtCore.Qt.ItemDataRole.UserRole) != label:
            return
        view = self.session.view(label) if current.data(FOUND_ROLE) else None
        for side, image in zip(("left", "right"), images, strict=True):
            pane = self.panes[side]
            pane.set_image(image)
            if view is None:
                pane.set_control([])
                self.vectors[side].set_points(None)
                pane.title.setText(f"{side.capitalize()} — {label}: set aside")
                pane.fit()
                continue
            detection = getattr(view, side)
            # a ring on every point; ids on at most about a dozen of them, so that they stay readable
            step = max(1, len(detection.ids) // 12)
            pane.set_control([(pid if k % step == 0 else "", tuple(px))
                              for k, (pid, px) in enumerate(zip(detection.ids, detection.pixels, strict=True))])
            segments = detail_model.residual_segments(self.session, label, side)
            data = item_from_pixels(segments) if len(segments) else np.zeros((0, 2))
            self.vectors[side].set_points(data)
            pane.title.setText(f"{side.capitalize()} — {label}: {len(detection.ids)} points")
            pane.fit()

    def isComplete(self) -> bool:  # noqa: N802 (Qt's name)
        return not self.busy and len(self.session.kept()) >= 3


class ComputePage(QtWidgets.QWizardPage):
    """The calibration from the ticked views in a worker (Stop stops it); the parameters with their σ,
    the fit and the validation, and a verdict consistent with the coverage advice."""

    HEADERS = ["", "Parameter", "Value ± σ"]

    def __init__(self, session: TargetSession, pool: QtCore.QThreadPool) -> None:
        super().__init__()
        self.session, self.pool = session, pool
        self.setTitle("Compute and judge")
        self.setSubTitle("The parameters with their σ; RMS over the kept and over all observations; held-out "
                         "views measured with the calibration; for boards in air, OpenCV's solution beside ours.")
        self.compute_button = QtWidgets.QPushButton("&Compute again")
        self.compute_button.clicked.connect(self.compute)
        self.stop_button = QtWidgets.QPushButton("&Stop")
        self.progress = QtWidgets.QProgressBar()
        self.progress.setRange(0, 0)
        self.progress.hide()
        self.work = PageJob(self, self.compute_button, self.stop_button, pool, self._on_finished, self._on_failed,
                            self._on_cancelled, busy=self.progress)
        self.target_label = QtWidgets.QLabel()
        self.table = QtWidgets.QTableWidget(0, len(self.HEADERS))
        self.table.setObjectName("parameters")
        self.table.setHorizontalHeaderLabels(self.HEADERS)
        self.table.verticalHeader().hide()
        self.table.verticalHeader().setDefaultSectionSize(self.table.fontMetrics().height() + 8)
        self.table.setEditTriggers(QtWidgets.QAbstractItemView.EditTrigger.NoEditTriggers)
        self.table.horizontalHeader().setStretchLastSection(True)
        self.table.setMinimumWidth(470)
        self.text = QtWidgets.QPlainTextEdit()
        self.text.setReadOnly(True)
        self.text.setObjectName("results")
        self.verdict = QtWidgets.QLabel()
        self.verdict.setWordWrap(True)
        self.verdict.setStyleSheet("font-weight: bold;")
        top = QtWidgets.QHBoxLayout()
        top.addWidget(self.compute_button)
        top.addWidget(self.stop_button)
        top.addWidget(self.progress, 1)
        top.addStretch(1)
        body = QtWidgets.QSplitter()
        body.addWidget(self.table)
        body.addWidget(self.text)
        body.setStretchFactor(0, 0)
        body.setStretchFactor(1, 1)
        body.setSizes([520, 700])
        layout = QtWidgets.QVBoxLayout(self)
        layout.addLayout(top)
        layout.addWidget(self.target_label)
        layout.addWidget(body, 1)
        layout.addWidget(self.verdict)

    def initializePage(self) -> None:  # noqa: N802 (Qt's name)
        if self.session.target is not None:
            self.target_label.setText(f"Target: {target_words(self.session.target)}")
        if self.session.result is None:
            self.compute()
        else:
            self._show()

    @property
    def busy(self) -> bool:
        return self.work.running

    def stop(self) -> None:
        self.work.stop()

    def compute(self) -> None:
        if self.busy:
            return
        try:
            job = self.session.calibration_job()
        except UsvipsError as error:
            self.verdict.setText(str(error))
            return
        self.text.setPlainText(f"calibrating from {len(self.session.kept())} views… (Stop: Alt+S)")
        self.table.setRowCount(0)
        self.verdict.clear()
        self.work.run(job, "calibration from target views")

    def _on_finished(self, result) -> None:
        self.session.set_result(result)
        self._show()

    def _on_failed(self, message: str) -> None:
        self.session.set_result(None)
        self.text.setPlainText(message)
        self.verdict.setStyleSheet("font-weight: bold; " + VERDICT_STYLE["poor"])
        self.verdict.setText("nothing is stored; change the views or the settings and compute again")

    def _on_cancelled(self) -> None:
        self.session.set_result(None)
        self.text.setPlainText("the calibration was stopped: no result")
        self.verdict.setStyleSheet("font-weight: bold;")
        self.verdict.setText("nothing is stored; Compute again (Alt+C) to start over")

    def _show(self) -> None:
        from usvips.app.board_verdict import judge

        result = self.session.result
        self._fill_table(result.calibration)
        self.text.setPlainText("\n".join(result.lines()))
        verdict = judge(result, self.session.coverage(), self.session.sigma_px)
        self.verdict.setStyleSheet("font-weight: bold; " + VERDICT_STYLE[verdict.level])
        self.verdict.setText(verdict.text)
        self.completeChanged.emit()

    def _fill_table(self, calibration) -> None:
        figures = parameter_table(calibration)
        self.table.setRowCount(len(figures))
        previous = None
        for row, figure in enumerate(figures):
            cells = [figure.group if figure.group != previous else "", figure.label, figure.text()]
            previous = figure.group
            for column, text in enumerate(cells):
                item = QtWidgets.QTableWidgetItem(text)
                item.setToolTip(f"{figure.name}: {figure.status}")
                if column == 2:
                    item.setTextAlignment(QtCore.Qt.AlignmentFlag.AlignRight | QtCore.Qt.AlignmentFlag.AlignVCenter)
                self.table.setItem(row, column, item)
        self.table.resizeColumnsToContents()

    def isComplete(self) -> bool:  # noqa: N802 (Qt's name)
        return not self.busy and self.session.result is not None


class SavePage(save_page.SavePage):
    """Name the calibration and the pairs it becomes active for, write its report if wanted; Finish
    stores it in the project (:class:`usvips.gui.qt.save_page.SavePage`, with the target path's report)."""

    def __init__(self, session: TargetSession, pool: QtCore.QThreadPool | None = None) -> None:
        from usvips.gui.qt.target_report import TargetReport

        super().__init__(session, lambda page: TargetReport(page, session, pool),
                         "Finish stores it in the project; Cancel leaves the project as it was.")


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
        self.save_page = SavePage(session, self.pool)
        for page in (self.source_page, self.views_page, self.compute_page, self.save_page):
            self.addPage(page)
        self.currentIdChanged.connect(self._on_page)
        self._fit_screen()

    def _fit_screen(self) -> None:
        """1280 × 720, less where the screen is smaller (1366 × 768 leaves about 700 px under a title bar)."""
        screen = self.screen().availableGeometry() if self.screen() is not None else None
        width, height = 1280, 720
        if screen is not None:
            width, height = min(width, screen.width() - 20), min(height, screen.height() - 40)
        self.resize(width, height)

    def _on_page(self, _page_id: int) -> None:
        """Back on the views page after a calibration: the view opened shows its residual vectors."""
        if self.currentPage() is self.views_page and self.session.views is not None:
            self.views_page.refresh_view()

    def reject(self) -> None:
        """Cancel: stop a running detection (its worker stops at the next image); nothing is stored."""
        self.views_page.stop()
        self.compute_page.stop()
        self.save_page.report.cancel()
        super().reject()


def open_target_wizard(project, phase: str, parent: QtWidgets.QWidget | None = None) -> TargetWizard:
    """The target wizard for ``phase`` over ``project``, shown (not modal)."""
    wizard = TargetWizard(TargetSession(project, phase), parent)
    wizard.setAttribute(QtCore.Qt.WidgetAttribute.WA_DeleteOnClose, True)
    wizard.show()
    return wizard

