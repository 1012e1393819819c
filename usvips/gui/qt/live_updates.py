"""Colleagues' changes seen live: objects other annotators add, change and delete in the open survey appear
in the window within about a second, without reopening it, marked with who changed them.

A background thread (:class:`ChangeFeed`) follows the survey on a store handle of its own, opened
read-only for the same location (an SQLite connection is not shared between threads, and the window's
handle stays the GUI thread's): it waits on the store's change signal (:meth:`ProjectStore.watch`: an
SQLite file's change counter, a PostgreSQL server's LISTEN/NOTIFY), reads the history rows after its
cursor and the versions their objects are stored at now (:func:`usvips.app.live_changes.read_changes`),
and hands them to the GUI thread by a queued signal. The GUI thread never waits on the store for this:
:class:`LiveUpdates` folds a batch against the versions the window's cache holds
(:func:`usvips.app.live_changes.fold`: the window's own writes are already there and give nothing), marks
each object with its :class:`~usvips.app.live_changes.ColleagueChange` (``ObjectCache.marks``: the object
list's row tint and tooltip, the overlays' labels, the review queue's rows, the QA panel's rows) and has
the cache read those objects again by id (:meth:`Workspace.objects_changed_in_store`), which every view
follows.

An object being edited when a colleague changes or deletes it — its cell open in the object list, or its
observation record in the observation form with the keyboard there — is not read again under the user's
cursor: the conflict is said at once in plain words, the typed text stays in the editor (the entries in
the form), and the object is read again when the editor closes (the form is stored or left). A save made
meanwhile names the version the user started from, so the store refuses it by name rather than overwrite
the colleague's change; the window then keeps the text as an unsaved edit (Edit › Retry unsaved edits
saves it over theirs, Discard drops it) and says so.

The feed stops when the project closes or another opens. When the store cannot be read (a server that
went away), it says so once in the status bar and tries again with growing pauses; once back, it goes on
from its cursor (the history is append-only: nothing is missed) and says that once too.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from pathlib import Path

from PySide6 import QtCore, QtGui, QtWidgets

from usvips.app.live_changes import ChangeBatch, ColleagueChange, clock_text, fold, read_changes, summary
from usvips.core.errors import UsvipsError
from usvips.core.redaction import redact
from usvips.gui.object_cache import project_location
from usvips.store.opening import open_project
from usvips.store.records import ServerUnreachableError

#: how long the feed waits for the store's change signal before looking again whether it must stop (s)
WAIT_S = 0.5
#: the history is read at least this often even when no change was signalled (a missed notification) (s)
IDLE_READ_S = 10.0
#: how long closing a project waits for its feed's thread to end (s; it ends within about WAIT_S)
JOIN_S = 2.0
#: the first and the longest pause before trying a store that could not be read again (s)
FIRST_BACKOFF_S, MAX_BACKOFF_S = 0.5, 5.0
#: the feed starts this many history rows before the newest when a project opens: a change committed between
#: the window's read of the objects and its read of the newest row is not missed (rows the window already
#: holds give nothing: their objects' versions are the ones it read)
CATCH_UP_ROWS = 200
#: above this many objects changed at once (a colleague's import), the window reads every object again by
#: one query rather than these by id (which reads each one's observation record on its own)
MANY = 500
#: how many colleagues' changes the status bar's tooltip lists
RECENT = 12
#: the tint of a row (object list, QA panel) a colleague changed
TINT = QtGui.QColor(255, 196, 64, 60)


def _reason(error: BaseException) -> str:
    """Why the store cannot be read, in one line without a password."""
    if isinstance(error, ServerUnreachableError):
        return "the server is unreachable"
    text = str(error).strip().splitlines()[0] if str(error).strip() else type(error).__name__
    return redact(text if isinstance(error, UsvipsError) else f"{type(error).__name__}: {text}")


class _Relay(QtCore.QObject):
    """Carries the feed's news from its thread to the GUI thread (queued): each with the feed's number, so
    that news from a feed already stopped is dropped."""

    batch = QtCore.Signal(int, object)
    trouble = QtCore.Signal(int, str)
    recovered = QtCore.Signal(int)


class ChangeFeed:
    """A daemon thread following the survey at ``location`` from history id ``after``: each batch of
    history rows read (a :class:`~usvips.app.live_changes.ChangeBatch`) goes out through ``relay.batch``;
    ``relay.trouble`` once when the store cannot be read, ``relay.recovered`` once when it can again.
    ``opener`` opens the feed's own handle (read-only)."""

    def __init__(self, location: str | Path, after: int, relay: _Relay, number: int,
                 opener: Callable[..., object] = open_project, wait_s: float = WAIT_S) -> None:
        self.location, self.after, self.relay, self.number = location, int(after), relay, number
        self._opener, self._wait_s = opener, wait_s
        self._stop = threading.Event()
        self.thread = threading.Thread(target=self._run, name="usvips-live-changes", daemon=True)

    def start(self) -> None:
        self.thread.start()

    def stop(self) -> None:
        """Ask the thread to end (it does within about :data:`WAIT_S`; it closes its handle itself)."""
        self._stop.set()

    def join(self, timeout_s: float | None = None) -> bool:
        """Wait for the thread to end; True when it has."""
        self.thread.join(timeout_s)
        return not self.thread.is_alive()

    def _run(self) -> None:
        store = watch = None
        cursor, backoff, failing, last_read = self.after, FIRST_BACKOFF_S, False, 0.0
        try:
            while not self._stop.is_set():
                try:
                    if store is None:
                        store = self._opener(self.location, read_only=True)
                        watch = store.watch()
                        due = True  # read at once: what was committed while (re)connecting
                    else:
                        due = watch.wait(self._wait_s) or time.monotonic() - last_read > IDLE_READ_S
                    batch = None
                    if due and not self._stop.is_set():
                        batch = read_changes(store, cursor)
                        last_read, cursor = time.monotonic(), batch.last
                    if failing and not self._stop.is_set():  # back: said before what was made meanwhile
                        failing = False
                        self.relay.recovered.emit(self.number)
                    if batch is not None and batch.entries and not self._stop.is_set():
                        self.relay.batch.emit(self.number, batch)
                    backoff = FIRST_BACKOFF_S
                except Exception as error:  # noqa: BLE001 - a background thread says why and tries again, never dies
                    store, watch = _closed(store, watch)
                    if not failing and not self._stop.is_set():
                        failing = True
                        self.relay.trouble.emit(self.number, _reason(error))
                    self._stop.wait(backoff)
                    backoff = min(backoff * 2, MAX_BACKOFF_S)
        finally:
            _closed(store, watch)


def _closed(store, watch) -> tuple[None, None]:
    """Close the feed's watch and handle, whatever state they are in (a handle whose server went away)."""
    for thing in (watch, store):
        if thing is not None:
            try:
                thing.close()
            except Exception:  # noqa: BLE001, S110 - closing what may already be broken: nothing left to do
                pass
    return None, None


class LiveUpdates(QtCore.QObject):
    """Colleagues' changes in ``window`` (its workspace, object list, review panel, status bar and log):
    one :class:`ChangeFeed` per open project; see the module docstring.

    :attr:`held` — colleagues' changes to the object being edited, applied when its editor closes;
    :attr:`recent` — the latest colleagues' changes shown (newest last); :attr:`paused` — why the feed
    cannot read the store now ('' while it can)."""

    def __init__(self, window) -> None:
        super().__init__(window)
        self.window = window
        self.workspace = window.workspace
        self.feed: ChangeFeed | None = None
        self._number = 0
        self.held: dict[int, ColleagueChange] = {}
        self._editing: tuple[int, str, str] | None = None  # the edit a held change interrupted
        self.recent: list[ColleagueChange] = []
        self.paused = ""
        self._applying = False
        #: batches read while the window's objects were still being read: folded once they arrive
        self._waiting: list[ChangeBatch] = []
        self.label = QtWidgets.QLabel("")
        self.label.setObjectName("live_status")
        window.statusBar().addPermanentWidget(self.label)
        ws = self.workspace
        ws.project_changed.connect(self._on_project)
        ws.objects_reset.connect(self._on_objects_read)
        for signal in (ws.objects_added, ws.objects_updated, ws.objects_removed):
            signal.connect(self._on_own_change)
        # a review stored here moves the object's version: the cache takes it (else the window's next edit
        # of that object would be refused as stale, and the feed would show the review as someone else's)
        window.review.reviewed.connect(self._on_reviewed)
        # a held change is applied once nothing of its object is being edited: the cell's editor closed, the
        # observation form stored or left
        window.object_list.table.itemDelegate().closeEditor.connect(self._on_editor_closed)
        window.observation.finished.connect(self._on_editor_closed)
        QtWidgets.QApplication.instance().focusChanged.connect(self._on_focus_changed)
        self._on_project(ws.project)

    # ------------------------------------------------------------------ the feed
    def _on_project(self, project) -> None:
        """Another project (or none): the previous feed stops, a new one follows ``project`` from just before
        its newest history row (the cache was just read: :data:`CATCH_UP_ROWS`)."""
        stopped = self.stop()
        if stopped is not None and project is None:  # closed (the window too, maybe): its thread ends first
            stopped.join(JOIN_S)
        self.held, self._editing, self.recent, self.paused = {}, None, [], ""
        self._waiting = []
        self._show_label()
        if project is None:
            return
        try:  # a little before the newest row: what was committed while the cache was being read is seen
            after = max(0, project.last_change_id() - CATCH_UP_ROWS)
        except UsvipsError as error:
            self.workspace.message.emit("warning", f"colleagues' changes will not be shown: {error}")
            return
        self._number += 1
        relay = _Relay(self)  # deleted with this object, on the GUI thread (never where the feed's thread ends)
        queued = QtCore.Qt.ConnectionType.QueuedConnection
        relay.batch.connect(self._on_batch, queued)
        relay.trouble.connect(self._on_trouble, queued)
        relay.recovered.connect(self._on_recovered, queued)
        self.feed = ChangeFeed(project_location(project), after, relay, self._number)
        self.feed.start()
        self._show_label()

    def stop(self) -> ChangeFeed | None:
        """Stop following the project (nothing the feed reads afterwards is applied); returns the stopped
        feed (its thread ends by itself shortly)."""
        feed, self.feed = self.feed, None
        self._number += 1
        if feed is not None:
            feed.stop()
        return feed

    def _on_batch(self, number: int, batch: ChangeBatch) -> None:
        if number != self._number or self.workspace.project is None:
            return  # a stopped feed's news
        if self.workspace.cache.loading:  # folded against the objects once they arrive
            self._waiting.append(batch)
            return
        changes = fold(batch, {i: self._version(i) for i in batch.object_ids if i in self.workspace.cache})
        if changes:
            self.apply(changes)

    def _on_objects_read(self, *_: object) -> None:
        """The window's objects arrived: the batches read meanwhile are shown (those the read already
        holds give nothing: :func:`~usvips.app.live_changes.fold` compares versions)."""
        if self.workspace.cache.loading or not self._waiting:
            return
        waiting, self._waiting = self._waiting, []
        for batch in waiting:
            self._on_batch(self._number, batch)

    def _on_trouble(self, number: int, reason: str) -> None:
        if number != self._number:
            return
        self.paused = reason
        self._show_label()
        self.workspace.message.emit("warning", f"colleagues' changes are not shown for now: {reason}; trying again "
                                               "in the background")

    def _on_recovered(self, number: int) -> None:
        if number != self._number:
            return
        self.paused = ""
        self._show_label()
        self.workspace.message.emit("info", "colleagues' changes are shown again (those made meanwhile too)")

    # ------------------------------------------------------------------ applying colleagues' changes
    def apply(self, changes: list[ColleagueChange], held: bool = False) -> None:
        """Show colleagues' ``changes``: each object marked and read again by id (the views follow the
        cache); the object being edited is held back until its editor closes (the conflict said now).
        ``held``: changes held back so far (the save refused over them may have read the object again)."""
        editing = self._being_edited()
        apply = []
        for change in changes:
            if editing is not None and change.object_id == editing[0]:
                cell = self._editor()
                if self._editing is None and cell is not None:  # the text typed from now on (a save may read
                    cell.textEdited.connect(self._on_typed)     # the cell again first)
                self.held[change.object_id] = change
                self._editing = editing
                self._say_conflict(change, editing[1])
            else:
                apply.append(change)
        if not apply:
            return
        cache = self.workspace.cache
        before = {c.object_id: self._version(c.object_id) for c in apply}
        earlier = {c.object_id: cache.marks.get(c.object_id) for c in apply}
        for change in apply:  # marked before the views hear of them, so that they draw the mark
            if change.what == "deleted":
                cache.marks.pop(change.object_id, None)
            else:
                cache.marks[change.object_id] = change
        added = tuple(c.object_id for c in apply if c.what == "added")
        again = tuple(c.object_id for c in apply if c.what != "added")  # read again: changed, or gone
        self._applying = True
        try:
            if len(apply) > MANY:  # a colleague's import: every object read again by one query
                self.workspace.reload_objects()
            else:
                self.workspace.objects_changed_in_store(added=added, updated=again)
        except UsvipsError as error:
            self.workspace.message.emit("warning", f"colleagues' changes cannot be shown: {error}")
            return
        finally:
            self._applying = False
        # a batch read before a later write of this window (its own edit, review or undo since) found the
        # object as the window already holds it: no colleague's change to show after all
        stale = [] if held else [c for c in apply if self._version(c.object_id) == before[c.object_id]]
        for change in stale:
            cache.marks.pop(change.object_id, None)
            if earlier[change.object_id] is not None:
                cache.marks[change.object_id] = earlier[change.object_id]
        if stale:
            self._applying = True  # the marks as they were: redrawn, not taken away as the user's own change
            try:
                self.workspace.show_as_cached(tuple(c.object_id for c in stale))
            finally:
                self._applying = False
        shown = [c for c in apply if c not in stale]
        if not shown:
            return
        self.recent = (self.recent + shown)[-RECENT:]
        self._show_label()
        self.window.log.add("info", "colleagues' changes: " + summary(shown) + " — "
                            + "; ".join(c.sentence() for c in shown[:5]) + ("; …" if len(shown) > 5 else ""))

    def _version(self, object_id: int) -> str | None:
        """The version the window holds of an object (None: it holds none)."""
        cache = self.workspace.cache
        return cache.get(object_id).modified if object_id in cache else None

    def _on_own_change(self, ids: tuple[int, ...]) -> None:
        """An object changed by this window: no longer marked as a colleague's (the views that drew the
        mark before hearing of it here are told again)."""
        if self._applying:
            return
        marks = self.workspace.cache.marks
        unmarked = tuple(i for i in ids if marks.pop(i, None) is not None)
        if unmarked:
            self.workspace.show_as_cached(unmarked)

    def _on_reviewed(self, object_id: int, _review) -> None:
        try:
            self.workspace.objects_changed_in_store(updated=(object_id,))
        except UsvipsError as error:
            self.workspace.message.emit("warning", f"object {object_id} cannot be read again: {error}")

    # ------------------------------------------------------------------ an object being edited
    def _editor(self) -> QtWidgets.QLineEdit | None:
        """The editor open on a cell of the object list (None: no cell is being edited)."""
        table = self.window.object_list.table
        if table.state() != QtWidgets.QAbstractItemView.State.EditingState:
            return None
        index = table.currentIndex()
        editor = table.indexWidget(index) if index.isValid() else None
        return editor if isinstance(editor, QtWidgets.QLineEdit) else None

    def _being_edited(self) -> tuple[int, str, str] | None:
        """(object id, what, text typed) of the object being edited — the object list's cell open in its
        editor, else the observation form with the keyboard in it — or None."""
        listing = self.window.object_list
        editor, index = self._editor(), listing.table.currentIndex()
        if editor is not None and 0 <= index.row() < listing.model.rowCount():
            return listing.model.object_id(index.row()), listing.model.columns[index.column()], editor.text()
        form = self.window.observation
        if form.object_id is not None and form.isAncestorOf(QtWidgets.QApplication.focusWidget()):
            return form.object_id, "observation record", form.species.currentText()
        return None

    def _say_conflict(self, change: ColleagueChange, column: str) -> None:
        if change.what == "deleted":
            then = "Enter keeps your text as an unsaved edit; Esc drops it"
        else:
            then = (f"Enter saves it only if that does not overwrite {change.who}'s change (else it is kept as an "
                    "unsaved edit); Esc drops it")
        where = "in the form" if column == "observation record" else "in the cell"
        self.workspace.message.emit("warning", f"Conflict: {change.sentence()} while you are editing its {column}. "
                                               f"Your text is kept {where}: {then}.")

    def _on_typed(self, text: str) -> None:
        """The user typed on in the cell a held change concerns: the text to name if it is not saved."""
        if self._editing is not None:
            self._editing = (*self._editing[:2], text)

    def _on_focus_changed(self, *_: object) -> None:
        if self.held:
            self._on_editor_closed()

    def _on_editor_closed(self, *_: object) -> None:
        QtCore.QTimer.singleShot(0, self._apply_held)  # after the view has left its editing state

    def _apply_held(self) -> None:
        """The editor closed: the held objects read again; an edit the store refused over a colleague's
        change is said to be kept (with the text typed)."""
        if not self.held or self._being_edited() is not None:
            return
        held, editing = list(self.held.values()), self._editing
        self.held, self._editing = {}, None
        unsaved = {object_id for object_id, _label in self.workspace.edits.unsaved}
        self.apply(held, held=True)
        for change in held:
            if editing is None or change.object_id not in unsaved:
                continue
            _, column, text = editing
            if change.what == "deleted":
                self.workspace.message.emit("warning", f"Your {column} of object {change.object_id} (“{text}”) was not "
                                                       f"saved: {change.who} deleted the object at "
                                                       f"{clock_text(change.at)}. Edit › Discard unsaved edits drops "
                                                       "it.")
            else:
                self.workspace.message.emit("warning", f"Your {column} of object {change.object_id} (“{text}”) is kept "
                                                       f"unsaved: {change.who} changed the object at "
                                                       f"{clock_text(change.at)} while you typed. Edit › Retry unsaved "
                                                       f"edits saves yours over theirs; Discard unsaved edits keeps "
                                                       "theirs.")

    # ------------------------------------------------------------------ the status bar
    def _show_label(self) -> None:
        if self.workspace.project is None or (self.feed is None and not self.paused):
            self.label.setText("")
            self.label.setToolTip("")
            return
        if self.paused:
            self.label.setText("live: paused")
            self.label.setToolTip(f"colleagues' changes are not shown for now: {self.paused}; trying again")
            return
        last = self.recent[-1] if self.recent else None
        self.label.setText("live" if last is None else f"live · {last.who} {last.what} #{last.object_id} "
                                                         f"{clock_text(last.at)}")
        lines = [c.sentence() for c in reversed(self.recent)]
        self.label.setToolTip("colleagues' changes are shown as they are made"
                              + ("".join(f"\n{line}" for line in lines) if lines else ""))
