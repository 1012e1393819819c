"""Measure › Pointing test… — click N rendered targets whose true points are known; the program estimates
your pointing σ with its interval and offers to store it for you (the annotator) in the project, where it
becomes the σ of your hand clicks in every figure (:mod:`usvips.app.pointing_settings`). A view over
:class:`~usvips.gui.pointing_test_model.PointingTestModel`; the targets are rendered in a worker.

Mouse: click the point (it is taken at once). Keyboard: the arrow keys move the cross-hair by a quarter of
an image pixel (with Shift, by two), Enter or Space takes it. The image is shown magnified
(:data:`ZOOM` × its pixels, as a loupe), the cross-hair drawn in red.

Measure › Check σ (Monte Carlo)… runs ``usvips project check --sigma`` in a worker and shows its table.
"""

from __future__ import annotations

from PySide6 import QtCore, QtGui, QtWidgets

from usvips.app.pointing_settings import add_estimate
from usvips.core.errors import UsvipsError
from usvips.core.pointing_test import HEIGHT, WIDTH
from usvips.gui.pointing_test_model import COUNT, PointingTestModel
from usvips.gui.qt.worker import Worker, start
from usvips.gui.window_context import WindowContext

#: how many screen pixels an image pixel is shown as
ZOOM = 4
#: the keyboard's steps (image pixels): plain, with Shift
STEP, BIG_STEP = 0.25, 2.0


class _Canvas(QtWidgets.QWidget):
    """The current trial's image, magnified, with the cross-hair at the model's cursor."""

    clicked = QtCore.Signal(float, float)

    def __init__(self, model: PointingTestModel, parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(parent)
        self.model = model
        self.setFixedSize(WIDTH * ZOOM, HEIGHT * ZOOM)
        self.setCursor(QtCore.Qt.CursorShape.CrossCursor)
        self.setFocusPolicy(QtCore.Qt.FocusPolicy.NoFocus)

    def paintEvent(self, event) -> None:  # noqa: N802 (Qt)
        painter = QtGui.QPainter(self)
        painter.fillRect(self.rect(), QtGui.QColor(40, 40, 40))
        trial = self.model.current
        if trial is None:
            return
        image = QtGui.QImage(trial.image.data, WIDTH, HEIGHT, WIDTH, QtGui.QImage.Format.Format_Grayscale8)
        painter.drawImage(QtCore.QRect(0, 0, WIDTH * ZOOM, HEIGHT * ZOOM), image)
        # image pixel (x, y) has its centre at screen ((x + 0.5) ZOOM, (y + 0.5) ZOOM)
        x, y = ((self.model.cursor + 0.5) * ZOOM).tolist()
        painter.setPen(QtGui.QPen(QtGui.QColor(255, 40, 40), 1))
        painter.drawLine(QtCore.QPointF(x - 12, y), QtCore.QPointF(x - 3, y))
        painter.drawLine(QtCore.QPointF(x + 3, y), QtCore.QPointF(x + 12, y))
        painter.drawLine(QtCore.QPointF(x, y - 12), QtCore.QPointF(x, y - 3))
        painter.drawLine(QtCore.QPointF(x, y + 3), QtCore.QPointF(x, y + 12))

    def mousePressEvent(self, event) -> None:  # noqa: N802 (Qt)
        if event.button() == QtCore.Qt.MouseButton.LeftButton:
            point = event.position()
            self.clicked.emit(point.x() / ZOOM - 0.5, point.y() / ZOOM - 0.5)


class PointingTestDialog(QtWidgets.QDialog):
    """The test of ``annotator`` (who is at the window) over ``context``'s workspace (the project an estimate
    is stored in) and messages."""

    def __init__(self, context: WindowContext, annotator: str, count: int = COUNT, seed: int | None = None,
                 parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(parent)
        self.workspace = context.workspace
        self.messages = context.messages
        self.annotator = annotator
        self.setWindowTitle("Pointing test")
        self.model = PointingTestModel(count, seed)
        self.canvas = _Canvas(self.model)
        self.canvas.clicked.connect(self._on_click)
        self.instruction = QtWidgets.QLabel()
        self.instruction.setWordWrap(True)
        self.feedback = QtWidgets.QLabel(" ")
        self.result = QtWidgets.QLabel()
        self.result.setWordWrap(True)
        self.result.setTextInteractionFlags(QtCore.Qt.TextInteractionFlag.TextSelectableByMouse)
        self.store = QtWidgets.QPushButton(f"&Store for {annotator}")
        self.store.setEnabled(False)
        self.store.clicked.connect(self.store_estimate)
        close = QtWidgets.QPushButton("&Close")
        close.clicked.connect(self.reject)
        buttons = QtWidgets.QHBoxLayout()
        buttons.addStretch(1)
        buttons.addWidget(self.store)
        buttons.addWidget(close)
        layout = QtWidgets.QVBoxLayout(self)
        layout.addWidget(QtWidgets.QLabel("Click the point each target asks for, as you would when measuring "
                                          "(arrow keys move the cross-hair, Enter takes it)."))
        layout.addWidget(self.instruction)
        layout.addWidget(self.canvas, 0, QtCore.Qt.AlignmentFlag.AlignHCenter)
        layout.addWidget(self.feedback)
        layout.addWidget(self.result)
        layout.addLayout(buttons)
        self.estimate = None
        self.worker = Worker(self.model.render, "rendering the pointing test")
        self.worker.signals.progress.connect(lambda f: self.instruction.setText(f"rendering the targets… {f:.0%}"))
        self.worker.signals.finished.connect(self._on_rendered)
        self.worker.signals.failed.connect(lambda message: self.instruction.setText(message))
        self.instruction.setText("rendering the targets…")
        start(self.worker)

    # ------------------------------------------------------------------ events
    def _on_rendered(self, trials) -> None:
        self.model.set_trials(trials)
        self._refresh()
        self.setFocus()

    def _on_click(self, x: float, y: float) -> None:
        if self.model.current is not None:
            self.feedback.setText(self.model.click(x, y))
            self._refresh()

    def keyPressEvent(self, event) -> None:  # noqa: N802 (Qt)
        step = BIG_STEP if event.modifiers() & QtCore.Qt.KeyboardModifier.ShiftModifier else STEP
        moves = {QtCore.Qt.Key.Key_Left: (-step, 0), QtCore.Qt.Key.Key_Right: (step, 0),
                 QtCore.Qt.Key.Key_Up: (0, -step), QtCore.Qt.Key.Key_Down: (0, step)}
        key = event.key()
        if self.model.current is not None and key in moves:
            self.model.move(*moves[key])
            self.canvas.update()
        elif self.model.current is not None and key in (QtCore.Qt.Key.Key_Return, QtCore.Qt.Key.Key_Enter,
                                                         QtCore.Qt.Key.Key_Space):
            self.feedback.setText(self.model.confirm())
            self._refresh()
        else:
            super().keyPressEvent(event)

    def _refresh(self) -> None:
        self.instruction.setText(self.model.progress_text)
        self.canvas.update()
        if not self.model.finished:
            return
        try:
            self.estimate = self.model.estimate()
            self.result.setText("\n".join(self.model.summary()))
            self.store.setEnabled(self.workspace.project is not None)
            self.store.setFocus()
        except UsvipsError as error:
            self.result.setText(str(error))

    def store_estimate(self) -> None:
        """Store the estimate for the window's annotator (in use from now on) and recompute every figure."""
        project = self.workspace.project
        if self.estimate is None or project is None:
            return
        add_estimate(project, self.estimate, self.annotator,
                     note=f"pointing test: {len(self.model.clicks)} clicks, {len(self.model.misses)} missed")
        self.workspace.pointing_changed()
        self.messages.info(f"pointing σ {self.estimate.sigma_px:.2f} px stored for {self.annotator}: every figure "
                           "of your clicks uses it now")
        self.store.setEnabled(False)
        self.store.setText("Stored")

    def reject(self) -> None:
        self.worker.cancel()
        super().reject()


def show_pointing_test(context: WindowContext, annotator: str, parent: QtWidgets.QWidget) -> PointingTestDialog:
    dialog = PointingTestDialog(context, annotator, parent=parent)
    dialog.setAttribute(QtCore.Qt.WidgetAttribute.WA_DeleteOnClose)
    dialog.show()
    return dialog


def show_sigma_check(context: WindowContext, parent: QtWidgets.QWidget) -> QtWidgets.QDialog | None:
    """Measure › Check σ (Monte Carlo)…: the σ check of the open project, in a worker, its table shown."""
    from usvips.app.sigma_check import COLUMNS, read_check, run_check

    project = context.workspace.project
    if project is None:
        context.messages.error("open a project first: the σ check runs over its objects")
        return None
    try:
        read = read_check(project)
    except UsvipsError as error:
        context.messages.error(str(error))
        return None
    dialog = QtWidgets.QDialog(parent)
    dialog.setWindowTitle("Check σ (Monte Carlo)")
    dialog.setAttribute(QtCore.Qt.WidgetAttribute.WA_DeleteOnClose)
    status = QtWidgets.QLabel(f"simulating {len(read.objects)} objects…")
    status.setWordWrap(True)
    table = QtWidgets.QTableWidget(0, len(COLUMNS))
    table.setHorizontalHeaderLabels(list(COLUMNS))
    table.setEditTriggers(QtWidgets.QAbstractItemView.EditTrigger.NoEditTriggers)
    close = QtWidgets.QPushButton("&Close")
    layout = QtWidgets.QVBoxLayout(dialog)
    for widget in (status, table, close):
        layout.addWidget(widget)
    worker = Worker(lambda progress, cancelled: run_check(read, cancel=cancelled,
                                                          progress=lambda done, total: progress(done / total)),
                    "the σ check")
    close.clicked.connect(lambda: (worker.cancel(), dialog.close()))

    def shown(report) -> None:
        rows = report.rows()
        table.setRowCount(len(rows))
        for r, row in enumerate(rows):
            for c, text in enumerate(row):
                table.setItem(r, c, QtWidgets.QTableWidgetItem(text))
        table.resizeColumnsToContents()
        status.setText("\n".join(report.summary()))

    worker.signals.progress.connect(lambda f: status.setText(f"simulating {len(read.objects)} objects… {f:.0%}"))
    worker.signals.finished.connect(shown)
    worker.signals.failed.connect(status.setText)
    dialog.resize(720, 320)
    dialog.show()
    start(worker)
    return dialog
