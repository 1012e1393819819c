"""The messaging service and the runner of long work: what the window's parts are handed instead of the
window. Said, redacted and levelled without a window; work announced from start to end."""

import pytest
from PySide6 import QtCore

from usvips.core.errors import UsvipsError
from usvips.gui.messages import LEVELS, Messages
from usvips.gui.qt.jobs import Jobs
from usvips.gui.qt.worker import Cancelled


def _listened(messages: Messages) -> list:
    heard = []
    messages.said.connect(lambda level, text: heard.append((level, text)))
    return heard


def test_messages_are_said_at_their_level_and_never_with_a_password():
    messages = Messages()
    heard = _listened(messages)
    messages.info("opened a.usvips")
    messages.warning("pair 'p1' has no active calibration")
    messages.error("cannot reach postgresql://ann:s3cr%40t@db.example/survey")
    assert [level for level, _ in heard] == list(LEVELS)
    assert "s3cr" not in heard[-1][1] and "db.example/survey" in heard[-1][1]
    with pytest.raises(ValueError, match="'loud'"):
        messages.say("loud", "a level nobody shows")
    assert len(heard) == 3


def test_jobs_say_failures_and_cancels_and_announce_the_work(qtbot):
    messages = Messages()
    heard = _listened(messages)
    events = []
    messages.work_started.connect(lambda label: events.append(("started", label)))
    messages.work_ended.connect(lambda: events.append(("ended",)))
    jobs = Jobs(QtCore.QThreadPool(), messages)
    results = []

    def failing(progress, cancelled):
        raise UsvipsError("frame 7 cannot be decoded")

    def stopping(progress, cancelled):
        raise Cancelled

    def refused(result):
        raise UsvipsError(f"{result} is refused")

    jobs.run(lambda progress, cancelled: 42, "the answer", results.append)
    qtbot.waitUntil(lambda: not jobs.busy, timeout=10000)
    jobs.run(failing, "decoding", results.append)
    qtbot.waitUntil(lambda: not jobs.busy, timeout=10000)
    jobs.run(stopping, "tracking", results.append)
    qtbot.waitUntil(lambda: not jobs.busy, timeout=10000)
    jobs.run(lambda progress, cancelled: 7, "checking", refused)
    qtbot.waitUntil(lambda: not jobs.busy, timeout=10000)
    assert results == [42]
    assert heard == [("error", "frame 7 cannot be decoded"), ("info", "tracking: cancelled"),
                     ("error", "7 is refused")]
    assert events == [("started", "the answer"), ("ended",), ("started", "decoding"), ("ended",),
                      ("started", "tracking"), ("ended",), ("started", "checking"), ("ended",)]


def test_the_video_and_tracking_controllers_work_without_a_window(qtbot, sample_copy):
    """The controllers are handed the context (workspace, messages, jobs), the panes and two callbacks —
    no MainWindow: a video is opened, its frame pair shown in the model, and what they say is heard."""
    from PySide6 import QtWidgets

    from usvips.app.opening import open_project
    from usvips.gui.qt.pane import StereoPane
    from usvips.gui.qt.track_controls import TrackController
    from usvips.gui.qt.video_controls import VideoController
    from usvips.gui.window_context import WindowContext
    from usvips.gui.workspace import Workspace

    parent = QtWidgets.QWidget()
    qtbot.addWidget(parent)
    messages = Messages()
    heard = _listened(messages)
    workspace = Workspace()
    workspace.message.connect(messages.say)
    context = WindowContext(workspace, messages, Jobs(QtCore.QThreadPool(), messages))
    panes = {side: StereoPane(side) for side in ("left", "right")}
    forgotten, refreshed = [], []
    video = VideoController(parent, context, panes, lambda: forgotten.append(True), lambda: refreshed.append(True))
    video.ask_before_proxies = False
    video.auto_proxies = False
    tracking = TrackController(parent, context, panes, video, workspace.pick_tool.set_tool)
    workspace.open_project(open_project(sample_copy("rov_flatport")))
    label = workspace.project.videos()[0].label
    assert video.open_video(label) and forgotten == [True]
    qtbot.waitUntil(lambda: workspace.video_frame is not None and not context.jobs.busy, timeout=30000)
    assert workspace.pair == label and workspace.images["left"] is not None
    assert any(level == "info" and text.startswith(f"video {label!r}:") for level, text in heard)  # not "video video:"
    before = len(heard)
    tracking.track()  # nothing selected: said through the messages, not the window
    assert len(heard) == before + 1 and heard[-1][0] in ("warning", "error"), heard[before:]
    video.shutdown()
    workspace.close_project()
