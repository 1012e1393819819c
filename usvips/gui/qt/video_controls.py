"""Stereo video in the workstation: a dock with the video chooser, frame and time, go-to, a timeline
with the frames that hold measurements marked, play/pause at a rate and the offset nudge; and the
controller that decodes frame pairs in workers (bounded cache, prefetch around the current frame) so
that the GUI never waits on a decoder.

Keys (on the panes and this dock, never window-wide: text fields keep their arrows): ←/→ one frame,
Shift+←/→ the jump (default 10), Home/End, Space play/pause.
"""

from __future__ import annotations

import itertools
import os
import threading
import time
from collections.abc import Callable

from PySide6 import QtCore, QtGui, QtWidgets

from usvips.core.errors import UsvipsError
from usvips.gui.qt.worker import Cancelled, Worker
from usvips.gui.video_model import (
    FrameCache,
    FrameSource,
    VideoNavigator,
    VideoSession,
    format_bytes,
    format_timecode,
    parse_position,
    prefetch_order,
    proxy_disk_bytes,
    rgb_pair,
    video_frame_of,
)
from usvips.gui.video_modules import video_project as _video_project
from usvips.gui.video_modules import video_proxy as _video_proxy
from usvips.gui.window_context import WindowContext


class Timeline(QtWidgets.QSlider):
    """A frame slider that paints a tick at every frame holding a measurement, and (issue 25) the span of
    the tracked object's tracks along its foot with the frames where a track stopped in another colour."""

    def __init__(self, parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(QtCore.Qt.Orientation.Horizontal, parent)
        self.marks: set[int] = set()
        #: the frames (first, last) every vertex of the tracked object is tracked over (None: no track)
        self.track_span: tuple[int, int] | None = None
        #: the frames where a track stopped early (occluded, lost, left the frame ...)
        self.track_stops: set[int] = set()
        self.setObjectName("video_timeline")

    def _x(self, frame: float) -> float:
        return 6 + (self.width() - 12) * (frame - self.minimum()) / (self.maximum() - self.minimum())

    def paintEvent(self, event: QtGui.QPaintEvent) -> None:  # noqa: N802 (Qt's name)
        super().paintEvent(event)
        if self.maximum() <= self.minimum() or not (self.marks or self.track_span or self.track_stops):
            return
        painter = QtGui.QPainter(self)
        painter.setPen(QtGui.QPen(QtGui.QColor(255, 140, 0), 2))
        for mark in self.marks:
            x = self._x(mark)
            painter.drawLine(int(x), 0, int(x), 6)
        self._paint_track(painter)
        painter.end()

    def _paint_track(self, painter: QtGui.QPainter) -> None:
        """The tracked span as a green bar along the slider's foot, each stop a red tick over it."""
        bottom = self.height() - 3
        if self.track_span is not None and self.track_span[0] <= self.track_span[1]:
            painter.setPen(QtGui.QPen(QtGui.QColor(40, 200, 90), 4))
            painter.drawLine(int(self._x(self.track_span[0])), bottom, int(self._x(self.track_span[1])), bottom)
        painter.setPen(QtGui.QPen(QtGui.QColor(230, 40, 40), 3))
        for stop in self.track_stops:
            x = int(self._x(stop))
            painter.drawLine(x, bottom - 6, x, bottom + 2)


class VideoDock(QtWidgets.QWidget):
    """The controls; owns no decoder (see :class:`VideoController`). Two rows that fit a 1366 px wide
    window: the video and its actions (Alt+D video, Alt+P play, Alt+J jump, Alt+S offset, Alt+Y sync,
    Alt+O period, Alt+T take as pair, Alt+X seek proxy, with its menu: build, cancel, delete), then go-to
    (Alt+G, or Ctrl+G from the panes), the timeline and the frame shown."""

    def __init__(self, parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(parent)
        self.setObjectName("video_controls")
        self.chooser = QtWidgets.QComboBox()
        self.chooser.setToolTip("the stereo video shown (choose one to show its frames)")
        self.chooser.setPlaceholderText(NONE_SHOWN)  # no video shown: the box says so rather than name one
        self.chooser.setSizeAdjustPolicy(QtWidgets.QComboBox.SizeAdjustPolicy.AdjustToContents)
        self.timeline = Timeline()
        self.timeline.setToolTip("the frames; a tick marks a frame holding measurements")
        self.frame_label = QtWidgets.QLabel("—")
        self.frame_label.setMinimumWidth(self.fontMetrics().horizontalAdvance("left 000000 | right 000000  "
                                                                              "0:00:00.000  (00000–000000)  ●"))
        self.goto = QtWidgets.QLineEdit()
        self.goto.setPlaceholderText("frame, 12.5s or mm:ss.sss")
        self.goto.setToolTip("go to a left frame number, a time in seconds (12.5s) or a time code (mm:ss.sss); Enter")
        self.goto.setMinimumWidth(self.goto.fontMetrics().horizontalAdvance(self.goto.placeholderText()) + 24)
        self.goto.setMaximumWidth(self.goto.minimumWidth() + 40)
        self.play = QtWidgets.QPushButton("&Play")
        self.play.setCheckable(True)
        self.play.setToolTip("play / pause at the rate chosen (Space on the panes)")
        self.rate = QtWidgets.QComboBox()
        self.rate.addItems(["0.1×", "0.25×", "0.5×", "1×", "2×", "4×"])
        self.rate.setCurrentText("1×")
        self.rate.setToolTip("playing rate (× real time)")
        self.jump = QtWidgets.QSpinBox()
        self.jump.setRange(2, 10_000)
        self.jump.setValue(10)
        self.jump.setToolTip("frames stepped by Shift+←/→")
        self.offset = QtWidgets.QSpinBox()
        self.offset.setRange(-100_000, 100_000)
        self.offset.setToolTip("right frame = left frame + offset (nudge while both panes show; stored)")
        self.period = QtWidgets.QPushButton("Peri&od…")
        self.period.setToolTip("mark a named period from this frame (EventMeasure's periods)")
        self.take = QtWidgets.QPushButton("&Take as pair…")
        self.take.setToolTip("make the synchronised frames shown an image pair of the project (e.g. the calibration "
                             "frame filmed in air or underwater), written as PNG under frames/ beside the project")
        self.sync = QtWidgets.QPushButton("S&ync…")
        self.sync.setToolTip("estimate the offset from the soundtracks, a flash seen by both cameras or the images "
                             "(epipolar consistency of moving things), with its confidence; stored")
        self.proxy = QtWidgets.QToolButton()
        self.proxy.setText("Seek pro&xy")
        self.proxy.setPopupMode(QtWidgets.QToolButton.ToolButtonPopupMode.MenuButtonPopup)
        self.proxy.setToolButtonStyle(QtCore.Qt.ToolButtonStyle.ToolButtonTextOnly)
        self.proxy.setToolTip("lossless all-intra copies of this video (proxies/ beside the project, 1.3–2.5 MB a "
                              "1080p frame) so that a random seek decodes one frame; pixels stay identical. Built "
                              "in the background when a video is first opened; click to build or cancel")
        self.proxy_menu = QtWidgets.QMenu(self.proxy)
        self.build_proxy_action = self.proxy_menu.addAction("&Build seek proxy")
        self.cancel_proxy_action = self.proxy_menu.addAction("&Cancel building")
        self.delete_proxy_action = self.proxy_menu.addAction("&Delete seek proxy")
        self.proxy.setMenu(self.proxy_menu)
        self.proxy_status = QtWidgets.QLabel("")
        self.proxy_status.setObjectName("proxy_status")
        self.proxy_status.setToolTip("the seek proxy: built and in use, building (in the background, at low "
                                     "priority), or none (seeks decode the original: exact, slower)")

        def labelled(text: str, buddy: QtWidgets.QWidget) -> QtWidgets.QLabel:
            label = QtWidgets.QLabel(text)
            label.setBuddy(buddy)
            return label

        top = QtWidgets.QHBoxLayout()
        top.setSpacing(4)
        for widget in (labelled("Vi&deo", self.chooser), self.chooser, self.play, self.rate,
                       labelled("&Jump", self.jump), self.jump, labelled("Off&set", self.offset), self.offset,
                       self.sync, self.period, self.take, self.proxy, self.proxy_status):
            top.addWidget(widget)
        top.addStretch(1)
        bottom = QtWidgets.QHBoxLayout()
        bottom.setSpacing(4)
        bottom.addWidget(labelled("&Go to", self.goto))
        bottom.addWidget(self.goto)
        bottom.addWidget(self.timeline, 1)
        bottom.addWidget(self.frame_label)
        layout = QtWidgets.QVBoxLayout(self)
        layout.setContentsMargins(4, 2, 4, 2)
        layout.setSpacing(2)
        layout.addLayout(top)
        layout.addLayout(bottom)
        order = (self.chooser, self.play, self.rate, self.jump, self.offset, self.sync, self.period, self.take,
                 self.proxy, self.goto, self.timeline)
        for first, second in itertools.pairwise(order):
            QtWidgets.QWidget.setTabOrder(first, second)


#: the video chooser's text while no video is shown
NONE_SHOWN = "choose…"


class TakePairDialog(QtWidgets.QDialog):
    """The label and medium of an image pair taken from the video frames shown."""

    def __init__(self, label: str, parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(parent)
        self.setWindowTitle("Take the frames shown as an image pair")
        self.label = QtWidgets.QLineEdit(label)
        self.medium = QtWidgets.QComboBox()
        self.medium.addItem("underwater (phase 2, measuring)", "water")
        self.medium.addItem("in air (phase 1 calibration)", "air")
        buttons = QtWidgets.QDialogButtonBox(QtWidgets.QDialogButtonBox.StandardButton.Ok
                                             | QtWidgets.QDialogButtonBox.StandardButton.Cancel)
        buttons.accepted.connect(self.accept)
        buttons.rejected.connect(self.reject)
        form = QtWidgets.QFormLayout(self)
        form.addRow("&Label", self.label)
        form.addRow("&Filmed", self.medium)
        form.addRow(buttons)


class VideoController(QtCore.QObject):
    """Shows a stored video's synchronised frame pairs in the window's panes.

    ``request(frame)`` shows a cached pair at once, or decodes it in a worker (the latest request wins);
    after each pair is shown, the frames around it are decoded into the cache (one prefetch at a time,
    cancelled by the next request)."""

    shown = QtCore.Signal(int)
    #: offer a video's seek proxies when a seek is first slow (built at once on opening, without a
    #: question, when ``ask_before_proxies`` is False) if it has none and needs them
    auto_proxies = True
    #: the niceness of the thread that builds proxies (Linux: per thread; its FFmpeg threads inherit it)
    PROXY_NICENESS = 15

    def __init__(self, parent: QtWidgets.QWidget, context: WindowContext, panes: dict,
                 forget_pair_loading: Callable[[], None], pairs_changed: Callable[[], None],
                 cache: FrameCache | None = None) -> None:
        """``parent``: the widget its shortcuts and questions belong to; ``context``: the workspace, the
        messages and the jobs; ``panes``: the stereo panes by side (their keys); ``forget_pair_loading()``:
        called when a video is opened over an image pair still being read; ``pairs_changed()``: after a
        frame pair was stored as an image pair."""
        super().__init__(parent)
        self.workspace, self.messages, self.jobs = context.workspace, context.messages, context.jobs
        self.forget_pair_loading, self.pairs_changed = forget_pair_loading, pairs_changed
        #: the window's dock that holds :attr:`dock_widget` (:meth:`attach_dock`), or None
        self.dock: QtWidgets.QDockWidget | None = None
        self.dock_widget = VideoDock()
        self.cache = cache or FrameCache()
        #: the video opened (its source, position and synchronisation: usvips.gui.video_model), or None
        self.session: VideoSession | None = None
        self.question: QtWidgets.QMessageBox | None = None  # "store this uncertain offset?", while open
        self.direction = 1
        self._request: Worker | None = None
        self._prefetch: Worker | None = None
        self._pending: int | None = None
        self._target: int | None = None  # the frame last asked for
        self.timer = QtCore.QTimer(self)
        self.timer.timeout.connect(self._tick)
        # the frames a user steps to are decoded in a pool of their own, at the GUI's priority (the window's
        # pool also runs bulk work, whose threads run nicer: gui/qt/worker.py)
        self.display_pool = QtCore.QThreadPool(self)
        self.display_pool.setMaxThreadCount(2)
        # seek proxies are built one at a time in a pool of their own, whose thread runs at low priority
        self.proxy_pool = QtCore.QThreadPool(self)
        self.proxy_pool.setMaxThreadCount(1)
        self._proxy_worker: Worker | None = None
        self._proxy_label: str | None = None
        self._proxy_progress = 0.0
        #: (project file, video) whose proxies were declined or deleted: not offered again in this session,
        #: even after another project was open meanwhile
        self._proxies_deleted: set[tuple[str, str]] = set()
        #: (project file, video) whose proxies were offered after a slow seek in this session
        self._proxies_offered: set[tuple[str, str]] = set()
        goto = QtGui.QShortcut(QtGui.QKeySequence("Ctrl+G"), parent)
        goto.activated.connect(self.focus_goto)
        for pane in panes.values():
            pane.graphics.installEventFilter(self)
        self._connect(self.dock_widget)
        # an object asked for (the object list's double-click or Zoom to): the frame it was measured on
        self.workspace.object_requested.connect(self.go_to_object)
        self.workspace.project_changed.connect(self.project_opened)  # another project: new controls
        self.workspace.pair_changed.connect(self._on_pair_changed)  # an image pair shown: the video is left

    def _connect(self, d: VideoDock) -> None:
        """Wire a dock's controls to this controller."""
        d.chooser.activated.connect(lambda _: self.open_video(d.chooser.currentText()))
        d.timeline.valueChanged.connect(self._on_slider)
        d.goto.returnPressed.connect(self._on_goto)
        d.play.toggled.connect(self.set_playing)
        d.rate.currentTextChanged.connect(self._on_rate)
        d.jump.valueChanged.connect(self._on_jump)
        d.offset.editingFinished.connect(self._on_offset)
        d.period.clicked.connect(self._on_period)
        d.take.clicked.connect(self._on_take_pair)
        d.proxy.clicked.connect(self._on_proxy_button)
        d.build_proxy_action.triggered.connect(lambda: self.build_proxies())
        d.cancel_proxy_action.triggered.connect(self.cancel_proxies)
        d.delete_proxy_action.triggered.connect(self.delete_proxies)
        d.sync.clicked.connect(self._on_sync)
        for widget in (d, d.timeline):
            widget.installEventFilter(self)

    def attach_dock(self, dock: QtWidgets.QDockWidget) -> None:
        """The window's dock that shows :attr:`dock_widget`: a new project's controls go into it, and it is
        shown for a project with videos."""
        self.dock = dock

    def show_track(self, label: str | None, span: tuple[int, int] | None, stops: set[int]) -> None:
        """Mark a track of video ``label`` on the timeline: the frames it covers (``span``, first and last)
        and where it stopped (``stops``); nothing when another video (or none) is shown."""
        timeline = self.dock_widget.timeline
        on_video = self.navigator is not None and label is not None and self.navigator.label == label
        timeline.track_span = span if on_video else None
        timeline.track_stops = set(stops) if on_video else set()
        timeline.update()

    @property
    def source(self) -> FrameSource | None:
        return None if self.session is None else self.session.source

    @property
    def navigator(self) -> VideoNavigator | None:
        return None if self.session is None else self.session.navigator

    # ------------------------------------------------------------------ videos
    def project_opened(self, project) -> None:
        """Fill the chooser with the project's videos, none without a project (and forget the previous
        project's); called by the workspace's ``project_changed``."""
        self.close_video()
        self.cancel_proxies()
        # a new project gets new controls: nothing of the previous one (offset, frame, range, go-to text,
        # rate, marks) can stay on screen, by construction rather than by a list of fields to clear
        old, d = self.dock_widget, VideoDock()
        self.dock_widget = d
        self._connect(d)
        dock = self.dock
        if dock is not None:
            dock.setWidget(d)
            old.hide()
            old.deleteLater()
        self.videos_changed(project)

    def videos_changed(self, project) -> None:
        """The project's videos in the chooser (one was added): the dock is shown when there are any."""
        d = self.dock_widget
        labels = [v.label for v in project.videos()] if project is not None else []
        if [d.chooser.itemText(i) for i in range(d.chooser.count())] != labels:
            d.chooser.clear()
            d.chooser.addItems(labels)
            shown = self.navigator.label if self.navigator is not None else None
            d.chooser.setCurrentIndex(labels.index(shown) if shown in labels else -1)
        d.setEnabled(bool(labels))
        dock = self.dock
        if dock is not None:  # shown for a project with videos (View › Video brings it back by hand)
            dock.setVisible(bool(labels))

    def open_video(self, label: str) -> bool:
        project = self.workspace.project
        if project is None or not label:
            return False
        self.close_video()
        self.forget_pair_loading()  # an image pair asked for before would replace the video's frames
        try:
            self.session = VideoSession(project, label)
        except UsvipsError as error:
            self.messages.say("error", str(error))
            return False
        d = self.dock_widget
        self.navigator.rate, self.navigator.jump = float(d.rate.currentText().rstrip("×")), d.jump.value()
        d.chooser.setCurrentText(label)
        d.timeline.blockSignals(True)
        d.timeline.setRange(self.navigator.first, self.navigator.last)
        d.timeline.marks = set(self.navigator.marks)
        d.timeline.blockSignals(False)
        d.offset.setValue(self.navigator.offset)
        self.messages.say("info", f"video {label!r}: {self.navigator.frame_count} frames at "
                                 f"{self.navigator.fps:.6g} fps, offset {self.navigator.offset:+d} "
                                 + (f"— {self.source.video.report}" if self.source.video.report else ""))
        self.request(self.navigator.first)
        self._show_proxy_status()
        if self.auto_proxies and not self.ask_before_proxies and self._proxy_key(label) not in self._proxies_deleted:
            self.build_proxies(automatic=True)  # scripts and benchmarks: built without a question, at once
        return True

    def close_video(self) -> None:
        """No video shown: its decoding stops, the dock names none (its frame, "—")."""
        self.set_playing(False)
        d = self.dock_widget
        d.chooser.setCurrentIndex(-1)
        d.frame_label.setText("—")
        for widget in (d.offset, d.timeline):  # nothing of the video left: its offset, position and go-to
            widget.blockSignals(True)
        d.offset.setValue(0)
        d.timeline.setRange(0, 0)
        d.timeline.marks = set()
        for widget in (d.offset, d.timeline):
            widget.blockSignals(False)
        d.goto.clear()
        for worker in (self._request, self._prefetch):
            if worker is not None:
                worker.cancel()
        self._request = self._prefetch = None
        self._target = None
        self.cache.clear()
        if self.session is not None:
            self.session.close()
        self.session = None

    def _on_pair_changed(self) -> None:
        """The workspace shows another pair: an image pair (no video frame) leaves the video, so that the
        arrows and Space on the panes no longer step a video that is not shown."""
        if self.session is not None and self.workspace.video_frame is None:
            self.close_video()

    def _proxy_key(self, label: str) -> tuple[str, str]:
        project = self.workspace.project
        return str(project.path.resolve()) if project is not None else "", label

    def _need_video(self) -> bool:
        """A control that works on the video shown was used: with none shown, the one chosen — or the
        project's only one — is opened first; with several and none chosen, the user is asked to choose
        (the chooser gets the keyboard). True when a video is shown."""
        if self.navigator is not None:
            return True
        d = self.dock_widget
        label = d.chooser.currentText() or (d.chooser.itemText(0) if d.chooser.count() == 1 else "")
        if label:
            return self.open_video(label)
        self.messages.say("warning", "no video is shown: choose one in the Video box (Alt+D)"
                                 if d.chooser.count() else "this project has no stereo video "
                                 "(File › Add stereo video…)")
        d.chooser.setFocus(QtCore.Qt.FocusReason.OtherFocusReason)
        return False

    # ------------------------------------------------------------------ stepping
    def step(self, frames: int) -> None:
        """Step from the frame last asked for (shown or still decoding): two quick Shift+→ go 20 frames."""
        if self.navigator is not None:
            self.direction = 1 if frames >= 0 else -1
            base = self._target if self._target is not None else self.navigator.frame
            self.request(base + frames)

    def request(self, frame: int) -> None:
        """Show left frame ``frame`` (clamped) and its partner, from the cache or a worker."""
        if self.navigator is None or self.source is None:
            return
        frame = self.navigator.clamp(frame)
        self._target = frame
        cached = self.cache.get(frame)
        if cached is not None:
            self._show(frame, cached)
            return
        self._pending = frame
        if self._prefetch is not None:
            self._prefetch.cancel()
        if self._request is not None:
            self._request.cancel()
        source, offset = self.source, self.navigator.offset

        def job(progress, cancelled):
            if cancelled():
                raise Cancelled
            started = time.perf_counter()
            pictures = source.pictures(frame, offset)
            return frame, pictures, time.perf_counter() - started

        worker = self._request = Worker(job, f"decoding frame {frame}", background=False)
        worker.signals.finished.connect(lambda result, w=worker: self._decoded(w, *result))
        worker.signals.failed.connect(lambda message: self._failed(message))
        self.display_pool.start(worker)

    def _failed(self, message: str) -> None:
        self._target = None  # step on from the frame shown
        self.messages.say("error", message)

    #: a frame asked for that took longer than this (s) to decode is a slow seek: the first one offers the
    #: video's seek proxies (when it needs them and they were not declined), rather than asking on opening
    slow_seek_s = 0.5

    def _decoded(self, worker: Worker, frame: int, item: tuple, seconds: float = 0.0) -> None:
        if (self.source is None or self.navigator is None or self.workspace.project is None
                or item[2] != frame + self.navigator.offset):
            return  # closed (the video or the project), or decoded at an offset since changed
        self.cache.put(frame, item)
        if worker is self._request and frame == self._pending:
            self._show(frame, item)
            if seconds > self.slow_seek_s:
                self._offer_proxies()

    def _offer_proxies(self) -> None:
        """A seek was slow: ask once per video and session whether to build its seek proxies."""
        label = self.navigator.label
        key = self._proxy_key(label)
        if not self.auto_proxies or key in self._proxies_deleted or key in self._proxies_offered:
            return
        self._proxies_offered.add(key)
        self.build_proxies(automatic=True)

    def _show(self, frame: int, item: tuple) -> None:
        left, right, partner, time_s = rgb_pair(item)
        nav = self.navigator
        nav.go(frame)
        # the views follow the model's pair_changed (only the objects measured on this frame are drawn)
        self.workspace.set_pair(nav.label, left, right, (nav.label, frame, partner, time_s))
        d = self.dock_widget
        d.timeline.blockSignals(True)
        d.timeline.setValue(frame)
        d.timeline.blockSignals(False)
        d.frame_label.setText(f"left {frame} | right {partner}  {format_timecode(time_s)}  "
                              f"({nav.first}–{nav.last})" + ("  ●" if frame in nav.marks else ""))
        self.shown.emit(frame)
        self._start_prefetch(frame)

    def _start_prefetch(self, frame: int) -> None:
        nav, source, cache = self.navigator, self.source, self.cache
        todo = [f for f in prefetch_order(frame, nav.first, nav.last, self.direction) if f not in cache]
        if not todo or (self._prefetch is not None and not self._prefetch.is_cancelled
                        and self._prefetch in self.jobs.workers):
            return
        if self._prefetch is not None:
            self._prefetch.cancel()
        offset = nav.offset

        def job(progress, cancelled):
            for f in todo:
                if cancelled():
                    raise Cancelled
                if f not in cache:
                    cache.put(f, source.pictures(f, offset))
            return len(todo)

        self._prefetch = Worker(job, "prefetching frames", background=False)
        self.display_pool.start(self._prefetch)

    # ------------------------------------------------------------------ controls
    def set_playing(self, on: bool) -> None:
        d = self.dock_widget
        if on and self.navigator is None and not self._need_video():
            on = False  # nothing to play: the button says Play again
        if d.play.isChecked() != on:
            d.play.setChecked(on)
        d.play.setText("&Pause" if on else "&Play")
        if on and self.navigator is not None:
            self.direction = 1
            self.timer.start(self.navigator.play_interval_ms())
        else:
            self.timer.stop()

    def _tick(self) -> None:
        nav = self.navigator
        if nav is None or nav.frame >= nav.last:
            self.set_playing(False)
            return
        if self._request is not None and self._pending != nav.frame and self._pending not in self.cache:
            return  # still decoding: drop this tick rather than queue work
        self.step(1)

    def _on_slider(self, value: int) -> None:
        self.direction = 1 if self.navigator is None or value >= self.navigator.frame else -1
        self.request(value)

    def _on_goto(self) -> None:
        if not self._need_video():
            return
        try:
            frame = parse_position(self.dock_widget.goto.text(), self.navigator.fps, self.source.times_s)
        except UsvipsError as error:
            self.messages.say("error", str(error))
            return
        if not self.navigator.first <= frame <= self.navigator.last:
            self.messages.say("error", f"frame {frame} has no synchronised pair (frames "
                                     f"{self.navigator.first} to {self.navigator.last})")
            return
        self.request(frame)

    def _on_rate(self, text: str) -> None:
        if self.navigator is not None:
            self.navigator.rate = float(text.rstrip("×"))
            if self.timer.isActive():
                self.timer.start(self.navigator.play_interval_ms())

    def _on_jump(self, value: int) -> None:
        if self.navigator is not None:
            self.navigator.jump = int(value)

    SYNC_METHODS = {"automatic: sound, else a flash, else the images": None, "flash": "flash",
                    "sound (audio)": "audio", "images (needs the rig's calibration)": "image"}

    def _on_sync(self) -> None:
        if not self._need_video():
            return
        choice, ok = QtWidgets.QInputDialog.getItem(self.dock_widget, "Synchronise", "Estimate the offset from:",
                                                    list(self.SYNC_METHODS), 0, False)
        if ok:
            self.synchronise(self.SYNC_METHODS[choice])

    def synchronise(self, method: str | None = None) -> Worker | None:
        """Estimate the shown video's offset by ``method`` (None: sound, else a flash, else the images) in a
        worker, then store it (as ``usvips video sync``) and show the pair at the new offset; the message
        gives the sub-frame offset, its confidence and the whole frame used."""
        session = self.session
        if session is None:
            return None
        try:
            job_data = session.sync_plan()
        except UsvipsError as error:
            self.messages.say("error", str(error))
            return None

        def job(progress, cancelled):
            def report(done: int, total: int) -> None:
                if cancelled():
                    raise Cancelled
                progress(done / max(total, 1))
            return _video_project().run_sync(job_data, method, progress=report)

        def done(estimate) -> None:
            if self.session is not session:  # another video (or project) since: not this one's offset
                return
            outcome = session.sync_outcome(estimate)

            def store() -> None:
                if self.session is session:
                    self._store_offset(estimate.frames, estimate.as_dict(), outcome.text)

            if outcome.action == "store":
                store()
                return
            self.messages.say(outcome.level, outcome.text)
            if outcome.action == "ask":
                self.ask_to_store(outcome.question, store)

        return self.jobs.run(job, f"synchronising {session.label}", done)

    def ask_to_store(self, question: str, store: Callable[[], None]) -> None:
        """Ask whether to store an offset estimated with little confidence: a Yes/No question (No by
        default) that does not block the window; ``store`` runs on Yes."""
        self.ask("Synchronise", question, store)

    def ask(self, title: str, question: str, yes: Callable[[], None], no: Callable[[], None] | None = None) -> None:
        """A Yes/No question (No by default) that does not block the window: ``yes`` runs on Yes, ``no``
        on No or Esc; :attr:`question` holds it while it is open."""
        box = QtWidgets.QMessageBox(QtWidgets.QMessageBox.Icon.Question, title, question,
                                    QtWidgets.QMessageBox.StandardButton.Yes | QtWidgets.QMessageBox.StandardButton.No,
                                    self.dock_widget)
        box.setDefaultButton(QtWidgets.QMessageBox.StandardButton.No)
        box.setAttribute(QtCore.Qt.WidgetAttribute.WA_DeleteOnClose)
        box.accepted.connect(yes)  # Yes is the accept role
        if no is not None:
            box.rejected.connect(no)
        box.open()
        self.question = box

    def _on_offset(self) -> None:
        value = self.dock_widget.offset.value()
        if self.navigator is None and value == 0:
            return  # the box emptied (another project), not an offset typed
        if not self._need_video():
            self.dock_widget.offset.setValue(0)
            return
        nav = self.navigator
        if value == nav.offset:
            return
        self._store_offset(value, {"method": "by hand"})

    def _store_offset(self, value: int, how: dict, said: str | None = None) -> None:
        """Store an offset through the session (the model decides and stores), then draw: new frame cache,
        the dock's offset and range, the same left frame requested again. ``said``: the line to show."""
        session = self.session
        frame = session.navigator.frame
        try:
            nav = session.store_offset(value, how)
        except UsvipsError as error:
            self.messages.say("error", str(error))
            self.dock_widget.offset.setValue(session.navigator.offset)
            return
        for worker in (self._request, self._prefetch):
            if worker is not None:
                worker.cancel()
        self.cache = FrameCache(self.cache.budget)  # a decode still running fills the old one, never this
        self.dock_widget.offset.setValue(value)
        self.dock_widget.timeline.setRange(nav.first, nav.last)
        self.messages.say("info", said or f"video {nav.label}: offset set to {value:+d} frames (stored)")
        self.request(frame)

    def _on_period(self) -> None:
        if not self._need_video():
            return
        nav = self.navigator
        text, ok = QtWidgets.QInputDialog.getText(self.dock_widget, "Mark period", "Name, first and last left frame:",
                                                  text=f"period {nav.frame} {nav.last}")
        if ok:
            self.mark_period(text)

    def mark_period(self, text: str) -> bool:
        """Store a period typed as ``NAME FIRST LAST`` (left frames; the name may hold spaces)."""
        if self.session is None:
            return False
        try:
            name, start, end = self.session.mark_period(text)
        except UsvipsError as error:
            self.messages.say("error", str(error))
            return False
        self.messages.say("info", f"period {name!r}: frames {start} to {end} (stored)")
        return True

    def _on_take_pair(self) -> None:
        if not self._need_video():
            return
        nav = self.navigator
        dialog = TakePairDialog(f"{nav.label}-{nav.frame}", self.dock_widget)
        if dialog.exec() == QtWidgets.QDialog.DialogCode.Accepted:
            self.take_pair(dialog.label.text(), dialog.medium.currentData())

    def take_pair(self, pair_label: str | None = None, medium: str = "water") -> Worker | None:
        """Make the synchronised frames shown an image pair ``pair_label`` (default ``VIDEO-FRAME``) taken in
        ``medium`` ("air" or "water"): decoded exactly and written as PNG in a worker, then added to the
        project on this thread (the service the command line's ``video take-pair`` uses). Returns the
        worker, or None when nothing is shown or the label is refused (a message says why)."""
        session = self.session
        if session is None:
            return None
        source, video = session.source, session.label
        try:
            pair_label, frame, offset, folder = session.plan_taken_pair(pair_label)
        except UsvipsError as error:
            self.messages.say("error", str(error))
            return None

        def job(progress, cancelled):
            left, right, partner, _ = source.pair(frame, offset)
            if cancelled():
                raise Cancelled
            return partner, _video_project().write_frame_pair(left, right, folder)

        def store(result) -> None:
            partner, paths = result
            session.add_taken_pair(pair_label, paths, medium)
            self.pairs_changed()
            self.messages.say("info", f"left frame {frame} and right frame {partner} of {video} are now "
                                             f"the {'in-air' if medium == 'air' else 'underwater'} image pair "
                                             f"{pair_label!r} (Calibration menu: calibrate from it)")

        return self.jobs.run(job, f"taking frame {frame} as a pair", store)

    # ------------------------------------------------------------------ seek proxies
    def _on_proxy_button(self) -> None:
        if self._proxy_worker is not None and self.navigator is not None and self._proxy_label == self.navigator.label:
            self.cancel_proxies()
        else:
            self.build_proxies()

    #: build seek proxies without asking (scripts, benchmarks); the window asks first, with their size
    ask_before_proxies = True

    def build_proxies(self, automatic: bool = False) -> Worker | None:
        """Build the shown video's seek proxies in the background (a pool of their own, at low priority,
        progress in the dock, cancel from the dock), then seek through them as soon as they are built and
        verified (the original is used until then). ``automatic``: after a slow seek (or when a video is
        opened, for scripts that do not ask); then only for
        a recording that needs one (:func:`usvips.io.video_proxy.needs_proxy`), and only after the user
        says Yes to a question giving their size on disk (:func:`usvips.gui.video_model.proxy_disk_bytes`;
        No: not asked again for that video in this session, the dock's Seek proxy builds them). None when
        there is nothing to build, a build is running or a question is open (a message says so unless
        automatic)."""
        nav, project, source = self.navigator, self.workspace.project, self.source
        if nav is None or project is None or source is None:
            return None
        if self._proxy_worker is not None:
            if not automatic:
                self.messages.say("info", f"seek proxies of {self._proxy_label} are being built")
            return None
        if automatic and not (_video_proxy().needs_proxy(source.left) or _video_proxy().needs_proxy(source.right)):
            return None
        folder = _video_project().proxy_folder(project)
        try:
            plan = source.proxy_plan(folder)
        except UsvipsError as error:
            self.messages.say("error", str(error))
            return None
        if not plan:
            if not automatic:
                self.messages.say("info", f"video {nav.label}: its seek proxies are already built and in use")
            return None
        label, niceness = nav.label, self.PROXY_NICENESS
        if automatic and self.ask_before_proxies:
            video = project.video(label)
            low, high = proxy_disk_bytes(video.frame_count, video.width, video.height)
            question = (f"Build seek proxies for video {label}? They make a jump to any frame fast (an exact "
                        f"lossless copy of every frame, kept in {folder.name}/ beside the project): about "
                        f"{format_bytes(low)} to {format_bytes(high)} on disk for its {video.frame_count} frames "
                        "a camera, both cameras together, built in the background at low priority. Without "
                        "them every frame is still exact; far jumps are slower. (The dock's Seek proxy button "
                        "builds or deletes them later.)")

            def declined() -> None:
                self._proxies_deleted.add(self._proxy_key(label))
                self.messages.say("info", f"no seek proxies for {label}: the dock's Seek proxy button builds "
                                                 "them when wanted")

            self.ask("Seek proxies", question, lambda: self.build_proxies(automatic=False), declined)
            return None

        def job(progress, cancelled):
            _lower_thread_priority(niceness)
            try:
                return _video_project().build_proxies(plan, lambda done, total: progress(done / total), cancelled)
            except InterruptedError:
                raise Cancelled from None

        worker = self._proxy_worker = Worker(job, f"building seek proxies of {label}")
        self._proxy_label, self._proxy_progress = label, 0.0
        worker.signals.progress.connect(lambda fraction, w=worker: self._proxy_advanced(w, fraction))
        worker.signals.finished.connect(lambda paths, w=worker: self._proxies_built(w, project, label, folder, paths))
        worker.signals.failed.connect(lambda message, w=worker: self._proxy_ended(
            w, "warning" if automatic else "error",
            f"seek proxies of {label} not built (seeks decode the original): {message}" if automatic else message))
        worker.signals.cancelled.connect(lambda w=worker: self._proxy_ended(
            w, "info", f"seek proxies of {label}: cancelled (seeks decode the original)"))
        self.proxy_pool.start(worker)
        self._show_proxy_status()
        return worker

    def _proxy_advanced(self, worker: Worker, fraction: float) -> None:
        if worker is self._proxy_worker:
            self._proxy_progress = fraction
            self._show_proxy_status()

    def _proxy_ended(self, worker: Worker, kind: str, message: str) -> None:
        if worker is not self._proxy_worker:
            return
        self._proxy_worker, self._proxy_label = None, None
        self._show_proxy_status()
        self.messages.say(kind, message)

    def _proxies_built(self, worker: Worker, project, label: str, folder, paths) -> None:
        if worker is not self._proxy_worker:
            return
        self._proxy_worker, self._proxy_label = None, None
        size = sum(p.stat().st_size for p in paths if p.exists()) / 2**20
        in_use = (self.source is not None and self.navigator is not None and self.navigator.label == label
                  and self.workspace.project is project and self.source.attach_proxies(folder))
        self._show_proxy_status()
        self.messages.say("info", f"video {label}: seek proxies built and checked ({size:.0f} MiB in "
                                         f"{folder})" + ("; random seeks now decode one frame" if in_use else ""))

    def cancel_proxies(self) -> None:
        """Stop the seek-proxy build running (nothing half-written stays; the original keeps being used)."""
        if self._proxy_worker is not None:
            self._proxy_worker.cancel()

    def delete_proxies(self) -> int:
        """Delete the shown video's seek proxies (cancelling a build of them): seeks decode the original
        again, and they are not rebuilt by themselves in this session. Returns the bytes freed."""
        nav, project = self.navigator, self.workspace.project
        if nav is None or project is None:
            return 0
        if self._proxy_label == nav.label:
            self.cancel_proxies()
        self._proxies_deleted.add(self._proxy_key(nav.label))
        if self.source is not None:
            self.source.detach_proxies()
        try:
            freed = _video_project().delete_proxies(project, nav.label)
        except UsvipsError as error:
            self.messages.say("error", str(error))
            return 0
        self._show_proxy_status()
        self.messages.say("info", f"video {nav.label}: " + (
            f"seek proxies deleted ({freed / 2**20:.1f} MiB freed); seeks decode the original" if freed
            else "it has no seek proxies"))
        return freed

    def _show_proxy_status(self) -> None:
        d, nav = self.dock_widget, self.navigator
        building = self._proxy_worker is not None and nav is not None and self._proxy_label == nav.label
        if nav is None or self.source is None:
            text = ""
        elif building:
            text = f"proxy {100 * self._proxy_progress:.0f} %"
        elif self.source.has_proxies:
            text = "proxy ✓"
        else:
            text = ""
        d.proxy_status.setText(text)
        d.proxy.setText("Cancel pro&xy" if building else "Seek pro&xy")
        d.cancel_proxy_action.setEnabled(building)
        d.build_proxy_action.setEnabled(not building)

    def shutdown(self) -> None:
        """Before the window closes: stop the proxy build and the frames' decoding and wait for their threads
        (each stops within a frame)."""
        self.workspace.project_changed.disconnect(self.project_opened)
        self.cancel_proxies()
        for worker in (self._request, self._prefetch):
            if worker is not None:
                worker.cancel()
        self.proxy_pool.waitForDone(10000)
        self.display_pool.waitForDone(5000)

    def focus_goto(self) -> None:
        """Ctrl+G: type a frame, seconds or a time code into the go-to field (the video chosen is opened
        first when none is shown)."""
        if self._need_video():
            self.dock_widget.goto.setFocus(QtCore.Qt.FocusReason.ShortcutFocusReason)
            self.dock_widget.goto.selectAll()

    def go_to_object(self, object_id: int) -> None:
        """The model's ``object_requested``: an object measured on a video is shown on its frame (opening
        its video if another is open); others are the window's."""
        ws = self.workspace
        where = video_frame_of(ws.stored_object(object_id)) if object_id in ws.cache else None
        if where is None:
            return
        video, frame = where
        if self.navigator is None or self.navigator.label != video:
            if not self.open_video(video):
                return
        self.direction = 1
        self.request(frame)

    def objects_changed(self) -> None:
        # the session's project only (another project's objects are announced before its project_changed)
        if self.session is not None and self.session.project is self.workspace.project:
            cache = self.workspace.cache  # the objects held in memory: reading every stored object again on each
            held = None if cache.loading else cache.objects()  # change (each slice of a Detect) grows with the survey
            self.dock_widget.timeline.marks = set(self.session.refresh_marks(held))
            self.dock_widget.timeline.update()

    def eventFilter(self, watched: QtCore.QObject, event: QtCore.QEvent) -> bool:  # noqa: N802 (Qt's name)
        if event.type() != QtCore.QEvent.Type.KeyPress or self.navigator is None:
            return False
        key, shift = event.key(), bool(event.modifiers() & QtCore.Qt.KeyboardModifier.ShiftModifier)
        if event.modifiers() & (QtCore.Qt.KeyboardModifier.ControlModifier | QtCore.Qt.KeyboardModifier.AltModifier):
            return False  # Ctrl(+Shift)+arrows nudge the current pick
        Key = QtCore.Qt.Key
        if key in (Key.Key_Left, Key.Key_Right):
            self.step((self.navigator.jump if shift else 1) * (1 if key == Key.Key_Right else -1))
        elif key == Key.Key_Home:
            self.direction = -1
            self.request(self.navigator.first)
        elif key == Key.Key_End:
            self.request(self.navigator.last)
        elif key == Key.Key_Space:
            self.set_playing(not self.timer.isActive())
        else:
            return False
        return True


def _lower_thread_priority(niceness: int) -> None:
    """Run the calling thread (and the threads it starts) at ``niceness`` (Linux: ``setpriority`` on a
    thread id affects that thread only); where that cannot be done, the work runs as it is."""
    try:
        os.setpriority(os.PRIO_PROCESS, threading.get_native_id(), niceness)
    except (AttributeError, OSError):
        pass
