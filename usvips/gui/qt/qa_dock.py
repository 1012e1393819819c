"""The QA panel: every object of the survey that breaks a quality rule (rule, value, limit, species,
where), checked in a worker from the window's object cache (:mod:`usvips.gui.qa_model`) and checked
again when objects or the rules change; a click or Enter on a row goes to its pair or video frame with
the object selected."""

from __future__ import annotations

from PySide6 import QtCore, QtGui, QtWidgets

from usvips.gui.panel_registry import Panel, register
from usvips.gui.qa_model import COLUMNS, QaModel, QaRow, summary
from usvips.gui.qt.live_updates import TINT
from usvips.gui.qt.worker import Worker, start
from usvips.gui.window_context import WindowContext


class QaTable(QtCore.QAbstractTableModel):
    """The model's rows for a table view (failures in the default colour, notes greyed)."""

    def __init__(self, model: QaModel, parent: QtCore.QObject | None = None) -> None:
        super().__init__(parent)
        self.model = model
        self.rows: list[QaRow] = []

    def set_rows(self, rows: list[QaRow]) -> None:
        self.beginResetModel()
        self.rows = list(rows)
        self.endResetModel()

    def rowCount(self, parent=QtCore.QModelIndex()) -> int:  # noqa: N802, B008 (Qt's names)
        return 0 if parent.isValid() else len(self.rows)

    def columnCount(self, parent=QtCore.QModelIndex()) -> int:  # noqa: N802, B008
        return 0 if parent.isValid() else len(COLUMNS)

    def data(self, index: QtCore.QModelIndex, role: int = QtCore.Qt.ItemDataRole.DisplayRole):
        if not index.isValid():
            return None
        row = self.rows[index.row()]
        if role == QtCore.Qt.ItemDataRole.DisplayRole:
            return row.cells[index.column()]
        mark = self.model.workspace.cache.marks.get(row.object_id)  # a colleague's change (gui.live_updates)
        if role == QtCore.Qt.ItemDataRole.ToolTipRole:
            return row.message + (f" ({mark.text()})" if mark is not None else "")
        if role == QtCore.Qt.ItemDataRole.BackgroundRole and mark is not None:
            return TINT
        if role == QtCore.Qt.ItemDataRole.ForegroundRole and not row.failure:
            return QtGui.QBrush(QtGui.QColor("gray"))
        return None

    def headerData(self, section: int, orientation, role: int = QtCore.Qt.ItemDataRole.DisplayRole):  # noqa: N802
        if role == QtCore.Qt.ItemDataRole.DisplayRole and orientation == QtCore.Qt.Orientation.Horizontal:
            return COLUMNS[section].capitalize()
        return None


class QaDock(QtWidgets.QWidget):
    """The survey's QA list. ``object_chosen(object_id)``: a row clicked or Enter pressed on it (the
    window hands it to ``Workspace.request_object``: selected, and the views that can show it go to it)."""

    object_chosen = QtCore.Signal(int)
    #: changes within this many ms are checked once (a burst of edits, an import)
    SETTLE_MS = 250

    def __init__(self, workspace, parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(parent)
        self.workspace = workspace
        self.model = QaModel(workspace)
        self.table_model = QaTable(self.model, self)
        self.summary = QtWidgets.QLabel(summary(None))
        self.summary.setObjectName("qa_summary")
        again = QtWidgets.QPushButton("Check &again")
        again.setToolTip("check every object again (after importing a species list, say)")
        again.clicked.connect(self.refresh)
        self.view = QtWidgets.QTableView()
        self.view.setModel(self.table_model)
        self.view.setSelectionBehavior(QtWidgets.QAbstractItemView.SelectionBehavior.SelectRows)
        self.view.setSelectionMode(QtWidgets.QAbstractItemView.SelectionMode.SingleSelection)
        self.view.setEditTriggers(QtWidgets.QAbstractItemView.EditTrigger.NoEditTriggers)
        self.view.verticalHeader().hide()
        self.view.verticalHeader().setDefaultSectionSize(self.view.fontMetrics().height() + 6)  # compact rows
        self.view.horizontalHeader().setStretchLastSection(True)
        self.view.setToolTip("click a row, or Enter, to go to where the object was measured")
        self.view.clicked.connect(self._on_row)
        for key in (QtCore.Qt.Key.Key_Return, QtCore.Qt.Key.Key_Enter):  # Enter on the current row
            enter = QtGui.QShortcut(QtGui.QKeySequence(key), self.view)
            enter.setContext(QtCore.Qt.ShortcutContext.WidgetShortcut)
            enter.activated.connect(lambda: self._on_row(self.view.currentIndex()))
        top = QtWidgets.QHBoxLayout()
        top.addWidget(self.summary, 1)
        top.addWidget(again)
        layout = QtWidgets.QVBoxLayout(self)
        layout.setContentsMargins(2, 2, 2, 2)
        layout.addLayout(top)
        layout.addWidget(self.view)
        self.timer = QtCore.QTimer(self)
        self.timer.setSingleShot(True)
        self.timer.setInterval(self.SETTLE_MS)
        self.timer.timeout.connect(self.refresh)
        self._worker: Worker | None = None
        self._stale = False  # objects changed while the panel was hidden: check when it is shown
        self.model.changed.connect(self._on_model_changed)
        self._events = ((workspace.objects_changed, self.schedule), (workspace.rules_changed, self.schedule))
        for signal, slot in self._events:
            signal.connect(slot)
        self.schedule()

    def cleanup(self) -> None:
        for signal, slot in self._events:
            signal.disconnect(slot)
        self.model.changed.disconnect(self._on_model_changed)
        if self._worker is not None:
            self._worker.cancel()

    @property
    def checking(self) -> bool:
        """A check is waiting (or due when the panel is shown) or running."""
        return self.timer.isActive() or self._worker is not None or self._stale

    def schedule(self, *_: object) -> None:
        """Check again once the changes settle; while the panel is hidden (closed, or a tab behind
        another), when it is shown."""
        self.summary.setText(summary(None))
        if not self.shown():
            self._stale = True
            return
        self.timer.start()

    def shown(self) -> bool:
        """On screen: not closed, and not a tab behind another (Qt moves those out of the window)."""
        return self.isVisible() and not self.visibleRegion().isEmpty()

    def on_shown(self, visible: bool = True) -> None:
        """The panel came on screen (its dock's ``visibilityChanged``): check if anything changed meanwhile."""
        if visible and self._stale:
            self._stale = False
            self.timer.start()

    def showEvent(self, event: QtGui.QShowEvent) -> None:  # noqa: N802 (Qt's name)
        super().showEvent(event)
        self.on_shown(self.shown())  # a tab behind another is "shown" out of the window: not on screen

    def refresh(self) -> None:
        """Check the survey now, in a worker (a newer check cancels an older one)."""
        self.timer.stop()
        if self._worker is not None:
            self._worker.cancel()
        job = self.model.job()
        worker = self._worker = Worker(job, "checking the survey's quality")
        worker.signals.finished.connect(lambda result, j=job, w=worker: self._on_checked(j, w, result))
        worker.signals.failed.connect(lambda message, w=worker: self._on_failed(w, message))
        worker.signals.cancelled.connect(lambda w=worker: self._ended(w))
        start(worker)

    def _ended(self, worker: Worker) -> bool:
        """Forget ``worker``; True when it was the newest (its result is the one to show)."""
        if worker is not self._worker:
            return False
        self._worker = None
        return True

    def _on_checked(self, job, worker: Worker, result) -> None:
        if self._ended(worker):
            self.model.take(job, result)

    def _on_failed(self, worker: Worker, message: str) -> None:
        if self._ended(worker):
            self.summary.setText(message)
            self.workspace.message.emit("error", message)

    def _on_model_changed(self) -> None:
        self.table_model.set_rows(self.model.rows)
        self.summary.setText(self.model.text)  # made in the worker with the rows
        if len(self.model.rows) <= 500:
            self.view.resizeColumnsToContents()

    def _on_row(self, index: QtCore.QModelIndex) -> None:
        if index.isValid() and index.row() < len(self.table_model.rows):
            self.object_chosen.emit(self.table_model.rows[index.row()].object_id)

    def focus_list(self) -> None:
        """Give the keyboard to the list (its first row current), for walking it with the arrows and Enter."""
        self.view.setFocus(QtCore.Qt.FocusReason.ShortcutFocusReason)
        if not self.view.currentIndex().isValid() and self.table_model.rows:
            self.view.setCurrentIndex(self.table_model.index(0, 0))


def _qa(context: WindowContext) -> QaDock:
    """The QA list; a row chosen asks the views to show its object (the model's event)."""
    qa = QaDock(context.workspace)
    qa.object_chosen.connect(context.workspace.request_object)
    return qa


#: the panel's declaration (usvips.gui.panel_registry): the window builds its dock from it
PANEL = register(Panel("qa", "QA", "bottom", _qa, group="records", order=80))
