"""The pane's one view ↔ pixel conversion, checked with real mouse clicks at several zoom levels."""

import numpy as np
import pytest
from PySide6 import QtCore

from tests.gui.conftest import viewport_point
from usvips.gui.qt.pane import StereoPane, item_from_pixels, pixel_from_item


def test_item_and_pixel_conventions_are_inverse_and_half_a_pixel_apart():
    pixels = np.array([[0.0, 0.0], [12.25, 7.5], [-0.5, 3.0]])
    items = item_from_pixels(pixels)
    assert np.allclose(items, pixels + 0.5)  # ImageItem puts pixel 0 on [0, 1): its centre is at 0.5
    assert np.allclose([pixel_from_item(*i) for i in items], pixels)


@pytest.fixture
def pane(qtbot):

    pane = StereoPane("left")
    qtbot.addWidget(pane)
    pane.resize(640, 480)
    pane.show()
    qtbot.waitExposed(pane)
    rng = np.random.default_rng(1)
    pane.set_image(rng.integers(0, 255, (300, 400), dtype=np.uint8))
    return pane


def _click(qtbot, pane, pixel):
    with qtbot.waitSignal(pane.clicked, timeout=2000) as blocker:
        qtbot.mouseClick(pane.graphics.viewport(), QtCore.Qt.MouseButton.LeftButton, pos=viewport_point(pane, pixel))
    return np.array(blocker.args)


@pytest.mark.parametrize("zoom", [None, 4.0, 8.0, 16.0])
def test_a_click_lands_on_the_pixel_shown_under_it(qtbot, pane, zoom):
    targets = [(37.3, 21.8), (200.0, 150.0), (399.2, 299.4), (0.1, 0.2)]
    for target in targets:
        if zoom is None:
            pane.fit()
        else:
            pane.zoom_to(zoom, target)
        level = pane.zoom_level()
        picked = _click(qtbot, pane, target)
        # a click is an integer screen position (rounded, and Qt takes the pixel's corner): at most one
        # screen pixel per axis off; a half-pixel convention error would be 0.5 image px (> 1/4 at zoom 4)
        assert np.all(np.abs(picked - target) <= 1.0 / level + 1e-6), (zoom, target, picked)


def test_a_click_still_lands_right_after_a_resize(qtbot, pane):
    pane.zoom_to(4.0, (120.0, 80.0))
    pane.resize(900, 500)
    qtbot.wait(50)
    pane.zoom_to(4.0, (120.0, 80.0))
    for target in [(118.6, 79.1), (125.25, 84.75)]:
        picked = _click(qtbot, pane, target)
        assert np.all(np.abs(picked - target) <= 1.0 / pane.zoom_level() + 1e-6)


def test_clicks_outside_the_image_are_not_picks(qtbot, pane):
    pane.zoom_to(2.0, (0.0, 0.0))
    received = []
    pane.clicked.connect(lambda x, y: received.append((x, y)))
    qtbot.mouseClick(pane.graphics.viewport(), QtCore.Qt.MouseButton.LeftButton,
                     pos=viewport_point(pane, (-20.0, -20.0)))
    assert received == []


def test_zoom_steps_and_one_to_one(qtbot, pane):
    pane.one_to_one((200.0, 150.0))
    assert pane.zoom_level() == pytest.approx(1.0, rel=1e-6)
    pane.zoom_by(2.0)
    assert pane.zoom_level() == pytest.approx(2.0, rel=1e-3)


def test_the_loupe_shows_the_neighbourhood_of_the_cursor(qtbot, pane):
    pane.zoom_to(2.0, (100.0, 100.0))
    pos = viewport_point(pane, (100.0, 100.0))
    with qtbot.waitSignal(pane.hovered, timeout=2000) as blocker:
        qtbot.mouseMove(pane.graphics.viewport(), pos)
    assert np.all(np.abs(np.array(blocker.args) - (100.0, 100.0)) <= 0.5)
    assert pane.loupe.isVisible() and not pane.loupe.pixmap().isNull()
    pane.set_loupe_enabled(False)
    assert not pane.loupe.isVisible()
    pane._update_loupe(110.0, 104.0)  # what the next mouse move calls
    assert not pane.loupe.isVisible()


def _hover(qtbot, pane, pixel):
    pos = viewport_point(pane, pixel)
    qtbot.mouseMove(pane.graphics.viewport(), pos + QtCore.QPoint(3, 2))  # the cursor may already be there
    qtbot.wait(60)  # two moves in a row: the second one is a move of its own
    with qtbot.waitSignal(pane.hovered, timeout=2000):
        qtbot.mouseMove(pane.graphics.viewport(), pos)
    return pos


@pytest.mark.parametrize("scale", [8, 16])
@pytest.mark.parametrize("pixel", [(100.0, 100.0), (20.0, 20.0), (150.0, 110.0), (30.0, 110.0)])
def test_the_loupe_follows_the_cursor_without_covering_it(qtbot, pane, pixel, scale):
    pane.set_loupe_scale(scale)
    pane.zoom_to(4.0, (90.0, 60.0))
    pos = _hover(qtbot, pane, pixel)
    assert pane.loupe.isVisible()
    area = pane.loupe.geometry()
    around = QtCore.QRect(pos.x() - 10, pos.y() - 10, 21, 21)  # the cursor and the pixels next to it
    assert not area.intersects(around)
    assert pane.graphics.viewport().rect().contains(area.topLeft())


def test_a_click_where_the_loupe_is_lands_on_the_image(qtbot, pane):
    pane.zoom_to(4.0, (100.0, 100.0))
    _hover(qtbot, pane, (100.0, 100.0))
    area = pane.loupe.geometry()
    assert pane.loupe.isVisible()
    under = area.center()
    viewport = pane.graphics.viewport()
    target = viewport.childAt(under) or viewport  # the widget a real click there is delivered to
    assert target is viewport
    expected = pane.pixel_at_scene(pane.graphics.mapToScene(under))
    with qtbot.waitSignal(pane.clicked, timeout=2000) as blocker:
        qtbot.mouseClick(target, QtCore.Qt.MouseButton.LeftButton, pos=under)
    assert np.allclose(blocker.args, expected, atol=0.5)


def test_the_loupe_magnification_is_adjustable(qtbot, pane):
    pane.zoom_to(2.0, (100.0, 100.0))
    sizes = []
    for scale in (4, 16):
        pane.set_loupe_scale(scale)
        _hover(qtbot, pane, (100.0 + scale, 100.0))
        sizes.append(pane.loupe.width())
        assert pane.loupe.pixmap().width() == (2 * pane.loupe_radius + 1) * scale
    assert sizes[1] > 2 * sizes[0]
    with pytest.raises(ValueError):
        pane.set_loupe_scale(5)


def _label_boxes(pane):
    return [label.screen_rect(pane.graphics) for label in pane.labels]


@pytest.mark.parametrize("zoom", [None, 4.0])
def test_labels_of_objects_side_by_side_do_not_cover_each_other(qtbot, pane, zoom):
    """Two fish a few pixels apart on one frame: their labels are drawn apart, also after a zoom."""
    labels = [("12 length Pagrus auratus 361.2 ± 4.1 mm", (200.0, 150.0), False),
              ("13 length Pagrus auratus 355.8 ± 4.3 mm", (206.0, 153.0), True),
              ("14 point", (300.0, 40.0), False)]
    pane.set_selection_marks(np.zeros((0, 2)), np.zeros((0, 2)), labels, 3)
    if zoom is not None:
        pane.zoom_to(zoom, (203.0, 150.0))
        qtbot.waitUntil(lambda: not pane._label_timer.isActive(), timeout=2000)
    boxes = [box for box, label in zip(_label_boxes(pane), pane.labels, strict=True)
             if pane.view_rect().contains(label.home)]
    assert len(boxes) >= 2
    assert not any(a.intersects(b) for i, a in enumerate(boxes) for b in boxes[i + 1:])


def _control_boxes(pane):
    """Each target number's box on screen (its dark box: what the eye reads as one label)."""
    view = pane.graphics
    return [label.deviceTransform(view.viewportTransform()).mapRect(label.boundingRect())
            for label in pane.control_labels]


@pytest.mark.parametrize("zoom", [None, 3.0])
def test_target_numbers_side_by_side_never_run_into_each_other(qtbot, pane, zoom):
    """Targets 17 and 8 a few pixels apart (and 3 more in a cluster): their numbers are drawn apart, each on
    its own dark box, so that "17" and "8" never read "178" — at the whole-image zoom and zoomed in."""
    marks = [("17", (200.0, 150.0)), ("8", (204.0, 150.5)), ("9", (206.0, 152.0)), ("10", (202.0, 147.0)),
             ("111", (300.0, 40.0))]
    pane.set_control(marks)
    if zoom is not None:
        pane.zoom_to(zoom, (203.0, 150.0))
        qtbot.waitUntil(lambda: not pane._label_timer.isActive(), timeout=2000)
    boxes = _control_boxes(pane)
    assert len(boxes) == len(marks) and all(box.width() > 4 for box in boxes)
    assert not any(a.intersects(b) for i, a in enumerate(boxes) for b in boxes[i + 1:])
    assert all(label.BOX.alpha() > 100 for label in pane.control_labels)
    pane.set_control(marks[:1])  # alone: back beside its point
    assert pane.control_labels[0].transform().dy() == pytest.approx(pane.control_labels[0].home_shift[1])


def _pixel_under(pane, point):
    return np.array(pane.pixel_at_scene(pane.graphics.mapToScene(point)))


def test_the_wheel_zooms_about_the_cursor(qtbot, pane):
    from PySide6 import QtGui, QtWidgets

    pane.zoom_to(2.0, (150.0, 120.0))
    viewport = pane.graphics.viewport()
    point = viewport_point(pane, (170.0, 100.0))
    before, level = _pixel_under(pane, point), pane.zoom_level()
    for _ in range(2):  # two notches forward
        event = QtGui.QWheelEvent(QtCore.QPointF(point), QtCore.QPointF(viewport.mapToGlobal(point)), QtCore.QPoint(),
                                  QtCore.QPoint(0, 120), QtCore.Qt.MouseButton.NoButton,
                                  QtCore.Qt.KeyboardModifier.NoModifier, QtCore.Qt.ScrollPhase.NoScrollPhase, False)
        QtWidgets.QApplication.sendEvent(viewport, event)
    assert pane.zoom_level() == pytest.approx(level * 1.02 ** 30, rel=1e-6)  # zoomed in ...
    assert np.allclose(_pixel_under(pane, point), before, atol=1e-6)  # ... about the pixel under the cursor


def test_a_left_drag_pans_and_is_no_click(qtbot, pane):
    pane.zoom_to(4.0, (200.0, 150.0))
    viewport = pane.graphics.viewport()
    start, end = QtCore.QPoint(300, 200), QtCore.QPoint(240, 170)
    grabbed, level = _pixel_under(pane, start), pane.zoom_level()
    received = []
    pane.clicked.connect(lambda x, y: received.append((x, y)))
    qtbot.mousePress(viewport, QtCore.Qt.MouseButton.LeftButton, pos=start)
    for step in range(1, 7):
        qtbot.mouseMove(viewport, start + (end - start) * step / 6)
    qtbot.mouseRelease(viewport, QtCore.Qt.MouseButton.LeftButton, pos=end)
    assert np.allclose(_pixel_under(pane, end), grabbed, atol=1e-6)  # the image followed the mouse
    assert pane.zoom_level() == pytest.approx(level) and received == []


def test_box_zoom_shows_the_box_drawn_and_makes_no_pick(qtbot, pane):
    pane.fit()
    pane.set_box_zoom(True)
    viewport = pane.graphics.viewport()
    corners = [viewport_point(pane, (100.0, 80.0)), viewport_point(pane, (180.0, 140.0))]
    received = []
    pane.clicked.connect(lambda x, y: received.append((x, y)))
    qtbot.mousePress(viewport, QtCore.Qt.MouseButton.LeftButton, pos=corners[0])
    for step in range(1, 5):
        qtbot.mouseMove(viewport, corners[0] + (corners[1] - corners[0]) * step / 4)
    qtbot.mouseRelease(viewport, QtCore.Qt.MouseButton.LeftButton, pos=corners[1])
    shown = pane.view_rect()
    drawn = QtCore.QRectF(*item_from_pixels(np.array([100.0, 80.0]))[0], 80.0, 60.0)
    assert shown.contains(drawn.adjusted(1, 1, -1, -1))  # the box is shown whole (corners within a screen px)
    assert shown.width() < 1.25 * drawn.width() or shown.height() < 1.25 * drawn.height()  # and fills the view
    assert received == []
    qtbot.mouseClick(viewport, QtCore.Qt.MouseButton.LeftButton, pos=viewport_point(pane, (140.0, 110.0)))
    assert received == []  # a click in box-zoom mode is no pick
    pane.set_box_zoom(False)
    qtbot.mouseClick(viewport, QtCore.Qt.MouseButton.LeftButton, pos=viewport_point(pane, (140.0, 110.0)))
    assert len(received) == 1
