"""GUI fixtures: sample projects copied to a temporary directory (the repository stays clean), windows
with their own settings file, and clicks placed through the pane's real view transform."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]
SAMPLES = ROOT / "sample_projects"


@pytest.fixture(autouse=True)
def no_modal_questions(monkeypatch):
    """Windows closed at the end of a test must not wait for a person: the questions asked before
    discarding work answer "discard" unless a test sets its own answer (on the instance)."""
    from usvips.gui.qt.calibration_wizard import CalibrationWizard
    from usvips.gui.qt.main_window import MainWindow

    monkeypatch.setattr(CalibrationWizard, "ask_discard", lambda self: "discard")
    monkeypatch.setattr(MainWindow, "ask_unfinished", lambda self, question: "discard")


@pytest.fixture
def sample_copy(tmp_path):
    """``sample_copy(name)`` → a fresh copy of a sample directory (its project file is created on open)."""

    def make(name: str) -> Path:
        target = tmp_path / name
        shutil.copytree(SAMPLES / name, target, ignore=shutil.ignore_patterns("project.usvips*"))
        return target

    return make


def truth_pixels(sample: Path, pair: str, group: str) -> tuple[dict, dict]:
    """Truth pixels of a pair: ``group`` "targets" → {number: (x, y)}; "objects" → {label: {point: (x, y)}}."""
    truth = json.loads((sample / "truth.json").read_text())
    cameras = next(p for p in truth["pairs"] if p["label"] == pair)["cameras"]
    return cameras["left"][group], cameras["right"][group]


def true_length(sample: Path, label: str) -> float:
    truth = json.loads((sample / "truth.json").read_text())
    return next(o for o in truth["objects"] if o["label"] == label)["length"]


def isolated_targets(left: dict, right: dict, clearance: float = 30.0) -> list[str]:
    """Targets seen in both images and at least ``clearance`` px from every other target in each (targets
    that overlap in an image are genuinely ambiguous)."""
    seen = [k for k in left if left[k] is not None and right.get(k) is not None]
    keep = []
    for k in seen:
        ok = True
        for image in (left, right):
            others = np.array([image[o] for o in image if o != k and image[o] is not None])
            if len(others) and np.min(np.linalg.norm(others - np.array(image[k]), axis=1)) < clearance:
                ok = False
        if ok:
            keep.append(k)
    return keep


@pytest.fixture
def make_window(qtbot, tmp_path):
    """``make_window(settings_file=None)`` → a shown MainWindow using its own settings file."""
    from PySide6 import QtCore

    from usvips.gui.qt.main_window import MainWindow

    windows = []

    def make(settings_file: Path | None = None):
        settings = QtCore.QSettings(str(settings_file or tmp_path / "settings.ini"), QtCore.QSettings.Format.IniFormat)
        window = MainWindow(settings=settings)
        qtbot.addWidget(window)
        window.resize(1366, 768)
        window.show()
        qtbot.waitExposed(window)
        windows.append(window)
        return window

    yield make
    for window in windows:
        window.close()


def wait_for_pair(qtbot, window, label: str) -> None:
    qtbot.waitUntil(lambda: window.workspace.pair == label and not window.busy, timeout=10000)


def open_sample(qtbot, window, directory: Path, pair: str) -> None:
    assert window.open_path(directory)
    window.load_pair(pair)
    wait_for_pair(qtbot, window, pair)


def review_circles(qtbot, window):
    """The review panel shown (made when first seen) and the proposals' 95 % circles and handles it drew."""
    from usvips.gui.qt.proposal_handles import circles

    window.docks["review"].show()
    window.docks["review"].raise_()
    qtbot.waitUntil(lambda: window.panels.is_built("review"), timeout=5000)
    return circles(window.context)


def viewport_point(pane, pixel):
    """The viewport position (integer screen pixels) that shows image ``pixel``, through the view."""
    from PySide6 import QtCore, QtWidgets

    from usvips.gui.qt.pane import item_from_pixels

    QtWidgets.QApplication.processEvents()  # a new view range (a resize) is applied on the next event round
    ix, iy = item_from_pixels(np.array(pixel))[0]
    scene = pane.image_item.mapToScene(QtCore.QPointF(ix, iy))
    return pane.graphics.mapFromScene(scene)


def click_pixel(qtbot, pane, pixel, zoom: float | None = 8.0):
    """Zoom around ``pixel`` (screen px per image px) and click it with the mouse; returns the zoom."""
    from PySide6 import QtCore

    if zoom is not None:
        pane.zoom_to(zoom, tuple(pixel))
    qtbot.mouseClick(pane.graphics.viewport(), QtCore.Qt.MouseButton.LeftButton, pos=viewport_point(pane, pixel))
    return pane.zoom_level()


def show_active(qtbot, widget):
    """``widget`` shown, exposed and the active window (so that it has the keyboard), closed with the test."""
    qtbot.addWidget(widget)
    widget.show()
    qtbot.waitExposed(widget)
    widget.activateWindow()
    qtbot.waitUntil(widget.isActiveWindow, timeout=5_000)
    return widget
