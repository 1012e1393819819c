"""The marks a stereo pane draws over its image, in plain Qt: points drawn as symbols of a fixed size on
screen (:class:`Points`), polylines with gaps (:class:`Lines`), circles sized in image pixels
(:class:`Circles`), handles a user drags (:class:`Handle`) and labels (:class:`MarkLabel`).

Every mark is placed in view coordinates (:mod:`usvips.gui.qt.pane`: pixel (i, j) covers [i, i+1) ×
[j, j+1)) as a child of the pane's canvas; pens are cosmetic, so widths and symbol sizes stay in screen
pixels at every zoom. Paths of many points are built in one go from numpy arrays (a ``QPainterPath`` read
from its serialised form), never point by point in Python.
"""

from __future__ import annotations

import numpy as np
from PySide6 import QtCore, QtGui, QtWidgets

#: QPainterPath element types (Qt's ``QPainterPath::ElementType``)
_MOVE, _LINE = 0, 1
_ELEMENT = np.dtype([("type", ">i4"), ("x", ">f8"), ("y", ">f8")])


def path_from_elements(kinds: np.ndarray, xy: np.ndarray) -> QtGui.QPainterPath:
    """A ``QPainterPath`` of ``kinds`` (Qt element types) at ``xy`` (N, 2), built from its serialised form."""
    count = len(kinds)
    data = np.empty(count, _ELEMENT)
    data["type"], data["x"], data["y"] = kinds, xy[:, 0], xy[:, 1]
    buffer = QtCore.QByteArray(np.array([count], ">i4").tobytes() + data.tobytes()
                               + np.array([0, 0], ">i4").tobytes())  # the first element, the fill rule
    path = QtGui.QPainterPath()
    QtCore.QDataStream(buffer) >> path
    return path


def polyline_path(points: np.ndarray, connect: str = "finite") -> QtGui.QPainterPath:
    """The path joining ``points`` (N, 2): ``"finite"`` joins consecutive points, a row with a NaN breaks
    the line there; ``"pairs"`` joins rows 0–1, 2–3, ... ."""
    points = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    if connect == "pairs":
        points = points[: len(points) // 2 * 2]
        kinds = np.tile([_MOVE, _LINE], len(points) // 2)
        keep = np.isfinite(points).all(axis=1).reshape(-1, 2).all(axis=1).repeat(2)
        points, kinds = points[keep], kinds[keep]
    else:
        finite = np.isfinite(points).all(axis=1)
        starts = finite & ~np.concatenate([[False], finite[:-1]])
        kinds = np.where(starts, _MOVE, _LINE)[finite]
        points = points[finite]
    if not len(points):
        return QtGui.QPainterPath()
    return path_from_elements(kinds, points)


def pen(colour: tuple[int, int, int], width: float = 1.0, dashed: bool = False) -> QtGui.QPen:
    """A cosmetic pen (its width in screen pixels at every zoom)."""
    result = QtGui.QPen(QtGui.QColor(*colour))
    result.setWidthF(width)
    result.setCosmetic(True)
    if dashed:
        result.setStyle(QtCore.Qt.PenStyle.DashLine)
    return result


def _symbol(name: str) -> QtGui.QPainterPath:
    """The outline of a symbol one unit across, centred on (0, 0)."""
    path = QtGui.QPainterPath()
    if name == "o":
        path.addEllipse(QtCore.QPointF(0, 0), 0.5, 0.5)
    elif name == "s":
        path.addRect(QtCore.QRectF(-0.5, -0.5, 1, 1))
    elif name in ("+", "x"):  # a cross a fifth as wide as long, outlined (turned 45° for "x")
        arm, half = 0.5, 0.1
        corners = np.array([(-arm, -half), (-arm, half), (-half, half), (-half, arm), (half, arm), (half, half),
                            (arm, half), (arm, -half), (half, -half), (half, -arm), (-half, -arm), (-half, -half)])
        if name == "x":
            turn = np.sqrt(0.5)
            corners = corners @ np.array([[turn, turn], [-turn, turn]])
        path.moveTo(*corners[0])
        for corner in corners[1:]:
            path.lineTo(*corner)
        path.closeSubpath()
    elif name == "star":
        angles = np.pi / 2 + np.arange(10) * np.pi / 5
        radii = np.where(np.arange(10) % 2, 0.191, 0.5)
        corners = np.column_stack([radii * np.cos(angles), -radii * np.sin(angles)])
        path.moveTo(*corners[0])
        for corner in corners[1:]:
            path.lineTo(*corner)
        path.closeSubpath()
    else:
        raise ValueError(f"no mark symbol {name!r}")
    return path


_TEMPLATES: dict[str, tuple[np.ndarray, np.ndarray]] = {}


def symbol_elements(name: str) -> tuple[np.ndarray, np.ndarray]:
    """The element types and (E, 2) coordinates of a symbol one unit across (cached)."""
    if name not in _TEMPLATES:
        path = _symbol(name)
        elements = [path.elementAt(k) for k in range(path.elementCount())]
        _TEMPLATES[name] = (np.array([int(e.type.value) for e in elements], np.int32),
                            np.array([[e.x, e.y] for e in elements], np.float64))
    return _TEMPLATES[name]


def symbols_path(centres: np.ndarray, name: str, size: float) -> QtGui.QPainterPath:
    """One path holding the symbol ``name``, ``size`` units across, at each of ``centres`` (N, 2)."""
    kinds, unit = symbol_elements(name)
    centres = np.asarray(centres, np.float64).reshape(-1, 2)
    if not len(centres):
        return QtGui.QPainterPath()
    xy = (centres[:, None, :] + unit[None] * size).reshape(-1, 2)
    return path_from_elements(np.tile(kinds, len(centres)), xy)


class Points(QtWidgets.QGraphicsItem):
    """Symbols (``"o"``, ``"s"``, ``"+"``, ``"x"``, ``"star"``) ``size`` screen pixels across at points in
    view coordinates, stroked with a cosmetic pen; a point may have a symbol of its own."""

    def __init__(self, size: float, colour: tuple[int, int, int], width: float = 1.0, symbol: str = "o",
                 dashed: bool = False) -> None:
        super().__init__()
        self.size, self.symbol = float(size), symbol
        self._pen = pen(colour, width, dashed)
        self._points = np.zeros((0, 2))
        self._symbols: list[str] | None = None
        self._bounds = QtCore.QRectF()

    def set_points(self, points: np.ndarray | None, symbols: list[str] | None = None) -> None:
        """Draw the symbol at ``points`` (N, 2, view coordinates; None or none: nothing); ``symbols``, one
        per point, in place of the item's own."""
        self.prepareGeometryChange()
        self._points = np.zeros((0, 2)) if points is None else np.asarray(points, np.float64).reshape(-1, 2)
        self._symbols = None if symbols is None else list(symbols)
        finite = self._points[np.isfinite(self._points).all(axis=1)]
        self._bounds = (QtCore.QRectF() if not len(finite) else
                        QtCore.QRectF(QtCore.QPointF(*finite.min(axis=0)), QtCore.QPointF(*finite.max(axis=0))))
        self.update()

    def points(self) -> np.ndarray:
        """The points drawn (N, 2, view coordinates)."""
        return self._points.copy()

    def symbols(self) -> list[str]:
        """Each point's symbol."""
        return list(self._symbols) if self._symbols is not None else [self.symbol] * len(self._points)

    def pen(self) -> QtGui.QPen:
        return QtGui.QPen(self._pen)

    def setPen(self, value: QtGui.QPen) -> None:  # noqa: N802 (as Qt's items name it)
        self._pen = QtGui.QPen(value)
        self.update()

    def boundingRect(self) -> QtCore.QRectF:  # noqa: N802 (Qt's name)
        if not len(self._points):
            return QtCore.QRectF()
        parent = self.parentItem()
        scale = abs(parent.transform().m11()) if parent is not None else 1.0
        margin = (self.size + self._pen.widthF() + 2) / max(scale, 1e-12)
        return self._bounds.adjusted(-margin, -margin, margin, margin)

    def paint(self, painter: QtGui.QPainter, option, widget=None) -> None:
        if not len(self._points):
            return
        device = painter.worldTransform()
        painter.save()
        painter.resetTransform()
        painter.setPen(self._pen)
        painter.setBrush(QtCore.Qt.BrushStyle.NoBrush)
        xy = self._points
        screen = np.column_stack([device.m11() * xy[:, 0] + device.m21() * xy[:, 1] + device.dx(),
                                  device.m12() * xy[:, 0] + device.m22() * xy[:, 1] + device.dy()])
        names = self.symbols()
        for name in dict.fromkeys(names):
            chosen = screen if self._symbols is None else screen[[n == name for n in names]]
            painter.drawPath(symbols_path(chosen, name, self.size))
        painter.restore()


class Lines(QtWidgets.QGraphicsPathItem):
    """Polylines through points in view coordinates (NaN rows break them, or ``connect="pairs"``: one
    segment per two rows) with a cosmetic pen; antialiased unless told otherwise."""

    def __init__(self, colour: tuple[int, int, int], width: float = 1.0, dashed: bool = False,
                 connect: str = "finite") -> None:
        super().__init__()
        self.setPen(pen(colour, width, dashed))
        self.connect = connect
        self.antialias = True
        self._points = np.zeros((0, 2))

    def set_points(self, points: np.ndarray | None, antialias: bool = True) -> None:
        """Draw lines through ``points`` (N, 2, view coordinates; None or none: nothing)."""
        self._points = np.zeros((0, 2)) if points is None else np.asarray(points, np.float64).reshape(-1, 2)
        self.antialias = bool(antialias)
        self.setPath(polyline_path(self._points, self.connect))

    def points(self) -> np.ndarray:
        """The points given (N, 2, view coordinates, NaN separators included)."""
        return self._points.copy()

    def paint(self, painter: QtGui.QPainter, option, widget=None) -> None:
        painter.setRenderHint(QtGui.QPainter.RenderHint.Antialiasing, self.antialias)
        super().paint(painter, option, widget)


class Circles(QtWidgets.QGraphicsPathItem):
    """Circles with centres and diameters in view coordinates (image pixels), a cosmetic pen."""

    def __init__(self, colour: tuple[int, int, int], width: float = 1.0) -> None:
        super().__init__()
        self.setPen(pen(colour, width))
        self._points = np.zeros((0, 2))

    def set_circles(self, centres: np.ndarray, diameters: np.ndarray) -> None:
        self._points = np.asarray(centres, np.float64).reshape(-1, 2)
        diameters = np.broadcast_to(np.asarray(diameters, np.float64), (len(self._points),))
        path = QtGui.QPainterPath()
        for (x, y), diameter in zip(self._points, diameters, strict=True):
            path.addEllipse(QtCore.QPointF(x, y), diameter / 2, diameter / 2)
        self.setPath(path)

    def points(self) -> np.ndarray:
        """The circles' centres (N, 2, view coordinates)."""
        return self._points.copy()


class Handle(QtWidgets.QGraphicsObject):
    """A symbol ``size`` screen pixels across at a point (view coordinates) that the user drags with the
    left button; ``dropped(handle)`` when the drag ends. Drawn with ``hover_colour`` under the cursor."""

    dropped = QtCore.Signal(object)

    def __init__(self, position: tuple[float, float], size: float, symbol: str, colour: tuple[int, int, int],
                 width: float, hover_colour: tuple[int, int, int], hover_width: float | None = None) -> None:
        super().__init__()
        self.size = float(size)
        self._path = symbols_path(np.zeros((1, 2)), symbol, self.size)
        self._pen, self._hover_pen = pen(colour, width), pen(hover_colour, hover_width or width)
        self._hovered = False
        self._grab = QtCore.QPointF()
        self.setFlag(QtWidgets.QGraphicsItem.GraphicsItemFlag.ItemIgnoresTransformations)
        self.setAcceptHoverEvents(True)
        self.setAcceptedMouseButtons(QtCore.Qt.MouseButton.LeftButton)
        self.setCursor(QtCore.Qt.CursorShape.SizeAllCursor)
        self.setPos(QtCore.QPointF(*position))

    def boundingRect(self) -> QtCore.QRectF:  # noqa: N802 (Qt's name)
        half = self.size / 2 + 3
        return QtCore.QRectF(-half, -half, 2 * half, 2 * half)

    def paint(self, painter: QtGui.QPainter, option, widget=None) -> None:
        painter.setPen(self._hover_pen if self._hovered else self._pen)
        painter.setBrush(QtCore.Qt.BrushStyle.NoBrush)
        painter.drawPath(self._path)

    def hoverEnterEvent(self, event) -> None:  # noqa: N802 (Qt's name)
        self._hovered = True
        self.update()

    def hoverLeaveEvent(self, event) -> None:  # noqa: N802 (Qt's name)
        self._hovered = False
        self.update()

    def _parent_point(self, event) -> QtCore.QPointF:
        parent = self.parentItem()
        return parent.mapFromScene(event.scenePos()) if parent is not None else event.scenePos()

    def mousePressEvent(self, event) -> None:  # noqa: N802 (Qt's name)
        self._grab = self._parent_point(event) - self.pos()
        event.accept()

    def mouseMoveEvent(self, event) -> None:  # noqa: N802 (Qt's name)
        self.setPos(self._parent_point(event) - self._grab)

    def mouseReleaseEvent(self, event) -> None:  # noqa: N802 (Qt's name)
        self.dropped.emit(self)


class MarkLabel(QtWidgets.QGraphicsSimpleTextItem):
    """A mark's name on a pane (a control point's target number, an object's label): the same size on
    screen at every zoom, beside its point — ``anchor`` the fraction of the text's width and height that
    sits on the point ((0, 0) its top-left corner). Qt keeps it upright and unscaled, so a view moved or
    zoomed costs no Python per label; ``color`` is its colour; ``boxed`` draws a dark box behind it."""

    #: screen pixels of blank around the text (placed as a text item's document margin places it)
    MARGIN = 4.0
    #: screen pixels of the dark box drawn behind the text beyond it: two numbers side by side read as two
    #: ("17" and "8", never "178"), and a number stays legible on a bright or busy image
    PAD = 1.5
    BOX = QtGui.QColor(0, 0, 0, 170)

    def __init__(self, text: str, color: tuple[int, int, int], anchor: tuple[float, float],
                 boxed: bool = True) -> None:
        super().__init__(text)
        self.color = QtGui.QColor(*color)
        self.boxed = boxed
        self.setBrush(self.color)
        self.setFlag(QtWidgets.QGraphicsItem.GraphicsItemFlag.ItemIgnoresTransformations)
        size, margin = super().boundingRect(), self.MARGIN
        #: where the text sits off its point (screen pixels) when no other label is in its way
        self.home_shift = (margin - anchor[0] * (size.width() + 2 * margin),
                           margin - anchor[1] * (size.height() + 2 * margin))
        self.shift_by(0.0)

    def shift_by(self, dy: float, dx: float = 0.0) -> None:
        """Move the text ``dy`` screen pixels down (up when negative) and ``dx`` right from its own place
        beside its point."""
        self.setTransform(QtGui.QTransform.fromTranslate(self.home_shift[0] + dx, self.home_shift[1] + dy))

    def boundingRect(self) -> QtCore.QRectF:  # noqa: N802 (Qt's name)
        pad = self.PAD
        return super().boundingRect().adjusted(-pad, -pad, pad, pad)

    def paint(self, painter: QtGui.QPainter, option, widget=None) -> None:
        if self.boxed:
            painter.fillRect(self.boundingRect(), self.BOX)
        super().paint(painter, option, widget)

    def toPlainText(self) -> str:  # noqa: N802 (named as Qt's text items name it)
        return self.text()

    def screen_rect(self, view: QtWidgets.QGraphicsView) -> QtCore.QRectF:
        """The label's box in ``view``'s viewport pixels."""
        return self.deviceTransform(view.viewportTransform()).mapRect(self.boundingRect())
