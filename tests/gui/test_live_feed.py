"""The live feed's thread (usvips.gui.qt.live_updates.ChangeFeed) when the store cannot be read: it says so
once — not on every attempt — tries again with growing pauses, says once that it is back, and goes on
from its cursor so that nothing committed meanwhile is missed. A store object of the test's own stands
for a survey that fails a given number of times; then the window on a real server of the test's own,
killed with SIGKILL and started again."""

from __future__ import annotations

import threading

from tests.store.conftest import database_url
from tests.store.test_server_failure import killable  # noqa: F401 - a server the test may kill
from usvips.gui.qt import live_updates
from usvips.gui.qt.live_updates import ChangeFeed, _Relay
from usvips.store.opening import create_project, open_project
from usvips.store.records import HistoryEntry, ServerUnreachableError, StoredObject, Vertex

BOUND_MS = 20000


class _Watch:
    def __init__(self) -> None:
        self.closed = False

    def wait(self, timeout_s: float) -> bool:
        threading.Event().wait(min(timeout_s, 0.01))
        return True

    def close(self) -> None:
        self.closed = True


class _FlakyStore:
    """A survey that cannot be opened the first ``failures`` times, then holds objects 1 and 2 with one
    history row each after history id 5."""

    opened = 0

    def __init__(self, failures: int) -> None:
        self.failures = failures

    def __call__(self, location, read_only: bool = False):
        assert read_only  # the feed only ever reads
        type(self).opened += 1
        if type(self).opened <= self.failures:
            raise ServerUnreachableError(f"{location}: the server is unreachable")
        return self

    def watch(self) -> _Watch:
        return _Watch()

    def changes_since(self, after: int, limit: int = 10000) -> list[HistoryEntry]:
        rows = [HistoryEntry(6, "2026-11-28T12:41:00+00:00", "bob", 1, "add", None, {}),
                HistoryEntry(7, "2026-11-28T12:42:00+00:00", "bob", 2, "edit", {}, {})]
        return [r for r in rows if r.id > after][:limit]

    def objects_with_ids(self, ids):
        return [StoredObject(i, "length", "", "", "bob", "t", f"v{i}", ()) for i in ids]

    def close(self) -> None:
        pass


def test_a_store_that_cannot_be_read_is_said_once_retried_with_back_off_and_nothing_missed(qtbot, monkeypatch):
    monkeypatch.setattr(live_updates, "FIRST_BACKOFF_S", 0.01)
    monkeypatch.setattr(live_updates, "MAX_BACKOFF_S", 0.04)
    _FlakyStore.opened = 0
    relay = _Relay()
    said: list[tuple] = []
    relay.trouble.connect(lambda number, reason: said.append(("trouble", number, reason)))
    relay.recovered.connect(lambda number: said.append(("recovered", number)))
    relay.batch.connect(lambda number, batch: said.append(("batch", number, batch)))
    feed = ChangeFeed("postgresql://host/survey", 5, relay, 3, opener=_FlakyStore(failures=6), wait_s=0.01)
    feed.start()
    try:
        qtbot.waitUntil(lambda: any(s[0] == "batch" for s in said), timeout=BOUND_MS)
    finally:
        feed.stop()
        assert feed.join(5.0)
    assert _FlakyStore.opened == 7  # six failed attempts, then one handle for good
    assert [s[0] for s in said][:3] == ["trouble", "recovered", "batch"]  # said once each, in that order
    assert said[0][1:] == (3, "the server is unreachable")
    batch = said[2][2]
    assert [e.id for e in batch.entries] == [6, 7] and batch.last == 7 and dict(batch.versions) == {1: "v1", 2: "v2"}
    assert [s[0] for s in said].count("batch") == 1  # the cursor moved on: the rows are not sent twice


def test_the_window_says_once_that_the_server_went_away_and_shows_what_was_made_meanwhile_when_back(
        qtbot, make_window, killable):  # noqa: F811
    url = database_url(killable.url, "live_kill")
    with create_project(url) as survey:
        survey.add_object("length", [Vertex(10.0, 20.0, 8.0, 20.0), Vertex(40.0, 20.0, 38.0, 20.0)], "fish")
    window = make_window()
    assert window.open_path(url)
    qtbot.waitUntil(lambda: not window.workspace.cache.loading, timeout=BOUND_MS)  # the objects read, then away
    live = window.live
    killable.kill()
    qtbot.waitUntil(lambda: live.paused != "", timeout=BOUND_MS)
    tip = live.label.toolTip()  # why, in one line (the store's words: the server unreachable, or cannot be opened)
    assert live.label.text() == "live: paused" and tip.startswith("colleagues' changes are not shown for now: ")
    assert "\n" not in tip and "Traceback" not in tip
    killable.start()
    with open_project(url) as bob:  # made while ann's feed was away
        bob.annotator = "bob"
        new = bob.add_object("point", [Vertex(5.0, 6.0, 4.0, 6.0)], "ling")
    qtbot.waitUntil(lambda: new in window.workspace.cache, timeout=BOUND_MS)
    assert live.paused == "" and window.workspace.cache.marks[new].who == "bob"
    log = window.log.toPlainText()
    assert log.count("colleagues' changes are not shown for now") == 1
    assert log.count("colleagues' changes are shown again") == 1
