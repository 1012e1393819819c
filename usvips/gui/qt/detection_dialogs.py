"""Measure › Detect fish on this frame / on a range of frames (usvips/gui/detect_model.py): the model's
description file asked once (kept in the settings), the detection run on the window's worker with its
progress and Stop in the status bar, the proposals stored as unreviewed objects and review mode opened on
them (A accepts, F flags, a re-picked vertex corrects a keypoint). Every line of the run goes to the log."""

from __future__ import annotations

import pyqtgraph as pg
from PySide6 import QtWidgets

from usvips.core.errors import UsvipsError
from usvips.gui.detect_model import DetectSession, correct_keypoint, proposal_keypoints, sigma_circles
from usvips.gui.qt.pane import item_from_pixels

SETTING = "detection/model"
MODEL_FILTER = "Model descriptions (*.toml *.json);;All files (*)"


SIGMA_COLOUR = (255, 170, 0)


class SigmaCircles:
    """The 95 % circles of the proposals' keypoints on the panes, and a handle on each keypoint that a
    reviewer drags to correct it (one undoable edit), redrawn when the pair or frame shown, or the objects,
    change (usvips.gui.detect_model.sigma_circles, proposal_keypoints, correct_keypoint)."""

    def __init__(self, window) -> None:
        self.window = window
        self.handles: list = []
        self.items = {}
        for side, pane in window.panes.items():
            item = pg.ScatterPlotItem(pxMode=False, symbol="o", brush=None, pen=pg.mkPen(SIGMA_COLOUR, width=1.5))
            pane.viewbox.addItem(item, ignoreBounds=True)
            self.items[side] = item
        ws = window.workspace
        for event in (ws.pair_changed, ws.objects_changed):
            event.connect(self.draw)

    def draw(self, *_: object) -> None:
        ws = self.window.workspace
        circles = sigma_circles(ws)
        for side, item in self.items.items():
            rows = circles[side]
            item.setData(pos=item_from_pixels(rows[:, :2]), size=2 * rows[:, 2])
        for handle, pane in self.handles:
            pane.viewbox.removeItem(handle)
        self.handles = []
        for object_id, index, side, pixel in proposal_keypoints(ws):
            pane = self.window.panes[side]
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
            correct_keypoint(self.window.workspace, object_id, index, side, pixel)
        except UsvipsError as error:
            self.window.show_message("error", str(error))
        self.draw()


def _session(window) -> DetectSession:
    session = getattr(window, "_detect_session", None)
    if session is None or session.workspace is not window.workspace:
        session = window._detect_session = DetectSession(window.workspace)
    if getattr(window, "_sigma_circles", None) is None:
        window._sigma_circles = SigmaCircles(window)
    return session


def choose_model(window, path: str | None = None) -> bool:
    """Ask for a model's description file (or take ``path``); kept in the settings for the next time."""
    if path is None:
        path, _ = QtWidgets.QFileDialog.getOpenFileName(window, "Detection model", str(
            window.settings.value(SETTING, "") or window.start_folder()), MODEL_FILTER)
        if not path:
            return False
    try:
        _session(window).choose_model(path)
    except UsvipsError as error:
        window.show_message("error", str(error))
        return False
    window.settings.setValue(SETTING, path)
    return True


def _ready(window) -> DetectSession | None:
    session = _session(window)
    if session.model is None:
        remembered = str(window.settings.value(SETTING, "") or "")
        if not (remembered and choose_model(window, remembered)) and not choose_model(window):
            return None
    return session


def detect_frame(window) -> None:
    """Detect on the image pair or video frame shown."""
    _run(window, 1, 1)


def detect_range(window, frames: int | None = None, every: int | None = None) -> None:
    """Detect on a range of the video's frames from the one shown (asked: how many, and every how many)."""
    if window.workspace.video_frame is None:
        window.show_message("warning", "a range of frames needs a video: show one of its frames")
        return
    if frames is None:
        frames, ok = QtWidgets.QInputDialog.getInt(window, "Detect on frames", "How many frames from this one:",
                                                   25, 1, 100000)
        if not ok:
            return
        every, ok = QtWidgets.QInputDialog.getInt(window, "Detect on frames", "Every how many frames:", 1, 1, 10000)
        if not ok:
            return
    _run(window, frames, every or 1)


def _run(window, frames: int, every: int) -> None:
    session = _ready(window)
    if session is None:
        return
    try:
        plan = session.plan(frames, every)
        job = session.job(plan)
    except UsvipsError as error:
        window.show_message("error", str(error))
        return

    def done(run) -> None:
        lines = session.store(run)
        window._sigma_circles.draw()
        for line in lines[:-2]:
            window.messages.info(line)
        window.show_message("info", "; ".join(lines[-2:]))
        if any(p.object_id is not None for p in run.proposals):
            window.show_review()

    window.run_worker(job, f"Detecting with {session.model.name}", done)
