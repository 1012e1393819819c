"""Who is annotating in the window: the name set once (File › Annotator: your name…), kept in the settings,
shown in the title bar, and made the annotator of the project the window opens (every store write in the window is
made as that name: ``usvips.store.annotator``). Until a name is set, it is ``$USVIPS_ANNOTATOR``, else the
login name."""

from __future__ import annotations

from PySide6 import QtCore, QtWidgets

from usvips.core.errors import UsvipsError
from usvips.store.annotator import MAX_NAME_LENGTH, checked_annotator, current_annotator

#: the settings key the name is kept under
SETTINGS_KEY = "annotator/name"


def saved_annotator(settings: QtCore.QSettings) -> str:
    """The name kept in ``settings`` when it is a usable one, else ``$USVIPS_ANNOTATOR`` / the login name
    (``"unknown"`` when neither is usable)."""
    kept = settings.value(SETTINGS_KEY)
    if isinstance(kept, str):
        try:
            return checked_annotator(kept, "the annotator in the settings")
        except UsvipsError:
            pass
    try:
        return current_annotator()
    except UsvipsError:
        return "unknown"


def save_annotator(settings: QtCore.QSettings, name: str) -> str:
    """Check ``name`` (one line, not empty …: a ``UsvipsError`` naming what is wrong) and keep it."""
    checked = checked_annotator(name, "annotator")
    settings.setValue(SETTINGS_KEY, checked)
    settings.sync()
    return checked


class AnnotatorDialog(QtWidgets.QDialog):
    """Asks the annotator's name; OK only for a usable name (what is wrong is said under the field)."""

    def __init__(self, current: str, parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(parent)
        self.setWindowTitle("Annotator")
        self.setMinimumWidth(420)
        self.edit = QtWidgets.QLineEdit(current)
        self.edit.setObjectName("annotator_name")
        self.edit.setMaxLength(MAX_NAME_LENGTH + 50)  # longer is refused by name below, not cut silently
        self.problem = QtWidgets.QLabel("")
        self.problem.setObjectName("annotator_problem")
        self.problem.setStyleSheet("color: #b00020")
        self.problem.setWordWrap(True)
        buttons = QtWidgets.QDialogButtonBox(QtWidgets.QDialogButtonBox.StandardButton.Ok
                                             | QtWidgets.QDialogButtonBox.StandardButton.Cancel)
        self.ok = buttons.button(QtWidgets.QDialogButtonBox.StandardButton.Ok)
        buttons.accepted.connect(self.accept)
        buttons.rejected.connect(self.reject)
        self.edit.textChanged.connect(self._check)
        layout = QtWidgets.QVBoxLayout(self)
        intro = QtWidgets.QLabel("Your name or initials: every object, pick, record and review you make is "
                                 "stamped with it, and the project's history shows it.")
        intro.setWordWrap(True)
        layout.addWidget(intro)
        layout.addWidget(self.edit)
        layout.addWidget(self.problem)
        layout.addWidget(buttons)
        self._check(current)

    def _check(self, text: str) -> None:
        try:
            checked_annotator(text, "")
        except UsvipsError as error:
            self.problem.setText(str(error).removeprefix(": "))
            self.ok.setEnabled(False)
            return
        self.problem.setText("")
        self.ok.setEnabled(True)

    def name(self) -> str:
        return self.edit.text().strip()
