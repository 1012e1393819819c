"""The messaging service and the runner of long work: what the window's parts are handed instead of the
window. Said, redacted and levelled without a window; work announced from start to end."""

import pytest
from PySide6 import QtCore

from usvips.core.errors import UsvipsError
from usvips.gui.jobs import Jobs
from usvips.gui.messages import LEVELS, Messages
from usvips.gui.worker import Cancelled


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
