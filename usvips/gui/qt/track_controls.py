"""Tracking in the window (issue 25): the Measure › Track actions, the tracks drawn on both panes and
on the video timeline, corrections, track-based proposals and storing the tracks as instants.

Keys (on the images): **T** tracks every vertex of the selected object (else the object just stored)
backward and forward from the frame it was measured on; **Shift+T** re-follows from the frame shown,
from the point just re-picked there (click it in the left image, then its partner: the pick tool keeps
it); **P** proposes the selected object's vertices on the frame shown (tracked from its frame: Enter
accepts each, a click corrects); **Ctrl+T** stores the tracks as instants of the object (every N frames,
or the frames typed; undoable). Tracking runs in a worker, with its progress and a Cancel that stops it
within a frame, so the window never waits on the decoder.

The tracks live in a :class:`usvips.gui.track_model.TrackModel` (Qt-free); this controller only runs the
work and draws: the tracked points on the frame shown (green circles; a corrected frame's as a star) with
a short trail of the frames before, and the timeline's green bar over the tracked span with red ticks
where a track stopped.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np
from PySide6 import QtCore, QtWidgets

from usvips.app.object_instants import add_instant
from usvips.core.errors import UsvipsError
from usvips.gui.pick_tool import TOOLS
from usvips.gui.qt.marks import Lines, Points
from usvips.gui.qt.pane import item_from_pixels
from usvips.gui.qt.worker import Cancelled
from usvips.gui.track_model import TrackModel, parse_instant_frames, tracking_core
from usvips.gui.undo import Command
from usvips.gui.window_context import WindowContext

if TYPE_CHECKING:
    from usvips.app.tracking import VertexProposal


def _tracking():
    """:mod:`usvips.app.tracking`, imported when first used, not at the window's start (imported here, not
    lazily at the top, so that any thread may be the first: the import lock guards it)."""
    from usvips.app import tracking

    return tracking


#: the colour of tracked points and their trails (RGB)
TRACK_COLOUR = (40, 230, 110)


def _instants_summary(workspace, object_id: int) -> str:
    """The one line on an object's instants (:mod:`usvips.gui.instants_model`, imported when first needed,
    not at the window's start)."""
    from usvips.gui.instants_model import object_instants

    return object_instants(workspace.project, object_id, workspace.rules, workspace.cache.calibrations).summary()


class TrackController(QtCore.QObject):
    """Runs tracking over the video shown and draws its tracks (see the module docstring)."""

    #: frames tracked each way from the object's frame (10 s at 25 fps; the track stops earlier by itself)
    REACH = 250
    #: frames of trail drawn behind the tracked point
    TRAIL = 12

    def __init__(self, parent: QtWidgets.QWidget, context: WindowContext, panes: dict, video,
                 set_tool: Callable[[str], object]) -> None:
        """``parent``: the widget its dialogs belong to; ``context``: the workspace, the messages and the
        jobs; ``panes``: the stereo panes by side (the tracks are drawn on them); ``video``: the
        :class:`~usvips.gui.qt.video_controls.VideoController` (its frames shown, its timeline's marks);
        ``set_tool(tool)``: choose the measuring tool (the window's toolbar follows)."""
        super().__init__(parent)
        self.workspace, self.messages, self.jobs = context.workspace, context.messages, context.jobs
        self.panes, self.video, self.set_tool = panes, video, set_tool
        self.model = TrackModel()
        self._settings = None  # the tracker's settings, made when first read (settings)
        self.range: tuple[int, int] = (0, 0)  # the frames asked for when the object was tracked
        self.worker = None
        self._last_stored: int | None = None
        self._last_point = None  # the workspace's last measured vertex, and the frame it was measured on
        self._last_point_frame: int | None = None
        self._proposals: tuple[int, int, list[VertexProposal]] | None = None  # object, frame, proposals
        self._proposed = -1  # the index of the vertex proposed last
        # (object, frame, the picks taken from its proposals): the object stored with those picks joins it
        self._instant_of: tuple[int, int, list] | None = None
        self._tracked_from: int | None = None  # the frame the proposals taken were tracked from
        #: the object just stored from the proposals, about to join its object as an instant (its species
        #: is the object's: the observation form does not ask for one)
        self.joining: int | None = None
        self._joining_whole: int | None = None
        self.items = {}
        for side, pane in panes.items():
            trail = Lines(TRACK_COLOUR, width=1.5)
            points = Points(13, TRACK_COLOUR, width=2, symbol="o")
            for item in (trail, points):
                pane.add_mark(item)
            self.items[side] = (trail, points)
        ws = self.workspace
        ws.stored.connect(self._on_stored)
        ws.picks_changed.connect(self._on_picks)
        ws.objects_reset.connect(self._on_reset)
        ws.project_changed.connect(self._on_project)
        ws.objects_removed.connect(self._on_removed)
        video.shown.connect(self.draw)

    @property
    def settings(self):
        """The tracker's settings (:class:`usvips.core.tracking.TrackSettings`; the tracker is imported when
        first used, not at the window's start)."""
        if self._settings is None:
            self._settings = tracking_core().TrackSettings()
        return self._settings

    # ------------------------------------------------------------------ what to track
    def joins_as_instant(self, object_id: int) -> int | None:
        """The object that stored object ``object_id`` joins as an instant — it was stored from the
        proposals, their vertices untouched, on their frame — else None."""
        if self.joining == int(object_id):
            return self._joining_whole
        if self._instant_of is None:
            return None
        whole, frame, taken = self._instant_of
        ws = self.workspace
        stored = ws.stored_object(object_id)
        picks = [((v.xl, v.yl), (v.xr, v.yr)) for v in stored.vertices]
        return whole if picks == taken and stored.vertices[0].frame_left == frame and whole in ws.cache else None

    def _on_stored(self, object_id: int) -> None:
        self._last_stored = int(object_id)
        whole = self.joins_as_instant(object_id)
        self._instant_of = None
        if whole is not None:
            # after the store has finished (and said so): the link is its own undoable step
            self.joining, self._joining_whole = int(object_id), whole
            tracked_from = self._tracked_from
            QtCore.QTimer.singleShot(0, lambda: self._join_stored(whole, int(object_id), tracked_from))

    def _join_stored(self, object_id: int, instant_id: int, tracked_from: int | None) -> None:
        try:
            self.join(object_id, instant_id, tracked_from)
        finally:
            self.joining = self._joining_whole = None

    def join(self, object_id: int, instant_id: int, tracked_from: int | None = None) -> bool:
        """Make stored object ``instant_id`` a further instant of ``object_id`` (one undoable step;
        ``tracked_from``: the frame its proposals were tracked from when a vertex was kept as proposed, so
        that its pick error is counted as shared with the object's); refused by name (different
        calibrations or kinds), nothing changed."""
        ws = self.workspace

        # each step names the version of the instant as this window last read it (a colleague's change since
        # is refused by name, not undone)
        def redo() -> None:
            add_instant(ws.project, object_id, instant_id, tracked_from, ws.stored_object(instant_id).modified)
            ws.cache.changed_in_store(updated=(object_id, instant_id))

        def undo() -> None:
            ws.project.remove_instant(instant_id, expected_modified=ws.stored_object(instant_id).modified)
            ws.cache.changed_in_store(updated=(object_id, instant_id))

        try:
            ws.undo.push(Command(f"make object {instant_id} an instant of object {object_id}", redo, undo))
            summary = _instants_summary(ws, object_id)
        except UsvipsError as error:
            self.messages.say("error", f"object {instant_id} stays an object of its own: {error}")
            return False
        self.messages.say("info", f"object {instant_id} is an instant of object {object_id} (Ctrl+Z undoes "
                                         f"it) — {summary}")
        return True

    def _on_reset(self, *_: object) -> None:
        """Another project: nothing of the previous one's tracks stays."""
        self.model.clear()
        self._last_stored, self._proposals = None, None
        self.draw()

    def _on_project(self, *_: object) -> None:
        """Another project: a proposal under way, or taken and waiting to be stored as an instant, was the
        previous project's object (an object of the same id here is another one)."""
        self._proposals, self._proposed, self._instant_of = None, -1, None
        self._last_point, self._last_point_frame = None, None

    def _start_frame(self, object_id: int) -> int | None:
        """The left frame object ``object_id`` was measured on (its proposals are tracked from there)."""
        stored = self.workspace.stored_object(object_id)
        return int(stored.vertices[0].frame_left) if stored.vertices and stored.vertices[0].frame_left is not None \
            else None

    def _on_removed(self, ids) -> None:
        if self.model.object_id in set(ids):
            self.model.clear()
            self.draw()

    def _on_picks(self) -> None:
        """Remember on which frame the last vertex was measured (a re-pick for Shift+T); after a proposed
        vertex is taken, propose the next."""
        ws = self.workspace
        if ws.pick_tool.last_point is not self._last_point:
            self._last_point = ws.pick_tool.last_point
            self._last_point_frame = ws.video_frame[1] if ws.video_frame is not None else None
        self._propose_next()

    def _frame(self) -> tuple[str, int]:
        frame = self.workspace.video_frame
        if frame is None:
            raise UsvipsError("tracking works on a stereo video: show a video's frames (File › Add stereo video…)")
        return frame[0], int(frame[1])

    def target(self) -> int:
        """The object to track: the one selected, else the one just stored."""
        ws = self.workspace
        if len(ws.selection) == 1:
            return int(ws.selection[0])
        if len(ws.selection) > 1:
            raise UsvipsError("select one object to track (several are selected)")
        if self._last_stored is not None and self._last_stored in ws.cache:
            return self._last_stored
        raise UsvipsError("select the object to track in the object list (or measure one on this frame)")

    def _object_on_video(self, object_id: int, label: str):
        stored = self.workspace.stored_object(object_id)
        first = stored.vertices[0] if stored.vertices else None
        if first is None or first.video is None:
            raise UsvipsError(f"object {object_id} was not measured on a video: there is nothing to track it through")
        if first.video != label:
            raise UsvipsError(f"object {object_id} was measured on video {first.video!r}, not on {label!r} shown")
        return stored

    # ------------------------------------------------------------------ tracking
    def track(self):
        """T: track every vertex of the object from its frame, both ways, in a worker; returns the worker
        (None when refused: the reason is in the status bar)."""
        try:
            label, _ = self._frame()
            object_id = self.target()
            stored = self._object_on_video(object_id, label)
            tracker = _tracking().VideoTracker.read(self.workspace.project, label)
        except UsvipsError as error:
            self.messages.say("error", str(error))
            return None
        start = int(stored.vertices[0].frame_left)
        first, last = start - self.REACH, start + self.REACH
        picks = [((v.xl, v.yl), (v.xr, v.yr)) for v in stored.vertices]
        settings = self.settings

        def job(progress, cancelled):
            counted = {"vertex": 0, "done": 0}

            def report(done: int, total: int) -> None:  # each vertex's frames are counted from 0 again
                if done < counted["done"]:
                    counted["vertex"] += 1
                counted["done"] = done
                progress(min((counted["vertex"] + done / max(total, 1)) / len(picks), 1.0))

            # every frame pair decoded once for all the vertices (VideoTracker.track_many)
            tracks = tracker.track_many(start, picks, first, last, settings, cancelled, report)
            if cancelled() or any(tracking_core().CANCELLED in (t.reason(-1), t.reason(1)) for t in tracks):
                raise Cancelled
            return tracks

        def done(tracks) -> None:
            self.model.begin(object_id, label, start, len(tracks))
            for k, track in enumerate(tracks):
                self.model.set_track(k, track)
            self.range = (first, last)
            self.draw()
            self.messages.say("info", f"tracked {self.model.describe()} — Shift+T re-follows from a point "
                                             "re-picked on a frame, Ctrl+T stores instants")

        return self._run(job, f"tracking object {object_id}", done)

    def refollow(self):
        """Shift+T: the vertex re-picked on the frame shown (the last measured point there) is followed on
        from that frame, replacing its track beyond it."""
        ws = self.workspace
        try:
            label, frame = self._frame()
            if self.model.object_id is None or self.model.label != label:
                raise UsvipsError("nothing is tracked on this video: select an object and press T first")
            if ws.pick_tool.last_point is None or self._last_point_frame != frame:
                raise UsvipsError(f"re-pick the point on this frame ({frame}) first: click it in the left image, "
                                  "then its partner (pick tool), then Shift+T")
            left, right = ws.pick_tool.last_point.left, ws.pick_tool.last_point.right
            vertex = self.model.nearest_vertex(frame, left)
            tracker = _tracking().VideoTracker.read(ws.project, label)
        except UsvipsError as error:
            self.messages.say("error", str(error))
            return None
        start = self.model.start
        first, last = self.range
        first, last = (frame, last) if frame > start else (first, frame) if frame < start else (first, last)
        settings = self.settings

        def job(progress, cancelled):
            track = tracker.track(frame, left, right, first, last, settings, cancelled,
                                  lambda done, total: progress(done / max(total, 1)))
            if cancelled():
                raise Cancelled
            return track

        def done(track) -> None:
            self.model.correct(vertex, track)
            self.draw()
            self.messages.say("info", f"vertex {vertex + 1} re-followed from frame {frame}: "
                                             f"{self.model.describe()}")

        return self._run(job, f"re-following vertex {vertex + 1} from frame {frame}", done)

    def _run(self, job, label: str, done):
        if self.worker is not None and self.worker in self.jobs.workers:
            self.messages.say("warning", "tracking is already running: wait for it or Cancel it")
            return None
        project = self.workspace.project

        def finished(result) -> None:
            if self.workspace.project is project:  # not another project's, opened meanwhile
                done(result)

        self.worker = self.jobs.run(job, label, finished,
                                             lambda: self.messages.say("info", f"{label}: cancelled, "
                                                                                      "nothing changed"))
        return self.worker

    # ------------------------------------------------------------------ drawing
    def draw(self, *_: object) -> None:
        """The tracked points on the frame shown with their trails, and the timeline's span and stops."""
        ws = self.workspace
        frame = ws.video_frame
        shown = frame is not None and self.model.object_id is not None and frame[0] == self.model.label
        for side, (trail_item, points_item) in self.items.items():
            column = 0 if side == "left" else 1
            if not shown:
                trail_item.set_points(None)
                points_item.set_points(None)
                continue
            at = sorted(self.model.points_at(frame[1]).items())
            points_item.set_points(np.array([item_from_pixels(pixels[column])[0] for _, pixels in at]).reshape(-1, 2),
                                   ["star" if frame[1] in self.model.corrected.get(vertex, set()) else "o"
                                    for vertex, _ in at])
            pieces = []
            for vertex in range(self.model.vertex_count):
                trail = self.model.trail(vertex, frame[1], self.TRAIL)[column]
                if len(trail) > 1:
                    pieces.extend([item_from_pixels(trail), np.full((1, 2), np.nan)])
            line = np.vstack(pieces) if pieces else np.zeros((0, 2))
            trail_item.set_points(line)
        self.video.show_track(self.model.label, self.model.span(),
                              {s.frame for s in self.model.stops() if s.reason != tracking_core().CANCELLED})

    # ------------------------------------------------------------------ instants
    def store_dialog(self) -> None:
        """Ctrl+T: ask which frames (every N, or a list) and store the tracks there as instants."""
        if not self.model.complete:
            self.messages.say("error", "nothing tracked to store: select an object and press T first")
            return
        span = self.model.span()
        text, ok = QtWidgets.QInputDialog.getText(
            self.parent(), "Store tracked instants",
            f"Object {self.model.object_id} is tracked over frames {span[0]}–{span[1]}.\n"
            "Store an instant every N frames (type N), or on the frames typed (e.g. 12, 40, 75):", text="10")
        if ok:
            self.store_instants(text)

    def store_instants(self, text: str) -> list[int]:
        """Store the tracks as instants of the tracked object on the frames ``text`` names (every N, or a
        list); one undoable step; the object list then shows the combined figure. Returns the new ids
        (none when refused: the reason is in the status bar, nothing stored)."""
        ws = self.workspace
        model = self.model
        try:
            frames = parse_instant_frames(text, model)
            if not frames:
                raise UsvipsError(f"no frame to store: the tracks reach frames {model.span()} and instants every "
                                  f"{text.strip()} frames from frame {model.start} fall outside them")
            tracks = model.ordered_tracks()
            label, object_id = model.label, model.object_id
            ids: list[int] = []
            taken: list = []

            #: each instant's version as this window left it: an undo over another annotator's later edit of
            #: an instant is refused by name (StaleEditError), never a silent delete of their work
            versions: dict[int, str] = {}

            def redo() -> None:
                if not ids:
                    ids.extend(_tracking().add_tracked_instants(ws.project, object_id, tracks, frames, label))
                    versions.update({i: ws.project.object(i).modified for i in ids})
                else:
                    with ws.project.transaction():
                        for rows in taken:
                            ws.project.put_back(rows)
                    versions.update({rows.object_id: rows.modified for rows in taken})
                ws.cache.changed_in_store(added=tuple(ids), updated=(object_id,))

            def undo() -> None:
                with ws.project.transaction():
                    taken[:] = [ws.project.take_object(i, expected_modified=versions.get(i)) for i in ids]
                ws.cache.changed_in_store(removed=tuple(ids), updated=(object_id,))
                ws.select([i for i in ws.selection if i not in ids])

            ws.undo.push(Command(f"store {len(frames)} tracked instants of object {object_id}", redo, undo))
            summary = _instants_summary(ws, object_id)
        except UsvipsError as error:
            self.messages.say("error", f"no instants stored: {error}")
            return []
        self.messages.say("info", f"stored {len(ids)} instants (frames {', '.join(map(str, frames))}; Ctrl+Z "
                                         f"undoes it) — {summary}")
        return list(ids)

    # ------------------------------------------------------------------ proposals
    def propose(self):
        """P: the selected object's vertices proposed on the frame shown, tracked from the frame it was
        measured on (in a worker); the first goes into the pick state (Enter accepts it, a click corrects)
        and each next one when the one before is taken."""
        ws = self.workspace
        try:
            label, frame = self._frame()
            object_id = self.target()
            stored = self._object_on_video(object_id, label)
            start = int(stored.vertices[0].frame_left)
            if start == frame:
                raise UsvipsError(f"object {object_id} is measured on this frame: go to another frame to measure "
                                  "it again")
            if abs(frame - start) > self.REACH:
                raise UsvipsError(f"object {object_id} was measured on frame {start}, {abs(frame - start)} frames "
                                  f"away: proposals track up to {self.REACH} frames")
            if ws.pick_tool.digitising.vertices:
                raise UsvipsError("finish (Ctrl+Enter) or cancel the object being digitised before proposing")
            known = self._known_proposals(object_id, frame)
            tracker = None if known is not None else _tracking().VideoTracker.read(ws.project, label)
        except UsvipsError as error:
            self.messages.say("error", str(error))
            return None
        if known is not None:
            self._start_proposals(object_id, frame, known)
            return None

        def job(progress, cancelled):
            found = _tracking().propose_with(tracker, stored, frame, self.settings, cancelled,
                                 lambda done, total: progress(done / max(total, 1)))
            if cancelled():
                raise Cancelled
            return found

        return self._run(job, f"proposing object {object_id} on frame {frame}",
                         lambda found: self._start_proposals(object_id, frame, found))

    def _known_proposals(self, object_id: int, frame: int) -> list[VertexProposal] | None:
        """The proposals from the tracks held, when they are the object's and reach ``frame``."""
        if self.model.object_id != object_id or not self.model.complete:
            return None
        at = self.model.points_at(frame)
        if len(at) != self.model.vertex_count:
            return None
        return [_tracking().VertexProposal(tuple(map(float, at[k][0])), tuple(map(float, at[k][1])))
                for k in range(self.model.vertex_count)]

    def _start_proposals(self, object_id: int, frame: int, proposals: list[VertexProposal]) -> None:
        ws = self.workspace
        if ws.video_frame is None or int(ws.video_frame[1]) != frame:
            self.messages.say("warning", f"the proposals were for frame {frame}, now another is shown")
            return
        self._proposals, self._proposed = None, -1
        kind = ws.stored_object(object_id).kind
        tool = "line" if kind == "length" else kind
        if ws.pick_tool.tool != tool and tool in TOOLS:  # the tool that measures the object's kind
            self.set_tool(tool)
        self._proposals = (object_id, frame, proposals)
        self._propose_next(force=True)

    def _propose_next(self, force: bool = False) -> None:
        """Propose vertex k (the number of vertices digitised) when the one proposed before was taken;
        the user dropping a proposal (Esc) or going to another frame ends the proposals."""
        if self._proposals is None:
            return
        ws = self.workspace
        object_id, frame, proposals = self._proposals
        if ws.video_frame is None or int(ws.video_frame[1]) != frame:
            self._proposals = None
            return
        if ws.pick_tool.state.source is not None and not force:
            return
        k = len(ws.pick_tool.digitising.vertices)
        if not force and k <= self._proposed:  # dropped, not taken
            self._proposals = None
            return
        if k >= len(proposals):
            self._proposals = None
            # only an object of the vertices taken now joins (not one measured after they were undone)
            taken = [(tuple(map(float, v.left)), tuple(map(float, v.right))) for v in ws.pick_tool.digitising.vertices]
            self._instant_of = (object_id, frame, taken)
            # a vertex kept as proposed carries the track's start pick (its error): the instant is tracked
            self._tracked_from = (self._start_frame(object_id)
                                  if any(t == (tuple(map(float, p.left)), tuple(map(float, p.right)))
                                         for t, p in zip(taken, proposals, strict=False) if p.left is not None)
                                  else None)
            self.messages.say("info", f"every vertex of object {object_id} taken on frame {frame}: Enter "
                                             "stores them as a new instant of the object")
            return
        proposal = proposals[k]
        if proposal.left is None:
            self._proposals = None
            self.messages.say("warning", f"no proposal for vertex {k + 1} of object {object_id}: "
                                                f"{proposal.reason}; pick it by hand")
            return
        try:
            self._proposed = k
            ws.pick_tool.propose_vertex(proposal.left, proposal.right,
                              f"vertex {k + 1} of {len(proposals)} of object {object_id}, tracked from its frame")
            for side, pixel in (("left", proposal.left), ("right", proposal.right)):
                self.panes[side].bring_into_view(pixel)  # never accepted unseen off a zoomed view
        except UsvipsError as error:
            self._proposals = None
            self.messages.say("error", str(error))
