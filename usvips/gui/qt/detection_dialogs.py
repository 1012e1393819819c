"""Measure › Detect fish on this frame / on a range of frames (usvips/gui/detect_model.py): the model's
description file asked once — Detection model… makes it the project's default (kept in the project, and in
the settings for new projects) — the detection run on the window's worker with its
progress and Stop in the status bar, the proposals stored as unreviewed objects and review mode opened on
them (A accepts, F flags, a re-picked vertex corrects a keypoint). Every line of the run goes to the log."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

from PySide6 import QtCore, QtWidgets

from usvips.app.detection_model import (
    DetectionModel,
    bundled_model_path,
    load_model,
    model_path_for,
    project_model_path,
)
from usvips.core.errors import UsvipsError
from usvips.gui.detect_model import DetectSession
from usvips.gui.figures_process import shared_process
from usvips.gui.messages import Messages
from usvips.gui.qt import proposal_handles
from usvips.gui.window_context import WindowContext
from usvips.store.interface import ProjectStore

SETTING = "detection/model"
MODEL_FILTER = "Model descriptions (*.toml *.json);;All files (*)"


#: the proposals' log lines the window adds in one turn of its event loop when a run ends
LINES_PER_TURN = 25


class _Detecting:
    """A workspace's detection session and the circles it draws (made when detection is first asked for)."""

    def __init__(self, context: WindowContext) -> None:
        self.session = DetectSession(context.workspace)
        self.circles = proposal_handles.circles(context)
        #: the description file *Detection model…* is loading on the worker (None: none), and how many files
        #: were chosen so far (a load that ends after a later choice is not adopted)
        self.loading: str | None = None
        self.choices = 0


#: each window's detection state, by its workspace's identity (a workspace is a dataclass: not hashable)
_STATES: dict[int, _Detecting] = {}


def _state(context: WindowContext) -> _Detecting:
    state = _STATES.get(id(context.workspace))
    if state is None or state.session.workspace is not context.workspace:
        state = _STATES[id(context.workspace)] = _Detecting(context)
    return state


def _session(context: WindowContext) -> DetectSession:
    return _state(context).session


def choose_model(context: WindowContext, parent: QtWidgets.QWidget, path: str | None = None) -> bool:
    """Ask for a model's description file (or take ``path``) and load it on the window's worker (a load reads,
    hashes and runs the network once: ~0.2 s, never on the window's thread): once loaded, the open project's
    default model, and kept in the settings for projects that have none. A file that is not a model is said
    as an error naming it and changes nothing. False when no file was chosen; True when the load started (or
    the file's model was loaded already). A Detect asked for while it loads uses this file."""
    if path is None:
        path = _ask_model_file(context, parent)
        if path is None:
            return False
    state = _state(context)
    session, project = state.session, context.workspace.project
    state.choices += 1
    choice = state.choices
    if session.is_loaded(path):
        state.loading = None
        _adopted(context, session.model, path, project)
        return True
    state.loading = path

    def settled() -> bool:
        """Whether this is still the latest choice (then nothing is loading any more)."""
        if choice != state.choices:
            return False
        state.loading = None
        return True

    def loaded(model: DetectionModel) -> None:
        if not settled():  # another file was chosen while this one loaded: the later choice stands
            context.messages.info(f"detection model {model.name}: loaded from {path}, but another was chosen since")
            return
        _adopted(context, model, path, project)
        context.messages.info(f"detection model {model.name}: loaded from {path}")

    def stopped() -> None:
        settled()
        context.messages.info(f"loading the detection model {Path(path).name}: cancelled")

    context.jobs.run(lambda progress, cancelled: load_model(path), f"Loading the detection model {Path(path).name}",
                     loaded, stopped, lambda _message: settled())
    return True


def loaded_model(context: WindowContext) -> DetectionModel | None:
    """The detection model the window has loaded (None: none yet)."""
    return _session(context).model


def _ask_model_file(context: WindowContext, parent: QtWidgets.QWidget) -> str | None:
    """The description file the user picks (starting where the last one was); None when cancelled."""
    settings = context.settings
    remembered = settings.value(SETTING, "") if settings is not None else ""
    path, _ = QtWidgets.QFileDialog.getOpenFileName(parent, "Detection model", str(
        remembered or context.start_folder()), MODEL_FILTER)
    return path or None


def _adopted(context: WindowContext, model: DetectionModel, path: str, project: ProjectStore | None) -> None:
    """``model`` (loaded from ``path``) the session's; the default of ``project`` when it is still the one open
    (another opened meanwhile keeps its own), and remembered in the settings."""
    _session(context).adopt(model, path, remember=project is not None and context.workspace.project is project)
    if context.settings is not None:
        context.settings.setValue(SETTING, path)


def _ready(context: WindowContext, parent: QtWidgets.QWidget) -> tuple[DetectSession, str | None, bool] | None:
    """The session and the model to detect with: (session, the description file the worker loads first —
    None when the model loaded is used —, whether to make it the project's default once loaded); None when
    the user chose no model. The model being loaded (*Detection model…*), else the project's default, else the
    model loaded, else the one remembered in the settings, else the model shipped with USVIPS (as ``usvips
    detect`` takes them); a file is asked for only when none is there. Nothing is loaded here: a load runs
    the network once, which is the worker's."""
    state = _state(context)
    session = state.session
    if state.loading is not None:
        return session, state.loading, True
    project = context.workspace.project
    try:  # the open project's default model first (another project opened in this window may have its own)
        default = model_path_for(project) if project is not None and project_model_path(project) else None
    except UsvipsError as error:  # the project's default is gone: say so, then ask for another
        context.messages.error(str(error))
        chosen = _ask_model_file(context, parent)
        return None if chosen is None else (session, chosen, True)
    if default is not None:
        return session, str(default), False
    if session.model is not None:
        return session, None, False
    remembered = str(context.settings.value(SETTING, "") or "") if context.settings is not None else ""
    if remembered and Path(remembered).is_file():
        return session, remembered, True
    try:  # as `usvips detect` does: the model shipped with USVIPS (it is no project's default for that)
        return session, str(bundled_model_path()), False
    except UsvipsError:
        chosen = _ask_model_file(context, parent)
        return None if chosen is None else (session, chosen, True)


def detect_frame(context: WindowContext, parent: QtWidgets.QWidget) -> None:
    """Detect on the image pair or video frame shown."""
    _run(context, parent, 1, 1)


def detect_range(context: WindowContext, parent: QtWidgets.QWidget, frames: int | None = None,
                 every: int | None = None) -> None:
    """Detect on a range of the video's frames from the one shown (asked: how many, and every how many)."""
    if context.workspace.video_frame is None:
        context.messages.warning("a range of frames needs a video: show one of its frames")
        return
    if frames is None:
        frames, ok = QtWidgets.QInputDialog.getInt(parent, "Detect on frames", "How many frames from this one:",
                                                   25, 1, 100000)
        if not ok:
            return
        every, ok = QtWidgets.QInputDialog.getInt(parent, "Detect on frames", "Every how many frames:", 1, 1, 10000)
        if not ok:
            return
    _run(context, parent, frames, every or 1)


def _run(context: WindowContext, parent: QtWidgets.QWidget, frames: int, every: int) -> None:
    ready = _ready(context, parent)
    if ready is None:
        return
    session, path, remember = ready
    try:
        plan = session.plan(frames, every)
        job = session.job(plan, path)
    except UsvipsError as error:
        context.messages.error(str(error))
        return
    name = session.model.name if path is None or session.is_loaded(path) else Path(path).stem
    shared_process().warm()  # the proposals' figures are asked for when the run ends: the child ready by then

    def done(run) -> None:
        if path is not None:
            session.adopt(run.model, path, remember)
            if remember and context.settings is not None:
                context.settings.setValue(SETTING, path)

        def ending():  # each step a turn of the event loop of its own (see _in_turns)
            yield from session.writing(run)  # the proposals stored and told to the views, STORE_STEP a turn
            shown = session.lines(run)
            body = shown[:-2]
            for i in range(0, len(body), LINES_PER_TURN):  # the proposals' lines, LINES_PER_TURN a turn
                for line in body[i:i + LINES_PER_TURN]:
                    context.messages.info(line)
                yield
            context.messages.info("; ".join(shown[-2:]))  # the summary, then review mode
            navigation = context.navigation
            if any(p.object_id is not None for p in run.proposals) and navigation and navigation.show_review:
                navigation.show_review()

        # one step per turn of the event loop, so that the window draws and answers between them (issue 35:
        # no freeze over 0.1 s): the proposals stored and shown, a slice a step (the views, their σ circles
        # included, redraw on the workspace's news); their lines; review mode
        _in_turns(ending(), context.messages, parent)

    context.jobs.run(job, f"Detecting with {name}", done)


def _in_turns(steps: Iterator[object], messages: Messages, owner: QtCore.QObject) -> None:
    """Advance ``steps`` (a generator doing a step of work up to each ``yield``) once a turn of the event loop
    (the window draws between them) until it is done; a step that fails with a :class:`UsvipsError` is said as
    an error and ends the rest. The steps belong to ``owner`` (the window): once it is gone, the rest are not
    taken."""

    def step() -> None:
        try:
            next(steps)
        except StopIteration:
            return
        except UsvipsError as error:
            messages.error(str(error))
            return
        QtCore.QTimer.singleShot(1, owner, step)

    QtCore.QTimer.singleShot(1, owner, step)  # a timer, not a posted call: what came due meanwhile goes first
