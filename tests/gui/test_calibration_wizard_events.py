"""The calibration wizard follows its session's events: the measure page's table when the observations or
their use change (whoever changed them), the results page when a result is set or dropped, the title when
the step changes; closing the wizard stops its listening."""

from PySide6 import QtCore

from tests.gui.qt.test_calibration_wizard import _compute, _to_results, _wait_idle, _wizard, project  # noqa: F401
from usvips.gui.calibration_session import CalibrationSession


def _rows(page) -> set[tuple[str, str]]:
    return {(page.table.item(r, 0).text(), page.table.item(r, 1).text()) for r in range(page.table.rowCount())}


def test_the_wizard_follows_the_sessions_step_data_and_result(qtbot, project):  # noqa: F811
    p, _ = project()
    session = CalibrationSession(p, "water")
    wizard = _wizard(qtbot, session)
    assert session.step == "setup" and wizard.windowTitle().endswith("set-up")
    measure = _to_results(qtbot, wizard, ["water1"])
    assert session.step == "measure" and wizard.windowTitle().endswith("measure the targets")
    # the session changed by another hand than the page's: the table follows its data events
    point = session.measured("water1")[0]
    values = session.observations[("water1", point)]
    session.remove_observation("water1", point)
    assert ("water1", point) not in _rows(measure) and len(_rows(measure)) == len(session.observations)
    session.set_observation("water1", point, values[:2], values[2:])
    assert ("water1", point) in _rows(measure)
    session.set_check("water1", point, True)
    checked = [r for r in range(measure.table.rowCount()) if measure.table.item(r, 1).text() == point
               and measure.table.item(r, 0).text() == "water1"]
    assert measure.table.item(checked[0], measure.COLUMNS.index("check")).checkState() == QtCore.Qt.CheckState.Checked

    # the results page shows the result the session announces ...
    result = _compute(qtbot, wizard)
    assert session.step == "results" and result is session.result
    results = wizard.results_page
    assert "σ0" in results.summary.text() and results.isComplete()
    # ... and says so when a change of the data drops it (the check box ticked in the table)
    item = measure.table.item(checked[0], measure.COLUMNS.index("check"))
    item.setCheckState(QtCore.Qt.CheckState.Unchecked)
    assert ("water1", point) not in session.check and session.result is None
    assert "compute again" in results.summary.text() and not results.isComplete()
    # a result set by another hand is shown too
    session.set_result(result)
    assert "σ0" in results.summary.text() and results.isComplete()

    _wait_idle(qtbot, results)
    wizard.done(0)  # closing: the session no longer calls into the wizard's pages
    assert len(session.step_changed) == len(session.data_changed) == len(session.result_changed) == 0
    session.remove_observation("water1", point)


def test_the_measure_page_labels_its_targets_and_highlights_the_row_selected(qtbot, project):  # noqa: F811
    p, _ = project()
    session = CalibrationSession(p, "water")
    wizard = _wizard(qtbot, session)
    measure = _to_results(qtbot, wizard, ["water1"])
    qtbot.waitUntil(lambda: bool(measure.workspace.images), timeout=10000)
    shown = measure.pair.currentText()
    measured = sorted(session.measured(shown))
    for side in ("left", "right"):
        assert sorted(label.toPlainText() for label in measure.panes[side].control_labels) == measured
        assert measure.panes[side].selected_control is None
    rows = [r for r in range(measure.table.rowCount()) if measure.table.item(r, 0).text() == shown]
    row = rows[len(rows) // 2]
    target = measure.table.item(row, 1).text()
    measure.table.selectRow(row)
    for side in ("left", "right"):
        assert measure.panes[side].selected_control == target
        labels = {label.toPlainText(): label for label in measure.panes[side].control_labels}
        assert labels[target].color.getRgb()[:3] != labels[next(t for t in measured if t != target)].color.getRgb()[:3]
    measure.table.clearSelection()  # nothing chosen: nothing highlighted
    assert measure.panes["left"].selected_control is None and len(measure.panes["left"].control_labels) == len(measured)
