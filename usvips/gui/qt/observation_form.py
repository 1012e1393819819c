"""The observation form: an object's observation record (species, number, stage, activity, comment)."""

from __future__ import annotations

from PySide6 import QtCore, QtWidgets

from usvips.core.errors import UsvipsError
from usvips.core.observation_record import STAGES, ObservationRecord, Species
from usvips.gui.panel_registry import Panel, register
from usvips.gui.species_choice import choose_species, species_label, species_of_attribute
from usvips.gui.workspace import Workspace


class ObservationForm(QtWidgets.QWidget):
    """The observation record of the object just stored (or the one selected), typed from the keyboard:
    species with type-ahead from the project's species list, number, stage, activity, comment. Enter
    stores it and hands the keyboard back to the images, Esc leaves it blank; *Keep values* starts the
    next record with these values. ``finished()`` fires after either."""

    finished = QtCore.Signal()

    def __init__(self, workspace: Workspace, parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(parent)
        self.workspace = workspace
        self.object_id: int | None = None
        self.target = QtWidgets.QLabel("no object")
        self.species = QtWidgets.QComboBox()
        self.species.setEditable(True)
        self.species.setInsertPolicy(QtWidgets.QComboBox.InsertPolicy.NoInsert)
        self.species.setMinimumContentsLength(18)
        self.species.setToolTip("type part of the genus, species or code; the list is the project's "
                                "(File › Import species list…); blank: not identified")
        self.number = QtWidgets.QSpinBox()
        self.number.setRange(1, 100000)
        self.number.setToolTip("number of individuals")
        self.stage = QtWidgets.QComboBox()
        self.stage.setEditable(True)
        self.stage.addItems(["", *STAGES])
        self.stage.setToolTip("life stage: AD adult, J juvenile, F female, M male, U unknown (or type one)")
        self.activity = QtWidgets.QLineEdit()
        self.activity.setPlaceholderText("activity")
        self.comment = QtWidgets.QLineEdit()
        self.comment.setPlaceholderText("comment")
        self.keep = QtWidgets.QCheckBox("Keep values")
        self.keep.setToolTip("start the next record with these values")
        self.ask = QtWidgets.QCheckBox("Ask after each measurement")
        self.ask.setChecked(True)
        store = QtWidgets.QPushButton("Store (Enter)")
        store.clicked.connect(self.store)
        workspace.project_changed.connect(self._on_project_changed)
        workspace.objects_removed.connect(self._on_objects_removed)  # its object undone or deleted: no longer shown
        self.status = QtWidgets.QLabel("")
        row = QtWidgets.QHBoxLayout()
        for label, widget in (("", self.target), ("Species", self.species), ("No.", self.number),
                              ("Stage", self.stage), ("", self.activity), ("", self.comment)):
            if label:
                row.addWidget(QtWidgets.QLabel(label))
            row.addWidget(widget, 2 if widget in (self.species, self.comment) else 0)
        row.addWidget(store)
        options = QtWidgets.QHBoxLayout()
        options.addWidget(self.keep)
        options.addWidget(self.ask)
        options.addWidget(self.status, 1)
        layout = QtWidgets.QVBoxLayout(self)
        layout.setContentsMargins(2, 2, 2, 2)
        layout.addLayout(row)
        layout.addLayout(options)
        layout.addStretch(1)
        self.refresh_species()

    def _on_project_changed(self, project) -> None:
        """Another project: no object, a blank record, that project's species list."""
        self.object_id = None
        self.target.setText("no object")
        self._show(ObservationRecord())
        self.status.setText("")
        self.refresh_species()

    def _on_objects_removed(self, ids) -> None:
        """The object shown is gone (its store undone, or deleted): the form names no object."""
        if self.object_id is not None and self.object_id in ids:
            self.status.setText(f"object {self.object_id} is no longer in the project")
            self.object_id = None
            self.target.setText("no object")
            self._show(ObservationRecord())

    def refresh_species(self) -> None:
        """Reload the type-ahead list from the open project."""
        project = self.workspace.project
        self._species = {} if project is None else {s.name.lower(): s for s in project.species_list()}
        text = self.species.currentText()
        self.species.clear()
        self.species.addItems([""] + [self._label(s) for s in self._species.values()])
        completer = QtWidgets.QCompleter([self.species.itemText(i) for i in range(1, self.species.count())], self)
        completer.setCaseSensitivity(QtCore.Qt.CaseSensitivity.CaseInsensitive)
        completer.setFilterMode(QtCore.Qt.MatchFlag.MatchContains)
        self.species.setCompleter(completer)
        self.species.setEditText(text)

    @staticmethod
    def _label(species: Species) -> str:
        return species_label(species)

    def begin(self, object_id: int) -> None:
        """Show the record of ``object_id`` and take the keyboard (after a measurement)."""
        self.load(object_id)
        self.status.setText("type the species (type-ahead), Tab to the next field, Enter stores, Esc skips")
        self.species.setFocus(QtCore.Qt.FocusReason.OtherFocusReason)
        self.species.lineEdit().selectAll()

    def load(self, object_id: int) -> None:
        """Show the record of ``object_id`` (its stored one, else blank or the kept values)."""
        self.object_id = object_id
        stored = self.workspace.project.object(object_id)
        self.target.setText(f"{stored.kind} {object_id}")
        record = self.workspace.project.record(object_id)
        if record is not None:
            self._show(record)
        elif not self.keep.isChecked():  # the toolbar's attribute, when it names a species, is the default
            default = species_of_attribute(stored.attribute, self._species.values())
            self._show(ObservationRecord.of(default) if default is not None else ObservationRecord())
        self.status.setText("")

    def _show(self, record: ObservationRecord) -> None:
        match = self._species.get(record.name.lower())
        self.species.setEditText(self._label(match) if match else record.name)
        self.number.setValue(record.number)
        self.stage.setEditText(record.stage)
        self.activity.setText(record.activity)
        self.comment.setText(record.comment)

    def chosen_species(self) -> Species | None:
        """The species typed: the list entry it names, or the ONE entry containing it (type-ahead: 'morh'
        is Gadus morhua when nothing else contains it); None when blank; an error naming the text when
        no entry or several contain it (:func:`usvips.gui.species_choice.choose_species`)."""
        return choose_species(self.species.currentText(), self._species.values())

    def store(self) -> bool:
        if self.object_id is None or self.workspace.project is None:
            self.status.setText("measure an object first (or select one in the object list)")
            return False
        try:
            record = ObservationRecord.of(self.chosen_species(), number=self.number.value(),
                                          stage=self.stage.currentText(), activity=self.activity.text(),
                                          comment=self.comment.text())
            self.workspace.edits.set_record(self.object_id, record)
        except UsvipsError as error:
            self.status.setText(str(error))  # nothing typed is lost: the fields keep it
            return False
        text = f"stored for object {self.object_id}: {record.name or 'not identified'} × {record.number}"
        attribute = self.workspace.stored_object(self.object_id).attribute
        named = species_of_attribute(attribute, self._species.values())
        if named is not None and named.name != record.name:  # one species, one place: say which counts
            text += (f" — its attribute {attribute!r} names {named.name}: the record's species is the one "
                     "exported")
        self.status.setText(text)
        if not self.keep.isChecked():
            self._show(ObservationRecord())
        self.finished.emit()
        return True

    def keyPressEvent(self, event) -> None:  # noqa: N802 (Qt's name)
        if event.key() in (QtCore.Qt.Key.Key_Return, QtCore.Qt.Key.Key_Enter):
            event.accept()
            self.store()
            return
        if event.key() == QtCore.Qt.Key.Key_Escape:
            event.accept()
            self.status.setText(f"object {self.object_id} left without a record")
            self.finished.emit()
            return
        super().keyPressEvent(event)


#: the panel's declaration (usvips.gui.panel_registry): the window builds its dock from it
PANEL = register(Panel("observation", "Observation", "bottom", lambda context: ObservationForm(context.workspace),
                     group="records", order=50, at_start=True))  # its project's species, its "Ask" on every store
