"""Measure › Detect fish on this frame / on a range of frames (usvips/gui/detect_model.py): the model's
description file asked once — Detection model… makes it the project's default (kept in the project, and in
the settings for new projects) — the detection run on the window's worker with its
progress and Stop in the status bar, the proposals stored as unreviewed objects and review mode opened on
them (A accepts, F flags, a re-picked vertex corrects a keypoint). Every line of the run goes to the log."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from PySide6 import QtCore, QtWidgets

from usvips.app.detection_model import bundled_model_path, model_path_for, project_model_path
from usvips.core.errors import UsvipsError
from usvips.gui.detect_model import DetectSession, correct_keypoint, proposal_keypoints, sigma_circles
from usvips.gui.messages import Messages
from usvips.gui.qt.marks import Circles, Handle
from usvips.gui.qt.pane import item_from_pixels
from usvips.gui.window_context import WindowContext

SETTING = "detection/model"
MODEL_FILTER = "Model descriptions (*.toml *.json);;All files (*)"


SIGMA_COLOUR = (255, 170, 0)
#: the proposals' log lines the window adds in one turn of its event loop when a run ends
LINES_PER_TURN = 25
#: the keypoint handles the window makes in one turn of its event loop
HANDLES_PER_TURN = 6


class SigmaCircles:
    """The 95 % circles of the proposals' keypoints on the panes, and a handle on each keypoint that a
    reviewer drags to correct it (one undoable edit), redrawn when the pair or frame shown, or the objects,
    change (usvips.gui.detect_model.sigma_circles, proposal_keypoints, correct_keypoint).

    A handle is a graphics item of its own (a few milliseconds each to make): the handles of keypoints
    still shown are moved, not made again, and new ones are made :data:`HANDLES_PER_TURN` a turn of the
    event loop, so that a run's many proposals, or a review's every accept, do not freeze the window."""

    def __init__(self, context: WindowContext) -> None:
        self.context = context
        self.handles: dict[tuple[int, int, str], tuple[Handle, object]] = {}
        self._wanted: dict[tuple[int, int, str], tuple[float, float]] = {}
        self._growing = False
        self.items = {}
        for side, pane in context.panes.items():
            item = Circles(SIGMA_COLOUR, width=1.5)
            pane.add_mark(item)
            self.items[side] = item
        ws = context.workspace
        for event in (ws.pair_changed, ws.objects_changed):
            event.connect(self.draw)

    def draw(self, *_: object) -> None:
        ws = self.context.workspace
        circles = sigma_circles(ws)
        for side, item in self.items.items():
            rows = circles[side]
            item.set_circles(item_from_pixels(rows[:, :2]), 2 * rows[:, 2])
        self._wanted = {(object_id, index, side): pixel for object_id, index, side, pixel in proposal_keypoints(ws)}
        for key in [key for key in self.handles if key not in self._wanted]:
            handle, pane = self.handles.pop(key)
            pane.remove_mark(handle)
        for key, (handle, _) in self.handles.items():
            position = tuple(item_from_pixels(self._wanted[key])[0])
            if (handle.pos().x(), handle.pos().y()) != position:
                handle.setPos(*position)
        if len(self.handles) < len(self._wanted) and not self._growing:
            self._growing = True
            self._next_turn()

    def _grow(self) -> None:
        """Make up to :data:`HANDLES_PER_TURN` of the missing handles; again next turn while some are missing."""
        missing = [key for key in self._wanted if key not in self.handles][:HANDLES_PER_TURN]
        for key in missing:
            object_id, index, side = key
            pane = self.context.panes[side]
            handle = Handle(tuple(item_from_pixels(self._wanted[key])[0]), 9, "o", SIGMA_COLOUR, 1,
                            (255, 255, 255), 2)
            handle.setToolTip(f"object {object_id}: drag to correct this keypoint")
            handle.dropped.connect(lambda item, key=key: self._moved(*key, item))
            pane.add_mark(handle)
            self.handles[key] = (handle, pane)
        self._growing = len(self.handles) < len(self._wanted)
        if self._growing:
            self._next_turn()

    def _next_turn(self) -> None:
        # tied to a pane: a window closed and gone meanwhile takes the timer with it
        QtCore.QTimer.singleShot(1, next(iter(self.context.panes.values())), self._grow)

    def _moved(self, object_id: int, index: int, side: str, item) -> None:
        position = item.pos()
        pixel = (position.x() - 0.5, position.y() - 0.5)
        try:
            correct_keypoint(self.context.workspace, object_id, index, side, pixel)
        except UsvipsError as error:
            self.context.messages.error(str(error))
        self.draw()


class _Detecting:
    """A workspace's detection session and the circles it draws (made when detection is first asked for)."""

    def __init__(self, context: WindowContext) -> None:
        self.session = DetectSession(context.workspace)
        self.circles = SigmaCircles(context) if context.panes else None


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
    """Ask for a model's description file (or take ``path``): the open project's default model from now
    on, and kept in the settings for projects that have none."""
    settings = context.settings
    if path is None:
        remembered = settings.value(SETTING, "") if settings is not None else ""
        path, _ = QtWidgets.QFileDialog.getOpenFileName(parent, "Detection model", str(
            remembered or context.start_folder()), MODEL_FILTER)
        if not path:
            return False
    try:
        _session(context).choose_model(path, remember=True)
    except UsvipsError as error:
        context.messages.error(str(error))
        return False
    if settings is not None:
        settings.setValue(SETTING, path)
    return True


def _ready(context: WindowContext, parent: QtWidgets.QWidget) -> tuple[DetectSession, str | None, bool] | None:
    """The session and the model to detect with: (session, the description file the worker loads first —
    None when the model loaded is used —, whether to make it the project's default once loaded); None when
    the user chose no model. The project's default, else the model loaded, else the one remembered in the
    settings, else the model shipped with USVIPS (as ``usvips detect`` takes them); a file is asked for only
    when none is there. Nothing is loaded here: a load runs the network once, which is the worker's."""
    session = _session(context)
    project = context.workspace.project
    try:  # the open project's default model first (another project opened in this window may have its own)
        default = model_path_for(project) if project is not None and project_model_path(project) else None
    except UsvipsError as error:  # the project's default is gone: say so, then ask for another
        context.messages.error(str(error))
        return (session, None, False) if choose_model(context, parent) else None
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
        return (session, None, False) if choose_model(context, parent) else None


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

    def done(run) -> None:
        if path is not None:
            session.adopt(run.model, path, remember)
            if remember and context.settings is not None:
                context.settings.setValue(SETTING, path)
        shown: list[str] = []

        def say(lines: list[str]) -> None:
            for line in lines:
                context.messages.info(line)

        def review() -> None:
            context.messages.info("; ".join(shown[-2:]))
            navigation = context.navigation
            if any(p.object_id is not None for p in run.proposals) and navigation and navigation.show_review:
                navigation.show_review()

        def lines() -> None:  # the proposals' lines, LINES_PER_TURN a turn, then the summary and review mode
            body = shown[:-2]
            steps = [lambda chunk=body[i:i + LINES_PER_TURN]: say(chunk) for i in range(0, len(body), LINES_PER_TURN)]
            _in_turns([*steps, review], context.messages, parent)

        # one step per turn of the event loop, so that the window draws and answers between them (issue 35:
        # no freeze over 0.1 s): the proposals stored; shown (the views, their σ circles included, redraw
        # on the workspace's news); their lines; review mode
        _in_turns([lambda: session.write(run), lambda: shown.extend(session.show(run)), lines], context.messages,
                  parent)

    context.jobs.run(job, f"Detecting with {name}", done)


def _in_turns(steps: list[Callable[[], None]], messages: Messages, owner: QtCore.QObject) -> None:
    """Call ``steps`` in order, each in a turn of the event loop of its own (the window draws between them);
    a step that fails with a :class:`UsvipsError` is said as an error and ends the rest. The steps belong to
    ``owner`` (the window): once it is gone, the rest are not called."""
    if not steps:
        return

    def step() -> None:
        try:
            steps[0]()
        except UsvipsError as error:
            messages.error(str(error))
            return
        _in_turns(steps[1:], messages, owner)

    QtCore.QTimer.singleShot(1, owner, step)  # a timer, not a posted call: what came due meanwhile goes first
