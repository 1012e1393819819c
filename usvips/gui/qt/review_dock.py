"""Review mode: a panel that walks the survey's unreviewed objects with the keyboard (the queue and its
rules are :mod:`usvips.gui.review_model`'s).

Keys while the panel has the keyboard (View › Review mode, Ctrl+Shift+R, gives it): N next, P previous,
A accept, F flag (asks the reason, one line), S skip (on to the next unreviewed object), J or Enter go to
the object's pair or video frame with it selected (``object_chosen``; the window goes there as the QA
panel does), H its history (``history_requested``). These single keys are the panel's while it has the
keyboard: the window's own single-key shortcuts (F fit, S snap …) work again as soon as the images have
it. "Go to each object" makes every move go there too. Every review is stored at once, as the window's
annotator.

Reviews stay current: every move reads the object's review again (one query), and so does
:meth:`ReviewDock.refresh_current` (the window calls it when it regains the focus); a review someone else
made meanwhile is shown in the panel and announced (``review_read``: the object list shows it). A review
refused because someone else changed the object is said in the panel itself (its notice line, naming
the object), besides the log, with the object's state as it now is.
"""

from __future__ import annotations

from collections.abc import Callable

from PySide6 import QtCore, QtGui, QtWidgets

from usvips.app.quality import object_facts
from usvips.core.errors import UsvipsError
from usvips.gui.panel_registry import Panel, register
from usvips.gui.qt.on_screen import ScreenWatch, on_screen
from usvips.gui.review_model import ReviewModel
from usvips.gui.video_model import video_frame_text
from usvips.gui.window_context import WindowContext
from usvips.gui.wording import species_text
from usvips.store.checks import MAX_REASON_LENGTH
from usvips.store.records import StaleEditError

Key = QtCore.Qt.Key
#: the panel's keys → what they do (the names of :class:`ReviewDock`'s methods)
KEYS = {Key.Key_N: "next", Key.Key_P: "previous", Key.Key_A: "accept", Key.Key_F: "flag", Key.Key_S: "skip",
        Key.Key_J: "jump", Key.Key_Return: "jump", Key.Key_Enter: "jump", Key.Key_H: "history"}


class ReasonDialog(QtWidgets.QDialog):
    """Asks why an object is flagged: one line, not empty (OK stays disabled until something is typed)."""

    def __init__(self, object_id: int, parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(parent)
        self.setWindowTitle(f"Flag object {object_id}")
        self.edit = QtWidgets.QLineEdit()
        self.edit.setObjectName("flag_reason")
        self.edit.setMaxLength(MAX_REASON_LENGTH)
        self.edit.setPlaceholderText("what is wrong (e.g. snout hidden, two fish overlap)")
        buttons = QtWidgets.QDialogButtonBox(QtWidgets.QDialogButtonBox.StandardButton.Ok
                                             | QtWidgets.QDialogButtonBox.StandardButton.Cancel)
        self.ok = buttons.button(QtWidgets.QDialogButtonBox.StandardButton.Ok)
        self.ok.setEnabled(False)
        self.edit.textChanged.connect(lambda text: self.ok.setEnabled(bool(text.strip())))
        buttons.accepted.connect(self.accept)
        buttons.rejected.connect(self.reject)
        layout = QtWidgets.QVBoxLayout(self)
        layout.addWidget(QtWidgets.QLabel(f"Why is object {object_id} flagged? (one line)"))
        layout.addWidget(self.edit)
        layout.addWidget(buttons)

    def reason(self) -> str:
        return self.edit.text().strip()

    @classmethod
    def ask(cls, parent: QtWidgets.QWidget, object_id: int) -> str | None:
        """The reason typed, or None when the flag was cancelled."""
        dialog = cls(object_id, parent)
        return dialog.reason() if dialog.exec() == QtWidgets.QDialog.DialogCode.Accepted else None


class _QueueRows(QtCore.QAbstractListModel):
    """The queue's rows, each described when drawn (``describe(object_id)``): a queue of 10,000 objects
    makes no row until it is on screen, and then only the rows drawn."""

    def __init__(self, describe: Callable[[int], str], parent: QtCore.QObject | None = None) -> None:
        super().__init__(parent)
        self.describe = describe
        self.ids: list[int] = []

    def set_ids(self, ids: list[int]) -> None:
        self.beginResetModel()
        self.ids = list(ids)
        self.endResetModel()

    def changed(self, row: int) -> None:
        index = self.index(row)
        self.dataChanged.emit(index, index)

    def rowCount(self, parent: QtCore.QModelIndex = QtCore.QModelIndex()) -> int:  # noqa: N802, B008 (Qt's)
        return 0 if parent.isValid() else len(self.ids)

    def data(self, index: QtCore.QModelIndex, role: int = QtCore.Qt.ItemDataRole.DisplayRole):
        if role == QtCore.Qt.ItemDataRole.DisplayRole and index.isValid() and 0 <= index.row() < len(self.ids):
            return self.describe(self.ids[index.row()])
        return None


class _QueueList(QtWidgets.QListView):
    """The queue; the panel's single keys are claimed here before the window's shortcuts see them. Rows
    by number as a list widget has them (:meth:`count`, :meth:`currentRow`, :meth:`row_text`)."""

    currentRowChanged = QtCore.Signal(int)  # noqa: N815 (Qt's style, as QListWidget's)

    def __init__(self, on_key: Callable[[QtCore.Qt.Key], bool], describe: Callable[[int], str]) -> None:
        super().__init__()
        self._on_key = on_key
        self.rows = _QueueRows(describe, self)
        self.setModel(self.rows)
        self.setUniformItemSizes(True)  # one line a row: 10,000 rows are not measured one by one
        self.setEditTriggers(QtWidgets.QAbstractItemView.EditTrigger.NoEditTriggers)
        self.selectionModel().currentRowChanged.connect(lambda current, _: self.currentRowChanged.emit(current.row()))

    def count(self) -> int:
        return self.rows.rowCount()

    def currentRow(self) -> int:  # noqa: N802 (as QListWidget's)
        return self.currentIndex().row()

    def setCurrentRow(self, row: int) -> None:  # noqa: N802 (as QListWidget's)
        self.setCurrentIndex(self.rows.index(row))

    def row_text(self, row: int) -> str:
        """The text of a row, as drawn."""
        return self.rows.index(row).data() or ""

    def event(self, event: QtCore.QEvent) -> bool:
        if event.type() == QtCore.QEvent.Type.ShortcutOverride and _panel_key(event) is not None:
            event.accept()  # ours: delivered as a key press below, not to a window shortcut
            return True
        return super().event(event)

    def keyPressEvent(self, event: QtGui.QKeyEvent) -> None:  # noqa: N802 (Qt's name)
        key = _panel_key(event)
        if key is not None and self._on_key(key):
            event.accept()
            return
        super().keyPressEvent(event)


def _panel_key(event: QtGui.QKeyEvent) -> QtCore.Qt.Key | None:
    """The panel key pressed (no Ctrl, Alt or Meta: those belong to the window), or None."""
    mods = event.modifiers() & ~QtCore.Qt.KeyboardModifier.KeypadModifier & ~QtCore.Qt.KeyboardModifier.ShiftModifier
    if mods != QtCore.Qt.KeyboardModifier.NoModifier:
        return None
    key = QtCore.Qt.Key(event.key())
    return key if key in KEYS else None


class ReviewDock(QtWidgets.QWidget):
    """The review panel over ``workspace`` (its project and object cache). ``object_chosen(object_id)``:
    go to where the object was measured and select it; ``reviewed(object_id, review)``: a review was
    stored (the object list shows it). ``ask_reason(object_id)`` asks why an object is flagged (None:
    cancelled); a test may replace it."""

    object_chosen = QtCore.Signal(int)
    reviewed = QtCore.Signal(int, object)
    review_read = QtCore.Signal(int, object)  # a review read again differs from the one shown (someone else's)
    history_requested = QtCore.Signal(int)

    def __init__(self, workspace, parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(parent)
        self.workspace = workspace
        self.model = ReviewModel()
        self.ask_reason: Callable[[int], str | None] = lambda object_id: ReasonDialog.ask(self, object_id)
        self.progress = QtWidgets.QLabel("")
        self.progress.setObjectName("review_progress")
        self.survey = QtWidgets.QLabel("")  # the whole survey's count, beside the queue's own
        self.survey.setObjectName("review_survey")
        self.survey.setToolTip("every object of the survey, also those reviewed before this queue was loaded")
        self.current = QtWidgets.QLabel("")
        self.current.setObjectName("review_current")
        self.current.setTextFormat(QtCore.Qt.TextFormat.PlainText)
        self.current.setWordWrap(True)
        self.notice = QtWidgets.QLabel("")  # a review refused (stale), naming the object; cleared by the next key
        self.notice.setObjectName("review_notice")
        self.notice.setTextFormat(QtCore.Qt.TextFormat.PlainText)
        self.notice.setWordWrap(True)
        self.notice.setStyleSheet("color: #b00020")
        self.notice.hide()
        self.follow = QtWidgets.QCheckBox("Go to each object")
        self.follow.setToolTip("every move (N, P, after A or F) also goes to the object's pair or frame")
        self.follow.setChecked(True)
        self.list = _QueueList(self._on_key, self._describe)
        self.list.setObjectName("review_queue")
        self.list.setToolTip("N next, P previous, A accept, F flag (with a reason), S skip, J or Enter: go to it, "
                             "H: its history")
        self.list.currentRowChanged.connect(self._on_row)
        self.list.doubleClicked.connect(lambda _: self.jump())
        buttons = QtWidgets.QHBoxLayout()  # one row over the queue: it stays in view in a low dock
        buttons.addWidget(self.progress)
        buttons.addWidget(self.survey)
        buttons.addSpacing(12)
        for text, slot, tip in (("&Previous", self.previous, "P"), ("&Next", self.next, "N"),
                                ("&Accept", self.accept, "A"), ("&Flag…", self.flag, "F"),
                                ("&Skip", self.skip, "S"), ("&Go to", self.jump, "J or Enter")):
            button = QtWidgets.QPushButton(text.replace("&", ""))  # the keys are the panel's, not mnemonics
            button.setToolTip(f"{text.replace('&', '').rstrip('…').lower()} ({tip})")
            button.setFocusPolicy(QtCore.Qt.FocusPolicy.NoFocus)  # the keyboard stays on the queue
            button.clicked.connect(slot)
            buttons.addWidget(button)
        buttons.addWidget(self.follow)
        buttons.addStretch(1)
        layout = QtWidgets.QVBoxLayout(self)
        layout.setContentsMargins(2, 2, 2, 2)
        layout.setSpacing(2)
        layout.addLayout(buttons)
        layout.addWidget(self.current)
        layout.addWidget(self.notice)
        layout.addWidget(self.list, 1)
        self._stale = True  # loaded when first on screen
        self._filling = False
        self._rebuild = True  # the queue's rows all written again on the next show (else only those changed)
        self._dirty: set[int] = set()  # objects whose rows changed (reviewed, edited)
        self._row_of: dict[int, int] = {}
        self.model.changed.connect(self._show)
        self.model.reviewed.connect(lambda object_id, _review: self._dirty.add(object_id))
        self.model.read.connect(self._on_read)
        self._events = ((workspace.objects_reset, self._on_reset), (workspace.objects_added, self._on_added),
                        (workspace.objects_removed, self._on_removed), (workspace.objects_updated, self._on_updated))
        for signal, slot in self._events:
            signal.connect(slot)
        self._watch = ScreenWatch(self, self._on_screen)  # a tab behind another is "visible" in Qt 6
        self._show()

    def cleanup(self) -> None:
        for signal, slot in self._events:
            signal.disconnect(slot)
        self.model.changed.disconnect(self._show)
        self.model.read.disconnect(self._on_read)

    def _on_read(self, object_id: int, review) -> None:
        """A review read again differs from the one shown: its row, and the object list, show it."""
        self._dirty.add(object_id)
        if object_id not in self._row_of:
            self._rebuild = True  # unreviewed again: it joined the queue
        self.review_read.emit(object_id, review)

    def refresh_current(self) -> None:
        """Read the current object's review again (one query; the window regains the focus)."""
        if self._stale or not on_screen(self):
            return
        self._moving(self.model.refresh_current)

    def _moving(self, move) -> None:
        """A move (or a read again) of the model; a review that cannot be read is said in one line."""
        self._say("")
        try:
            move()
        except UsvipsError as error:
            self.workspace.message.emit("warning", f"the review cannot be read again: {error}")

    def _say(self, text: str) -> None:
        self.notice.setText(text)
        self.notice.setVisible(bool(text))

    # ------------------------------------------------------------------ the queue
    def load(self) -> None:
        """Read the queue of the open project again (unreviewed objects now)."""
        self._stale = False
        self._rebuild = True
        project = self.workspace.project
        try:
            self.model.load(project, self.workspace.cache.objects() if project is not None else None)
        except UsvipsError as error:
            self.model.load(None)
            self.workspace.message.emit("error", str(error))

    def _on_reset(self, *_: object) -> None:
        if on_screen(self):
            self.load()
        else:
            self._stale = True

    def _on_added(self, ids: tuple[int, ...]) -> None:
        if not self._stale:
            self._rebuild = True
            self.model.add([self.workspace.stored_object(i) for i in ids if i in self.workspace.cache])

    def _on_updated(self, ids: tuple[int, ...]) -> None:
        if not self._stale:  # edited in the window: their new versions, reviews (an edit returns an accepted
            present = [i for i in ids if i in self.workspace.cache]  # object to unreviewed) and rows again
            self.model.updated([self.workspace.stored_object(i) for i in present])
            self._dirty.update(ids)
            try:
                if self.model.reread(present):
                    self._rebuild = True  # one that went back to unreviewed may have joined the queue
            except UsvipsError as error:
                self.workspace.message.emit("warning", f"the review states cannot be read: {error}")
            self._show()

    def _on_removed(self, ids: tuple[int, ...]) -> None:
        if not self._stale:
            self._rebuild = True
            self.model.forget(ids)

    def _on_screen(self) -> None:
        """The panel came on screen (shown, or its tab brought to the front): its queue read if stale."""
        if self._stale:
            self.load()

    def focus_queue(self) -> None:
        """Give the keyboard to the queue (the panel's keys then work)."""
        if self._stale:
            self.load()
        self.list.setFocus(QtCore.Qt.FocusReason.ShortcutFocusReason)

    # ------------------------------------------------------------------ what is shown
    def _describe(self, object_id: int) -> str:
        ws = self.workspace
        if object_id not in ws.cache:
            return f"{object_id}  (no longer in the project)"
        stored = ws.stored_object(object_id)
        where = video_frame_text(stored) or ", ".join(dict.fromkeys(v.pair for v in stored.vertices if v.pair))
        parts = [str(object_id), stored.kind, species_text(ws.cache.record(object_id)) or stored.attribute, where]
        review = self.model.state(object_id)
        state = review.state + (f": {review.reason}" if review.reason else "")
        mark = ws.cache.marks.get(object_id)  # a colleague's change (usvips.gui.qt.live_updates)
        return "  ".join(p for p in parts if p) + f"  — {state}" + (f"  ({mark.text()})" if mark is not None else "")

    def _facts(self, object_id: int) -> list[str]:
        """The rules the object breaks: the one verdict (usvips.app.quality.object_facts), as the QA panel's."""
        ws = self.workspace
        if object_id not in ws.cache:
            return []
        known = ws.cache.known_figures(object_id)
        return object_facts(ws.stored_object(object_id), known.measurement if known is not None else None, ws.rules,
                            ws.cache.record(object_id), ws.species_maxima())

    def _show(self) -> None:
        reviewed, total, flagged = self.model.counts()
        self.progress.setText(self.model.progress())
        survey = self.model.survey_progress(self.workspace.cache.ids()) if self.workspace.project is not None else ""
        self.survey.setText(f"({survey})" if survey else "")
        current = self.model.current
        if current is None:
            self.current.setText("No object to review." if self.workspace.project is not None else "No project open.")
        else:
            review = self.model.state(current)
            who = f" by {review.reviewer}" if review.reviewer else ""
            self.current.setText(f"Object {current}: {review.state}{who}"
                                 + (f" ({review.reason})" if review.reason else "")
                                 + ("  — all reviewed" if total and reviewed == total else "")
                                 + "".join(f"\n{fact}" for fact in self._facts(current)))
        self._filling = True
        try:
            if self._rebuild or self.list.count() != len(self.model.queue):
                self._rebuild = False
                self.list.rows.set_ids(self.model.queue)  # rows described when drawn
                self._row_of = {object_id: row for row, object_id in enumerate(self.model.queue)}
            else:  # a key press: only the rows that changed drawn again
                for object_id in self._dirty | ({current} if current is not None else set()):
                    row = self._row_of.get(object_id)
                    if row is not None:
                        self.list.rows.changed(row)
            self._dirty.clear()
            if current is not None:
                self.list.setCurrentRow(self.model.position)
        finally:
            self._filling = False

    def _on_row(self, row: int) -> None:
        if self._filling or not 0 <= row < len(self.model.queue):
            return
        self._moving(lambda: self.model.go_to(self.model.queue[row]))
        self._followed()

    # ------------------------------------------------------------------ the keys
    def _on_key(self, key: QtCore.Qt.Key) -> bool:
        getattr(self, KEYS[key])()
        return True

    def next(self) -> None:
        self._moving(self.model.next)
        self._followed()

    def previous(self) -> None:
        self._moving(self.model.previous)
        self._followed()

    def skip(self) -> None:
        self._moving(self.model.skip)
        self._followed()

    def accept(self) -> None:
        self._review(lambda: self.model.accept())

    def flag(self) -> None:
        object_id = self.model.current
        if object_id is None:
            return
        reason = self.ask_reason(object_id)
        if reason is None:
            return  # cancelled: nothing stored
        self._review(lambda: self.model.flag(reason))

    def _review(self, make) -> None:
        object_id = self.model.current
        if object_id is None:
            self.workspace.message.emit("warning", "nothing to review")
            return
        self._say("")
        try:
            review = make()
        except UsvipsError as error:
            self.workspace.message.emit("error", str(error))
            if isinstance(error, StaleEditError):  # the whole message is in the log; here what to do
                self._say(f"Not stored: object {object_id} was changed by someone else since it was shown here "
                          "(as it is now: above). Look at it again, then A or F again.")
            return
        self.reviewed.emit(object_id, review)
        self.workspace.message.emit("info", f"object {object_id} {review.state}"
                                    + (f": {review.reason}" if review.reason else "") + f" — {self.model.progress()}")
        if self.model.current != object_id:
            self._followed()

    def jump(self) -> None:
        """Go to the current object's pair or video frame, with it selected."""
        if self.model.current is not None:
            self.object_chosen.emit(self.model.current)
            self.list.setFocus(QtCore.Qt.FocusReason.OtherFocusReason)  # the keys stay the panel's

    def history(self) -> None:
        """The current object's history (who made it, every change)."""
        if self.model.current is not None:
            self.history_requested.emit(self.model.current)

    def _followed(self) -> None:
        if self.follow.isChecked():
            self.jump()


def _review(context: WindowContext) -> ReviewDock:
    """Review mode's panel; the object walked to is shown by the views (the model's event)."""
    review = ReviewDock(context.workspace)
    review.object_chosen.connect(context.workspace.request_object)
    return review


#: the panel's declaration (usvips.gui.panel_registry): the window builds its dock from it
PANEL = register(Panel("review", "Review", "bottom", _review, group="records", order=90))
