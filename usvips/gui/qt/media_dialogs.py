"""File › New project…, Add image pairs…, Add stereo video…, Relocate missing media…, Accept changed media…:
a user's own material into the open project. Each action asks with dialogs, then does its work through
:mod:`usvips.app.video_project` and :mod:`usvips.app.media_acceptance`; the paths can also be handed in
(tests, scripts), skipping the dialogs. Reading a video's files runs in a worker; the project is written on
the GUI thread.

Each is handed the window's context (:class:`usvips.gui.window_context.WindowContext`: the workspace, the
messages, the worker, what the window may be asked to show) and a parent widget for its dialogs — never the
window itself."""

from __future__ import annotations

from pathlib import Path

from PySide6 import QtWidgets

from usvips.app import media_acceptance, video_project
from usvips.core.errors import UsvipsError
from usvips.gui.pair_import import PairImport
from usvips.gui.qt.pair_import_dialog import PairImportDialog
from usvips.gui.qt.worker import Cancelled
from usvips.gui.window_context import WindowContext
from usvips.gui.wording import plural
from usvips.io.exif import DamagedExifError
from usvips.io.pairing import RULE_NAMES
from usvips.store.opening import create_project

VIDEO_FILTER = "Videos (*.mp4 *.MP4 *.mov *.MOV *.avi *.AVI *.mkv *.mts *.MTS *.m4v);;All files (*)"


def new_project(context: WindowContext, parent: QtWidgets.QWidget, path: str | Path | None = None) -> bool:
    """Create an empty project file and open it."""
    if path is None:
        path, _ = QtWidgets.QFileDialog.getSaveFileName(parent, "New project", context.start_folder("survey.usvips"),
                                                        "USVIPS projects (*.usvips)")
        if not path:
            return False
        path = path if path.endswith(".usvips") else path + ".usvips"
    try:
        create_project(path).close()
    except UsvipsError as error:
        context.messages.error(str(error))
        return False
    return context.navigation.open_project(path)


def confirm_pairs(parent: QtWidgets.QWidget, model: PairImport) -> bool:
    """Show the pairs found (medium, prefix, labels, sizes, statuses, ticks) for the user to edit and
    confirm; True when they chose Add."""
    dialog = PairImportDialog(model, parent)
    return dialog.exec() == QtWidgets.QDialog.DialogCode.Accepted


def add_image_pairs(context: WindowContext, parent: QtWidgets.QWidget, left: list | None = None,
                    right: list | None = None, prefix: str = "",
                    confirm=confirm_pairs) -> int:
    """Pair two folders (or lists) of images; the user chooses the medium, a label prefix or labels, and
    which pairs (``confirm(parent, model)`` edits a :class:`PairImport`); the good ones are added and the
    others named. Returns the number of pairs added."""
    project = context.need_project()
    if project is None:
        return 0
    if left is None:
        start = str(project.path.parent)
        folder = QtWidgets.QFileDialog.getExistingDirectory(parent, "Folder of LEFT images", start)
        if not folder:
            return 0
        other = QtWidgets.QFileDialog.getExistingDirectory(parent, "Folder of RIGHT images", folder)
        if not other:
            return 0
        left, right = [folder], [other]
    try:
        try:
            plan, rule = video_project.plan_image_pairs(left, right)
        except DamagedExifError as error:  # the window offers no rule: by order, said, and confirmed below
            plan, rule = video_project.plan_image_pairs(left, right, by="order")
            context.messages.warning(f"{Path(error.path).name}: damaged EXIF, its capture time cannot be read: "
                                     "paired by name order instead; check each pair before adding")
        model = PairImport(project, plan, RULE_NAMES[rule], prefix)
        if not confirm(parent, model):
            return 0
        added, left_out = model.add()
    except UsvipsError as error:
        context.messages.error(f"no pairs added: {error}")
        return 0
    context.navigation.pairs_changed()
    if left_out:
        context.messages.warning(f"{plural(len(left_out), 'pair')} not added: " + "; ".join(left_out))
    context.messages.say("info" if added else "error",
                        f"added {plural(len(added), 'image pair')} ({model.medium}, paired by {model.rule})"
                        + (f"; {plural(len(left_out), 'pair')} not added (see the log)" if left_out else ""))
    if context.workspace.pair is None and added:
        context.navigation.show_pair(added[0])
    return len(added)


def add_video(context: WindowContext, parent: QtWidgets.QWidget, left: list | None = None,
              right: list | None = None, label: str | None = None,
              medium: str = "water") -> None:
    """Choose each camera's file(s) (several = chapters in order), the label and the medium the cameras
    looked through (water, or air for an in-air calibration video), read and check them in a worker, then
    store the video and show it."""
    project = context.need_project()
    if project is None:
        return
    if left is None:
        left, _ = QtWidgets.QFileDialog.getOpenFileNames(parent, "LEFT camera: file or chapters",
                                                         str(project.path.parent), VIDEO_FILTER)
        if not left:
            return
        right, _ = QtWidgets.QFileDialog.getOpenFileNames(parent, "RIGHT camera: file or chapters",
                                                          str(Path(left[0]).parent), VIDEO_FILTER)
        if not right:
            return
        text, ok = QtWidgets.QInputDialog.getText(parent, "Add stereo video", "Label:",
                                                  text=Path(left[0]).stem)
        if not ok:
            return
        label = text.strip() or None
        chosen, ok = QtWidgets.QInputDialog.getItem(
            parent, "Add stereo video", "The cameras looked through (an in-air calibration video: air):",
            ["water", "air"], 0, False)
        if not ok:
            return
        medium = chosen

    def job(progress, cancelled):
        return video_project.inspect_video(sorted(left, key=lambda p: Path(p).name),
                                           sorted(right, key=lambda p: Path(p).name), label)

    def store(plan) -> None:
        added = video_project.store_video(project, plan, medium)
        for warning in added.warnings:
            context.messages.warning(warning)
        context.navigation.videos_changed(project)
        level = "warning" if added.warnings else "info"
        text = (f"added {added.summary}"
                + (f" — {plural(len(added.warnings), 'problem')} found (see the log)" if added.warnings
                   else "; both streams clean")
                + "; set its offset (the Video dock's Sync… or offset) before measuring")

        def again() -> None:  # said once more above the first frame, over the pair's own notes
            context.navigation.hint(text, level)

        context.navigation.show_video(added.label, again)
        context.messages.say(level, text)

    context.jobs.run(job, "reading the video files", store)


def _media_resolved(context: WindowContext, stored_paths: list[str]) -> None:
    """Tell the window (when there is one) that these media files no longer need a warning."""
    if stored_paths and context.navigation is not None and context.navigation.media_resolved is not None:
        context.navigation.media_resolved(stored_paths)


def relocate_media(context: WindowContext, parent: QtWidgets.QWidget, answers: dict[str, str] | None = None) -> int:
    """For every missing media file, ask where it is now (or take ``answers``: stored path → new path);
    a file that is not the one added (size, SHA-256) is refused. Returns the number relocated."""
    project = context.need_project()
    if project is None:
        return 0
    missing = [stored for stored, problem in project.media_problems(check_hash=False) if problem.startswith("missing")]
    if not missing:
        context.messages.info("no media file is missing")
        return 0
    done = 0
    for stored in missing:
        if answers is not None:
            new = answers.get(stored)
        else:
            new, _ = QtWidgets.QFileDialog.getOpenFileName(parent, f"Where is {stored} now?", str(project.path.parent))
        if not new:
            continue
        try:
            project.relocate_media(stored, new)
            done += 1
            _media_resolved(context, [stored])
        except UsvipsError as error:
            context.messages.error(str(error))
    context.messages.info(f"relocated {done} of {len(missing)} missing media files")
    return done


def accept_changed_media(context: WindowContext, parent: QtWidgets.QWidget,
                         answers: set[str] | None = None) -> None:
    """Find the media files changed since they were added (each read whole in a worker, with progress and
    Cancel), list them with how each differs (:class:`usvips.gui.qt.accept_media_dialog.AcceptMediaDialog`),
    and take those the user ticks — or the stored paths in ``answers`` — as the recordings the project
    means (:mod:`usvips.app.media_acceptance`: a file that cannot stand in for its recording is refused)."""
    project = context.need_project()
    if project is None:
        return
    records, shapes = project.media_records(), media_acceptance.recorded_shapes(project)

    def job(progress, cancelled):
        try:
            return media_acceptance.find_changed_media(records, shapes, lambda done, total: progress(done / total),
                                                       cancelled)
        except video_project.Cancelled:
            raise Cancelled from None

    def found(changed: list[media_acceptance.ChangedMedia]) -> None:
        if context.workspace.project is not project:
            return  # another project opened meanwhile
        if not changed:
            context.messages.info("no media file has changed since it was added (a missing one: File › Relocate "
                                  "missing media…)")
            return
        if answers is not None:
            chosen = [media for media in changed if media.stored in answers]
        else:
            from usvips.gui.qt.accept_media_dialog import AcceptMediaDialog

            dialog = AcceptMediaDialog(changed, parent)
            if dialog.exec() != QtWidgets.QDialog.DialogCode.Accepted:
                return
            chosen = dialog.chosen()
        if not chosen:
            context.messages.info(f"{plural(len(changed), 'changed media file')} found; none accepted")
            return
        accepted: list[str] = []
        try:
            media_acceptance.accept_changed(project, chosen, accepted)
        except UsvipsError as error:
            context.messages.error(str(error))
            return
        finally:
            _media_resolved(context, accepted)
        context.messages.info(f"accepted {', '.join(accepted)} as the recording{'s' if len(accepted) > 1 else ''} "
                              "the project means")

    context.jobs.run(job, "reading the media files for changes", found)
