"""An object's history in the window: who made it and when (the object, each vertex's pick, its
observation record, its review) and every recorded change to it, oldest first — when, who, what kind of
change, and what it did (old → new), as ``usvips project history --object ID`` prints it. Read from the
store when opened (and by Refresh): changes made by other annotators since show up then."""

from __future__ import annotations

from PySide6 import QtCore, QtWidgets

from usvips.app.history_text import what_changed
from usvips.core.errors import UsvipsError
from usvips.store.records import Provenance

#: the table's columns
COLUMNS = ("#", "When (UTC)", "Who", "Change", "What (old → new)")


def provenance_text(provenance: Provenance, review) -> str:
    """Who made what of an object, on a few lines (times as stored: ISO 8601 UTC)."""
    creator, created, modified = provenance.object
    lines = [f"Made by {creator or 'unknown'} on {created}; last changed {modified}."]
    pickers: dict[str, int] = {}
    for who, _ in provenance.vertices:
        pickers[who or "unknown"] = pickers.get(who or "unknown", 0) + 1
    if pickers:
        lines.append("Vertices picked by " + ", ".join(f"{who} ({count})" for who, count in pickers.items()) + ".")
    record = provenance.record
    lines.append(f"Observation record by {record[0]} on {record[1]}." if record else "No observation record.")
    if review is not None and review.state != "unreviewed":
        lines.append(f"Review: {review.state} by {review.reviewer} on {review.reviewed}"
                     + (f" — {review.reason}" if review.reason else "") + ".")
    else:
        lines.append("Review: unreviewed.")
    return "\n".join(lines)


class HistoryDialog(QtWidgets.QDialog):
    """The history of object ``object_id`` of ``store`` (any ProjectStore); not modal."""

    def __init__(self, store, object_id: int, parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(parent)
        self.store, self.object_id = store, int(object_id)
        self.setWindowTitle(f"History of object {self.object_id}")
        self.setObjectName("history_dialog")
        self.summary = QtWidgets.QLabel("")
        self.summary.setObjectName("history_summary")
        self.summary.setTextFormat(QtCore.Qt.TextFormat.PlainText)
        self.summary.setWordWrap(True)
        self.summary.setTextInteractionFlags(QtCore.Qt.TextInteractionFlag.TextSelectableByMouse)
        self.table = QtWidgets.QTableWidget(0, len(COLUMNS))
        self.table.setObjectName("history_table")
        self.table.setHorizontalHeaderLabels(list(COLUMNS))
        self.table.verticalHeader().hide()
        self.table.setEditTriggers(QtWidgets.QAbstractItemView.EditTrigger.NoEditTriggers)
        self.table.setSelectionBehavior(QtWidgets.QAbstractItemView.SelectionBehavior.SelectRows)
        self.table.setWordWrap(False)
        self.table.horizontalHeader().setStretchLastSection(True)
        buttons = QtWidgets.QDialogButtonBox(QtWidgets.QDialogButtonBox.StandardButton.Close)
        refresh = buttons.addButton("&Refresh", QtWidgets.QDialogButtonBox.ButtonRole.ActionRole)
        refresh.clicked.connect(self.refresh)
        buttons.rejected.connect(self.close)
        layout = QtWidgets.QVBoxLayout(self)
        layout.addWidget(self.summary)
        layout.addWidget(self.table, 1)
        layout.addWidget(buttons)
        self.resize(900, 420)
        self.refresh()

    def refresh(self) -> None:
        """Read the object's history and provenance again."""
        try:
            entries = self.store.history(self.object_id)
        except UsvipsError as error:
            self.summary.setText(str(error))
            self.table.setRowCount(0)
            return
        try:
            summary = provenance_text(self.store.provenance(self.object_id), self.store.review(self.object_id))
        except UsvipsError:  # deleted: its history stays
            summary = f"Object {self.object_id} is no longer in the project; its recorded changes stay."
        self.summary.setText(summary)
        self.table.setRowCount(len(entries))
        for row, entry in enumerate(entries):
            for column, value in enumerate((str(entry.id), entry.at, entry.annotator, entry.change,
                                            what_changed(entry))):
                item = QtWidgets.QTableWidgetItem(value)
                item.setToolTip(value)
                self.table.setItem(row, column, item)
        self.table.resizeColumnsToContents()
        if entries:
            self.table.scrollToBottom()  # the newest change last, in view
