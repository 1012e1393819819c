"""The view a stereo pane shows its image in, in plain Qt: a ``QGraphicsView`` whose scene coordinates are
its viewport's pixels, holding a canvas item whose transform maps view coordinates (image pixels, y down)
onto them — one uniform scale (the aspect is locked) and a shift, set from a wanted range.

Mouse: the wheel zooms about the cursor; a left (or middle) drag pans, or in box-zoom mode draws a box
that is zoomed to on release; a right drag zooms about where it started (up: in); a left press and
release without a drag is a click. A press an item takes (a handle being dragged) is left to it.
"""

from __future__ import annotations

import math

from PySide6 import QtCore, QtGui, QtWidgets

#: the wheel's zoom: the range shrinks by WHEEL_BASE ** (degrees × 8 / 8) per notch turned forward
WHEEL_BASE = 1.02
#: a right drag zooms by DRAG_BASE per screen pixel moved (up: in)
DRAG_BASE = 1.02
#: the box drawn while zooming to a box: its outline and fill (RGB, RGBA)
BOX_PEN, BOX_FILL = (255, 255, 100), (255, 255, 0, 100)


class _Canvas(QtWidgets.QGraphicsObject):
    """The parent of everything drawn in view coordinates; draws nothing itself."""

    def __init__(self) -> None:
        super().__init__()
        self.setFlag(QtWidgets.QGraphicsItem.GraphicsItemFlag.ItemHasNoContents)

    def boundingRect(self) -> QtCore.QRectF:  # noqa: N802 (Qt's name)
        return QtCore.QRectF()

    def paint(self, painter, option, widget=None) -> None:
        pass


class ImageView(QtWidgets.QGraphicsView):
    """``range_changed()`` when the part of the canvas shown changes; ``mouse_moved(scene_pos)`` on every
    mouse move; ``clicked(scene_pos)`` on a left click without a drag (not a double click's second)."""

    range_changed = QtCore.Signal()
    mouse_moved = QtCore.Signal(QtCore.QPointF)
    clicked = QtCore.Signal(QtCore.QPointF)

    def __init__(self, background: tuple[int, int, int]) -> None:
        super().__init__()
        scene = QtWidgets.QGraphicsScene(self)
        scene.setItemIndexMethod(QtWidgets.QGraphicsScene.ItemIndexMethod.NoIndex)  # few items, bounds that zoom
        self.setScene(scene)
        self.setBackgroundBrush(QtGui.QColor(*background))
        for policy in (self.setHorizontalScrollBarPolicy, self.setVerticalScrollBarPolicy):
            policy(QtCore.Qt.ScrollBarPolicy.ScrollBarAlwaysOff)
        self.setFrameShape(QtWidgets.QFrame.Shape.NoFrame)
        self.setTransformationAnchor(QtWidgets.QGraphicsView.ViewportAnchor.NoAnchor)
        self.setResizeAnchor(QtWidgets.QGraphicsView.ViewportAnchor.NoAnchor)
        self.setAlignment(QtCore.Qt.AlignmentFlag.AlignLeft | QtCore.Qt.AlignmentFlag.AlignTop)
        self.setViewportUpdateMode(QtWidgets.QGraphicsView.ViewportUpdateMode.FullViewportUpdate)
        self.setRenderHint(QtGui.QPainter.RenderHint.Antialiasing, True)
        self.viewport().setMouseTracking(True)
        self.canvas = _Canvas()
        scene.addItem(self.canvas)
        self.box_zoom = False
        self._wanted = QtCore.QRectF(0, 0, 1, 1)  # the range asked for; the one shown also fills the aspect
        self._press: QtCore.QPointF | None = None
        self._last = QtCore.QPointF()
        self._button = QtCore.Qt.MouseButton.NoButton
        self._dragging = False
        self._double = False
        self._item_press = False  # an item (a handle) took the press: a drag is its own, a click still a click
        self._box = QtWidgets.QGraphicsRectItem()
        outline = QtGui.QPen(QtGui.QColor(*BOX_PEN))
        outline.setCosmetic(True)
        self._box.setPen(outline)
        self._box.setBrush(QtGui.QColor(*BOX_FILL))
        self._box.setZValue(1e9)
        self._box.hide()
        scene.addItem(self._box)
        self._cross: QtCore.QPointF | None = None
        self._cross_pen = QtGui.QPen(QtGui.QColor(0, 230, 0))
        self._cross_pen.setCosmetic(True)

    # ------------------------------------------------------------------ range
    def view_rect(self) -> QtCore.QRectF:
        """The part of the canvas shown (view coordinates)."""
        return self.canvas.transform().inverted()[0].mapRect(QtCore.QRectF(self.viewport().rect()))

    def scale_factor(self) -> float:
        """Screen pixels per view unit."""
        return self.canvas.transform().m11()

    def set_range(self, rect: QtCore.QRectF, padding: float | None = None) -> None:
        """Show ``rect`` (view coordinates) whole and centred, grown by ``padding`` (a fraction of its size
        on each side; default a little, less for a large viewport), the other axis filled to keep the
        aspect."""
        if padding is None:
            width = max(self.viewport().width(), 1)
            padding = min(max(1.0 / math.sqrt(width), 0.02), 0.1)
        rect = QtCore.QRectF(rect).normalized()
        dx, dy = rect.width() * padding, rect.height() * padding
        self._wanted = rect.adjusted(-dx, -dy, dx, dy)
        self._apply()

    def scale_about(self, factor: float, centre: QtCore.QPointF | None = None) -> None:
        """Scale the range shown by ``factor`` (< 1 zooms in) about ``centre`` (view coordinates; default
        the middle of the view)."""
        shown = self.view_rect()
        centre = shown.center() if centre is None else centre
        self._wanted = QtCore.QRectF(centre + (shown.topLeft() - centre) * factor,
                                     centre + (shown.bottomRight() - centre) * factor)
        self._apply()

    def pan_by(self, dx: float, dy: float) -> None:
        """Move the range shown by (dx, dy) view units."""
        self._wanted = self.view_rect().translated(dx, dy)
        self._apply()

    def _apply(self) -> None:
        viewport = self.viewport().rect()
        width, height = max(viewport.width(), 1), max(viewport.height(), 1)
        wanted = self._wanted
        scale = min(width / max(wanted.width(), 1e-12), height / max(wanted.height(), 1e-12))
        centre = wanted.center()
        shift_x, shift_y = width / 2 - scale * centre.x(), height / 2 - scale * centre.y()
        transform = QtGui.QTransform(scale, 0, 0, scale, shift_x, shift_y)
        if transform != self.canvas.transform():
            self.canvas.setTransform(transform)
            self.viewport().update()
            self.range_changed.emit()

    def resizeEvent(self, event: QtGui.QResizeEvent) -> None:  # noqa: N802 (Qt's name)
        super().resizeEvent(event)
        self.setSceneRect(QtCore.QRectF(self.viewport().rect()))  # scene coordinates = viewport pixels
        self._apply()

    # ------------------------------------------------------------------ cross-hair
    def set_cross(self, point: QtCore.QPointF | None) -> None:
        """Draw the cross-hair's lines through ``point`` (view coordinates) across the view; None: none."""
        self._cross = point
        self.viewport().update()

    def cross(self) -> QtCore.QPointF | None:
        return self._cross

    def drawForeground(self, painter: QtGui.QPainter, rect: QtCore.QRectF) -> None:  # noqa: N802 (Qt's name)
        if self._cross is None:
            return
        at = self.canvas.mapToScene(self._cross)
        area = self.sceneRect()
        painter.setRenderHint(QtGui.QPainter.RenderHint.Antialiasing, False)  # one crisp screen pixel wide
        painter.setPen(self._cross_pen)
        painter.drawLine(QtCore.QPointF(at.x(), area.top()), QtCore.QPointF(at.x(), area.bottom()))
        painter.drawLine(QtCore.QPointF(area.left(), at.y()), QtCore.QPointF(area.right(), at.y()))

    # ------------------------------------------------------------------ mouse
    def wheelEvent(self, event: QtGui.QWheelEvent) -> None:  # noqa: N802 (Qt's name)
        delta = event.angleDelta().y() or event.angleDelta().x()
        if not delta:
            return
        centre = self.canvas.mapFromScene(self.mapToScene(event.position().toPoint()))
        self.scale_about(WHEEL_BASE ** (-delta / 8), centre)
        event.accept()

    def mousePressEvent(self, event: QtGui.QMouseEvent) -> None:  # noqa: N802 (Qt's name)
        super().mousePressEvent(event)
        self._item_press = self.scene().mouseGrabberItem() is not None
        self._press = event.position()
        self._last = event.position()
        self._button = event.button()
        self._dragging = False
        event.accept()

    def mouseDoubleClickEvent(self, event: QtGui.QMouseEvent) -> None:  # noqa: N802 (Qt's name)
        self.mousePressEvent(event)
        self._double = True

    def mouseMoveEvent(self, event: QtGui.QMouseEvent) -> None:  # noqa: N802 (Qt's name)
        super().mouseMoveEvent(event)
        position = event.position()
        self.mouse_moved.emit(self.mapToScene(position.toPoint()))
        if self._press is None:
            return
        if not self._dragging:
            moved = position - self._press
            if abs(moved.x()) + abs(moved.y()) < QtWidgets.QApplication.startDragDistance():
                return
            self._dragging = True
        if not self._item_press:
            self._drag(position)
        self._last = position

    def _drag(self, position: QtCore.QPointF) -> None:
        button = self._button
        if button == QtCore.Qt.MouseButton.LeftButton and self.box_zoom:
            self._box.setRect(QtCore.QRectF(self._press, position).normalized())
            self._box.show()
        elif button in (QtCore.Qt.MouseButton.LeftButton, QtCore.Qt.MouseButton.MiddleButton):
            scale = self.scale_factor()
            step = position - self._last
            self.pan_by(-step.x() / scale, -step.y() / scale)
        elif button == QtCore.Qt.MouseButton.RightButton:
            centre = self.canvas.mapFromScene(self._press)
            self.scale_about(DRAG_BASE ** (position.y() - self._last.y()), centre)

    def mouseReleaseEvent(self, event: QtGui.QMouseEvent) -> None:  # noqa: N802 (Qt's name)
        super().mouseReleaseEvent(event)
        press, double = self._press, self._double
        self._press, self._double = None, False
        if press is None or event.button() != self._button:
            return
        if self._dragging:
            if self._box.isVisible():
                self._box.hide()
                corners = QtCore.QRectF(press, event.position()).normalized()
                self.set_range(self.canvas.mapRectFromScene(corners))
            return
        if event.button() == QtCore.Qt.MouseButton.LeftButton and not double and not self._item_press:
            # a press an item took (a handle moved by less than a drag's distance: a small correction) is
            # the item's, never also a click on the image beneath it
            self.clicked.emit(self.mapToScene(event.position().toPoint()))
