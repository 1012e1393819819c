"""Measure › Detect fish on this frame / on a range of frames (usvips/gui/detect_model.py): the model's
description file asked once — Detection model… makes it the project's default (kept in the project, and in
the settings for new projects) — the detection run on the window's worker with its
progress and Stop in the status bar, the proposals stored as unreviewed objects and review mode opened on
them (A accepts, F flags, a re-picked vertex corrects a keypoint). Every line of the run goes to the log."""

from __future__ import annotations

import pyqtgraph as pg
from PySide6 import QtWidgets

from usvips.core.errors import UsvipsError
from usvips.gui.detect_model import DetectSession, correct_keypoint, proposal_keypoints, sigma_circles
from usvips.gui.qt.pane import item_from_pixels
from usvips.gui.window_context import WindowContext

SETTING = "detection/model"
MODEL_FILTER = "Model descriptions (*.toml *.json);;All files (*)"


SIGMA_COLOUR = (255, 170, 0)


class SigmaCircles:
    """The 95 % circles of the proposals' keypoints on the panes, and a handle on each keypoint that a
    reviewer drags to correct it (one undoable edit), redrawn when the pair or frame shown, or the objects,
    change (usvips.gui.detect_model.sigma_circles, proposal_keypoints, correct_keypoint)."""

    def __init__(self, context: WindowContext) -> None:
        self.context = context
        self.handles: list = []
        self.items = {}
        for side, pane in context.panes.items():
            item = pg.ScatterPlotItem(pxMode=False, symbol="o", brush=None, pen=pg.mkPen(SIGMA_COLOUR, width=1.5))
            pane.viewbox.addItem(item, ignoreBounds=True)
            self.items[side] = item
        ws = context.workspace
        for event in (ws.pair_changed, ws.objects_changed):
            event.connect(self.draw)

    def draw(self, *_: object) -> None:
        ws = self.context.workspace
        circles = sigma_circles(ws)
        for side, item in self.items.items():
            rows = circles[side]
            item.setData(pos=item_from_pixels(rows[:, :2]), size=2 * rows[:, 2])
        for handle, pane in self.handles:
            pane.viewbox.removeItem(handle)
        self.handles = []
        for object_id, index, side, pixel in proposal_keypoints(ws):
            pane = self.context.panes[side]
            handle = pg.TargetItem(tuple(item_from_pixels(pixel)[0]), size=9, symbol="o",
                                   pen=pg.mkPen(SIGMA_COLOUR, width=1), hoverPen=pg.mkPen((255, 255, 255), width=2))
            handle.setToolTip(f"object {object_id}: drag to correct this keypoint")
            handle.sigPositionChangeFinished.connect(
                lambda item, o=object_id, i=index, s=side: self._moved(o, i, s, item))
            pane.viewbox.addItem(handle, ignoreBounds=True)
            self.handles.append((handle, pane))

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


def _ready(context: WindowContext, parent: QtWidgets.QWidget) -> DetectSession | None:
    session = _session(context)
    try:  # the open project's default model first (another project opened in this window may have its own)
        if session.project_model() is not None:
            return session
    except UsvipsError as error:  # the project's default is gone: say so, then ask for another
        context.messages.error(str(error))
        return session if choose_model(context, parent) else None
    if session.model is None:
        remembered = str(context.settings.value(SETTING, "") or "") if context.settings is not None else ""
        if not (remembered and choose_model(context, parent, remembered)) and not choose_model(context, parent):
            return None
    return session


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
    session = _ready(context, parent)
    if session is None:
        return
    try:
        plan = session.plan(frames, every)
        job = session.job(plan)
    except UsvipsError as error:
        context.messages.error(str(error))
        return

    def done(run) -> None:
        lines = session.store(run)
        circles = _state(context).circles
        if circles is not None:
            circles.draw()
        for line in lines[:-2]:
            context.messages.info(line)
        context.messages.info("; ".join(lines[-2:]))
        navigation = context.navigation
        if any(p.object_id is not None for p in run.proposals) and navigation and navigation.show_review:
            navigation.show_review()

    context.jobs.run(job, f"Detecting with {session.model.name}", done)
