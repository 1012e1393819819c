"""The QA panel's model without Qt: the same report as ``usvips project check`` from the window's object
cache, no figure computed twice, and kept up to date as objects change."""

import pytest

from tests.app.test_quality import build_survey
from usvips.app.quality import FAIL, NOTE, Issue, Place, QualityReport, check_project
from usvips.core.measurements import QualityRules
from usvips.gui.qa_model import COLUMNS, QaModel, number_text, qa_rows, summary
from usvips.gui.workspace import Workspace
from usvips.store import Project


@pytest.fixture
def survey(tmp_path):
    ids = build_survey(tmp_path / "survey.usvips")
    ws = Workspace()
    ws.open_project(Project.open(tmp_path / "survey.usvips"))
    yield ws, ids
    ws.close_project()


def _issues(report):
    return sorted((i.object_id, i.rule, i.status, i.value, i.limit) for i in report.issues)


def test_the_panel_reports_what_project_check_reports(survey):
    ws, ids = survey
    model = QaModel(ws)
    heard = []
    model.changed.connect(lambda: heard.append(1))
    model.refresh_now()
    assert heard == [1]
    assert _issues(model.report) == _issues(check_project(ws.project))
    assert model.report.checked == len(ids) - 1  # the second instant is checked with the first
    failing = {row.object_id for row in model.rows if row.failure}
    assert failing == {ids[n] for n in ("too long", "rms", "range", "precision", "no figures")}
    # failures first, then notes; each row's cells in the column order, with units
    flags = [row.failure for row in model.rows]
    assert flags == sorted(flags, reverse=True)
    too_long = next(r for r in model.rows if r.object_id == ids["too long"])
    assert len(too_long.cells) == len(COLUMNS)
    assert too_long.cells[1] == "length > species maximum" and too_long.cells[3] == "250.0 mm"
    assert too_long.cells[4] == "Pagrus auratus" and too_long.cells[5] == "pair dive"
    assert too_long.place.pair == "dive" and too_long.place.video is None
    notes = [r for r in model.rows if not r.failure]
    assert {r.object_id for r in notes} == {ids["no maximum"], ids["unknown"]}
    assert all(r.cells[1].startswith("note: ") for r in notes)
    assert summary(model.report) == f"{len(ids) - 1} objects checked: 5 break a rule (2 notes)"


def test_cached_figures_are_not_computed_again_and_computed_ones_are_kept(survey):
    ws, ids = survey
    model = QaModel(ws)
    first = model.job()
    assert first.figures is not None  # nothing cached yet: the job computes them
    model.take(first, first())
    assert all(ws.cache.known_figures(i) is not None for i in ids.values() if i != ids["instant 2"])
    again = model.job()
    assert again.figures is None  # every figure cached: the check only
    before = _issues(model.report)
    model.take(again, again())
    assert _issues(model.report) == before


def test_the_report_follows_edits_and_the_rules(survey):
    ws, ids = survey
    model = QaModel(ws)
    model.refresh_now()
    ws.edits.delete_object(ids["too long"])
    model.refresh_now()
    assert ids["too long"] not in {r.object_id for r in model.rows}
    ws.undo.undo()
    model.refresh_now()
    assert ids["too long"] in {r.object_id for r in model.rows}
    ws.set_rules(QualityRules(max_range_m=1.0))  # every object lies beyond 1 m: all with figures break it
    model.refresh_now()
    in_range = {r.object_id for r in model.rows if r.cells[1] == "range"}
    assert in_range == {i for n, i in ids.items() if n not in ("no figures", "instant 2")}


def test_a_job_made_before_an_edit_does_not_keep_stale_figures(survey):
    ws, ids = survey
    model = QaModel(ws)
    stale = model.job()
    result = stale()
    ws.edits.edit_object(ids["rms"], "moved", "")  # the object changed after the job copied it
    model.take(stale, result)
    assert ws.cache.known_figures(ids["rms"]) is None  # dropped by the cache: the next check computes it again
    assert model.job().figures is not None


def test_numbers_and_an_empty_survey():
    assert number_text(0.0234, "m") == "23.4 mm" and number_text(0.125, "1") == "12.5 %"
    assert number_text(None, "m") == ""
    ws = Workspace()
    model = QaModel(ws)
    model.refresh_now()
    assert model.rows == [] and summary(model.report) == "0 objects checked: 0 break a rule"
    assert summary(None) == "checking…" and qa_rows(model.report) == []


def test_the_summary_counts_in_words_for_one_object_and_one_note():
    failure = Issue("1", "rms", FAIL, 0.03, 0.02, "m", "length", "", Place(), "ray RMS too large")
    note = Issue("1", "species", NOTE, None, None, "1", "length", "", Place(), "not in the species list")
    assert summary(QualityReport((failure, note), 1)) == "1 object checked: 1 breaks a rule (1 note)"
    assert summary(QualityReport((failure,), 3)) == "3 objects checked: 1 breaks a rule"


def test_the_calculator_review_and_qa_panel_give_one_verdict_per_object(survey, qtbot):
    """The geo-calculator said "passes the rules" of a fish the QA panel listed over its species maximum:
    every place that shows a verdict now asks the one function (app.quality.judge)."""
    from usvips.gui.qt.calculator_panel import CalculatorPanel

    ws, ids = survey
    model = QaModel(ws)
    model.refresh_now()
    panel = CalculatorPanel(ws)
    qtbot.addWidget(panel)
    failing = {row.object_id for row in model.rows if row.failure}
    for name in ("good", "too long", "rms", "no maximum"):
        ws.select([ids[name]])
        qtbot.waitUntil(lambda: "quality:" in panel.output.toPlainText(), timeout=10000)
        verdict = next(line for line in panel.output.toPlainText().splitlines() if line.startswith("quality:"))
        assert (verdict == "quality: passes the rules") == (ids[name] not in failing), (name, verdict)
    assert panel.output.toPlainText().splitlines()[0] == f"object {ids['no maximum']}"  # not "objects 4"
    ws.select([ids["too long"]])
    qtbot.waitUntil(lambda: "maximum" in panel.output.toPlainText(), timeout=10000)


def test_the_gui_thread_does_no_work_per_object(survey, monkeypatch):
    """What runs per object (its place, weak vertices, the check, the rows and the summary line) runs in the
    job, on the worker's thread: the GUI thread only takes references (job) and keeps the result (take), so
    10,000 objects never freeze the window."""
    import threading

    from usvips.gui import qa_model

    ws, ids = survey
    threads: dict[str, set[int]] = {}
    for name in ("Place", "weak_vertices", "check", "qa_rows", "summary"):
        original = getattr(qa_model, name)
        if name == "Place":
            class Recorded(original):
                @classmethod
                def of(cls, stored, _original=original):
                    threads.setdefault("Place", set()).add(threading.get_ident())
                    return _original.of(stored)
            monkeypatch.setattr(qa_model, "Place", Recorded)
            continue

        def recorded(*args, _name=name, _original=original, **kwargs):
            threads.setdefault(_name, set()).add(threading.get_ident())
            return _original(*args, **kwargs)
        monkeypatch.setattr(qa_model, name, recorded)
    model = QaModel(ws)
    model.take(model.job(), model.job()())  # figures computed and cached first
    threads.clear()
    job = model.job()
    done = []
    worker = threading.Thread(target=lambda: done.append(job()))
    worker.start()
    worker.join()
    model.take(job, done[0])
    assert set(threads) == {"Place", "weak_vertices", "check", "qa_rows", "summary"}
    assert all(seen == {worker.ident} for seen in threads.values()), threads
    assert model.rows and "objects checked" in model.text
