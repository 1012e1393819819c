"""The object list: the measured objects; select (drives the geo-calculator and the highlight), edit
attribute and notes in place, delete, zoom to, go to the frame measured on; each one's review state, and
its history (right-click › History…, or H in the list). An object measured on several
instants shows its combined figure and how many instants it has; a further instant's row is greyed and
its figure cell names its object (its own figure alone is in the tooltip, not to be read as the object's)."""

from __future__ import annotations

import bisect
from collections import Counter

from PySide6 import QtCore, QtGui, QtWidgets

from usvips.core.errors import UsvipsError
from usvips.core.measurements.breakdown import breakdown_text
from usvips.gui.calculator import format_figure
from usvips.gui.video_model import video_frame_text
from usvips.gui.wording import species_text
from usvips.gui.worker import Worker, start
from usvips.gui.workspace import Workspace


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

    def __init__(self, workspace: Workspace, parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(parent)
        self.workspace = workspace
        self.table = QtWidgets.QTableWidget(0, len(self.COLUMNS))
        self.table.setHorizontalHeaderLabels([c.capitalize() for c in self.COLUMNS])
        self.table.setSelectionBehavior(QtWidgets.QAbstractItemView.SelectionBehavior.SelectRows)
        self.table.verticalHeader().hide()
        self.table.horizontalHeader().setStretchLastSection(True)
        self.table.setEditTriggers(QtWidgets.QAbstractItemView.EditTrigger.DoubleClicked
                                   | QtWidgets.QAbstractItemView.EditTrigger.EditKeyPressed)
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
        buttons.addStretch(1)
        repick.clicked.connect(lambda: self._edit_vertex(self.workspace.start_repick))
        delete_vertex.clicked.connect(lambda: self._edit_vertex(self.workspace.delete_vertex))
        self.table.itemSelectionChanged.connect(self._on_vertex_range)
        layout = QtWidgets.QVBoxLayout(self)
        layout.setContentsMargins(2, 2, 2, 2)
        layout.addWidget(self.table)
        layout.addLayout(buttons)
        delete.clicked.connect(self._on_delete)
        zoom.clicked.connect(self._on_zoom)
        delete.setToolTip("delete the selected objects (Delete in the list; Ctrl+Z undoes it)")
        # the Delete key in the list (not while a cell is being edited: the editor has the key then)
        self.delete_shortcut = QtGui.QShortcut(QtGui.QKeySequence(QtCore.Qt.Key.Key_Delete), self.table)
        self.delete_shortcut.setContext(QtCore.Qt.ShortcutContext.WidgetShortcut)
        self.delete_shortcut.activated.connect(self._on_delete)
        self.table.itemSelectionChanged.connect(self._on_table_selection)
        # an object's history (who made it, every change): the context menu, or H on its row
        self.table.setContextMenuPolicy(QtCore.Qt.ContextMenuPolicy.CustomContextMenu)
        self.table.customContextMenuRequested.connect(self._context_menu)
        self.history_shortcut = QtGui.QShortcut(QtGui.QKeySequence(QtCore.Qt.Key.Key_H), self.table)
        self.history_shortcut.setContext(QtCore.Qt.ShortcutContext.WidgetShortcut)
        self.history_shortcut.activated.connect(self.show_history)
        self.history_dialogs: list = []  # open history windows (not modal)
        self._reviews: dict[int, object] = {}  # object id → its Review (read with the rows)
        self.table.itemChanged.connect(self._on_item_changed)
        self.table.cellDoubleClicked.connect(self._on_double_click)
        self._filling = False
        self._ids: list[int] = []  # the object id of each row, ascending (rows are in id order)
        self._worker: Worker | None = None
        self._pending: list[int] = []  # the ids the running figures worker computes
        self._links: dict[int, int] = {}  # a further instant's id -> the id of the object it is an instant of
        self._instants: Counter = Counter()  # an object's id -> how many further instants it has
        self._marked: set[int] = set()  # the objects whose rows are greyed or carry a figure tooltip
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

    def selected_ids(self) -> list[int]:
        rows = sorted({index.row() for index in self.table.selectedIndexes()})
        return [self._ids[r] for r in rows if r < len(self._ids)]

    #: Objects whose figures are computed at once when they change; more go to a worker thread.
    SYNCHRONOUS = 2
    #: Up to this many rows the columns are fitted to their contents on every change.
    FIT_ROWS = 200

    def row_of(self, object_id: int) -> int | None:
        """The table row showing ``object_id`` (None when it has none)."""
        row = bisect.bisect_left(self._ids, object_id)
        return row if row < len(self._ids) and self._ids[row] == object_id else None

    # ------------------------------------------------------------------ the model's events
    def refresh(self, *_: object) -> None:
        """Every row again (another project, new rules): the objects come from the model's cache, the
        figures that are not known yet are computed (in a worker when many)."""
        objects = self.workspace.objects()
        self._reviews = self._read_reviews()
        self._read_links(show=False)
        self._filling = True
        self.table.setUpdatesEnabled(False)
        try:
            self.table.clearContents()
            self.table.setRowCount(len(objects))
            self._ids = [o.id for o in objects]
            for row, stored in enumerate(objects):
                self._set_row(row, stored)
        finally:
            self.table.setUpdatesEnabled(True)
            self._filling = False
        self._compute([o.id for o in objects])
        self._fit()
        self._on_model_selection(self.workspace.selection)

    def _on_added(self, ids: tuple[int, ...]) -> None:
        self._read_links()
        self._filling = True
        try:
            for object_id in ids:
                row = bisect.bisect_left(self._ids, object_id)
                self._ids.insert(row, object_id)
                self.table.insertRow(row)
                self._set_row(row, self.workspace.stored_object(object_id))
        finally:
            self._filling = False
        self._compute(list(ids))
        self._fit()

    def _on_updated(self, ids: tuple[int, ...]) -> None:
        self._read_links()
        self._read_reviews_of(ids)  # an edit returns an accepted object to unreviewed
        self._filling = True
        try:
            for object_id in ids:
                row = self.row_of(object_id)
                if row is not None:
                    self._set_row(row, self.workspace.stored_object(object_id))
        finally:
            self._filling = False
        self._compute(list(ids))
        self._on_vertex_range()

    def _on_removed(self, ids: tuple[int, ...]) -> None:
        for object_id in ids:
            row = self.row_of(object_id)
            if row is not None:
                self.table.removeRow(row)
                del self._ids[row]
        self._read_links()

    def _on_rules_changed(self, _rules) -> None:
        self._compute(list(self._ids))

    def _on_model_selection(self, ids: tuple[int, ...]) -> None:
        """Show the model's selection (when the list did not make it)."""
        if set(ids) == set(self.selected_ids()):
            return
        self.table.blockSignals(True)
        try:
            self.table.clearSelection()
            for object_id in ids:
                row = self.row_of(object_id)
                if row is not None:
                    self.table.selectRow(row)
        finally:
            self.table.blockSignals(False)
        self.table.viewport().update()
        self._on_vertex_range()

    def _on_table_selection(self) -> None:
        ids = self.selected_ids()
        self.workspace.select(ids)
        self.selection_changed.emit(ids)

    # ------------------------------------------------------------------ rows and figures
    #: the columns edited in place (every other cell is read-only)
    EDITABLE = ("attribute", "notes")
    _READ_ONLY = QtWidgets.QTableWidgetItem().flags() & ~QtCore.Qt.ItemFlag.ItemIsEditable
    _FIGURE, _QUALITY = COLUMNS.index("figure"), COLUMNS.index("quality")

    def _set_row(self, row: int, stored) -> None:
        """The row's cells made anew, its figure as known (a survey's 10,000 rows: each cell once, no
        re-reading of what was just written)."""
        main, quality, tip = self._figure_texts(stored.id)
        values = (str(stored.id), stored.kind, species_text(self.workspace.object_record(stored.id)), stored.attribute,
                  str(len(stored.vertices)), main, quality, review_text(self._reviews.get(stored.id)), stored.notes,
                  ", ".join(dict.fromkeys(v.pair for v in stored.vertices if v.pair)), video_frame_text(stored))
        read_only, table = self._READ_ONLY, self.table
        for column, (name, value) in enumerate(zip(self.COLUMNS, values, strict=True)):
            item = QtWidgets.QTableWidgetItem(value)
            if name not in self.EDITABLE:
                item.setFlags(read_only)
            table.setItem(row, column, item)
        self._marked.discard(stored.id)  # new cells: not greyed, no tooltip
        if self._needs_marking(stored.id) or tip:
            self._mark_instant(row, stored.id, tip)

    def _figure_texts(self, object_id: int) -> tuple[str, str, str]:
        """(figure cell, quality cell, figure tooltip) of an object, from the figures known now."""
        result = self.workspace.object_figures(object_id)
        if result is None:
            main, quality = "computing…", ""
        else:
            main = format_figure(result.figures[0]) if result.figures else result.reason
            quality = "; ".join(result.failures) or "ok"
        main, tip = self._instant_figure(object_id, main, result is not None and bool(result.figures))
        if result is not None and result.measurement is not None:  # the sigma's breakdown (one Qt-free text)
            tip = "\n".join(filter(None, [tip, "sigma " + breakdown_text(result.measurement)]))
        return main, quality, tip

    def _needs_marking(self, object_id: int) -> bool:
        """Whether a row's greying or tooltip may have to change: it is (or was) an instant or has some."""
        return object_id in self._links or object_id in self._instants or object_id in self._marked

    def _show_figures(self, row: int, object_id: int) -> None:
        main, quality, tip = self._figure_texts(object_id)
        filling, self._filling = self._filling, True
        try:
            for column, value in ((self._FIGURE, main), (self._QUALITY, quality)):
                item = self.table.item(row, column)
                if item is not None and item.text() != value:
                    item.setText(value)
            if self._needs_marking(object_id) or tip:
                self._mark_instant(row, object_id, tip)
        finally:
            self._filling = filling

    # ---- survey (issue 25): an instant's row belongs to its object ----
    def _read_links(self, show: bool = True) -> None:
        """The project's instant links (as the object cache holds them); the rows whose part in them changed
        (the instant and its object, for the count) are shown again when ``show``."""
        links = self.workspace.cache.instant_links()
        if links == self._links:
            return
        touched = {i for link in set(links.items()) ^ set(self._links.items()) for i in link}
        self._links, self._instants = links, Counter(links.values())
        for object_id in sorted(touched) if show else ():
            row = self.row_of(object_id)
            if row is not None:
                self._show_figures(row, object_id)

    def _instant_figure(self, object_id: int, main: str, figured: bool) -> tuple[str, str]:
        """The figure cell's text and tooltip: an object over several instants says how many (its figure is
        the combined one); a further instant names its object, its own figure only in the tooltip."""
        whole = self._links.get(object_id)
        if whole is not None:
            return (f"instant of #{whole}",
                    f"one instant of object {whole}; this instant alone: {main}. The object's figure is row "
                    f"#{whole}'s, combined over its instants.")
        count = self._instants.get(object_id, 0) + 1
        if count > 1 and figured:
            return f"{main} ({count} instants)", f"combined over {count} instants (I lists them)"
        return main, ""

    def _mark_instant(self, row: int, object_id: int, tip: str) -> None:
        """A further instant's row greyed (every cell), the figure cell's tooltip set."""
        grey = object_id in self._links
        if grey or tip:
            self._marked.add(object_id)
        else:
            self._marked.discard(object_id)
        brush = self.palette().brush(QtGui.QPalette.ColorGroup.Disabled, QtGui.QPalette.ColorRole.Text) \
            if grey else QtGui.QBrush()
        for column in range(self.table.columnCount()):
            item = self.table.item(row, column)
            if item is not None and (item.foreground() != brush):
                item.setForeground(brush)
        item = self.table.item(row, self.COLUMNS.index("figure"))
        if item is not None and item.toolTip() != tip:
            item.setToolTip(tip)

    def _compute(self, ids: list[int]) -> None:
        """Figures of ``ids`` not yet known: at once for a few, else in a worker (the newest job wins)."""
        missing = [i for i in ids if self.workspace.object_figures(i) is None]
        if 0 < len(missing) <= self.SYNCHRONOUS:
            for object_id in missing:
                self.workspace.figures([object_id])
                row = self.row_of(object_id)
                if row is not None:
                    self._show_figures(row, object_id)
        elif missing:
            if self._worker is not None:
                self._worker.cancel()
                missing = sorted(set(missing) | set(self._pending))
            self._pending = missing
            job = self.workspace.figures_job(missing)
            worker = self._worker = Worker(job, "computing the objects' figures")
            worker.signals.finished.connect(lambda results, j=job, w=worker: self._on_figures(j, w, results))
            start(worker)

    def _on_figures(self, job, worker: Worker, results: dict) -> None:
        if worker is self._worker:
            self._worker, self._pending = None, []
        for object_id in self.workspace.remember_figures(job, results):
            row = self.row_of(object_id)
            if row is not None:
                self._show_figures(row, object_id)
        self._fit()

    def _fit(self) -> None:
        if len(self._ids) <= self.FIT_ROWS:
            self.table.resizeColumnsToContents()

    def _on_item_changed(self, item: QtWidgets.QTableWidgetItem) -> None:
        if self._filling:
            return
        row = item.row()
        object_id = int(self.table.item(row, 0).text())
        attribute = self.table.item(row, self.COLUMNS.index("attribute")).text()
        notes = self.table.item(row, self.COLUMNS.index("notes")).text()
        self.workspace.edit_object(object_id, attribute, notes)

    def _on_vertex_range(self) -> None:
        ids = self.selected_ids()
        count = len(self.workspace.stored_object(ids[0]).vertices) if len(ids) == 1 else 1
        self.vertex.setRange(1, max(count, 1))
        self.kind.clear()
        if len(ids) == 1:
            self.kind.addItems(self.workspace.kinds_for(ids[0]))

    def _on_set_kind(self) -> None:
        ids = self.selected_ids()
        if len(ids) != 1 or not self.kind.currentText():
            self.workspace.message.emit("warning", "select one object in the list to change its kind")
            return
        try:
            self.workspace.change_kind(ids[0], self.kind.currentText())
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
            self.workspace.delete_object(object_id)

    def _on_double_click(self, row: int, _column: int) -> None:
        if row < len(self._ids):
            self.object_activated.emit(self._ids[row])
            self.workspace.request_object(self._ids[row])  # other views (the video) go to it by the model

    def _on_zoom(self) -> None:
        ids = self.selected_ids()
        if ids:
            self.zoom_requested.emit(ids[0])
            self.workspace.request_object(ids[0])

    # ------------------------------------------------------------------ reviews and history
    def _read_reviews(self) -> dict[int, object]:
        """Every object's review, by one query (none without a project, or when it cannot be read)."""
        project = self.workspace.project
        if project is None:
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
        try:
            if len(ids) == 1:
                self._reviews[ids[0]] = project.review(ids[0])
            else:
                every = {r.object_id: r for r in project.reviews()}
                self._reviews.update({i: every[i] for i in ids if i in every})
        except UsvipsError as error:
            self.workspace.message.emit("warning", f"the review states cannot be shown: {error}")

    def refresh_review(self, object_id: int) -> None:
        """Read one object's review again (one query) and show it (another annotator's review)."""
        self._read_reviews_of((object_id,))
        if object_id in self._reviews:
            self.show_review(object_id, self._reviews[object_id])

    def reload_reviews(self) -> None:
        """Read every object's review again (others may have reviewed meanwhile) and show the changed ones."""
        self._reviews = self._read_reviews()
        column = self.COLUMNS.index("review")
        filling, self._filling = self._filling, True
        try:
            for row, object_id in enumerate(self._ids):
                item, text = self.table.item(row, column), review_text(self._reviews.get(object_id))
                if item is not None and item.text() != text:
                    item.setText(text)
        finally:
            self._filling = filling

    def show_review(self, object_id: int, review) -> None:
        """An object's review changed (review mode): its Review cell."""
        self._reviews[object_id] = review
        row = self.row_of(object_id)
        item = self.table.item(row, self.COLUMNS.index("review")) if row is not None else None
        if item is not None:
            filling, self._filling = self._filling, True
            try:
                item.setText(review_text(review))
            finally:
                self._filling = filling

    def _context_menu(self, position: QtCore.QPoint) -> None:
        row = self.table.rowAt(position.y())
        if not 0 <= row < len(self._ids):
            return
        menu = QtWidgets.QMenu(self)
        menu.addAction(f"History of object {self._ids[row]}…\tH", lambda: self.show_history(self._ids[row]))
        menu.addAction("Zoom to", lambda: self.zoom_requested.emit(self._ids[row]))
        for action in self.table.actions():  # what the window adds for the list (the object's instants)
            menu.addAction(action)
        menu.exec(self.table.viewport().mapToGlobal(position))

    def show_history(self, object_id: int | None = None):
        """Open the history of ``object_id`` (default: the current row's object); returns the dialog."""
        from usvips.gui.history_dialog import HistoryDialog

        if object_id is None:
            row = self.table.currentRow()
            if not 0 <= row < len(self._ids):
                self.workspace.message.emit("warning", "select an object in the list to see its history")
                return None
            object_id = self._ids[row]
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


def review_text(review) -> str:
    """A review in the list: ``unreviewed`` (the default), ``accepted``, ``flagged: reason``."""
    if review is None:
        return "unreviewed"
    return review.state + (f": {review.reason}" if review.reason else "")
