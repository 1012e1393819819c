"""The window's model when the server fails (issue 34, item 3), on a server of the test's own killed with
SIGKILL and started again: an edit made while it is down is never shown as saved (the object list's cell
shows the object as stored, the message says "the server is unreachable" in plain words), the edit is
kept, and once the server is back a retry saves it — on the objects read afresh after the reconnection
(a colleague's change made meanwhile is there, not overwritten)."""

from __future__ import annotations

from tests.store.conftest import database_url
from tests.store.test_server_failure import killable  # noqa: F401 - a server the test may kill
from usvips.gui.workspace import Workspace
from usvips.store.opening import create_project, open_project
from usvips.store.records import Vertex


def test_an_edit_while_the_server_is_down_is_not_shown_saved_is_kept_and_saved_by_a_retry(killable):  # noqa: F811
    url = database_url(killable.url, "window_kill")
    with create_project(url) as survey:
        survey.add_object("length", [Vertex(10.0, 20.0, 8.0, 20.0), Vertex(40.0, 20.0, 38.0, 20.0)], "fish")
        survey.add_object("point", [Vertex(5.0, 6.0, 4.0, 6.0)], "ling")
    ws = Workspace()
    ws.open_project(open_project(url))
    said: list[tuple[str, str]] = []
    shown: list[tuple[int, ...]] = []
    ws.message.connect(lambda level, text: said.append((level, text)))
    ws.object_events.updated.connect(lambda ids: shown.append(tuple(ids)))
    try:
        killable.kill()
        ws.edits.edit_object(1, "snapper", "")  # typed in the object list's cell while the server is down
        level, text = said[-1]
        assert level == "error" and "not saved" in text and "the server is unreachable" in text
        assert "OperationalError" not in text and "\n" not in text
        assert shown[-1] == (1,) and ws.stored_object(1).attribute == "fish"  # the cell shows what is stored
        assert [kept.reason for kept in ws.edits.unsaved.values()] == ["the server is unreachable"]
        assert ws.edits.retry_unsaved() == 0 and len(ws.edits.unsaved) == 1  # still down: kept again
        killable.start()
        with open_project(url) as colleague:  # meanwhile a colleague edits the other object
            colleague.update_object(2, notes="bob: measured again")
        assert ws.edits.retry_unsaved() == 1 and not ws.edits.unsaved
        assert ws.project.object(1).attribute == "snapper"
        assert ws.project.reconnections >= 1
        assert ws.stored_object(2).notes == "bob: measured again"  # everything read afresh after reconnecting
    finally:
        ws.close_project()
