"""The double-read report in the window (File › Double-read report…, Alt+F then B): choose two annotators, the time
tolerance (in seconds or in frames of the video: one of the two), the gate (m) and k; the report
(:mod:`usvips.app.double_read`, the same as ``usvips project double-read``) is computed in a worker with
progress and a cancel that stops it. The table lists the disagreements first, then species conflicts,
unmatched objects and the pairs that agree; a click on a column's header sorts by it (numbers as numbers,
empty cells last; again: the other way); activating a row (double-click or Enter) goes to its object
(reader A's, else B's) as the QA panel does; another click on the same row goes to the other reader's
object. Save CSV… writes the table as the command line does (in the report's order)."""

from __future__ import annotations

import math

from PySide6 import QtCore, QtWidgets

from usvips.app.double_read import COLUMNS, DoubleReadReport, ReportCancelled, annotators, compute, read_inputs
from usvips.core.errors import UsvipsError
from usvips.gui.qt.field_errors import FormFields
from usvips.gui.qt.worker import Cancelled, Worker, start
from usvips.gui.window_context import WindowContext
from usvips.io.double_read_table import write_double_read_csv

#: the units the time tolerance may be given in: (shown, suffix, decimals, default, largest)
TOLERANCE_UNITS = (("seconds", " s", 2, 0.5, 3600.0), ("frames", " frames", 0, 12, 100000.0))

#: the table's columns: (header, key, lengths shown in mm)
SHOWN = (("what", "row", False), ("object A", "object_a", False), ("object B", "object_b", False),
         ("where", "source", False), ("time s", "time_s", False), ("species", "species", False),
         ("A mm", "value_a", True), ("σA mm", "sigma_a", True), ("B mm", "value_b", True), ("σB mm", "sigma_b", True),
         ("A−B mm", "difference", True), ("σ mm", "combined_sigma", True), ("(A−B)/σ", "normalised", False))


def _text(value: object, millimetres: bool) -> str:
    if value is None:
        return ""
    if isinstance(value, float):
        if math.isinf(value):
            return "∞"
        return f"{1000 * value:.1f}" if millimetres else f"{value:.2f}"
    return str(value)


class _Cell(QtWidgets.QTableWidgetItem):
    """A cell that sorts by its value, not its text: numbers as numbers, then texts, empty cells last (in
    either direction of the sort: a column of differences keeps its blanks at the bottom)."""

    def __init__(self, value: object, millimetres: bool, row: int) -> None:
        super().__init__(_text(value, millimetres))
        self.report_index = row  # the report row it shows (an index in the dialog's ``rows``)
        number = isinstance(value, (int, float)) and not isinstance(value, bool)
        self.key = (0, float(value), "") if number else (1, 0.0, str(value)) if value not in (None, "") else None

    def __lt__(self, other: QtWidgets.QTableWidgetItem) -> bool:  # noqa: D105 (Qt's sort)
        mine, theirs = self.key, getattr(other, "key", None)
        if mine is None or theirs is None:  # empty cells after every value, whichever the order
            descending = (self.tableWidget() is not None
                          and self.tableWidget().horizontalHeader().sortIndicatorOrder()
                          == QtCore.Qt.SortOrder.DescendingOrder)
            return (mine is not None and theirs is None) != descending and mine is not theirs
        return mine < theirs


class DoubleReadDialog(QtWidgets.QDialog):
    """Two readers compared over ``context``'s workspace (its project and rules); rows clickable to jump to
    their object (the workspace's object request, which the views follow); messages said through
    ``context.messages``."""

    def __init__(self, context: WindowContext, parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(parent)
        self.workspace = context.workspace
        self.messages = context.messages
        self.setWindowTitle("Double-read report")
        self.report: DoubleReadReport | None = None
        self.rows: list[dict] = []
        self.worker: Worker | None = None
        self._last: tuple[int, int] | None = None  # (row, object) last gone to
        self.reader_a, self.reader_b = QtWidgets.QComboBox(), QtWidgets.QComboBox()
        self.tolerance = self._spin(0.5, 0.0, 3600.0, 2, " s")
        self.tolerance_unit = QtWidgets.QComboBox()
        self.tolerance_unit.addItems([unit[0] for unit in TOLERANCE_UNITS])
        self.tolerance_unit.setToolTip("the time tolerance in seconds, or in frames of the video")
        self.tolerance_unit.currentIndexChanged.connect(self._on_tolerance_unit)
        tolerance = QtWidgets.QHBoxLayout()
        tolerance.addWidget(self.tolerance, 1)
        tolerance.addWidget(self.tolerance_unit)
        self.gate = self._spin(0.3, 0.001, 100.0, 3, " m")
        self.k = self._spin(2.0, 0.1, 100.0, 2, "")
        form = QtWidgets.QFormLayout()
        form.addRow("Reader A", self.reader_a)
        form.addRow("Reader B", self.reader_b)
        form.addRow("Same instant within", tolerance)
        form.addRow("Midpoints within", self.gate)
        form.addRow("Flag differences beyond k × combined σ, k", self.k)
        self.compare_button = QtWidgets.QPushButton("&Compare")
        self.compare_button.clicked.connect(self.compare)
        self.cancel_button = QtWidgets.QPushButton("Cance&l")
        self.cancel_button.setEnabled(False)
        self.cancel_button.clicked.connect(self.cancel)
        self.save_button = QtWidgets.QPushButton("&Save CSV…")
        self.save_button.setEnabled(False)
        self.save_button.clicked.connect(lambda: self.save_csv())
        self.progress = QtWidgets.QProgressBar()
        self.progress.setRange(0, 100)
        self.summary = QtWidgets.QLabel("")
        self.summary.setWordWrap(True)
        self.summary.setTextInteractionFlags(QtCore.Qt.TextInteractionFlag.TextSelectableByMouse)
        #: the form's fields by the parameter an error names (a bad choice said with the field's label, the
        #: field outlined and given the keyboard)
        self.field_errors = FormFields({"readers": (self.reader_b, "Reader B"),
                                        "tolerance_s": (self.tolerance, "Same instant within"),
                                        "tolerance_frames": (self.tolerance, "Same instant within"),
                                        "gate_m": (self.gate, "Midpoints within"),
                                        "k": (self.k, "k")}, self.summary.setText)
        self.table = QtWidgets.QTableWidget(0, len(SHOWN))
        self.table.setHorizontalHeaderLabels([header for header, _, _ in SHOWN])
        self.table.setEditTriggers(QtWidgets.QAbstractItemView.EditTrigger.NoEditTriggers)
        self.table.setSelectionBehavior(QtWidgets.QAbstractItemView.SelectionBehavior.SelectRows)
        self.table.setSelectionMode(QtWidgets.QAbstractItemView.SelectionMode.SingleSelection)
        self.table.activated.connect(lambda index: self.go_to_row(index.row()))
        self.table.setSortingEnabled(True)
        buttons = QtWidgets.QHBoxLayout()
        for button in (self.compare_button, self.cancel_button, self.save_button):
            buttons.addWidget(button)
        buttons.addWidget(self.progress, 1)
        layout = QtWidgets.QVBoxLayout(self)
        layout.addLayout(form)
        layout.addLayout(buttons)
        layout.addWidget(self.summary)
        layout.addWidget(self.table, 1)
        self._on_project_changed(self.workspace.project)
        # not modal: another project may be opened while it is up (its rows' ids are the old project's)
        self.workspace.project_changed.connect(self._on_project_changed)
        self.resize(1000, 600)

    def _on_project_changed(self, project) -> None:
        """The readers of ``project`` (None: none), no report: a report running or shown is the previous
        project's, and its rows name that project's object ids."""
        if self.worker is not None:
            self.worker.cancel()
        self.worker, self.report, self.rows, self._last = None, None, [], None
        self.table.setRowCount(0)
        self.cancel_button.setEnabled(False)
        self.save_button.setEnabled(False)
        self.progress.setValue(0)
        names = list(annotators(project)) if project is not None else []
        for box, index in ((self.reader_a, 0), (self.reader_b, 1)):
            box.clear()
            box.addItems(names)
            box.setCurrentIndex(min(index, len(names) - 1))
        self.compare_button.setEnabled(len(names) >= 2)
        self.summary.setText("" if len(names) >= 2 else
                             "this survey's objects were measured by fewer than two annotators")

    @staticmethod
    def _spin(value: float, low: float, high: float, decimals: int, suffix: str) -> QtWidgets.QDoubleSpinBox:
        spin = QtWidgets.QDoubleSpinBox()
        spin.setRange(low, high)
        spin.setDecimals(decimals)
        spin.setValue(value)
        spin.setSuffix(suffix)
        return spin

    def _on_tolerance_unit(self, index: int) -> None:
        """The tolerance's unit changed: its box shows that unit, with its default value."""
        _, suffix, decimals, default, largest = TOLERANCE_UNITS[index]
        self.tolerance.setDecimals(decimals)
        self.tolerance.setRange(0.0, largest)
        self.tolerance.setSuffix(suffix)
        self.tolerance.setValue(default)

    def tolerances(self) -> tuple[float | None, float | None]:
        """(tolerance_s, tolerance_frames) as chosen: exactly one of them is a number."""
        value = self.tolerance.value()
        return (value, None) if self.tolerance_unit.currentIndex() == 0 else (None, value)

    def compare(self) -> Worker | None:
        """Read both readers' objects (here, on the project's thread) and compute the report in a worker."""
        project = self.workspace.project
        if project is None:
            self.summary.setText("open a project first")
            return None
        if self.worker is not None:
            self.worker.cancel()
        try:
            inputs = read_inputs(project, self.reader_a.currentText(), self.reader_b.currentText())
        except UsvipsError as error:
            self.field_errors.show(error)
            return None
        self.field_errors.clear()
        (tolerance_s, tolerance_frames), gate, k = self.tolerances(), self.gate.value(), self.k.value()

        def job(progress, cancelled):
            try:
                return compute(inputs, tolerance_s, gate, k, self.workspace.rules, progress, cancelled,
                               tolerance_frames)
            except ReportCancelled:
                raise Cancelled() from None

        worker = self.worker = Worker(job, "the double-read report")
        worker.signals.progress.connect(lambda f, w=worker: self.progress.setValue(int(100 * f))
                                        if w is self.worker else None)
        worker.signals.finished.connect(lambda report, w=worker: self._on_report(w, report))
        worker.signals.failed.connect(lambda message, w=worker: self._on_ended(w, message))
        worker.signals.cancelled.connect(lambda w=worker: self._on_ended(w, "cancelled"))
        self.cancel_button.setEnabled(True)
        self.summary.setText("comparing …")
        self.progress.setValue(0)
        return start(worker)

    def cancel(self) -> None:
        if self.worker is not None:
            self.worker.cancel()

    def _on_ended(self, worker: Worker, message: str) -> None:
        if worker is self.worker:
            self.worker = None
            self.cancel_button.setEnabled(False)
            self.summary.setText(message)

    def _on_report(self, worker: Worker, report: DoubleReadReport) -> None:
        if worker is not self.worker:
            return
        self.worker = None
        self.cancel_button.setEnabled(False)
        self.report, self.rows, self._last = report, report.rows(), None
        self.summary.setText("\n".join(report.summary()))
        self.table.setSortingEnabled(False)  # filled in the report's order (sorting while filling moves rows)
        self.table.horizontalHeader().setSortIndicator(-1, QtCore.Qt.SortOrder.AscendingOrder)
        self.table.setRowCount(len(self.rows))
        for r, row in enumerate(self.rows):
            for c, (_, key, millimetres) in enumerate(SHOWN):
                self.table.setItem(r, c, _Cell(row[key], millimetres, r))
        self.table.setSortingEnabled(True)
        if len(self.rows) <= 500:
            self.table.resizeColumnsToContents()
        self.save_button.setEnabled(True)
        self.progress.setValue(100)

    def report_row(self, table_row: int) -> int | None:
        """The index in :attr:`rows` of what the table shows on ``table_row`` (the table may be sorted)."""
        item = self.table.item(table_row, 0)
        return item.report_index if isinstance(item, _Cell) else None

    def object_of_row(self, row: int) -> int | None:
        """The object report row ``row`` (an index in :attr:`rows`) goes to: reader A's, or B's when A has
        none there — and the other one when the same row is activated again (to see both readings of a
        pair in turn)."""
        if not 0 <= row < len(self.rows):
            return None
        ids = [i for i in (self.rows[row]["object_a"], self.rows[row]["object_b"]) if i is not None]
        if self._last is not None and self._last[0] == row and len(ids) == 2:
            chosen = ids[1 - ids.index(self._last[1])]
        else:
            chosen = ids[0]
        self._last = (row, chosen)
        return chosen

    def go_to_row(self, table_row: int) -> None:
        """Show the object of the table's row ``table_row`` (as sorted) in the window (its frame or pair,
        selected)."""
        row = self.report_row(table_row)
        object_id = None if row is None else self.object_of_row(row)
        if object_id is not None:
            self.workspace.request_object(object_id)  # the views go to it (the model's event)

    def save_csv(self, path: str | None = None) -> bool:
        """Write the report's table (every row, the statistics as comment lines) to a CSV file."""
        if self.report is None:
            return False
        if path is None:
            path, _ = QtWidgets.QFileDialog.getSaveFileName(self, "Save the double-read report",
                                                            "double_read.csv", "CSV (*.csv)")
            if not path:
                return False
        try:
            write_double_read_csv(path, COLUMNS, self.rows, self.report.summary())
        except UsvipsError as error:
            self.messages.error(str(error))
            return False
        self.messages.info(f"double-read report written to {path}")
        return True

    def done(self, result: int) -> None:  # noqa: D102 (Qt's name): a running report stops with the dialog
        self.cancel()
        self.workspace.project_changed.disconnect(self._on_project_changed)
        super().done(result)


def show_double_read(context: WindowContext, parent: QtWidgets.QWidget) -> DoubleReadDialog | None:
    """File › Double-read report…: the dialog on the open project (non-modal, so rows can be followed)."""
    if context.workspace.project is None:
        context.messages.error("open a project first")
        return None
    dialog = DoubleReadDialog(context, parent)
    dialog.setAttribute(QtCore.Qt.WidgetAttribute.WA_DeleteOnClose)
    dialog.show()
    return dialog
