"""File › New project…, Add image pairs…, Add stereo video…, Relocate missing media…: a user's own
material into the open project. Each action asks with dialogs, then does its work through
:mod:`usvips.app.video_project`; the paths can also be handed in (tests, scripts), skipping the dialogs.
Reading a video's files runs in a worker; the project is written on the GUI thread."""

from __future__ import annotations

from pathlib import Path

from PySide6 import QtWidgets

from usvips.app import video_project
from usvips.core.errors import UsvipsError
from usvips.gui.pair_import import PairImport
from usvips.gui.qt.pair_import_dialog import PairImportDialog
from usvips.gui.wording import plural
from usvips.io.pairing import RULE_NAMES
from usvips.store.interface import ProjectStore
from usvips.store.opening import create_project

VIDEO_FILTER = "Videos (*.mp4 *.MP4 *.mov *.MOV *.avi *.AVI *.mkv *.mts *.MTS *.m4v);;All files (*)"


def _need_project(window) -> ProjectStore | None:
    project = window.workspace.project
    if project is None:
        window.show_message("error", "open or create a project first (File › New project…)")
    return project


def new_project(window, path: str | Path | None = None) -> bool:
    """Create an empty project file and open it."""
    if path is None:
        here = window.workspace.project.path.parent if window.workspace.project is not None else Path.home()
        path, _ = QtWidgets.QFileDialog.getSaveFileName(window, "New project", str(here / "survey.usvips"),
                                                        "USVIPS projects (*.usvips)")
        if not path:
            return False
        path = path if path.endswith(".usvips") else path + ".usvips"
    try:
        create_project(path).close()
    except UsvipsError as error:
        window.show_message("error", str(error))
        return False
    return window.open_path(path)


def confirm_pairs(window, model: PairImport) -> bool:
    """Show the pairs found (medium, prefix, labels, sizes, statuses, ticks) for the user to edit and
    confirm; True when they chose Add."""
    dialog = PairImportDialog(model, window)
    return dialog.exec() == QtWidgets.QDialog.DialogCode.Accepted


def add_image_pairs(window, left: list | None = None, right: list | None = None, prefix: str = "",
                    confirm=confirm_pairs) -> int:
    """Pair two folders (or lists) of images; the user chooses the medium, a label prefix or labels, and
    which pairs (``confirm(window, model)`` edits a :class:`PairImport`); the good ones are added and the
    others named. Returns the number of pairs added."""
    project = _need_project(window)
    if project is None:
        return 0
    if left is None:
        start = str(project.path.parent)
        folder = QtWidgets.QFileDialog.getExistingDirectory(window, "Folder of LEFT images", start)
        if not folder:
            return 0
        other = QtWidgets.QFileDialog.getExistingDirectory(window, "Folder of RIGHT images", folder)
        if not other:
            return 0
        left, right = [folder], [other]
    try:
        plan, rule = video_project.plan_image_pairs(left, right)
        model = PairImport(project, plan, RULE_NAMES[rule], prefix)
        if not confirm(window, model):
            return 0
        added, left_out = model.add()
    except UsvipsError as error:
        window.show_message("error", f"no pairs added: {error}")
        return 0
    window.refresh_pair_box()
    if left_out:
        window.show_message("warning", f"{plural(len(left_out), 'pair')} not added: " + "; ".join(left_out))
    window.show_message("info" if added else "error",
                        f"added {plural(len(added), 'image pair')} ({model.medium}, paired by {model.rule})"
                        + (f"; {plural(len(left_out), 'pair')} not added (see the log)" if left_out else ""))
    if window.workspace.pair is None and added:
        window.load_pair(added[0])
    return len(added)


def add_video(window, left: list | None = None, right: list | None = None, label: str | None = None,
              medium: str = "water") -> None:
    """Choose each camera's file(s) (several = chapters in order), the label and the medium the cameras
    looked through (water, or air for an in-air calibration video), read and check them in a worker, then
    store the video and show it."""
    project = _need_project(window)
    if project is None:
        return
    if left is None:
        left, _ = QtWidgets.QFileDialog.getOpenFileNames(window, "LEFT camera: file or chapters",
                                                         str(project.path.parent), VIDEO_FILTER)
        if not left:
            return
        right, _ = QtWidgets.QFileDialog.getOpenFileNames(window, "RIGHT camera: file or chapters",
                                                          str(Path(left[0]).parent), VIDEO_FILTER)
        if not right:
            return
        text, ok = QtWidgets.QInputDialog.getText(window, "Add stereo video", "Label:",
                                                  text=Path(left[0]).stem)
        if not ok:
            return
        label = text.strip() or None
        chosen, ok = QtWidgets.QInputDialog.getItem(
            window, "Add stereo video", "The cameras looked through (an in-air calibration video: air):",
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
            window.show_message("warning", warning)
        window.video.videos_changed(project)
        level = "warning" if added.warnings else "info"
        text = (f"added {added.summary}"
                + (f" — {plural(len(added.warnings), 'problem')} found (see the log)" if added.warnings
                   else "; both streams clean")
                + "; set its offset (the Video dock's Sync… or offset) before measuring")

        def again(_frame: int) -> None:  # said once more above the first frame, over the pair's own notes
            window.video.shown.disconnect(again)
            window.set_hint(text, level)

        window.video.shown.connect(again)
        if not window.video.open_video(added.label):
            window.video.shown.disconnect(again)
        window.show_message(level, text)

    window.run_worker(job, "reading the video files", store)


def relocate_media(window, answers: dict[str, str] | None = None) -> int:
    """For every missing media file, ask where it is now (or take ``answers``: stored path → new path);
    a file that is not the one added (size, SHA-256) is refused. Returns the number relocated."""
    project = _need_project(window)
    if project is None:
        return 0
    missing = [stored for stored, problem in project.media_problems(check_hash=False) if problem.startswith("missing")]
    if not missing:
        window.show_message("info", "no media file is missing")
        return 0
    done = 0
    for stored in missing:
        if answers is not None:
            new = answers.get(stored)
        else:
            new, _ = QtWidgets.QFileDialog.getOpenFileName(window, f"Where is {stored} now?", str(project.path.parent))
        if not new:
            continue
        try:
            project.relocate_media(stored, new)
            done += 1
        except UsvipsError as error:
            window.show_message("error", str(error))
    window.show_message("info", f"relocated {done} of {len(missing)} missing media files")
    return done
