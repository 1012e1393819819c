"""The object list: the measured objects; select (drives the geo-calculator and the highlight), edit
attribute and notes in place, delete, zoom to, go to the frame measured on; each one's review state, and
its history (right-click › History…, or H in the list). An object measured on several
instants shows its combined figure and how many instants it has; a further instant's row is greyed and
its figure cell names its object (its own figure alone is in the tooltip, not to be read as the object's).

A view over :class:`usvips.gui.qt.object_table.ObjectTableModel`, which reads each drawn row from the
workspace's object cache: a survey of 100,000 objects opens and scrolls without a row made per object,
and the figures are computed (in a worker) for the rows drawn. Sorting (click a column's header) and the
filter (text in any cell) live in the model."""

from __future__ import annotations

from collections.abc import Iterable

from PySide6 import QtCore, QtGui, QtWidgets

from usvips.core.errors import UsvipsError
from usvips.gui.panel_registry import Panel, register
from usvips.gui.qt.object_table import ObjectTableModel, figure_texts, instant_figure, review_text
from usvips.gui.qt.worker import Worker, start
from usvips.gui.workspace import Workspace

__all__ = ["ObjectList", "figure_texts", "instant_figure", "review_text"]


class ObjectList(QtWidgets.QWidget):
    """The measured objects: select (drives the geo-calculator and the highlight), edit attribute and
    notes in place, delete, zoom to."""

    zoom_requested = QtCore.Signal(int)
    selection_changed = QtCore.Signal(list)
    #: an object's row double-clicked (its id): the video goes to the frame it was measured on
    object_activated = QtCore.Signal(int)

    #: species: the observation record's (the one place a species is kept), × the number when more than one;
    #: pair: the image pair or video measured on; frame: a video's left | right frame and time; review: the
    #: second reader's verdict (unreviewed, accepted, flagged: reason)
    COLUMNS = ("id", "type", "species", "attribute", "vertices", "figure", "quality", "review", "notes", "pair",
               "frame")
    #: the columns edited in place (every other cell is read-only)
    EDITABLE = ("attribute", "notes")
    #: Objects whose figures are computed at once when they change; more go to a worker thread.
    SYNCHRONOUS = 2
    #: Up to this many rows the columns are fitted to their contents on every change.
    FIT_ROWS = 200
    #: Rows whose figures are computed when a project opens before any row is drawn (a screenful)
    FIRST_ROWS = 60
    #: Up to this many objects every figure is computed in a worker when the list is made or the rules
    #: change; in a larger survey only the drawn rows' figures are (as they are drawn)
    EAGER = 1000
    #: Objects a figures worker takes at a time: their inputs are copied out of the project on the GUI
    #: thread (0.15-0.25 ms an object; a sort by length of 100,000 copied them all at once, a 14 s freeze),
    #: the others wait in a queue and are copied job by job (~15-25 ms a job)
    JOB_OBJECTS = 100

    def __init__(self, workspace: Workspace, parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(parent)
        self.workspace = workspace
        grey = self.palette().brush(QtGui.QPalette.ColorGroup.Disabled, QtGui.QPalette.ColorRole.Text)
        self.model = ObjectTableModel(workspace, self.COLUMNS, self.EDITABLE, grey, self._edit_cell, self)
        self.table = QtWidgets.QTableView()
        self.table.setModel(self.model)
        self.table.setSelectionBehavior(QtWidgets.QAbstractItemView.SelectionBehavior.SelectRows)
        self.table.verticalHeader().hide()
        self.table.verticalHeader().setSectionResizeMode(QtWidgets.QHeaderView.ResizeMode.Fixed)
        self.table.horizontalHeader().setStretchLastSection(True)
        self.table.horizontalHeader().setSortIndicatorShown(True)
        self.table.horizontalHeader().setSortIndicatorClearable(True)  # a third click: the stored order
        self.table.horizontalHeader().setSectionsClickable(True)
        self.table.horizontalHeader().setSortIndicator(-1, QtCore.Qt.SortOrder.AscendingOrder)
        self.table.horizontalHeader().sortIndicatorChanged.connect(self.sort)
        self.table.setWordWrap(False)  # one line a row (a long figure is elided; its tooltip and width show it)
        self.table.setEditTriggers(QtWidgets.QAbstractItemView.EditTrigger.DoubleClicked
                                   | QtWidgets.QAbstractItemView.EditTrigger.EditKeyPressed)
        self.filter = QtWidgets.QLineEdit()
        self.filter.setPlaceholderText("filter: text in any column")
        self.filter.setClearButtonEnabled(True)
        self.filter.textChanged.connect(self.set_filter)
        # a sort by a figure, or a filter, at survey size: every figure computed first (in the worker)
        self.completing = QtWidgets.QProgressBar()
        self.completing.setObjectName("figures_for_order")
        self.completing.setRange(0, 100)
        self.completing.setMinimumWidth(190)
        self.completing.hide()
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
        buttons.addSpacing(12)
        buttons.addWidget(self.filter, 1)  # beside the buttons: the dock's height is for rows
        buttons.addWidget(self.completing)
        repick.clicked.connect(lambda: self._edit_vertex(self.workspace.pick_tool.start_repick))
        delete_vertex.clicked.connect(lambda: self._edit_vertex(self.workspace.edits.delete_vertex))
        layout = QtWidgets.QVBoxLayout(self)
        layout.setContentsMargins(2, 2, 2, 2)
        #: shown while the project's objects are being read (a worker): the rows follow when they arrive
        self.reading = QtWidgets.QLabel("reading the objects…")
        self.reading.setObjectName("objects_reading")
        self.reading.hide()
        layout.addWidget(self.reading)
        layout.addWidget(self.table)
        layout.addLayout(buttons)
        delete.clicked.connect(self._on_delete)
        zoom.clicked.connect(self._on_zoom)
        delete.setToolTip("delete the selected objects (Delete in the list; Ctrl+Z undoes it)")
        # the Delete key in the list (not while a cell is being edited: the editor has the key then)
        self.delete_shortcut = QtGui.QShortcut(QtGui.QKeySequence(QtCore.Qt.Key.Key_Delete), self.table)
        self.delete_shortcut.setContext(QtCore.Qt.ShortcutContext.WidgetShortcut)
        self.delete_shortcut.activated.connect(self._on_delete)
        self.table.selectionModel().selectionChanged.connect(self._on_table_selection)
        self.table.selectionModel().selectionChanged.connect(self._on_vertex_range)
        # an object's history (who made it, every change): the context menu, or H on its row
        self.table.setContextMenuPolicy(QtCore.Qt.ContextMenuPolicy.CustomContextMenu)
        self.table.customContextMenuRequested.connect(self._context_menu)
        self.history_shortcut = QtGui.QShortcut(QtGui.QKeySequence(QtCore.Qt.Key.Key_H), self.table)
        self.history_shortcut.setContext(QtCore.Qt.ShortcutContext.WidgetShortcut)
        self.history_shortcut.activated.connect(self.show_history)
        self.history_dialogs: list = []  # open history windows (not modal)
        self.table.doubleClicked.connect(self._on_double_click)
        self._worker: Worker | None = None
        self._pending: list[int] = []  # the ids the running figures worker computes
        self._queue: list[int] = []  # the ids waiting for the next figures worker (see JOB_OBJECTS)
        self._queued_total = 0  # the ids of the jobs since the queue was last empty (the progress of a sort)
        self._asked: set[int] = set()  # the ids the rows had asked for at the last look (_compute_wanted)
        #: why every figure is being computed (a sort by a figure, a filter), the rows arranged again when done
        self._completing: str | None = None
        self._fitted = False  # a large list's columns fitted to the rows on screen with their figures
        self._sorts_due = 0  # sorts by a figure whose missing figures are yet to be looked for (see sort)
        # the figures of drawn rows not known yet: gathered while the rows are drawn, computed after
        self._wanted_timer = QtCore.QTimer(self)
        self._wanted_timer.setSingleShot(True)
        self._wanted_timer.setInterval(0)
        self._wanted_timer.timeout.connect(self._compute_wanted)
        self.model.wanted.connect(self._wanted_timer.start)
        self._events = ((workspace.objects_reset, self.refresh), (workspace.objects_added, self._on_added),
                        (workspace.objects_updated, self._on_updated), (workspace.objects_removed, self._on_removed),
                        (workspace.rules_changed, self._on_rules_changed),
                        (workspace.selection_changed, self._on_model_selection),
                        (workspace.project_changed, self._close_history_dialogs))
        for signal, slot in self._events:
            signal.connect(slot)
        self.refresh()

    def cleanup(self) -> None:
        for signal, slot in self._events:
            signal.disconnect(slot)
        if self._worker is not None:  # what it reports is dropped: the list may be gone by then
            self._worker.cancel()
            self._worker, self._pending, self._completing = None, [], None
        self._queue = []

    # ------------------------------------------------------------------ rows
    def row_count(self) -> int:
        return self.model.rowCount()

    def object_id(self, row: int) -> int:
        """The id of the object on ``row``."""
        return self.model.object_id(row)

    def row_of(self, object_id: int) -> int | None:
        """The table row showing ``object_id`` (None when it has none: not stored, or filtered out)."""
        return self.model.row_of(object_id)

    def text(self, row: int, column: str) -> str:
        """The text of a cell (``column`` by name), as drawn."""
        return self.model.index(row, self.COLUMNS.index(column)).data() or ""

    def selected_ids(self) -> list[int]:
        rows = sorted(index.row() for index in self.table.selectionModel().selectedRows())
        return [self.model.object_id(r) for r in rows if r < self.model.rowCount()]

    def visible_rows(self) -> range:
        """The rows the table shows now (the first screenful when it is not laid out yet)."""
        count = self.model.rowCount()
        top = self.table.rowAt(0)
        if top < 0 or not self.table.isVisible():
            return range(min(count, self.FIRST_ROWS))
        bottom = self.table.rowAt(self.table.viewport().height() - 1)
        return range(top, (count - 1 if bottom < 0 else bottom) + 1)

    # ------------------------------------------------------------------ sorting and filtering
    #: the columns made from an object's figures: a sort by them needs every figure
    FIGURE_COLUMNS = ("figure", "quality")

    def sort(self, column: int, order: QtCore.Qt.SortOrder = QtCore.Qt.SortOrder.AscendingOrder) -> None:
        """Rows by ``column`` (-1: by id). By a figure column in a survey whose figures are not all known
        yet: sorted at once by what is known (the others last), every missing figure computed in the worker
        (progress beside the filter) and the rows sorted again when they are in (:attr:`arranging` until
        then).

        The missing figures are looked for, and the first job's inputs copied, at a later turn of the event
        loop, so that the rows arranged by what is known are drawn (and a key or click handled) first: the
        click was one step of ~0.12 s at 20,000 objects. Nothing is marked as waiting meanwhile — a figures
        job that ends in between cannot complete the sort early — and the later turn looks again at what is
        missing then."""
        self.model.sort(column, order)
        if column >= 0 and self.COLUMNS[column] in self.FIGURE_COLUMNS:
            project = self.workspace.project
            self._sorts_due += 1
            if self._completing is None and self.workspace.cache.missing_figures() > self.SYNCHRONOUS:  # said now
                self.completing.setFormat(f"sorting by {self.COLUMNS[column]}: %p%")
                self.completing.setValue(0)
                self.completing.show()
            # a timer, not a queued call: that would run with the paint, in one step
            QtCore.QTimer.singleShot(1, self, lambda: self._complete_sort(column, order, project))

    @property
    def arranging(self) -> bool:
        """A sort or filter is waiting for figures (its rows are arranged again when they are in)."""
        return self._sorts_due > 0 or self._completing is not None

    def _complete_sort(self, column: int, order: QtCore.Qt.SortOrder, project: object) -> None:
        """A sort's missing figures computed (see :meth:`sort`); nothing when the rows are sorted otherwise or
        another project is open by now."""
        self._sorts_due -= 1
        if (self.model.sort_column, self.model.sort_order) == (column, order) and self.workspace.project is project:
            self._complete_figures(f"sorting by {self.COLUMNS[column]}")
        if self._completing is None and self._sorts_due == 0:  # every figure was known: nothing to wait for
            self.completing.hide()

    def set_filter(self, text: str) -> None:
        """Only the rows with ``text`` in a cell; a figure's text counts too, so the missing figures are
        computed (in the worker, with progress) and the rows filtered again when they are in."""
        self.model.set_filter(text)
        if text.strip():
            self._complete_figures("filtering")

    def _complete_figures(self, why: str) -> None:
        missing = [i for i, known in self.workspace.cache.figures_known(self.workspace.cache.ids()).items()
                   if known is None]
        if not missing:
            return
        self._completing = why
        if len(missing) > self.SYNCHRONOUS:
            self.workspace.message.emit("info", f"{why}: computing the figures of {len(missing):,} objects first "
                                                "(the rows are arranged again when they are in)")
        self._compute(missing, checked=True)
        if self._worker is None:  # computed at once
            self._completed()

    def _on_completing_progress(self, fraction: float) -> None:
        self.completing.setValue(self._completed_share(fraction))

    def _completed(self) -> None:
        """Every figure the sort or filter asked for is known: the rows arranged again."""
        if self._completing is not None:
            self._completing = None
            self.completing.hide()
            self.model.rearrange()
            self._fitted = False  # other rows on screen: the columns fitted to them
            self._fit()

    # ------------------------------------------------------------------ the model's events
    def refresh(self, *_: object) -> None:
        """Every row again (another project, everything read again): the rows come from the model's cache;
        the figures of the first screenful are computed at once (a worker when many), the others' as they
        are drawn. While the objects are being read the list is empty and says so."""
        self.reading.setVisible(self.workspace.cache.loading)
        self.model.reset(self.workspace.cache.instant_links(), self._read_reviews())
        self._pending, self._queue, self._fitted = [], [], False
        self._compute(self._first_figures())
        self._fit()
        self._on_model_selection(self.workspace.selection)

    def _on_added(self, ids: tuple[int, ...]) -> None:
        self._read_links()
        self.model.add(ids)
        self._compute(list(ids), queue=True)
        self._fit(ids)

    def _on_updated(self, ids: tuple[int, ...]) -> None:
        self._read_links()
        self._read_reviews_of(ids)  # an edit returns an accepted object to unreviewed
        self.model.changed(ids)
        self._compute(list(ids), queue=True)
        self._on_vertex_range()

    def _on_removed(self, ids: tuple[int, ...]) -> None:
        gone = set(ids)
        self._pending = [i for i in self._pending if i not in gone]
        self._queue = [i for i in self._queue if i not in gone]
        self.model.remove(ids)
        self._read_links()

    def _on_rules_changed(self, _rules) -> None:
        """New rules: every figure again, computed for the rows drawn (the others when they are)."""
        self.model.forget_figures()
        if self._worker is not None:  # computing under the old rules: what it finds would be dropped
            self._worker.cancel()
        column = self.model.sort_column
        if column >= 0 and self.COLUMNS[column] in self.FIGURE_COLUMNS:
            self._complete_figures(f"sorting by {self.COLUMNS[column]}")  # the new figures may reorder the rows
        elif self.model.filter_text:
            self._complete_figures("filtering")
        else:
            self._compute(self._first_figures())

    def _first_figures(self) -> list[int]:
        """The ids whose figures are computed at once: every object's in a small project, else the drawn
        rows' (the others as they are drawn)."""
        if self.model.rowCount() <= self.EAGER:
            return self.model.ids()
        return [self.model.object_id(r) for r in self.visible_rows()]

    def _read_links(self) -> None:
        """The project's instant links (as the object cache holds them); the rows whose part in them changed
        (the instant and its object, for the count) are drawn again."""
        self.model.set_links(self.workspace.cache.instant_links())

    def _on_model_selection(self, ids: tuple[int, ...]) -> None:
        """Show the model's selection (when the list did not make it)."""
        if set(ids) == set(self.selected_ids()):
            return
        selection = QtCore.QItemSelection()
        last = len(self.COLUMNS) - 1
        rows = [row for row in (self.model.row_of(i) for i in ids) if row is not None]
        for row in rows:
            selection.select(self.model.index(row, 0), self.model.index(row, last))
        selecting = self.table.selectionModel()
        selecting.blockSignals(True)
        try:
            selecting.select(selection, QtCore.QItemSelectionModel.SelectionFlag.ClearAndSelect)
            if rows:
                selecting.setCurrentIndex(self.model.index(rows[0], 0),
                                          QtCore.QItemSelectionModel.SelectionFlag.NoUpdate)
        finally:
            selecting.blockSignals(False)
        self.table.viewport().update()
        self._on_vertex_range()

    def _on_table_selection(self, *_: object) -> None:
        ids = self.selected_ids()
        self.workspace.select(ids)
        self.selection_changed.emit(ids)

    # ------------------------------------------------------------------ figures
    def _compute_wanted(self) -> None:
        """The figures the rows asked for since the last call, and those asked for before whose rows are still
        on screen: a row scrolled away before its figure came asks again when it is drawn again (a fast
        scroll through a survey would otherwise queue every page it passed, each on the GUI thread)."""
        shown = {self.model.object_id(r) for r in self.visible_rows()}
        stale = {i for i in self.model.requested & self._asked if i not in shown}
        self.model.requested -= stale
        self._asked = set(self.model.requested)
        wanted = [i for i in sorted(self.model.requested) if i in self.workspace.cache]
        self._compute(wanted)

    def _compute(self, ids: list[int], queue: bool = False, checked: bool = False) -> None:
        """Figures of ``ids`` not yet known: at once for a few, else in workers of :data:`JOB_OBJECTS` objects
        at a time, ``ids`` first. A job replaced by a newer one hands on the ids still wanted — all of them
        while a sort or filter waits for every figure or in a small list, else only the rows drawn (a fast
        scroll through a survey asked for every page it passed). With ``queue`` (objects stored or changed) a
        running job is not replaced: ``ids`` wait next in line (a run's proposals come a slice a turn; replacing
        the job for each slice copied the inputs of every slice before it again on the window's thread; an id
        of the running job changed meanwhile is computed again after it, :meth:`_on_figures`). ``checked``:
        ``ids`` are held objects whose figures are not known, just looked at (a sort's 20,000: not again)."""
        cache = self.workspace.cache
        missing = ids if checked else [i for i, known in cache.figures_known(i for i in ids if i in cache).items()
                                       if known is None]
        running = self._worker is not None and not self._worker.is_cancelled
        pending, waiting = (set(self._pending), set(self._queue)) if running else (set(), set())
        if 0 < len(missing) <= self.SYNCHRONOUS and not set(missing) & (pending | waiting):
            for object_id in missing:  # (one a worker holds is not computed here too: an object of many
                self.workspace.figures([object_id])  # instants takes tens of ms on the window's thread)
            self.model.changed(missing)
        elif missing:
            if running:
                if set(missing) <= pending:
                    return  # being computed
                if queue or len(missing) <= self.SYNCHRONOUS or set(missing) <= pending | waiting:  # next in line
                    self._queued_total += sum(i not in pending and i not in waiting for i in missing)
                    self._queue = list(dict.fromkeys([*(i for i in missing if i not in pending), *self._queue]))
                    return
            if self._worker is not None:
                done = max(self._queued_total - len(self._pending) - len(self._queue), 0)
                self._worker.cancel()
                keep_all = self._completing is not None or self.model.rowCount() <= self.EAGER
                carried = [i for i in (*self._pending, *self._queue)
                           if i in cache and (keep_all or i in self.model.requested)]
                missing = list(dict.fromkeys([*missing, *carried]))
                self._queued_total = done + len(missing)
            else:
                self._queued_total = len(missing)
            self._start_job(missing)

    def _start_job(self, ids: list[int]) -> None:
        """A figures worker for the first :data:`JOB_OBJECTS` of ``ids`` still without figures; the rest
        queued for the next (looked at only as their turn comes: the whole queue of a sort of 100,000 looked
        at for every job would itself be a step of the GUI thread that grows with the survey)."""
        cache = self.workspace.cache
        taken, looked = [], 0
        while looked < len(ids) and len(taken) < self.JOB_OBJECTS:
            object_id = ids[looked]
            looked += 1
            if object_id in cache and cache.known_figures(object_id) is None:
                taken.append(object_id)
        self._pending, self._queue = taken, ids[looked:]
        if not taken:
            return
        job = cache.figures_job(self._pending)
        worker = self._worker = Worker(job, "computing the objects' figures")
        worker.signals.finished.connect(lambda results, j=job, w=worker: self._on_figures(j, w, results))
        worker.signals.cancelled.connect(lambda w=worker: self._on_cancelled(w))
        if self._completing is not None:  # a sort or filter waits for these: say how far
            self.completing.setFormat(f"{self._completing}: %p%")
            self.completing.setValue(self._completed_share(0.0))
            self.completing.show()
            worker.signals.progress.connect(self._on_completing_progress)  # a method: dropped with the list
        start(worker)

    def _completed_share(self, fraction: float) -> int:
        """Percent of the ids queued since the queue was last empty that are done (``fraction`` of the
        running job's)."""
        total = max(self._queued_total, 1)
        waiting = len(self._queue) + (1.0 - fraction) * len(self._pending)
        return int(100 * min(max(1.0 - waiting / total, 0.0), 1.0))

    def _on_cancelled(self, worker: Worker) -> None:
        """A figures worker stopped early: the rows still drawn without figures ask again when drawn."""
        if worker is self._worker:
            self._worker, self._pending, self._queue = None, [], []
            self.model.requested.clear()
            self._completing = None
            self.completing.hide()

    def _on_figures(self, job, worker: Worker, results: dict) -> None:
        current = worker is self._worker
        if current:
            self._worker, self._pending = None, []
        cache = self.workspace.cache
        kept = cache.remember(job, results)
        self.model.requested -= set(kept)
        self.model.changed(kept)
        done = set(kept)
        stale = [i for i in job.versions if i not in done and i in cache and cache.known_figures(i) is None]
        if current and stale:  # changed while computed (a fish's object told again with its later instants): next
            self._queue = list(dict.fromkeys([*stale, *self._queue]))
            self._queued_total += len(stale)
        if current and self._queue:  # the next job of the queue (its inputs copied now, a job's worth)
            self._start_job(self._queue)
        if self._worker is None:
            self._completed()
        self._fit(kept)
        if current or self._worker is None:
            self._compute_wanted()  # rows drawn meanwhile

    def _fit(self, ids: Iterable[int] | None = None) -> None:
        """The columns fitted to their contents: to every row's in a small list, else to the rows on
        screen once their figures are shown (a survey's 100,000 rows are not read to size a column). With
        ``ids`` (objects added, figures come) a small list's columns only widen to those rows' texts: fitting
        every row again on each change cost 0.15 ms a row on the GUI thread (30 ms at 200 rows, every
        object stored)."""
        if self.model.rowCount() <= self.FIT_ROWS:
            if ids is None:
                self.table.resizeColumnsToContents()
            else:
                rows = [row for row in (self.model.row_of(i) for i in ids) if row is not None]
                self._widen_to(rows, shrink=False)
        elif not self._fitted and self.table.isVisible():
            rows = self.visible_rows()
            self._widen_to(rows, shrink=True)
            self._fitted = bool(rows) and all(self.workspace.cache.known_figures(self.model.object_id(r)) is not None
                                              for r in rows)

    def _widen_to(self, rows: Iterable[int], shrink: bool) -> None:
        """Each column (but the last, which stretches) as wide as its title and the texts of ``rows``; with
        ``shrink`` False never narrower than it is."""
        ids = [self.model.object_id(r) for r in rows]
        if not ids:
            return
        cache = self.workspace.cache
        # each row's cells made once (a row whose figures are not known yet — one just stored — keeps no texts:
        # asked cell by cell, its whole row was made again for each of its 11 cells)
        rows_texts = [self.model.texts(i) if i in cache else ("",) * len(self.COLUMNS) for i in ids]
        metrics, header = self.table.fontMetrics(), self.table.horizontalHeader()
        for column in range(len(self.COLUMNS) - 1):
            widest = max([metrics.horizontalAdvance(texts[column]) for texts in rows_texts], default=0)
            title = header.fontMetrics().horizontalAdvance(self.COLUMNS[column].capitalize())
            width = max(widest, title) + 16
            if shrink or width > self.table.columnWidth(column):
                self.table.setColumnWidth(column, width)

    def _edit_cell(self, object_id: int, column: str, text: str) -> None:
        """Attribute or notes typed in place: stored (undoably) with the other of the two unchanged."""
        stored = self.workspace.stored_object(object_id)
        attribute = text if column == "attribute" else stored.attribute
        notes = text if column == "notes" else stored.notes
        self.workspace.edits.edit_object(object_id, attribute, notes)

    def _on_vertex_range(self, *_: object) -> None:
        ids = self.selected_ids()
        count = len(self.workspace.stored_object(ids[0]).vertices) if len(ids) == 1 else 1
        self.vertex.setRange(1, max(count, 1))
        self.kind.clear()
        if len(ids) == 1:
            self.kind.addItems(self.workspace.edits.kinds_for(ids[0]))

    def _on_set_kind(self) -> None:
        ids = self.selected_ids()
        if len(ids) != 1 or not self.kind.currentText():
            self.workspace.message.emit("warning", "select one object in the list to change its kind")
            return
        try:
            self.workspace.edits.change_kind(ids[0], self.kind.currentText())
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
            self.workspace.edits.delete_object(object_id)

    def _on_double_click(self, index: QtCore.QModelIndex) -> None:
        if index.isValid():
            object_id = self.model.object_id(index.row())
            self.object_activated.emit(object_id)
            self.workspace.request_object(object_id)  # other views (the video) go to it by the model

    def _on_zoom(self) -> None:
        ids = self.selected_ids()
        if ids:
            self.zoom_requested.emit(ids[0])
            self.workspace.request_object(ids[0])

    # ------------------------------------------------------------------ reviews and history
    def _read_reviews(self) -> dict[int, object]:
        """Every object's review, by one query (none without a project, or when it cannot be read)."""
        project = self.workspace.project
        if project is None or self.workspace.cache.loading:  # read with the objects, once they arrive
            return {}
        try:
            return {r.object_id: r for r in project.reviews()}
        except UsvipsError as error:
            self.workspace.message.emit("warning", f"the review states cannot be shown: {error}")
            return {}

    def _read_reviews_of(self, ids: tuple[int, ...]) -> None:
        """The reviews of the objects ``ids`` read again (one query for one object, else one for all)."""
        project = self.workspace.project
        if project is None or not ids:
            return
        reviews = self.model.reviews
        try:
            if len(ids) == 1:
                reviews[ids[0]] = project.review(ids[0])
            else:
                every = {r.object_id: r for r in project.reviews()}
                reviews.update({i: every[i] for i in ids if i in every})
        except UsvipsError as error:
            self.workspace.message.emit("warning", f"the review states cannot be shown: {error}")

    def refresh_review(self, object_id: int) -> None:
        """Read one object's review again (one query) and show it (another annotator's review)."""
        self._read_reviews_of((object_id,))
        if object_id in self.model.reviews:
            self.show_review(object_id, self.model.reviews[object_id])

    def reload_reviews(self) -> None:
        """Read every object's review again (others may have reviewed meanwhile) and show the changed ones."""
        reviews = self._read_reviews()
        changed = [i for i in set(reviews) | set(self.model.reviews)
                   if review_text(reviews.get(i)) != review_text(self.model.reviews.get(i))]
        self.model.reviews = reviews
        self.model.changed(changed)

    def show_review(self, object_id: int, review) -> None:
        """An object's review changed (review mode): its Review cell."""
        self.model.reviews[object_id] = review
        self.model.changed([object_id])

    def _context_menu(self, position: QtCore.QPoint) -> None:
        row = self.table.rowAt(position.y())
        if not 0 <= row < self.model.rowCount():
            return
        object_id = self.model.object_id(row)
        menu = QtWidgets.QMenu(self)
        menu.addAction(f"History of object {object_id}…\tH", lambda: self.show_history(object_id))
        menu.addAction("Zoom to", lambda: self.zoom_requested.emit(object_id))
        for action in self.table.actions():  # what the window adds for the list (the object's instants)
            menu.addAction(action)
        menu.exec(self.table.viewport().mapToGlobal(position))

    def show_history(self, object_id: int | None = None):
        """Open the history of ``object_id`` (default: the current row's object); returns the dialog."""
        from usvips.gui.qt.history_dialog import HistoryDialog

        if object_id is None:
            row = self.table.currentIndex().row()
            if not 0 <= row < self.model.rowCount():
                self.workspace.message.emit("warning", "select an object in the list to see its history")
                return None
            object_id = self.model.object_id(row)
        if self.workspace.project is None:
            return None
        dialog = HistoryDialog(self.workspace.project, object_id, self.window())
        dialog.setAttribute(QtCore.Qt.WidgetAttribute.WA_DeleteOnClose)
        dialog.destroyed.connect(lambda _=None, d=dialog: self.history_dialogs.remove(d)
                                 if d in self.history_dialogs else None)
        self.history_dialogs.append(dialog)
        dialog.show()
        return dialog

    def _close_history_dialogs(self, _project=None) -> None:
        """Another project (or none) is open: the history windows of the previous one's objects close (their
        store is closed; an object of the same number in the new project is another object)."""
        for dialog in list(self.history_dialogs):
            self.history_dialogs.remove(dialog)
            dialog.close()


#: the panel's declaration (usvips.gui.panel_registry): the window builds its dock from it
PANEL = register(Panel("objects", "Objects", "bottom", lambda context: ObjectList(context.workspace),
                     group="records", order=40, size=240))  # (about six rows with its buttons)
