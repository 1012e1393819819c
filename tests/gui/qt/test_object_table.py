"""The object list as a model over the object cache: in a large survey only the drawn rows' figures are
computed; rows sort by a column's header and filter by a text in any cell, the selection and the ids
following; no row is made per object."""

import numpy as np
from PySide6 import QtCore

from usvips.gui.qt.bench import survey_project
from usvips.gui.qt.object_list import ObjectList
from usvips.gui.qt.object_table import figure_order
from usvips.gui.workspace import Workspace
from usvips.store import Project
from usvips.store.records import Vertex


def _shown_list(qtbot, ws: Workspace) -> ObjectList:
    """The list over ``ws`` shown 900 × 300, refreshed once laid out (the rows on screen), its first figures in."""
    listing = ObjectList(ws)
    qtbot.addWidget(listing)
    listing.resize(900, 300)
    listing.show()
    qtbot.waitExposed(listing)
    listing.refresh()  # laid out now: the rows on screen
    qtbot.waitUntil(lambda: listing._worker is None, timeout=20000)
    return listing


def test_a_large_survey_computes_the_figures_of_the_rows_drawn_and_sorts_and_filters_in_the_model(
        qtbot, tmp_path, monkeypatch):
    monkeypatch.setattr(ObjectList, "EAGER", 10)  # a survey of 60 stands for one of 100,000 ...
    monkeypatch.setattr(ObjectList, "FIRST_ROWS", 5)  # ... its first screenful ...
    monkeypatch.setattr(ObjectList, "FIT_ROWS", 5)  # ... and its columns are not fitted to every row
    ws = Workspace()
    ws.open_project(Project.open(survey_project(tmp_path / "survey", 60)))
    listing = _shown_list(qtbot, ws)
    model = listing.model
    ids = ws.cache.ids()
    assert model.rowCount() == 60 and model.ids() == ids
    drawn = {listing.object_id(r) for r in listing.visible_rows()}
    assert drawn and all(ws.cache.known_figures(i) is not None for i in drawn)
    assert sum(ws.cache.known_figures(i) is not None for i in ids) < 60  # the rows never drawn: not computed
    # a row drawn (asked for) gets its figure from a worker
    last = listing.row_count() - 1
    assert listing.text(last, "figure") == "computing…"
    qtbot.waitUntil(lambda: "mm" in listing.text(last, "figure"), timeout=20000)
    # sorting: by the attribute's text descending (the header's sort indicator), then back to the stored order
    header = listing.table.horizontalHeader()
    ws.select([ids[5]])
    header.setSortIndicator(ObjectList.COLUMNS.index("attribute"), QtCore.Qt.SortOrder.DescendingOrder)
    texts = [listing.text(r, "attribute") for r in range(listing.row_count())]
    assert texts == sorted(texts, key=str.casefold, reverse=True) and texts[0] == "fish 9"
    assert listing.selected_ids() == [ids[5]] and ws.selection == (ids[5],)  # the selection follows its object
    assert listing.row_of(ids[5]) == texts.index(ws.stored_object(ids[5]).attribute)
    header.setSortIndicator(-1, QtCore.Qt.SortOrder.AscendingOrder)
    assert model.ids() == ids
    # with the mouse: a click on the header sorts ascending, a second descending, a third gives the stored order
    column = ObjectList.COLUMNS.index("attribute")
    where = QtCore.QPoint(header.sectionViewportPosition(column) + 5, 5)
    for first in ("fish 1", "fish 9", "fish 1"):
        qtbot.mouseClick(header.viewport(), QtCore.Qt.MouseButton.LeftButton, pos=where)
        assert listing.text(0, "attribute") == first
    assert model.ids() == ids
    # filtering: the rows whose cells hold the text; an object added while filtered appears only if it matches
    listing.filter.setText("FISH 1")  # any case: "fish 1", "fish 10" ... "fish 19"
    shown = model.ids()
    assert shown == [i for i in ids if "fish 1" in ws.stored_object(i).attribute + ws.stored_object(i).notes]
    assert 0 < len(shown) < 60
    ws.edits.delete_object(shown[0])
    assert model.ids() == shown[1:] and listing.row_of(shown[0]) is None
    listing.filter.clear()
    assert model.ids() == [i for i in ids if i != shown[0]]
    # an object stored now is the last row; every row is still found by its object
    model.row_of(ids[1])  # the rows' index made
    new = ws.project.add_object("point", [Vertex(300.0, 200.0, 280.0, 200.0, pair="measure1")])
    ws.objects_changed_in_store(added=(new,))
    assert listing.row_of(new) == listing.row_count() - 1
    assert all(listing.row_of(i) == row for row, i in enumerate(model.ids()))
    listing.cleanup()
    ws.close_project()


def test_a_sort_by_figure_computes_every_figure_first_and_says_so(qtbot, tmp_path, monkeypatch):
    """In a survey whose figures are computed as rows are drawn, a sort by the figure (or the quality) cannot
    be made from the drawn rows alone: every missing figure is computed in the worker, with its progress
    shown beside the filter, then the rows are sorted again; a filter matches figure texts the same way."""
    monkeypatch.setattr(ObjectList, "EAGER", 10)
    monkeypatch.setattr(ObjectList, "FIRST_ROWS", 5)
    monkeypatch.setattr(ObjectList, "FIT_ROWS", 5)
    ws = Workspace()
    ws.open_project(Project.open(survey_project(tmp_path / "survey", 40, seed=3)))
    messages = []
    ws.message.connect(lambda level, text: messages.append(text))
    listing = _shown_list(qtbot, ws)
    ids = ws.cache.ids()
    assert sum(ws.cache.known_figures(i) is not None for i in ids) < 40
    column = ObjectList.COLUMNS.index("figure")
    listing.table.horizontalHeader().setSortIndicator(column, QtCore.Qt.SortOrder.DescendingOrder)
    assert listing.completing.isVisible() and "sorting by figure" in listing.completing.format()
    known = [ws.cache.known_figures(i) is not None for i in listing.model.ids()]
    assert known == sorted(known, reverse=True)  # meanwhile, by what is known; the others last, in either order
    qtbot.waitUntil(lambda: any("sorting by figure: computing the figures of" in m for m in messages), timeout=5000)
    qtbot.waitUntil(lambda: not listing.completing.isVisible(), timeout=30000)
    assert all(ws.cache.known_figures(i) is not None for i in ids)
    values = [ws.cache.known_figures(listing.object_id(r)).figures[0].value for r in range(listing.row_count())]
    assert values == sorted(values, reverse=True) and sorted(listing.model.ids()) == ids
    listing.sort(column, QtCore.Qt.SortOrder.AscendingOrder)  # every figure known: nothing shown to wait for
    assert not listing.completing.isVisible()
    qtbot.waitUntil(lambda: not listing.arranging, timeout=5000)
    assert not listing.completing.isVisible()
    # a figure's text filters as any other cell's (every figure is known now: filtered at once)
    text = listing.text(0, "figure")
    listing.filter.setText(text)
    assert listing.model.ids() and all(listing.text(r, "figure") == text for r in range(listing.row_count()))
    assert not listing.completing.isVisible()
    listing.cleanup()
    ws.close_project()


def test_an_object_without_figures_is_not_called_ok_and_its_row_says_why_once():
    """A stored proposal without a length (or any object whose figures cannot be computed) has no verdict:
    its quality cell says there is no figure, never "ok", and its figure cell gives the reason without
    repeating the object's id (the row's own)."""
    from collections import Counter

    from usvips.gui.calculator import Result
    from usvips.gui.qt.object_table import NO_FIGURE, figure_texts

    reason = Result((), (), "object 7: it has vertices without 3-D coordinates")
    main, quality, _ = figure_texts(reason, 7, {}, Counter())
    assert (main, quality) == ("it has vertices without 3-D coordinates", NO_FIGURE)


def _survey_list(qtbot, tmp_path, monkeypatch, count: int):
    """A list over a survey of ``count`` objects standing for 100,000 (drawn rows computed, jobs of 7)."""
    monkeypatch.setattr(ObjectList, "EAGER", 10)
    monkeypatch.setattr(ObjectList, "FIRST_ROWS", 5)
    monkeypatch.setattr(ObjectList, "FIT_ROWS", 5)
    monkeypatch.setattr(ObjectList, "JOB_OBJECTS", 7, raising=False)
    ws = Workspace()
    ws.open_project(Project.open(survey_project(tmp_path / "survey", count, seed=5)))
    jobs: list[list[int]] = []
    making = ws.cache.figures_job
    monkeypatch.setattr(ws.cache, "figures_job", lambda ids: (jobs.append(list(ids)), making(ids))[1])
    listing = _shown_list(qtbot, ws)
    return ws, listing, jobs


def test_a_sort_copies_the_figures_inputs_a_job_at_a_time(qtbot, tmp_path, monkeypatch):
    """A sort by the figure needs every figure: their inputs are copied out of the project a job of
    JOB_OBJECTS at a time (all at once froze the window 14 s on 100,000 objects), the progress counts over
    the jobs, and every figure comes."""
    ws, listing, jobs = _survey_list(qtbot, tmp_path, monkeypatch, 45)
    jobs.clear()
    shown = []
    listing.completing.valueChanged.connect(shown.append)
    listing.sort(ObjectList.COLUMNS.index("figure"), QtCore.Qt.SortOrder.AscendingOrder)
    assert listing.arranging
    qtbot.waitUntil(lambda: not listing.arranging and not listing.completing.isVisible(), timeout=60000)
    ids = ws.cache.ids()
    assert all(ws.cache.known_figures(i) is not None for i in ids)
    assert len(jobs) >= 5 and max(len(job) for job in jobs) <= 7
    assert shown == sorted(shown) and 0 < max(shown) <= 100  # one progress over all the jobs
    values = [ws.cache.known_figures(listing.object_id(r)).figures[0].value for r in range(listing.row_count())]
    assert values == sorted(values)
    listing.cleanup()
    ws.close_project()


def test_a_job_ending_before_the_sort_looks_for_its_figures_does_not_end_the_sort(qtbot, tmp_path, monkeypatch):
    """The missing figures of a sort are looked for a turn after the click; a figures job of the rows on screen
    that ends in between (what ends a sort waiting for figures) leaves the sort to complete: every figure is
    computed and the rows end in order."""
    ws, listing, jobs = _survey_list(qtbot, tmp_path, monkeypatch, 45)
    listing.sort(ObjectList.COLUMNS.index("figure"), QtCore.Qt.SortOrder.DescendingOrder)
    listing._completed()  # a job of the rows on screen ends before the sort's turn
    listing._on_cancelled(listing._worker) if listing._worker is not None else None
    qtbot.waitUntil(lambda: not listing.arranging and listing._worker is None, timeout=60000)
    ids = ws.cache.ids()
    assert all(ws.cache.known_figures(i) is not None for i in ids)
    values = [ws.cache.known_figures(listing.object_id(r)).figures[0].value for r in range(listing.row_count())]
    assert values == sorted(values, reverse=True)
    listing.cleanup()
    ws.close_project()


def test_a_sort_by_another_column_before_its_turn_computes_nothing(qtbot, tmp_path, monkeypatch):
    ws, listing, jobs = _survey_list(qtbot, tmp_path, monkeypatch, 45)
    jobs.clear()
    listing.sort(ObjectList.COLUMNS.index("figure"), QtCore.Qt.SortOrder.AscendingOrder)
    listing.sort(ObjectList.COLUMNS.index("id"), QtCore.Qt.SortOrder.AscendingOrder)
    qtbot.waitUntil(lambda: not listing.arranging, timeout=10000)
    assert listing.completing.isHidden() and listing.model.ids() == sorted(ws.cache.ids())
    assert sum(len(job) for job in jobs) < 45  # at most the rows on screen, never every figure
    listing.cleanup()
    ws.close_project()


def test_a_fast_scroll_computes_the_rows_on_screen_not_every_page_passed(qtbot, tmp_path, monkeypatch):
    """Scrolling a page at a time faster than the figures come: each job holds the rows on screen (and those
    not yet done that are still there), never the rows of the pages passed, which ask again when drawn."""
    ws, listing, jobs = _survey_list(qtbot, tmp_path, monkeypatch, 80)
    jobs.clear()
    bar = listing.table.verticalScrollBar()
    pages = range(0, bar.maximum() + 1, max(1, bar.pageStep()))
    for value in pages:
        bar.setValue(value)
        listing.table.viewport().repaint()
        made = len(jobs)
        listing._compute_wanted()  # what the drawn rows' request does at the next turn of the event loop
        shown = {listing.object_id(r) for r in listing.visible_rows()}
        assert all(set(job) <= shown for job in jobs[made:])
    assert len(jobs) >= len(pages) - 1  # (each page's rows asked while the one before was computed)
    qtbot.waitUntil(lambda: listing._worker is None, timeout=20000)
    shown = {listing.object_id(r) for r in listing.visible_rows()}
    assert all(ws.cache.known_figures(i) is not None for i in shown)
    assert sum(ws.cache.known_figures(i) is not None for i in ws.cache.ids()) < 80
    listing.cleanup()
    ws.close_project()


def test_a_small_lists_columns_widen_to_an_added_object_without_measuring_every_row(qtbot, tmp_path, monkeypatch):
    """In a list small enough to fit every row, an object stored later widens the columns its texts need
    (its long attribute is shown whole), measuring its own row only: every row measured again on each
    stored object cost 30 ms at 200 rows."""
    ws = Workspace()
    ws.open_project(Project.open(survey_project(tmp_path / "survey", 30, seed=7)))
    listing = _shown_list(qtbot, ws)
    fitted = []
    monkeypatch.setattr(listing.table, "resizeColumnsToContents", lambda: fitted.append(True))
    column = ObjectList.COLUMNS.index("attribute")
    before = listing.table.columnWidth(column)
    attribute = "a very long attribute that no fish of the survey has " * 2
    new = ws.project.add_object("point", [Vertex(300.0, 200.0, 280.0, 200.0, pair="measure1")], attribute)
    ws.objects_changed_in_store(added=(new,))
    width = listing.table.columnWidth(column)
    assert not fitted and width > before
    assert width >= listing.table.fontMetrics().horizontalAdvance(attribute)
    listing.cleanup()
    ws.close_project()


def test_objects_stored_together_widen_the_columns_making_each_rows_cells_once(qtbot, tmp_path, monkeypatch):
    """A run's proposals stored together (their figures not known yet, so their rows keep no texts) widen a
    small list's columns by each new row's cells made once, not once for each of its cells (11 times: 22 ms
    on the window's thread for 38 proposals)."""
    ws = Workspace()
    ws.open_project(Project.open(survey_project(tmp_path / "survey", 12, seed=7)))
    listing = _shown_list(qtbot, ws)
    made = []
    texts = listing.model.texts
    monkeypatch.setattr(listing.model, "texts", lambda object_id, request=True: made.append(object_id)
                        or texts(object_id, request))
    new = tuple(ws.project.add_object("point", [Vertex(300.0 + k, 200.0, 280.0 + k, 200.0, pair="measure1")],
                                      "a long attribute " * (k + 1)) for k in range(6))
    ws.objects_changed_in_store(added=new)
    assert sorted(made) == sorted(new)
    column = ObjectList.COLUMNS.index("attribute")
    assert listing.table.columnWidth(column) >= listing.table.fontMetrics().horizontalAdvance("a long attribute " * 6)
    listing.cleanup()
    ws.close_project()


def test_a_sort_by_figure_asks_for_each_figure_once_and_the_rules_once(qtbot, tmp_path, monkeypatch):
    """Arranging a survey's rows by the figure asks the cache for the rules once, not once a row (a sort of
    20,000 objects did 20,000 times, on the window's thread), and keeps the order: by value, then id, the
    objects without a figure last in the stored order."""
    ws = Workspace()
    ws.open_project(Project.open(survey_project(tmp_path / "survey", 40, seed=3)))
    listing = _shown_list(qtbot, ws)
    unknown = ws.cache.ids()[::7]
    ws.cache.forget_figures(unknown)
    asked = []
    rules = ws.cache._rules
    monkeypatch.setattr(ws.cache, "_rules", lambda: asked.append(True) or rules())
    listing.model.sort(ObjectList.COLUMNS.index("figure"), QtCore.Qt.SortOrder.DescendingOrder)
    assert len(asked) == 1
    ids = listing.model.ids()
    valued = [(ws.cache.known_figures(i).figures[0].value, i) for i in ids[:len(ids) - len(unknown)]]
    assert valued == sorted(valued, reverse=True) and ids[len(valued):] == unknown
    listing.cleanup()
    ws.close_project()


def test_rows_by_figure_are_ordered_by_value_then_id_with_a_nan_last_in_either_order():
    """The sort by the figure (numpy's, for speed) orders as sorting (value, id) pairs does, ascending and
    descending, over random values with many ties; a NaN value comes after every number either way."""
    rng = np.random.default_rng(7)
    for _ in range(200):
        n = int(rng.integers(0, 40))
        values = rng.integers(0, 6, n).astype(float) * 0.25  # many equal values
        ids = rng.permutation(1000)[:n].tolist()
        pairs = list(zip(values.tolist(), ids, strict=True))
        assert figure_order(values.tolist(), ids) == [i for _, i in sorted(pairs)]
        assert figure_order(values.tolist(), ids, descending=True) == [i for _, i in sorted(pairs, reverse=True)]
    values, ids = [2.0, float("nan"), 1.0, float("nan")], [4, 3, 2, 1]
    assert figure_order(values, ids) == [2, 4, 1, 3]
    assert figure_order(values, ids, descending=True) == [4, 2, 3, 1]
