"""File › Add image pairs…'s dialog: the medium, a label prefix, and a table of the pairs found (tick,
label — editable —, left file, right file, size in pixels, status). It only shows and edits a
:class:`usvips.gui.pair_import.PairImport`; the model decides what is added."""

from __future__ import annotations

from PySide6 import QtCore, QtWidgets

from usvips.gui.pair_import import MEDIA, OK, PairImport
from usvips.gui.wording import plural

COLUMNS = ("Add", "Label", "Left", "Right", "Size (px)", "Status")


class PairImportDialog(QtWidgets.QDialog):
    """Edit a :class:`PairImport` before its pairs are added (OK adds the ticked good ones)."""

    def __init__(self, model: PairImport, parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(parent)
        self.model = model
        self.setWindowTitle("Add image pairs")
        self.medium = QtWidgets.QComboBox()
        for medium in MEDIA:
            self.medium.addItem({"water": "Underwater (water)", "air": "In air (calibration in air)"}[medium], medium)
        self.medium.setCurrentIndex(MEDIA.index(model.medium))
        self.prefix = QtWidgets.QLineEdit(model.prefix)
        self.prefix.setPlaceholderText("e.g. dive2- (put before every label)")
        form = QtWidgets.QFormLayout()
        medium_label = QtWidgets.QLabel("&Medium:")
        medium_label.setBuddy(self.medium)
        prefix_label = QtWidgets.QLabel("Label &prefix:")
        prefix_label.setBuddy(self.prefix)
        form.addRow(medium_label, self.medium)
        form.addRow(prefix_label, self.prefix)
        self.table = QtWidgets.QTableWidget(len(model.rows), len(COLUMNS))
        self.table.setHorizontalHeaderLabels(COLUMNS)
        self.table.verticalHeader().setVisible(False)
        self.summary = QtWidgets.QLabel()
        self.summary.setWordWrap(True)
        self.buttons = QtWidgets.QDialogButtonBox(QtWidgets.QDialogButtonBox.StandardButton.Ok
                                                  | QtWidgets.QDialogButtonBox.StandardButton.Cancel)
        self.buttons.accepted.connect(self.accept)
        self.buttons.rejected.connect(self.reject)
        layout = QtWidgets.QVBoxLayout(self)
        layout.addLayout(form)
        layout.addWidget(QtWidgets.QLabel("Untick a pair to leave it out; double-click a label to change it."))
        layout.addWidget(self.table)
        layout.addWidget(self.summary)
        layout.addWidget(self.buttons)
        self._filling = False
        self.refresh()
        self.table.setWordWrap(False)
        header = self.table.horizontalHeader()
        for column in range(len(COLUMNS) - 1):  # labels grow with a prefix: the columns follow
            header.setSectionResizeMode(column, QtWidgets.QHeaderView.ResizeMode.ResizeToContents)
        header.setStretchLastSection(True)
        self.medium.currentIndexChanged.connect(lambda _: model.set_medium(self.medium.currentData()))
        self.prefix.textEdited.connect(model.set_prefix)
        self.table.itemChanged.connect(self._edited)
        model.changed.connect(self.refresh)
        self.resize(860, 460)

    def _cell(self, row: int, column: int) -> QtWidgets.QTableWidgetItem:
        """The table's item at (row, column), made once (edits update it in place, never replace it)."""
        item = self.table.item(row, column)
        if item is None:
            item = QtWidgets.QTableWidgetItem()
            if column == 0:
                item.setFlags(QtCore.Qt.ItemFlag.ItemIsUserCheckable | QtCore.Qt.ItemFlag.ItemIsEnabled
                              | QtCore.Qt.ItemFlag.ItemIsSelectable)
            elif column != 1:
                item.setFlags(item.flags() & ~QtCore.Qt.ItemFlag.ItemIsEditable)
            self.table.setItem(row, column, item)
        return item

    def refresh(self) -> None:
        """Show the model's rows (labels, sizes, statuses) and the summary line."""
        self._filling = True
        model = self.model
        for row, found in enumerate(model.rows):
            self._cell(row, 0).setCheckState(QtCore.Qt.CheckState.Checked if found.ticked
                                             else QtCore.Qt.CheckState.Unchecked)
            status = model.status(row)
            for column, text in enumerate((model.label(row), found.left.name, found.right.name, model.size_text(row),
                                           status), start=1):
                if self._cell(row, column).text() != text:
                    self._cell(row, column).setText(text)
            self._cell(row, 2).setToolTip(str(found.left))
            self._cell(row, 3).setToolTip(str(found.right))
            self._cell(row, 5).setForeground(QtCore.Qt.GlobalColor.red if status != OK and found.ticked
                                             else self.palette().text().color())
        good = len(model.good())
        bad = model.bad()
        self.summary.setText(model.summary() + (":\n" + "\n".join(bad[:5]) + ("\n…" if len(bad) > 5 else "")
                                                if bad else ""))
        ok = self.buttons.button(QtWidgets.QDialogButtonBox.StandardButton.Ok)
        ok.setText(f"&Add {plural(good, 'pair')}")
        ok.setEnabled(good > 0)
        self._filling = False

    def _edited(self, item: QtWidgets.QTableWidgetItem) -> None:
        if self._filling:
            return
        if item.column() == 0:
            self.model.set_ticked(item.row(), item.checkState() == QtCore.Qt.CheckState.Checked)
        elif item.column() == 1:
            self.model.set_label(item.row(), item.text())
