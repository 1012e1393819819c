"""The object list (offscreen) with an object measured on several instants: the object's row shows the
combined figure and how many instants it has; a further instant's row is greyed and its figure cell names
its object (its own length only in the tooltip), and both follow links made, removed, an instant
edited, instants deleted and undone. The geo-calculator says whether its figures are one instant's or
the object's combined ones."""

import numpy as np
import pytest
from PySide6 import QtCore, QtGui

from tests.app.test_object_instants import _store_instants
from usvips.app.object_instants import add_instant
from usvips.app.project_figures import evaluate, measurement_input
from usvips.bench import scaling
from usvips.gui.calculator import format_figure
from usvips.gui.qt.calculator_panel import CalculatorPanel
from usvips.gui.qt.object_list import ObjectList
from usvips.gui.workspace import Workspace
from usvips.io.calibration_file import calibration_to_dict, load_calibration
from usvips.store import Project


@pytest.fixture
def listed(qtbot, tmp_path):
    """A workspace on a project with three lengths of one fish (at three places) and another fish, and
    its object list; returns (list, workspace, the fish's ids, the other's id)."""
    calibration = load_calibration(scaling.CALIBRATION)
    project = Project.create(tmp_path / "p.usvips")
    project.add_pair("dive")
    calibration_id = project.add_calibration("cal", calibration_to_dict(calibration), ("dive",))
    rng = np.random.default_rng(11)
    fish = _store_instants(project, calibration, calibration_id, [0.36, 0.36, 0.36], rng)
    other = _store_instants(project, calibration, calibration_id, [0.25], rng)[0]
    ws = Workspace()
    ws.open_project(project)
    view = ObjectList(ws)
    qtbot.addWidget(view)
    yield view, ws, fish, other
    view.cleanup()
    ws.close_project()


class _Cell:
    """A cell of the list's model: its text and tooltip as drawn."""

    def __init__(self, view, object_id, column):
        self.index = view.model.index(view.row_of(object_id), view.COLUMNS.index(column))

    def text(self):
        return self.index.data() or ""

    def toolTip(self):  # noqa: N802 (as Qt names it)
        return self.index.data(QtCore.Qt.ItemDataRole.ToolTipRole) or ""


def _cell(view, object_id, column="figure"):
    return _Cell(view, object_id, column)


def _figure(ws, object_id):
    return format_figure(evaluate(measurement_input(ws.project, ws.project.object(object_id))).figures[0])


def _greyed(view, object_id):
    grey = view.palette().brush(QtGui.QPalette.ColorGroup.Disabled, QtGui.QPalette.ColorRole.Text)
    row = view.row_of(object_id)
    model = view.model
    return all(model.index(row, c).data(QtCore.Qt.ItemDataRole.ForegroundRole) == grey
               for c in range(model.columnCount()))


def test_an_object_shows_its_combined_figure_and_its_instants_their_object(qtbot, listed):
    view, ws, (whole, second, third), other = listed
    own = {i: _figure(ws, i) for i in (whole, second, third, other)}
    qtbot.waitUntil(lambda: _cell(view, whole).text() == own[whole], timeout=10000)  # computed in a worker
    assert not _greyed(view, whole)
    # linked as the app links them; the window announces only the instant: the object's row follows
    for instant in (second, third):
        add_instant(ws.project, whole, instant)
        ws.cache.changed_in_store(updated=(instant,))
    combined = _figure(ws, whole)
    assert combined != own[whole]  # the combined length is not the first instant's
    qtbot.waitUntil(lambda: _cell(view, whole).text() == f"{combined} (3 instants)", timeout=10000)
    assert "combined over 3 instants" in _cell(view, whole).toolTip()
    for instant in (second, third):
        cell = _cell(view, instant)
        assert cell.text() == f"instant of #{whole}" and _greyed(view, instant)
        assert own[instant] in cell.toolTip() and f"object {whole}" in cell.toolTip()
        assert "mm" not in cell.text()  # no length a user could read as the fish's
    assert _cell(view, other).text() == own[other] and not _greyed(view, other)
    # a list made afresh on the project (opened again) shows the same
    fresh = ObjectList(ws)
    qtbot.addWidget(fresh)
    qtbot.waitUntil(lambda: _cell(fresh, whole).text() == f"{combined} (3 instants)", timeout=10000)
    assert _cell(fresh, third).text() == f"instant of #{whole}" and _greyed(fresh, third)
    fresh.cleanup()
    # an instant's vertices changed (say re-picked on a wrong fish): the object's combined figure follows
    ws.project.update_object(third, vertices=list(ws.project.object(other).vertices))
    ws.cache.changed_in_store(updated=(third,))
    moved = _figure(ws, whole)
    assert moved != combined
    qtbot.waitUntil(lambda: _cell(view, whole).text() == f"{moved} (3 instants)", timeout=10000)
    own[third] = _figure(ws, third)
    # an instant unlinked: an object of its own again, the object's figure over the two left
    ws.project.remove_instant(third)
    ws.cache.changed_in_store(updated=(third,))
    two = _figure(ws, whole)
    qtbot.waitUntil(lambda: _cell(view, whole).text() == f"{two} (2 instants)", timeout=10000)
    assert _cell(view, third).text() == own[third] and not _greyed(view, third)
    assert _cell(view, third).toolTip().startswith("sigma ± ")  # its sigma's breakdown, no word of instants
    assert "pointing" in _cell(view, third).toolTip() and "instant" not in _cell(view, third).toolTip()
    # an instant deleted (undoably): the object is one instant again; undo brings the instant back
    ws.edits.delete_object(second)
    qtbot.waitUntil(lambda: _cell(view, whole).text() == own[whole], timeout=10000)
    ws.undo.undo()
    qtbot.waitUntil(lambda: _cell(view, whole).text() == f"{two} (2 instants)", timeout=10000)
    assert _cell(view, second).text() == f"instant of #{whole}" and _greyed(view, second)
    # the object itself deleted: its instants stand alone, each with its own figure
    ws.edits.delete_object(whole)
    qtbot.waitUntil(lambda: _cell(view, second).text() == own[second], timeout=10000)
    assert not _greyed(view, second) and view.row_of(whole) is None


def test_the_calculator_says_whether_it_shows_an_instant_or_the_combined_object(qtbot, listed):
    view, ws, (whole, second, third), other = listed
    panel = CalculatorPanel(ws)
    qtbot.addWidget(panel)
    for instant in (second, third):
        add_instant(ws.project, whole, instant)
    ws.cache.changed_in_store(updated=(second, third))
    panel.set_selection([second])
    text = panel.output.toPlainText()
    assert f"one instant of object {whole}: its figures alone, not the object's" in text
    assert _figure(ws, second) in text  # the instant's own figure, said to be one instant's
    panel.set_selection([whole])
    text = panel.output.toPlainText()
    assert "combined over 3 instants" in text and _figure(ws, whole) in text
    panel.set_selection([other])
    assert "instant" not in panel.output.toPlainText()
    ws.project.remove_instant(third)
    ws.cache.changed_in_store(updated=(third,))
    panel.set_selection([whole])
    assert "combined over 2 instants" in panel.output.toPlainText()
