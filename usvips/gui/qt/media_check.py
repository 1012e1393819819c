"""The full check of an open project's media files, in the background: after a project opens, every
recorded media file (image pairs' images, videos' files) is read whole in a worker and its SHA-256
compared with the one recorded when it was added (:func:`usvips.app.video_project.verify_media`), with
its progress in the status bar; closing the project (or opening another, or the Cancel button) stops the
reading at once. A file found missing, resized or changed is named in the status bar, the log and a box
that stays until closed but blocks nothing: a swapped recording (camera file names repeat across cards)
is noticed before anything is measured on it.
"""

from __future__ import annotations

from collections.abc import Sequence

from PySide6 import QtCore, QtWidgets

from usvips.gui.qt.worker import Cancelled, Worker
from usvips.gui.video_modules import video_project as _video_project
from usvips.gui.window_context import WindowContext
from usvips.store.interface import ProjectStore

#: how many changed files a warning names before it says "and N more"
NAMED = 3


def media_warning(project_name: str, problems: list[tuple[str, str]]) -> str:
    """One line naming the changed media files of ``project_name``: ``(stored path, problem)`` each."""
    named = "; ".join(f"{stored}: {problem}" for stored, problem in problems[:NAMED])
    more = f"; and {len(problems) - NAMED} more" if len(problems) > NAMED else ""
    files = "a media file is" if len(problems) == 1 else f"{len(problems)} media files are"
    return (f"{project_name}: {files} not the one added — {named}{more}. Measurements on it may be on "
            "the wrong recording: put the right file back, or File › Relocate missing media… / Accept changed "
            "media… (usvips project relocate-media / accept-media)")


class MediaCheck:
    """Runs the full media check of each project the window opens; :attr:`worker` while it runs,
    :attr:`problems` (stored path, problem) of the last check that finished, :attr:`box` the warning
    shown for them (not modal)."""

    def __init__(self, parent: QtWidgets.QWidget, context: WindowContext) -> None:
        """``parent``: the widget its warning box belongs to; ``context``: the messages and the jobs."""
        self.parent, self.context, self.messages, self.jobs = parent, context, context.messages, context.jobs
        self.worker: Worker | None = None
        self.problems: list[tuple[str, str]] | None = None
        self.box: QtWidgets.QMessageBox | None = None

    def project_opened(self, project: ProjectStore) -> Worker | None:
        """Start checking ``project``'s media files (stopping a check of a previous project); None when it
        records none."""
        self.project_closed()
        self.problems = None
        records = project.media_records()
        if not records:
            self.problems = []
            return None
        name = project.path.name

        def job(progress, cancelled):
            def report(done: int, total: int) -> None:
                progress(done / max(total, 1))
            try:
                return _video_project().verify_media(records, report, cancelled)
            except _video_project().Cancelled:
                raise Cancelled from None

        def done(problems: list[tuple[str, str]]) -> None:
            if self.worker is not worker:
                return  # a check of a project closed since
            self.worker = None
            self.problems = problems
            if problems:
                text = media_warning(name, problems)
                self.messages.warning(text)
                self._show_box(text, any(not problem.startswith("missing") for _, problem in problems))

        def cancelled() -> None:
            if self.worker is worker:
                self.worker = None

        worker = self.worker = self.jobs.run(job, f"checking the media files of {name}", done, on_cancelled=cancelled)
        return worker

    def project_closed(self) -> None:
        """Stop the check of the project being closed (its worker stops reading at its next block) and
        close its warning."""
        if self.worker is not None:
            self.worker.cancel()
            self.worker = None
        if self.box is not None:
            self.box.close()
            self.box = None

    def resolved(self, stored_paths: Sequence[str]) -> None:
        """The media files at ``stored_paths`` were accepted or relocated: the last check's problems and its
        warning box no longer name them, and the box closes when none is left."""
        if not self.problems:
            return
        gone = set(stored_paths)
        self.problems = [(stored, problem) for stored, problem in self.problems if stored not in gone]
        if self.box is None:
            return
        if not self.problems:
            self.box.close()
            self.box = None
            return
        project = self.context.workspace.project
        self.box.setText(media_warning(project.path.name if project is not None else "the project", self.problems))
        if all(problem.startswith("missing") for _, problem in self.problems):
            for button in self.box.buttons():
                if self.box.buttonRole(button) == QtWidgets.QMessageBox.ButtonRole.ActionRole:
                    self.box.removeButton(button)

    def _show_box(self, text: str, changed: bool = False) -> None:
        """The warning in a box that stays until closed (a later status message cannot hide it) and blocks
        nothing; with ``changed`` files (not only missing ones) its *Accept changed media…* button starts
        File › Accept changed media…"""
        box = QtWidgets.QMessageBox(QtWidgets.QMessageBox.Icon.Warning, "Media files changed", text,
                                    QtWidgets.QMessageBox.StandardButton.Ok, self.parent)
        box.setWindowModality(QtCore.Qt.WindowModality.NonModal)
        box.setAttribute(QtCore.Qt.WidgetAttribute.WA_DeleteOnClose)
        # with a second button a QMessageBox has no escape button of its own, and then neither Escape, nor its
        # title bar's close, nor close() closes it
        box.setEscapeButton(QtWidgets.QMessageBox.StandardButton.Ok)
        if changed:
            from usvips.gui.qt.media_dialogs import accept_changed_media

            button = box.addButton("Accept changed media…", QtWidgets.QMessageBox.ButtonRole.ActionRole)
            button.clicked.connect(lambda: accept_changed_media(self.context, self.parent))
        box.finished.connect(lambda _result: self._box_closed(box))
        box.show()
        self.box = box

    def _box_closed(self, box: QtWidgets.QMessageBox) -> None:
        """The user closed the warning: it deletes itself (it must not be closed again later)."""
        if self.box is box:
            self.box = None
