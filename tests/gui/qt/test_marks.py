"""The pane's plain-Qt marks: paths built from numpy arrays, and a handle dragged with the mouse."""

import numpy as np
import pytest
from PySide6 import QtCore, QtWidgets

from tests.gui.conftest import viewport_point
from usvips.gui.qt.marks import Handle, Lines, Points, polyline_path, symbols_path
from usvips.gui.qt.pane import StereoPane, item_from_pixels, pixel_from_item


def _elements(path):
    return [(int(e.type.value), e.x, e.y) for e in (path.elementAt(k) for k in range(path.elementCount()))]


def test_a_polyline_breaks_at_nan_rows_and_pairs_join_two_rows_each(qapp):
    points = np.array([[0, 0], [1, 2], [np.nan, np.nan], [3, 4], [5, 6], [7, 8]], float)
    assert _elements(polyline_path(points)) == [(0, 0, 0), (1, 1, 2), (0, 3, 4), (1, 5, 6), (1, 7, 8)]
    assert _elements(polyline_path(points[[0, 1, 3, 4]], "pairs")) == [(0, 0, 0), (1, 1, 2), (0, 3, 4), (1, 5, 6)]
    assert polyline_path(np.full((3, 2), np.nan)).isEmpty() and polyline_path(np.zeros((0, 2))).isEmpty()


@pytest.mark.parametrize("symbol", ["o", "s", "+", "x", "star"])
def test_symbols_are_their_size_across_at_each_point(qapp, symbol):
    centres = np.array([[10.0, 20.0], [-5.0, 3.0]])
    path = symbols_path(centres, symbol, 12.0)
    assert all(path.boundingRect().contains(QtCore.QPointF(*centre)) for centre in centres)
    single = symbols_path(centres[:1], symbol, 12.0).boundingRect()
    assert 8.0 <= max(single.width(), single.height()) <= 12.0 + 1e-9
    centre = single.center()
    assert centre.x() == pytest.approx(10.0, abs=1e-9) and centre.y() == pytest.approx(20.0, abs=0.6)  # star: 0.5


def test_marks_keep_what_they_draw(qapp):
    points = Points(9, (255, 0, 0), symbol="s")
    points.set_points(np.array([[1.0, 2.0], [3.0, 4.0]]), ["o", "star"])
    assert np.array_equal(points.points(), [[1, 2], [3, 4]]) and points.symbols() == ["o", "star"]
    points.set_points(None)
    assert len(points.points()) == 0 and points.symbols() == []
    lines = Lines((0, 255, 0))
    lines.set_points(np.array([[0.0, 0.0], [np.nan, np.nan], [1.0, 1.0], [2.0, 2.0]]), antialias=False)
    assert lines.points().shape == (4, 2) and not lines.antialias


@pytest.fixture
def pane(qtbot):
    pane = StereoPane("left")
    qtbot.addWidget(pane)
    pane.resize(640, 480)
    pane.show()
    qtbot.waitExposed(pane)
    pane.set_image(np.random.default_rng(2).integers(0, 255, (300, 400), dtype=np.uint8))
    return pane


def _handle_at(pane, pixel):
    """A handle on ``pane`` at image ``pixel``; the lists of where it was dropped (image px) and of the
    clicks on the image, filled as they happen."""
    handle = Handle(tuple(item_from_pixels(np.array(pixel))[0]), 15, "o", (255, 176, 0), 2, (255, 0, 255))
    pane.add_mark(handle)
    dropped, picks = [], []
    handle.dropped.connect(lambda item: dropped.append(pixel_from_item(item.pos().x(), item.pos().y())))
    pane.clicked.connect(lambda x, y: picks.append((x, y)))
    return dropped, picks


def test_a_handle_dragged_with_the_mouse_moves_there_and_the_view_stays(qtbot, pane):
    pane.zoom_to(3.0, (120.0, 100.0))
    dropped, picks = _handle_at(pane, (110.0, 95.0))
    viewport, shown = pane.graphics.viewport(), pane.view_rect()
    start, end = viewport_point(pane, (110.0, 95.0)), viewport_point(pane, (130.0, 105.0))
    qtbot.mousePress(viewport, QtCore.Qt.MouseButton.LeftButton, pos=start)
    for step in range(1, 6):
        qtbot.mouseMove(viewport, start + (end - start) * step / 5)
    qtbot.mouseRelease(viewport, QtCore.Qt.MouseButton.LeftButton, pos=end)
    assert len(dropped) == 1 and np.allclose(dropped[0], (130.0, 105.0), atol=1.0 / pane.zoom_level() + 1e-6)
    assert pane.view_rect() == shown and picks == []  # the drag moved the handle, not the view; no pick


def test_a_handle_moved_less_than_a_drag_is_moved_and_is_no_click_on_the_image(qtbot, pane):
    """A reviewer's small correction (a keypoint moved 2–3 px, under the platform's drag distance) moves the
    handle; the press was the handle's, so it is not also a click that starts a pick under it."""
    pane.zoom_to(1.0, (120.0, 100.0))
    dropped, picks = _handle_at(pane, (110.0, 95.0))
    viewport = pane.graphics.viewport()
    start, end = viewport_point(pane, (110.0, 95.0)), viewport_point(pane, (113.0, 97.0))
    assert (end - start).manhattanLength() < QtWidgets.QApplication.startDragDistance()
    qtbot.mousePress(viewport, QtCore.Qt.MouseButton.LeftButton, pos=start)
    qtbot.mouseMove(viewport, end)
    qtbot.mouseRelease(viewport, QtCore.Qt.MouseButton.LeftButton, pos=end)
    assert len(dropped) == 1 and np.allclose(dropped[0], (113.0, 97.0), atol=1.0)
    assert picks == []
