"""A detection model's proposals on the panes, for review: the 95 % circles of their keypoints and a handle
on each keypoint that a reviewer drags to correct it (:mod:`usvips.gui.proposal_marks`). One set per window,
made when the window's review panel is first made or a Detect first runs — whichever comes first — and kept
up to date from then on, so that proposals stored by ``usvips detect`` or an earlier session can be
corrected too. Light: nothing of detection is imported."""

from __future__ import annotations

from PySide6 import QtCore

from usvips.core.errors import UsvipsError
from usvips.gui.proposal_marks import correct_keypoint, proposal_keypoints, sigma_circles
from usvips.gui.qt.marks import Circles, Handle
from usvips.gui.qt.pane import item_from_pixels
from usvips.gui.window_context import WindowContext

#: the colour of the circles and handles (RGB)
SIGMA_COLOUR = (255, 170, 0)
#: the keypoint handles the window makes in one turn of its event loop
HANDLES_PER_TURN = 6


class SigmaCircles:
    """The 95 % circles of the proposals' keypoints on the panes, and a handle on each keypoint that a
    reviewer drags to correct it (one undoable edit), redrawn when the pair or frame shown, or the objects,
    change (usvips.gui.proposal_marks.sigma_circles, proposal_keypoints, correct_keypoint).

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


#: each window's circles, by its workspace's identity (a workspace is a dataclass: not hashable)
_CIRCLES: dict[int, SigmaCircles] = {}


def circles(context: WindowContext) -> SigmaCircles | None:
    """The window's proposal circles and handles, made the first time they are asked for (None: a context
    without panes)."""
    if not context.panes:
        return None
    made = _CIRCLES.get(id(context.workspace))
    if made is None or made.context.workspace is not context.workspace:
        made = _CIRCLES[id(context.workspace)] = SigmaCircles(context)
    return made


def show_proposals(context: WindowContext) -> None:
    """Draw the proposals of the pair or frame shown — an earlier session's, or ``usvips detect``'s — with
    their keypoints' 95 % circles and the handles that correct them (see the module docstring)."""
    made = circles(context)
    if made is not None:
        made.draw()
