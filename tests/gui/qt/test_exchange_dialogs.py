"""File › Import calibration (OpenCV)…, Export calibration (OpenCV)…, Calibration report (PDF)…, Deployment and
georeference…, and the calibration wizard's Report (PDF)… button, driven offscreen with file names and
answers handed in (no modal dialog left open)."""

import cv2
import numpy as np
import pytest
from PySide6 import QtCore, QtWidgets

from tests.gui.conftest import open_sample
from usvips.app.calibrations import read_calibration
from usvips.gui.qt import exchange_dialogs
from usvips.gui.qt.worker import Cancelled
from usvips.io.calibration_file import load_calibration
from usvips.io.opencv_calibration import read_opencv_stereo

WORK_BOUND_MS = 600_000  # a generous bound on background work on a loaded machine, not an expected duration


def _menu_texts(window) -> list[str]:
    file_menu = next(a.menu() for a in window.menuBar().actions() if a.text() == "&File")
    return [a.text() for a in file_menu.actions()]


def _opencv_file_without_size(path):
    storage = cv2.FileStorage(str(path), cv2.FILE_STORAGE_WRITE)
    matrix = np.array([[800.0, 0, 320], [0, 800, 240], [0, 0, 1]])
    for name, value in (("M1", matrix), ("D1", np.array([[0.1, -0.2, 0.001, 0.0005, 0.03]])), ("M2", matrix),
                        ("D2", np.zeros((1, 5))), ("R", np.eye(3)), ("T", np.array([[-0.3], [0.0], [0.01]]))):
        storage.write(name, value)
    storage.release()


def _wait_idle(qtbot, window):
    assert window.pool.waitForDone(WORK_BOUND_MS), "background work did not end"
    qtbot.waitUntil(lambda: not window.busy, timeout=WORK_BOUND_MS)


def test_the_file_menu_holds_the_exchange_entries(make_window):
    texts = _menu_texts(make_window())
    for entry in ("Import &calibration (OpenCV)…", "Ex&port calibration (OpenCV)…", "Calibration repor&t (PDF)…",
                  "&Deployment and georeference…"):
        assert entry in texts


def test_import_asks_the_image_size_the_file_lacks_and_stores_the_calibration(qtbot, make_window, sample_copy,
                                                                               tmp_path):
    window = make_window()
    open_sample(qtbot, window, sample_copy("tank_system1"), "measure1")
    before = len(window.workspace.project.calibrations())
    source = tmp_path / "stereo.yml"
    _opencv_file_without_size(source)
    asked = []
    assert exchange_dialogs.import_calibration(window.context, window, [source], tmp_path / "cal.json",
                                               ask_size=lambda w: asked.append(1) or None,
                                               ask_sigma=lambda w: asked.append(2) or None) is None
    assert asked and not (tmp_path / "cal.json").exists()
    assert "image size is needed" in window.statusBar().currentMessage()
    offered = {}

    def tick_the_shown_pair(dialog):  # the import asks what the calibration is active for
        offered.update({dialog.labels.item(i).text(): dialog.labels.item(i).checkState()
                        for i in range(dialog.labels.count())})
        return True

    out = exchange_dialogs.import_calibration(window.context, window, [source], tmp_path / "cal.json",
                                              ask_size=lambda w: (640, 480),
                                              ask_sigma=lambda w: asked.append(2) or None, run=tick_the_shown_pair)
    imported = load_calibration(out)
    # the file states no residual: sigma0 was asked, declined, and stays assumed, said at import
    assert asked.count(2) == 1 and imported.sigma0_origin == "assumed"
    assert "sigma0 0.5 px ASSUMED" in window.log.toPlainText() and "pointing share only" in window.log.toPlainText()
    assert (imported.left.width, imported.left.height) == (640, 480) and imported.left.interior.k3 == 0.03
    assert len(window.workspace.project.calibrations()) == before + 1
    shown = next(text for text in offered if text.startswith("measure1 "))
    size = shown.split("(")[1].rstrip(")")  # each pair is offered with its size
    assert offered[shown] == QtCore.Qt.CheckState.Checked and size.endswith(" px")
    # the sample's pictures are not 640 × 480: the shown pair keeps its calibration, both sizes named
    project = window.workspace.project
    assert project.active_calibration("measure1") != project.calibrations()[-1].id
    message = window.statusBar().currentMessage()
    assert "not made active" in message and size in message and "640 × 480 px" in message
    assert QtWidgets.QApplication.activeModalWidget() is None
    exchange_dialogs.import_calibration(window.context, window, [tmp_path / "missing.yml"], tmp_path / "x.json")
    assert "import failed" in window.statusBar().currentMessage() and not (tmp_path / "x.json").exists()


def test_export_to_opencv_shows_what_is_left_out_and_round_trips(qtbot, make_window, sample_copy, tmp_path):
    window = make_window()
    open_sample(qtbot, window, sample_copy("tank_system1"), "measure1")
    left_out = exchange_dialogs.export_calibration(window.context, window, out=tmp_path / "stereo.yml")
    assert left_out  # an underwater calibration: the housing cannot be held by OpenCV
    assert "left out" in window.statusBar().currentMessage()
    assert window.log.toPlainText().count("OpenCV cannot hold") == len(left_out)
    again = read_opencv_stereo(tmp_path / "stereo.yml")
    active = window.workspace.project.active_calibration("measure1")
    stored = window.workspace.project.calibration(active)
    assert again.left.interior.f == pytest.approx(stored["cameras"]["left"]["interior"]["f"], rel=1e-12)


def test_the_calibration_report_is_written_in_the_worker(qtbot, make_window, sample_copy, tmp_path):
    window = make_window()
    open_sample(qtbot, window, sample_copy("tank_system1"), "measure1")
    worker = exchange_dialogs.calibration_report(window.context, window, out=tmp_path / "report.pdf")
    assert worker is not None and worker in window.workers or (tmp_path / "report.pdf").exists()
    _wait_idle(qtbot, window)
    assert (tmp_path / "report.pdf").read_bytes().startswith(b"%PDF")
    assert "pages)" in window.statusBar().currentMessage()
    assert [p.name for p in tmp_path.iterdir() if p.name.endswith(".part.pdf")] == []


def test_a_cancelled_report_leaves_nothing(tmp_path):
    from usvips.locations import sample_project

    calibration = load_calibration(sample_project("rov_flatport") / "calibration.json")
    job = exchange_dialogs.report_job(calibration, tmp_path / "r.pdf")
    with pytest.raises(Cancelled):
        job(lambda f: None, lambda: True)
    assert list(tmp_path.iterdir()) == []
    assert job(lambda f: None, lambda: False) >= 3 and (tmp_path / "r.pdf").read_bytes().startswith(b"%PDF")


def test_the_deployment_dialog_names_a_bad_value_keeps_the_typing_and_stores_both(qtbot, make_window, sample_copy):
    window = make_window()
    open_sample(qtbot, window, sample_copy("tank_system1"), "measure1")
    project = window.workspace.project
    seen = {}

    def fill(dialog):
        dialog.fields["opcode"].setText("BRUV-07")
        dialog.fields["date"].setText("2024-03-01")
        dialog.fields["latitude"].setText("-32.2")
        dialog.fields["successful_length"].setChecked(False)
        dialog.georeferenced.setChecked(True)
        dialog.geo_fields["latitude"].setText("-132.2")  # out of range
        dialog.geo_fields["longitude"].setText("115.1")
        assert not dialog.store()
        seen["message"] = dialog.message.text()
        assert dialog.field_errors["georeference"].marked() == ["origin latitude"]  # the field outlined
        assert dialog.fields["opcode"].text() == "BRUV-07" and project.deployment() is None
        dialog.geo_fields["latitude"].setText("-32.2")
        dialog.geo_fields["heading_deg"].setText("45")
        assert dialog.store()

    assert exchange_dialogs.edit_deployment(window.context, window, fill)
    assert seen["message"].startswith("georeference: Origin latitude (°): must be between -90 and 90")
    assert project.deployment().opcode == "BRUV-07" and project.deployment().successful_length is False
    assert project.georeference().heading_deg == 45.0 and project.georeference().latitude == -32.2
    assert exchange_dialogs.edit_deployment(window.context, window, lambda d: d.reject()) is False
    assert project.deployment().opcode == "BRUV-07"
    assert QtWidgets.QApplication.activeModalWidget() is None



def test_the_campaign_is_entered_in_the_deployment_dialog_and_a_bad_value_is_named(qtbot, make_window, sample_copy):
    window = make_window()
    open_sample(qtbot, window, sample_copy("tank_system1"), "measure1")
    project = window.workspace.project
    seen = {}

    def fill(dialog):
        assert not dialog.campaigned.isChecked()  # none stored yet
        dialog.campaigned.setChecked(True)
        dialog.campaign_fields["campaign_id"].setText("2024-03 Reef")  # a space: not a file-name prefix
        dialog.campaign_fields["method"].setText("stereo-BRUVs")
        assert not dialog.store()
        seen["message"] = dialog.message.text()
        assert dialog.field_errors["campaign"].marked() == ["campaign_id"]
        assert project.campaign() is None
        dialog.campaign_fields["campaign_id"].setText("2024-03_Reef_stereo-BRUVs")
        assert dialog.store()

    assert exchange_dialogs.edit_deployment(window.context, window, fill)
    assert seen["message"].startswith("campaign: CampaignID: ")  # the field's label, not the library's name
    campaign = project.campaign()
    assert (campaign.campaign_id, campaign.method, campaign.image_analysis) == (
        "2024-03_Reef_stereo-BRUVs", "stereo-BRUVs", "USVIPS")

    def untick(dialog):
        assert dialog.campaigned.isChecked() and dialog.campaign_fields["method"].text() == "stereo-BRUVs"
        dialog.campaigned.setChecked(False)
        assert dialog.store()

    assert exchange_dialogs.edit_deployment(window.context, window, untick)
    assert project.campaign() is None
def test_the_wizards_last_page_writes_the_report_of_its_result(qtbot, sample_copy, tmp_path):
    """The Save page's Report (PDF)… button writes the session's result with the observations it used,
    in a worker, and says so; pressed while it runs it would cancel."""
    from usvips.app.samples import open_or_create_from_manifest
    from usvips.gui.calibration_session import CalibrationSession
    from usvips.gui.qt.calibration_wizard import SavePage

    project = open_or_create_from_manifest(sample_copy("rov_flatport"))
    try:
        session = CalibrationSession(project, "air", automatic_blunders=True)
        session.set_pairs(["air1"])
        assert session.load_project_observations() > 6
        session.set_result(session.job()(lambda f: None, lambda: False))
        page = SavePage(session)
        qtbot.addWidget(page)
        page.show()
        assert page.report.button.text() == "&Report (PDF)…"  # Alt+R, as on the target path's Save page
        worker = page.report.write(tmp_path / "wizard.pdf")
        assert worker is not None and page.report.button.text() == "Cancel the report"
        assert QtCore.QThreadPool.globalInstance().waitForDone(WORK_BOUND_MS)
        qtbot.waitUntil(lambda: page.report.worker is None, timeout=WORK_BOUND_MS)
        assert "Wrote" in page.report.status.text() and "pages" in page.report.status.text()
        assert (tmp_path / "wizard.pdf").read_bytes().startswith(b"%PDF")
        data = page.report.report_data()
        assert len(data.observations.ids) == len(session.measured("air1")) > 6
    finally:
        QtCore.QThreadPool.globalInstance().waitForDone(WORK_BOUND_MS)
        project.close()


def test_the_entries_are_reached_with_the_keyboard(qtbot, make_window, sample_copy, monkeypatch):
    """Alt+F opens File; each exchange entry has its own accelerator letter there (none taken twice)."""
    window = make_window()
    open_sample(qtbot, window, sample_copy("tank_system1"), "measure1")
    shown = []
    monkeypatch.setattr(exchange_dialogs.DeploymentDialog, "exec", lambda self: shown.append(self) or self.reject())
    menu = next(a.menu() for a in window.menuBar().actions() if a.text() == "&File")
    letters = [a.text().split("&")[1][0].lower() for a in menu.actions() if "&" in a.text()]
    for letter in "cptd":
        assert letters.count(letter) == 1, letter
    menu.popup(window.mapToGlobal(QtCore.QPoint(0, 0)))
    qtbot.waitExposed(menu)
    qtbot.keyClick(menu, QtCore.Qt.Key.Key_D)
    qtbot.waitUntil(lambda: len(shown) == 1, timeout=5000)
    assert not menu.isVisible() and QtWidgets.QApplication.activeModalWidget() is None


def test_a_video_gets_a_deployment_of_its_own_in_the_dialog(qtbot, make_window, tmp_path):
    from usvips.core.deployment import Deployment
    from usvips.gui.qt import media_dialogs

    window = make_window()
    assert media_dialogs.new_project(window.context, window, tmp_path / "p.usvips")
    project = window.workspace.project
    files = []
    for side in ("l", "r"):
        files.append(tmp_path / f"{side}.mp4")
        files[-1].write_bytes(side.encode())
    project.add_video("T1", [(files[0], 10, 25.0)], [(files[1], 10, 25.0)], 25.0, 10, (64, 48))
    project.set_deployment(Deployment("ALL", site="Bay"))

    def fill(dialog):
        assert dialog.fields["opcode"].text() == "ALL" and dialog.fields["site"].text() == "Bay"
        dialog.scope.setCurrentIndex(dialog.scope.findData("T1"))
        assert dialog.fields["opcode"].text() == "" and dialog.fields["site"].text() == ""
        dialog.fields["opcode"].setText("DOV-3")
        dialog.fields["successful_count"].setChecked(False)
        dialog.scope.setCurrentIndex(0)
        assert dialog.fields["opcode"].text() == "ALL"  # the project's, as stored
        dialog.fields["site"].setText("Reef")
        dialog.scope.setCurrentIndex(dialog.scope.findData("T1"))
        assert dialog.fields["opcode"].text() == "DOV-3"  # kept while switching
        assert dialog.store()

    assert exchange_dialogs.edit_deployment(window.context, window, fill)
    assert project.deployment().site == "Reef"
    assert project.deployment("T1").opcode == "DOV-3" and not project.deployment("T1").successful_count


def test_a_usvips_calibration_is_imported_and_made_active_for_the_pairs_ticked(qtbot, make_window, sample_copy,
                                                                                tmp_path):
    """Calibration › Import a USVIPS calibration…: the file is checked and stored, the dialog that follows
    ticks the pair shown (keyboard: its list takes Space), and the pair is then measured with it; Use a
    stored calibration… moves another pair to it; a damaged file stores nothing."""
    window = make_window()
    calibration = window.menuBar().actions()[[a.text() for a in window.menuBar().actions()].index("&Calibration")]
    texts = [a.text() for a in calibration.menu().actions()]
    assert "&Import a USVIPS calibration…" in texts and "&Use a stored calibration…" in texts
    folder = sample_copy("rov_flatport")
    open_sample(qtbot, window, folder, "measure1")
    project = window.workspace.project
    before = project.active_calibration("measure1")
    seen = {}

    def tick_water2_too(dialog):
        seen["ticked"] = dialog.active_for()
        water2 = dialog.labels.findItems("water2  (", QtCore.Qt.MatchFlag.MatchStartsWith)[0]  # "label  (W × H px)"
        dialog.labels.setCurrentItem(water2)
        qtbot.keyClick(dialog.labels, QtCore.Qt.Key.Key_Space)
        return True

    new = exchange_dialogs.import_usvips_calibration(window.context, window, folder / "calibration.json",
                                                     run=tick_water2_too)
    assert new is not None and new != before and seen["ticked"] == ["measure1"]
    assert project.active_calibration("measure1") == new and project.active_calibration("water2") == new
    assert window.workspace.geometry is not None and f"calibration {new} is active" in \
        window.statusBar().currentMessage()
    assert exchange_dialogs.use_calibration(window.context, window, before, run=lambda d: True)
    assert project.active_calibration("measure1") == before and project.active_calibration("water2") == new
    damaged = tmp_path / "damaged.json"
    damaged.write_text((folder / "calibration.json").read_text()[:500])
    count = len(project.calibrations())
    assert exchange_dialogs.import_usvips_calibration(window.context, window, damaged, run=lambda d: True) is None
    assert len(project.calibrations()) == count and "import failed, nothing stored" in \
        window.statusBar().currentMessage()


def test_a_project_calibration_is_reported_with_its_data_as_the_command_line_reports_its_file(
        qtbot, make_window, sample_copy):
    window = make_window()
    directory = sample_copy("tank_system1")
    open_sample(qtbot, window, directory, "measure1")
    project = window.workspace.project
    active = project.active_calibration("measure1")
    calibration = read_calibration(project, active)
    data = exchange_dialogs.project_report_data(project, calibration)
    assert data.control is not None and data.observations is not None  # residual plots, check points
    assert all("not found" not in why for _, _, why in data.files)  # the files beside the project
    for name in ("control.csv", "observations_air.csv", "observations_water.csv"):
        (directory / name).unlink()
    data = exchange_dialogs.project_report_data(project, calibration)  # files gone: the project's own data
    assert data.control is not None and len(data.observations.ids) > 0
    assert set(data.observations.pairs) <= set(calibration.stations)
    assert data.files[0][0] == "project" and "held by the project" in data.files[0][2]


def test_the_campaign_fields_show_a_whole_campaign_id(qtbot, tmp_path):
    """Seen in the walkthrough: long labels left the campaign's fields a few characters wide, so a
    CampaignID showed only its tail; the labels are short, the forms are the empty fields' hints."""
    from usvips.store import Project

    with Project.create(tmp_path / "s.usvips") as project:
        dialog = exchange_dialogs.DeploymentDialog(project)
        qtbot.addWidget(dialog)
        dialog.show()
        qtbot.waitExposed(dialog)
        field = dialog.campaign_fields["campaign_id"]
        campaign_id = "2024-03_Abrolhos.Reef_stereo-BRUVs"
        field.setText(campaign_id)
        assert field.width() > field.fontMetrics().horizontalAdvance(campaign_id)
        assert field.placeholderText() == "YYYY-MM_Project.name_Method"
        assert dialog.campaign_fields["start_date"].placeholderText() == "YYYY-MM-DD"
        dialog.close()


def test_the_deployment_dialog_fits_the_screen_with_its_buttons_in_view(qtbot, tmp_path):
    """Seen in the walkthrough at 1366 × 768: the dialog was about 770 px tall and OK / Cancel sat on the
    screen's edge; the fields now scroll within the screen's height and the buttons stay in view."""
    from usvips.store import Project

    with Project.create(tmp_path / "s.usvips") as project:
        dialog = exchange_dialogs.DeploymentDialog(project)
        qtbot.addWidget(dialog)
        dialog.show()
        qtbot.waitExposed(dialog)
        screen = dialog.screen().availableGeometry()
        # room left on the screen for a window manager's title bar and a task bar (offscreen: 800 × 800)
        assert dialog.sizeHint().height() <= screen.height() - 100 and dialog.height() <= screen.height() - 100
        buttons = dialog.findChild(QtWidgets.QDialogButtonBox)
        bottom = buttons.mapTo(dialog, QtCore.QPoint(0, buttons.height())).y()
        assert buttons.isVisible() and bottom <= dialog.height()
        dialog.close()
