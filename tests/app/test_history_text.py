"""A history row in words names only the fields that changed."""

from datetime import UTC

from usvips.app.history_text import what_changed
from usvips.store.records import HistoryEntry


def _edit(old: dict, new: dict) -> HistoryEntry:
    return HistoryEntry(1, "2026-11-28T09:00:00Z", "ann", 7, "edit", old, new)


def test_an_edit_lists_the_fields_that_changed_not_those_written_unchanged():
    text = what_changed(_edit({"attribute": "", "notes": "old"}, {"attribute": "", "notes": "new"}))
    assert text == "notes 'old' → 'new'"


def test_an_edit_that_changed_nothing_says_so():
    assert what_changed(_edit({"attribute": "cod"}, {"attribute": "cod"})) == "no field changed"
    assert what_changed(_edit({}, {})) == "no field given"


def test_vertices_are_counted_only_when_they_moved():
    same = [[1.0, 2.0], [3.0, 4.0]]
    assert what_changed(_edit({"vertices": same, "attribute": "a"}, {"vertices": same, "attribute": "b"})) == \
        "attribute 'a' → 'b'"
    assert what_changed(_edit({"vertices": same}, {"vertices": [[1.0, 2.0], [3.0, 5.0]]})) == \
        "vertices 2 → 2 (1 changed)"


def test_an_added_object_names_no_empty_attribute_and_counts_its_vertices_in_words():
    def added(state: dict) -> HistoryEntry:
        return HistoryEntry(1, "2026-11-28T09:00:00Z", "ann", 7, "add", None, state)

    assert what_changed(added({"kind": "length", "attribute": "", "vertices": [[1, 2], [3, 4]]})) == \
        "length, 2 vertices"
    assert what_changed(added({"kind": "point", "attribute": "cod", "vertices": [[1, 2]]})) == "point 'cod', 1 vertex"


def test_a_history_time_reads_as_local_date_and_time_to_the_second():
    from datetime import datetime

    from usvips.app.history_text import moment_text

    stored = "2026-11-28T13:34:01.010196+00:00"
    local = datetime(2026, 11, 28, 13, 34, 1, 10196, tzinfo=UTC).astimezone()
    assert moment_text(stored) == local.strftime("%Y-%m-%d %H:%M:%S")
    assert "." not in moment_text(stored) and "+" not in moment_text(stored)
    assert moment_text("not a time") == "not a time"
