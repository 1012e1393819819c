"""The window names its own field for an error (usvips.gui.qt.field_errors): where a form's value makes the
library refuse, the form says so with the field's label (not the library's name for the setting), outlines
the field and gives it the keyboard; editing the field takes the outline away. Driven with pytest-qt on the
forms where users type numbers: the phase-2 housing values of both calibration wizards, the target path's
chessboard, the deployment dialog (in test_exchange_dialogs.py) and the double-read report's readers."""

from PySide6 import QtWidgets

from tests.gui.conftest import open_sample, show_active
from usvips.app.samples import open_or_create_from_manifest
from usvips.core.errors import InvalidParameterError, UsvipsError
from usvips.gui.calibration_session import CalibrationSession
from usvips.gui.qt import double_read_dialog
from usvips.gui.qt.field_errors import MARKED, FormFields
from usvips.gui.target_session import TargetSession
from usvips.store import Project


def test_a_form_marks_focuses_and_names_the_field_an_error_concerns(qtbot):
    form = QtWidgets.QWidget()
    depth, count = QtWidgets.QLineEdit(form), QtWidgets.QSpinBox(form)
    layout = QtWidgets.QFormLayout(form)
    layout.addRow("Depth (m)", depth)
    layout.addRow("Count", count)
    show_active(qtbot, form)
    said = []
    fields = FormFields({"depth_m": (depth, "Depth (m)"), "count": (count, "Count")}, said.append)
    depth.setText("-3")
    count.setFocus()
    found = fields.show(InvalidParameterError("depth_m", "must be between 0 and 11000 metres, got -3"))
    assert found.label == "Depth (m)" and said[-1] == "Depth (m): must be between 0 and 11000 metres, got -3"
    assert fields.marked() == ["depth_m"] and depth.hasFocus() and depth.selectedText() == "-3"
    qtbot.keyClicks(depth, "3")  # the user corrects it: the outline goes
    assert fields.marked() == [] and not depth.property(MARKED)
    assert fields.show(UsvipsError("the project is read-only")) is None  # naming no field: said as it is
    assert said[-1] == "the project is read-only" and fields.marked() == []


def test_the_target_paths_phase_two_names_a_bad_housing_value(qtbot, tmp_path):
    from usvips.gui.qt.target_pages import TargetWizard

    with Project.create(tmp_path / "p.usvips") as project:
        wizard = show_active(qtbot, TargetWizard(TargetSession(project, "water")))
        page = wizard.source_page
        page.use_chessboard()
        page.housing.setCurrentText("flat-port")
        page.known["n2"].setText("1.5 ± 0.01")
        qtbot.keyClicks(page.known["t"], "-0.002")
        page.holdout.setFocus()
        wizard.next()
        assert wizard.currentPage() is page
        assert page.message.text().startswith("housing value t (m): must be > 0 m, got -0.002")
        assert page.field_errors.marked() == ["t"] and page.known["t"].hasFocus()
        qtbot.keyClicks(page.known["t"], "0.012")  # typed over the selected value
        assert page.field_errors.marked() == [] and page.known_values()["t"] == (0.012, None)
        wizard.reject()


def test_the_target_paths_chessboard_names_its_corners(qtbot, tmp_path):
    from usvips.gui.qt.target_pages import TargetWizard

    with Project.create(tmp_path / "p.usvips") as project:
        wizard = show_active(qtbot, TargetWizard(TargetSession(project, "air")))
        page = wizard.source_page
        page.cols.setValue(8)
        page.rows.setValue(8)
        page.use_chessboard()
        assert page.message.text().startswith("inner corners: a 8 × 8 chessboard looks the same turned")
        assert page.field_errors.marked() == ["upright"] and page.cols.hasFocus()
        page.cols.setValue(9)
        assert page.field_errors.marked() == []
        wizard.reject()


def test_the_classic_phase_two_page_names_a_bad_housing_value(qtbot, sample_copy):
    from usvips.gui.qt.calibration_wizard import CalibrationWizard

    project = open_or_create_from_manifest(sample_copy("tank_system1"))
    try:
        wizard = show_active(qtbot, CalibrationWizard(CalibrationSession(project, "water")))
        page = wizard.setup_page
        assert page.base.currentData() is not None  # the sample holds its phase-1 calibration
        page.known["n3"].setText("1.34 ± 0.01")
        page.known["r"].setText("five cm")
        assert not page.validatePage()
        assert page.message.text().startswith("housing value r (m): 'five cm': type a value (fixed)")
        assert page.field_errors.marked() == ["r"] and page.known["r"].hasFocus()
        page.known["r"].setText("0.09")
        assert page.validatePage() and page.field_errors.marked() == []
        assert wizard.session.known["r"] == (0.09, None) and wizard.session.known["n3"] == (1.34, 0.01)
        wizard.reject()
    finally:
        project.close()


def test_the_double_read_report_names_the_reader_field(qtbot, make_window, sample_copy):
    window = make_window()
    open_sample(qtbot, window, sample_copy("tank_system1"), "measure1")
    dialog = double_read_dialog.show_double_read(window.context, window)
    dialog.activateWindow()
    qtbot.waitUntil(dialog.isActiveWindow, timeout=5_000)
    dialog.reader_b.setCurrentText(dialog.reader_a.currentText())
    assert dialog.compare() is None
    assert dialog.summary.text().startswith("Reader B: give two different annotators")
    assert dialog.field_errors.marked() == ["readers"] and dialog.reader_b.hasFocus()
    dialog.close()
