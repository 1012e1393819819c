"""The dialog of File › Accept changed media…: the media files found changed since they were added, each
with how it differs, ticked by the user to be taken as the recording the project means. A file that cannot
stand in for its recording (another frame count, frame rate or size: :mod:`usvips.app.media_acceptance`)
is listed with the reason and cannot be ticked. Nothing is ticked at first: accepting a file points every
object stored on it at what the file holds now, so each is the user's own choice. Keys: the arrows move
between files, Space ticks one, Enter accepts the ticked ones, Tab goes to Accept then Cancel."""

from __future__ import annotations

from collections.abc import Sequence

from PySide6 import QtCore, QtWidgets

from usvips.app.media_acceptance import ChangedMedia

#: what the dialog says above the list
EXPLANATION = ("These media files differ from the ones added to the project. Accept a file only when it is "
               "the same recording (re-exported or repaired): every object stored on it will be read from it "
               "as it is now. A file that is not the same recording: put the right one back instead.")


class AcceptMediaDialog(QtWidgets.QDialog):
    """Lists ``changed``; :meth:`chosen` the ones ticked when accepted."""

    def __init__(self, changed: Sequence[ChangedMedia], parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(parent)
        self.setWindowTitle("Accept changed media")
        self.changed = list(changed)
        text = QtWidgets.QLabel(EXPLANATION)
        text.setWordWrap(True)
        self.files = QtWidgets.QListWidget()
        self.files.setWordWrap(True)
        self.files.setHorizontalScrollBarPolicy(QtCore.Qt.ScrollBarPolicy.ScrollBarAlwaysOff)
        for media in self.changed:
            line = f"{media.stored} — {media.problem}"
            if not media.acceptable:
                line += f"\n    cannot stand in: {media.refusal}"
            item = QtWidgets.QListWidgetItem(line)
            flags = QtCore.Qt.ItemFlag.ItemIsUserCheckable | QtCore.Qt.ItemFlag.ItemIsSelectable
            item.setFlags(flags | QtCore.Qt.ItemFlag.ItemIsEnabled if media.acceptable else flags)
            item.setCheckState(QtCore.Qt.CheckState.Unchecked)
            item.setToolTip(line)
            self.files.addItem(item)
        self.buttons = QtWidgets.QDialogButtonBox(QtWidgets.QDialogButtonBox.StandardButton.Cancel)
        self.accept_button = self.buttons.addButton("Accept ticked files",
                                                    QtWidgets.QDialogButtonBox.ButtonRole.AcceptRole)
        self.accept_button.setEnabled(False)
        self.accept_button.setDefault(True)  # Enter accepts once a file is ticked, never before
        self.buttons.accepted.connect(self.accept)
        self.buttons.rejected.connect(self.reject)
        self.files.itemChanged.connect(lambda _item: self.accept_button.setEnabled(bool(self.chosen())))
        layout = QtWidgets.QVBoxLayout(self)
        layout.addWidget(text)
        layout.addWidget(self.files)
        layout.addWidget(self.buttons)
        cancel = self.buttons.button(QtWidgets.QDialogButtonBox.StandardButton.Cancel)
        QtWidgets.QWidget.setTabOrder(self.files, self.accept_button)  # (in one window: after the layout)
        QtWidgets.QWidget.setTabOrder(self.accept_button, cancel)
        self.resize(720, 320)

    def chosen(self) -> list[ChangedMedia]:
        """The files ticked (never one that cannot stand in)."""
        return [media for row, media in enumerate(self.changed)
                if media.acceptable and self.files.item(row).checkState() == QtCore.Qt.CheckState.Checked]
