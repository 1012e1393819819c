"""The target wizard as a calibration workbench: every value of the target's description typed is the value
used (a square typed after *Use this chessboard* once stayed 30 mm: a silent 25 % scale error); the
parameters with their σ and a verdict consistent with the advice; every view opens (its points, its
residual vectors, why it was set aside); Stop stops a calibration and a stopped detection leaves nothing
to compute from; the Save page writes the report; Finish there closes the phase-1 wizard behind it."""

from __future__ import annotations

import numpy as np
import pytest
from PySide6 import QtWidgets

from tests.app.board_images import air_scene
from tests.gui.test_target_wizard import _Gated
from usvips.gui.calibration_session import CalibrationSession
from usvips.gui.qt.calibration_wizard import CalibrationWizard
from usvips.gui.qt.target_pages import TargetWizard
from usvips.gui.target_session import TargetSession, known_options
from usvips.io.images import write_image
from usvips.store import Project

VIEWS = 5


@pytest.fixture(scope="module")
def scene(tmp_path_factory):
    folder = tmp_path_factory.mktemp("workbench_boards")
    board, rig, pairs, _ = air_scene(folder, VIEWS, seed=11)
    blank = folder / "zR.png"  # a pair whose right image shows no board: set aside
    write_image(blank, np.full((360, 480), 128, np.uint8))
    left = folder / "zL.png"
    left.write_bytes(pairs[0][0].read_bytes())
    return board, rig, pairs, (left, blank)


@pytest.fixture()
def project(tmp_path):
    with Project.create(tmp_path / "p.usvips") as p:
        yield p


def _wizard(qtbot, project, phase="air"):
    wizard = TargetWizard(TargetSession(project, phase))
    qtbot.addWidget(wizard)
    wizard.show()
    qtbot.waitExposed(wizard)
    return wizard


def _type(qtbot, box, text):
    """Select the box's text and type ``text`` key by key, as a person does."""
    box.setFocus()
    box.selectAll()
    qtbot.keyClicks(box, text)


@pytest.mark.parametrize(("field", "typed", "key", "expected"), [
    ("square", "24", "square", 0.024), ("cols", "7", "cols", 7), ("rows", "4", "rows", 4)])
def test_every_field_typed_is_the_value_used(qtbot, project, field, typed, key, expected):
    wizard = _wizard(qtbot, project)
    page = wizard.source_page
    page.use_chessboard()  # the defaults first (9 × 6, 30 mm) ...
    assert page.square.value() == 30.0
    _type(qtbot, getattr(page, field), typed)  # ... then a value typed
    described = wizard.session.target.describe()
    assert described[key] == pytest.approx(expected)
    assert f"{1000 * described['square']:.2f} mm" in page.target_label.text()
    # and what the calibration job takes is that target
    assert wizard.session.target.control_points().xyz.max() == pytest.approx(
        described["square"] * (max(described["cols"], described["rows"]) - 1))


def test_the_square_typed_after_use_sets_the_scale(qtbot, project, scene):
    """The issue's case: 24 mm in the field, Use, then the true 30 mm typed: the baseline comes out true."""
    _, rig, pairs, _ = scene
    wizard = _wizard(qtbot, project)
    page = wizard.source_page
    _type(qtbot, page.square, "24")
    page.use_chessboard()
    _type(qtbot, page.square, "30")
    page.set_images("left", [str(a) for a, _ in pairs])
    page.set_images("right", [str(b) for _, b in pairs])
    page.holdout.setValue(0)
    wizard.next()
    views = wizard.views_page
    qtbot.waitUntil(lambda: not views.busy and wizard.session.views is not None, timeout=120_000)
    assert "square 30.00 mm" in views.target_label.text()
    wizard.next()
    compute = wizard.compute_page
    qtbot.waitUntil(lambda: not compute.busy, timeout=300_000)
    baseline = np.linalg.norm(wizard.session.result.calibration.relative.base)
    assert baseline == pytest.approx(np.linalg.norm(rig.relative.base), rel=0.01)
    # the parameter table: every interior figure of both cameras and the baseline, each with its σ
    cells = [[compute.table.item(r, c).text() for c in range(compute.table.columnCount())]
             for r in range(compute.table.rowCount())]
    labels = [row[1] for row in cells]
    assert labels.count("focal length") == 2 and labels.count("principal point x") == 2
    assert any("radial distortion K1" == label for label in labels)
    row = cells[labels.index("baseline (between the perspective centres)")]
    assert "±" in row[2] and row[2].endswith(" m")
    assert "±" in cells[labels.index("focal length")][2]
    # five views: the verdict says what the advice says, not "the fit is consistent"
    text = compute.verdict.text()
    assert "the fit is consistent" not in text and "film at least 15" in text and "trial" in text


def test_views_set_aside_are_listed_and_open_with_why(qtbot, project, scene):
    _, _, pairs, blank = scene
    wizard = _wizard(qtbot, project)
    page = wizard.source_page
    page.use_chessboard()
    chosen = list(pairs[:3]) + [blank]
    page.set_images("left", [str(a) for a, _ in chosen])
    page.set_images("right", [str(b) for _, b in chosen])
    page.holdout.setValue(0)
    wizard.next()
    views = wizard.views_page
    qtbot.waitUntil(lambda: not views.busy and wizard.session.views is not None, timeout=120_000)
    texts = [views.list.item(i).text() for i in range(views.list.count())]
    assert len(texts) == 4 and texts[-1].endswith("set aside")
    views.list.setCurrentRow(3)  # the set-aside view opens: why, and its images
    assert views.view_text.text().startswith("set aside:") and "right image" in views.view_text.text()
    qtbot.waitUntil(lambda: "set aside" in views.panes["left"].title.text(), timeout=30_000)
    assert views.panes["left"].display is not None and len(views.panes["left"].control_item.points()) == 0
    # the set-aside view cannot be ticked: three views are used
    assert len(wizard.session.kept()) == 3 and views.isComplete()
    # a found view opens with its points; after the calibration, back here, with its residual vectors
    views.list.setCurrentRow(0)
    qtbot.waitUntil(lambda: len(views.panes["left"].control_item.points()) == 54, timeout=30_000)
    assert len(views.vectors["left"].points()) == 0
    wizard.next()
    qtbot.waitUntil(lambda: not wizard.compute_page.busy, timeout=300_000)
    assert wizard.session.result is not None
    wizard.back()
    qtbot.waitUntil(lambda: len(views.vectors["left"].points()) > 0,
                    timeout=30_000)
    assert "reprojection RMS" in views.view_text.text()
    # the coverage maps carry their scale, and the next pose is suggested
    assert "px" in views.scale_label.text() and "views covering a cell" in views.scale_label.text()
    assert views.next_pose.text().startswith("Next: hold the board")


def test_stop_stops_the_calibration_and_a_stopped_detection_leaves_nothing(qtbot, project, scene):
    _, _, pairs, _ = scene
    wizard = _wizard(qtbot, project)
    page = wizard.source_page
    page.use_chessboard()
    page.set_images("left", [str(a) for a, _ in pairs])
    page.set_images("right", [str(b) for _, b in pairs])
    page.holdout.setValue(0)
    wizard.next()
    views = wizard.views_page
    qtbot.waitUntil(lambda: not views.busy and wizard.session.views is not None, timeout=120_000)
    wizard.next()
    compute = wizard.compute_page
    assert compute.busy and compute.stop_button.isEnabled()
    compute.stop_button.click()
    qtbot.waitUntil(lambda: not compute.busy, timeout=120_000)
    assert wizard.session.result is None and "stopped" in compute.text.toPlainText()
    assert not compute.isComplete()
    # back to the views: detect again and stop it mid-way (a detector held at a gate after its first image):
    # the old views are gone, the list is empty and Next stays off (Next computed from the old views)
    wizard.back()
    assert len(wizard.session.kept()) == VIEWS
    gated = _Gated()
    wizard.session.target = gated  # the same board, detected slowly
    views.detect()
    assert views.busy
    qtbot.waitUntil(lambda: gated.calls >= 2, timeout=30_000)
    views.stop()
    gated.gate.set()
    qtbot.waitUntil(lambda: not views.busy, timeout=60_000)
    assert wizard.session.views is None and wizard.session.kept() == []
    assert views.list.count() == 0 and not views.isComplete()
    assert not wizard.button(QtWidgets.QWizard.WizardButton.NextButton).isEnabled()


def test_the_save_page_writes_the_report(qtbot, project, scene, tmp_path):
    _, _, pairs, _ = scene
    wizard = _wizard(qtbot, project)
    page = wizard.source_page
    page.use_chessboard()
    page.set_images("left", [str(a) for a, _ in pairs])
    page.set_images("right", [str(b) for _, b in pairs])
    page.holdout.setValue(20)
    wizard.next()
    qtbot.waitUntil(lambda: not wizard.views_page.busy and wizard.session.views is not None, timeout=120_000)
    wizard.next()
    qtbot.waitUntil(lambda: not wizard.compute_page.busy, timeout=300_000)
    wizard.next()
    save = wizard.save_page
    assert wizard.currentPage() is save and "Report (PDF)" in save.report.button.text()
    out = tmp_path / "report.pdf"
    save.report.write(out)
    qtbot.waitUntil(lambda: save.report.worker is None, timeout=120_000)
    assert out.read_bytes().startswith(b"%PDF") and "Wrote" in save.report.status.text()


def test_finish_in_the_target_wizard_closes_the_calibration_wizard(qtbot, project):
    classic = CalibrationWizard(CalibrationSession(project, "air"))
    qtbot.addWidget(classic)
    classic.show()
    button = next(b for b in classic.currentPage().findChildren(QtWidgets.QPushButton) if "&target" in b.text())
    button.click()
    target = next(w for w in QtWidgets.QApplication.topLevelWidgets() if isinstance(w, TargetWizard)
                  and w.isVisible())
    target.accepted.emit()  # what Finish emits once the Save page stored the calibration
    qtbot.waitUntil(lambda: not classic.isVisible(), timeout=5_000)
    assert classic.result() == QtWidgets.QDialog.DialogCode.Accepted


def test_known_housing_values_become_options():
    assert known_options({"t": (0.012, None), "n2": (1.52, 0.01)}) == {
        "fix_values": {"t": 0.012}, "priors": {"n2": (1.52, 0.01)}}
    assert known_options({}) == {"fix_values": {}, "priors": {}}


def test_phase_two_takes_the_cameras_unmoved_and_the_known_values(qtbot, project, scene):
    from usvips.app.calibrations import store_calibration
    from usvips.core.camera import Camera, Exterior
    from usvips.core.interior import Interior
    from usvips.core.stereo_calibration import StereoCalibration

    _, _, pairs, _ = scene
    base = StereoCalibration.from_cameras(Camera(Interior(500.0, 240.0, 180.0), Exterior(0, 0, 0)),
                                          Camera(Interior(500.0, 240.0, 180.0), Exterior(0.12, 0, 0)), "air", 0.3)
    base_id = store_calibration(project, "phase 1", base)
    wizard = _wizard(qtbot, project, "water")
    page = wizard.source_page
    page.use_chessboard()
    page.set_images("left", [str(a) for a, _ in pairs])
    page.set_images("right", [str(b) for _, b in pairs])
    page.base.setCurrentIndex(page.base.findData(base_id))
    page.housing.setCurrentText("flat-port")
    assert not page.unmoved.isChecked()
    page.unmoved.click()  # by mouse
    page.known["t"].setFocus()
    qtbot.keyClicks(page.known["t"], "0.012")
    assert page.validatePage()
    options = wizard.session.calibration_options()
    assert options.cameras_unmoved and options.fix_values == {"t": 0.012} and options.priors == {}
    page.known["t"].clear()
    qtbot.keyClicks(page.known["t"], "one")
    assert not page.validatePage() and "housing value t" in page.message.text()
