"""The target path of the calibration wizards, driven by keys: a chessboard described on the first page,
image pairs chosen, detection in a worker, the views listed with their coverage and detections, a view
unticked with Space, the calibration computed and judged, Finish stores it; Stop really stops a
detection; nothing is stored when the wizard is cancelled."""

from __future__ import annotations

import threading

import cv2
import numpy as np
import pytest
from PySide6 import QtCore, QtWidgets

from tests.app.board_images import air_scene, board_poses, render_pairs
from tests.gui.conftest import show_active
from usvips.app.video_project import add_video
from usvips.core.calibration_targets import CalibrationTarget, kind
from usvips.gui.calibration_session import CalibrationSession
from usvips.gui.qt.calibration_wizard import CalibrationWizard
from usvips.gui.qt.target_pages import TargetWizard
from usvips.gui.target_session import TargetSession
from usvips.io.video_writer import encode_video
from usvips.store import Project

VIEWS = 5
ALT = QtCore.Qt.KeyboardModifier.AltModifier


@pytest.fixture(scope="module")
def scene(tmp_path_factory):
    folder = tmp_path_factory.mktemp("gui_boards")
    board, rig, pairs, _ = air_scene(folder, VIEWS, seed=11)
    return board, rig, pairs


@pytest.fixture()
def project(tmp_path):
    with Project.create(tmp_path / "p.usvips") as p:
        yield p


def _wizard(qtbot, project, phase="air"):
    return show_active(qtbot, TargetWizard(TargetSession(project, phase)))


def _key(qtbot, wizard, key, modifier=QtCore.Qt.KeyboardModifier.NoModifier):
    """A key to the focused widget; a button's mnemonic holds it down for a short animation and then clicks
    it: wait for every button to be up again (an event, not a time)."""
    widget = QtWidgets.QApplication.focusWidget() or wizard
    qtbot.keyClick(widget, key, modifier)
    buttons = wizard.findChildren(QtWidgets.QAbstractButton)
    qtbot.waitUntil(lambda: not any(button.isDown() for button in buttons), timeout=10_000)


def _choose(wizard, pairs):
    page = wizard.source_page
    page.set_images("left", [str(left) for left, _ in pairs][::-1])  # name order pairs them, not the order chosen
    page.set_images("right", [str(right) for _, right in pairs])


def test_calibrate_from_board_images_by_keys(qtbot, project, scene):
    board, rig, pairs = scene
    wizard = _wizard(qtbot, project)
    page = wizard.source_page
    # describe the board: the square size typed, then Alt+U uses it
    page.square.setFocus()
    page.square.selectAll()
    qtbot.keyClicks(page.square, "30")
    _key(qtbot, wizard, QtCore.Qt.Key.Key_U, ALT)
    assert wizard.session.target is not None and "square 30.00 mm (54 points)" in page.target_label.text()
    _choose(wizard, pairs)
    page.holdout.setValue(0)
    _key(qtbot, wizard, QtCore.Qt.Key.Key_N, ALT)  # Next: detection starts in a worker
    views = wizard.views_page
    assert wizard.currentPage() is views
    qtbot.waitUntil(lambda: not views.busy and wizard.session.views is not None, timeout=120_000)
    assert views.list.count() == VIEWS
    assert [p[0] for p in wizard.session.pairs] == sorted(p[0] for p in wizard.session.pairs)
    assert views.isComplete() and wizard.button(QtWidgets.QWizard.WizardButton.NextButton).isEnabled()
    assert "5 of 5 pairs" in views.tally.text() and "% of the image covered" in views.advice.text()
    # the first view's detections are drawn on its images
    qtbot.waitUntil(lambda: views.panes["left"].display is not None, timeout=30_000)
    left = views.panes["left"]
    assert len(left.control_item.points()) == 54  # a ring per corner found
    assert 1 <= sum(bool(label.toPlainText()) for label in left.control_labels) <= 14  # ids on a few
    # untick the second view with Space
    views.list.setFocus()
    views.list.setCurrentRow(1)
    dropped = views.list.currentItem().data(QtCore.Qt.ItemDataRole.UserRole)
    qtbot.keyClick(views.list, QtCore.Qt.Key.Key_Space)
    assert wizard.session.dropped() == [dropped]
    assert wizard.session.coverage().views == VIEWS - 1
    _key(qtbot, wizard, QtCore.Qt.Key.Key_N, ALT)  # Next: the calibration in a worker
    compute = wizard.compute_page
    qtbot.waitUntil(lambda: not compute.busy, timeout=300_000)
    result = wizard.session.result
    assert result is not None and dropped in result.dropped and dropped not in result.kept
    assert "air calibration" in compute.text.toPlainText() and compute.verdict.text()
    assert abs(result.calibration.left.interior.f / rig.left.f - 1) < 0.02
    _key(qtbot, wizard, QtCore.Qt.Key.Key_N, ALT)
    assert wizard.currentPage() is wizard.save_page
    before = len(project.calibrations())
    with qtbot.waitSignal(wizard.saved, timeout=10_000):
        _key(qtbot, wizard, QtCore.Qt.Key.Key_F, ALT)  # Finish
    assert len(project.calibrations()) == before + 1


class _Gated(CalibrationTarget):
    """A board whose detector waits at a gate after its first image (to stop a detection mid-way); no
    ``kind``: it does not join the registry."""

    def __init__(self) -> None:
        self.board = kind("chessboard")(9, 6, 0.03)
        self.gate = threading.Event()
        self.calls = 0

    def describe(self):
        return self.board.describe()  # the board it finds

    @classmethod
    def from_description(cls, description, source=""):
        return cls()

    def control_points(self):
        return self.board.control_points()

    def detect(self, image):
        self.calls += 1
        if self.calls > 1:
            self.gate.wait(30)
        return self.board.detect(image)


def test_stop_stops_the_detection_and_cancel_stores_nothing(qtbot, project, scene):
    _, _, pairs = scene
    wizard = _wizard(qtbot, project)
    gated = _Gated()
    wizard.session.target = gated
    wizard.session.target_source = "gated"
    _choose(wizard, pairs)
    wizard.next()
    views = wizard.views_page
    assert views.busy
    qtbot.waitUntil(lambda: gated.calls >= 2, timeout=30_000)
    _key(qtbot, wizard, QtCore.Qt.Key.Key_S, ALT)  # Stop
    gated.gate.set()
    qtbot.waitUntil(lambda: not views.busy, timeout=30_000)
    assert gated.calls == 2 and wizard.session.views is None
    assert "stopped" in views.set_aside.text() and not views.isComplete()
    wizard.reject()
    assert project.calibrations() == []


def test_bad_choices_are_one_line_on_the_page(qtbot, project, scene):
    _, _, pairs = scene
    wizard = _wizard(qtbot, project)
    page = wizard.source_page
    wizard.next()
    assert wizard.currentPage() is page and "target" in page.message.text()
    page.use_chessboard()
    page.set_images("left", [str(pairs[0][0])])
    wizard.next()
    assert wizard.currentPage() is page and "1 left and 0 right images" in page.message.text()
    page.cols.setValue(8)
    page.rows.setValue(8)
    page.use_chessboard()
    assert "upright" in page.message.text()


def test_phase_two_needs_a_base(qtbot, project, scene):
    _, _, pairs = scene
    wizard = _wizard(qtbot, project, "water")
    page = wizard.source_page
    assert "no phase-1 (in-air) calibration yet" in page.message.text()
    page.use_chessboard()
    _choose(wizard, pairs)
    wizard.next()
    assert wizard.currentPage() is page and "phase-1" in page.message.text()


def test_the_calibration_wizard_opens_the_target_path(qtbot, project):
    wizard = CalibrationWizard(CalibrationSession(project, "air"))
    qtbot.addWidget(wizard)
    wizard.show()
    buttons = [b for b in wizard.currentPage().findChildren(QtWidgets.QPushButton) if "&target" in b.text()]
    assert len(buttons) == 1
    buttons[0].click()
    opened = [w for w in QtWidgets.QApplication.topLevelWidgets() if isinstance(w, TargetWizard) and w.isVisible()]
    assert opened and opened[-1].session.phase == "air"
    opened[-1].reject()


def test_phase_one_from_a_project_video_then_phase_two_from_images(qtbot, project, scene, tmp_path):
    board, rig, pairs = scene
    frames = {"left": [], "right": []}
    for left, right in pairs:
        for side, path in (("left", left), ("right", right)):
            grey = cv2.imread(str(path), cv2.IMREAD_GRAYSCALE)
            frames[side].append(cv2.cvtColor(grey, cv2.COLOR_GRAY2RGB))
    files = {}
    for side in ("left", "right"):
        files[side] = tmp_path / f"{side}.mkv"
        encode_video(files[side], frames[side], 25.0, "ffv1")
    add_video(project, [files["left"]], [files["right"]], "cal")
    # phase 1 from the video
    wizard = _wizard(qtbot, project)
    page = wizard.source_page
    page.use_chessboard()
    assert page.from_video.isEnabled() and page.video.currentText() == "cal"
    page.from_video.setChecked(True)
    page.every.setValue(1)
    page.holdout.setValue(0)
    wizard.next()
    views = wizard.views_page
    qtbot.waitUntil(lambda: not views.busy and wizard.session.views is not None, timeout=120_000)
    assert views.list.count() >= 3 and all(v.label.startswith("cal-") for v in wizard.session.views.views)
    qtbot.waitUntil(lambda: views.panes["right"].display is not None, timeout=30_000)  # decoded from the video
    assert len(views.panes["right"].control_item.points()) == 54
    wizard.next()
    qtbot.waitUntil(lambda: not wizard.compute_page.busy, timeout=300_000)
    assert wizard.session.result is not None, wizard.compute_page.text.toPlainText()
    wizard.next()
    assert wizard.currentPage() is wizard.save_page
    with qtbot.waitSignal(wizard.saved, timeout=10_000):
        wizard.accept()
    base_id = project.calibrations()[-1].id
    # phase 2 through a flat port from rendered images, starting from it
    rng = np.random.default_rng(3)
    water_rig = rig.in_water("flat-port", rng)
    water = render_pairs(tmp_path, water_rig, board, board_poses(water_rig, board, rng, VIEWS, (0.7, 1.0)), "w")
    wizard = _wizard(qtbot, project, "water")
    page = wizard.source_page
    page.use_chessboard()
    _choose(wizard, water)
    assert page.base.findData(base_id) >= 0
    page.base.setCurrentIndex(page.base.findData(base_id))
    page.housing.setCurrentText("flat-port")
    # known housing values, typed as a person types them: a value holds it, 'value ± sigma' weights it
    truth_t = float(water_rig.housings[0].t)
    page.known["t"].setFocus()
    qtbot.keyClicks(page.known["t"], f"{truth_t:.6g}")
    qtbot.keyClicks(page.known["n2"], "1.5 ± 0.01")
    page.holdout.setValue(0)
    wizard.next()
    assert wizard.session.known == {"t": (pytest.approx(truth_t), None), "n2": (1.5, 0.01)}
    views = wizard.views_page
    qtbot.waitUntil(lambda: not views.busy and wizard.session.views is not None, timeout=120_000)
    wizard.next()
    qtbot.waitUntil(lambda: not wizard.compute_page.busy, timeout=300_000)
    result = wizard.session.result
    assert result is not None, wizard.compute_page.text.toPlainText()
    assert result.result.report.housing == "flat-port"
    assert "through flat-port" in wizard.compute_page.text.toPlainText()
    parameters = result.calibration.parameters
    assert parameters["t"].value == pytest.approx(truth_t) and parameters["t"].status == "fixed"
    assert parameters["n2"].status == "prior"
    wizard.next()
    with qtbot.waitSignal(wizard.saved, timeout=10_000):
        wizard.accept()
    assert project.calibrations()[-1].phase in ("water", "joint")
