"""One stereo pane: an image in a plain-Qt view (:class:`usvips.gui.qt.image_view.ImageView`) with zoom,
pan, a crosshair cursor, a loupe, and the marks (picks, proposal, epipolar curve, objects;
:mod:`usvips.gui.qt.marks`) the window asks it to draw.

The pane converts between the view and image pixels in exactly one place (:func:`pixel_from_item` and
:func:`item_from_pixels`): the image item puts pixel (i, j) on the square [i, i+1) × [j, j+1) of its own
(= view) coordinates, while USVIPS pixels have their origin at the centre of the top-left pixel
(ARCHITECTURE.md), so the two differ by half a pixel. Scene → item goes through the item's transform
(``mapFromScene``), never by hand. The pane is plain Qt so that the window starts without pyqtgraph (the
plots import it when they are first shown).
"""

from __future__ import annotations

import numpy as np
from PySide6 import QtCore, QtGui, QtWidgets

from usvips.gui.label_layout import keep_inside, stack_labels
from usvips.gui.outline_set import OutlineSet, raster, raster_scale
from usvips.gui.qt.image_view import ImageView
from usvips.gui.qt.marks import Lines, MarkLabel, Points, pen
from usvips.gui.view_options import LOUPE_SCALES

#: Image item (view) coordinate of the centre of pixel 0.
PIXEL_CENTRE = 0.5
LOUPE_RADIUS = 10  # image pixels each side of the cursor
LOUPE_SCALE = 8
#: Magnifications the loupe offers (screen pixels per image pixel).
#: Gap (screen pixels) between the cursor and the loupe's nearest corner: the loupe never covers the cursor.
LOUPE_OFFSET = 24
#: Opacity (of 255) of the raster drawn in place of many outlines: the image shows through where they crowd.
RASTER_ALPHA = 190

COLOURS = {"control": (60, 220, 120), "cursor": (0, 230, 0), "pick": (255, 40, 40), "proposal": (255, 220, 0),
           "weak proposal": (0, 255, 255),
           "curve": (255, 140, 0), "object": (0, 200, 255), "selected": (255, 0, 255), "label": (230, 230, 230)}


def pixel_from_item(x: float, y: float) -> tuple[float, float]:
    """Image item (view) coordinates → USVIPS pixels."""
    return x - PIXEL_CENTRE, y - PIXEL_CENTRE


def item_from_pixels(pixels: np.ndarray) -> np.ndarray:
    """USVIPS pixels (N, 2) → image item (= view) coordinates."""
    return np.asarray(pixels, dtype=np.float64).reshape(-1, 2) + PIXEL_CENTRE


def to_qimage(array: np.ndarray) -> QtGui.QImage:
    """A uint8 grey or RGB array as a QImage (copied; uint16 is scaled to 8 bits)."""
    if array.dtype != np.uint8:
        array = (array.astype(np.float32) * (255.0 / 65535.0)).astype(np.uint8)
    array = np.ascontiguousarray(array)
    h, w = array.shape[:2]
    if array.ndim == 2:
        return QtGui.QImage(array.data, w, h, w, QtGui.QImage.Format.Format_Grayscale8).copy()
    return QtGui.QImage(array.data, w, h, 3 * w, QtGui.QImage.Format.Format_RGB888).copy()


class ImageItem(QtWidgets.QGraphicsItem):
    """The image, pixel (i, j) on [i, i+1) × [j, j+1) of its coordinates, drawn unsmoothed (a zoomed-in
    pixel is a square; a zoomed-out image is scaled by the painter, never re-sampled in Python). Held as a
    pixmap, converted once to the screen's format: a grey or RGB image drawn as it is would be converted
    again at every repaint (about 40 ms for 4000 × 3000 colour)."""

    def __init__(self) -> None:
        super().__init__()
        self.pixmap: QtGui.QPixmap | None = None

    def set_array(self, array: np.ndarray | None) -> None:
        self.prepareGeometryChange()
        self.pixmap = None if array is None else QtGui.QPixmap.fromImage(to_qimage(array))
        self.update()

    def boundingRect(self) -> QtCore.QRectF:  # noqa: N802 (Qt's name)
        return QtCore.QRectF() if self.pixmap is None else QtCore.QRectF(self.pixmap.rect())

    def paint(self, painter: QtGui.QPainter, option, widget=None) -> None:
        if self.pixmap is not None:
            painter.drawPixmap(self.boundingRect(), self.pixmap, QtCore.QRectF(self.pixmap.rect()))


class StereoPane(QtWidgets.QWidget):
    """``clicked(x, y)`` in pixels on a left click without drag; ``hovered(x, y)`` as the cursor moves
    (NaN when it leaves the image)."""

    clicked = QtCore.Signal(float, float)
    hovered = QtCore.Signal(float, float)

    def __init__(self, side: str, parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(parent)
        self.side = side
        self.setObjectName(f"{side}_pane")
        self.graphics = ImageView(background=(24, 24, 28))
        self.canvas = self.graphics.canvas
        #: ``range_changed()`` when the part of the image shown changes (a zoom, a pan, a resize)
        self.range_changed = self.graphics.range_changed
        # labels are laid out apart in screen pixels: again after a zoom or pan (at most every 50 ms)
        self._label_timer = QtCore.QTimer(self)
        self._label_timer.setSingleShot(True)
        self._label_timer.setInterval(50)
        self._label_timer.timeout.connect(self.layout_labels)
        self._label_timer.timeout.connect(self.layout_control_labels)
        self._label_timer.timeout.connect(self._draw_outlines)
        self.range_changed.connect(self._label_timer.start)
        # never re-sampled on a zoom: the painter scales the one image (about 2 ms per step, see `usvips bench`)
        self.image_item = ImageItem()
        self.image_item.setParentItem(self.canvas)
        self.title = QtWidgets.QLabel(side.capitalize())
        self.title.setStyleSheet("font-weight: bold; padding: 2px 4px;")
        layout = QtWidgets.QVBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.setSpacing(0)
        layout.addWidget(self.title)
        layout.addWidget(self.graphics)
        self._add_overlays()
        # the loupe follows the cursor at an offset (never under it) and lets every mouse event through
        self.loupe = QtWidgets.QLabel(self.graphics.viewport())
        self.loupe.setObjectName(f"{side}_loupe")
        self.loupe.setAttribute(QtCore.Qt.WidgetAttribute.WA_TransparentForMouseEvents, True)
        self.loupe.setStyleSheet("border: 1px solid #00e600; background: black;")
        self.loupe.setScaledContents(True)
        self.loupe.hide()
        self.loupe_enabled = True
        self.loupe_scale = LOUPE_SCALE
        self._fit_loupe()
        # keys (accept, nudge, ...) reach the window's image shortcuts once an image has the focus
        self.graphics.setFocusPolicy(QtCore.Qt.FocusPolicy.StrongFocus)
        self.display: np.ndarray | None = None
        self.graphics.mouse_moved.connect(self._on_mouse_moved)
        self.graphics.clicked.connect(self._on_mouse_clicked)

    def _add_overlays(self) -> None:
        self.curve_item = Lines(COLOURS["curve"], width=1.5, dashed=True)
        # the stored objects' outlines, at a level of detail (:meth:`_draw_outlines`): those in or near the
        # view stroked one by one when at most MAX_PATHS are there, else all of them as one raster
        self.outlines_item = Lines(COLOURS["object"], width=2)
        self.outlines_item.setCacheMode(QtWidgets.QGraphicsItem.CacheMode.DeviceCoordinateCache)
        self.raster_item = QtWidgets.QGraphicsPixmapItem()
        self.raster_item.setShapeMode(QtWidgets.QGraphicsPixmapItem.ShapeMode.BoundingRectShape)
        self.raster_item.hide()
        self.outlines: OutlineSet | None = None
        self.outline_side = 0
        self._raster_version = -1  # the version of the outlines the raster item shows
        self._raster_count = 0  # ... and how many outlines it holds
        self._raster_worker = None
        # the raster is built once the outlines stop changing for a moment (an open hands them over in slices)
        self._raster_timer = QtCore.QTimer(self)
        self._raster_timer.setSingleShot(True)
        self._raster_timer.setInterval(self.RASTER_WAIT_MS)
        self._raster_timer.timeout.connect(self._build_raster)
        self.selected_item = Lines(COLOURS["selected"], width=3)
        self.vertex_item = Points(7, COLOURS["object"], symbol="s")
        self.pick_item = Points(15, COLOURS["pick"], width=2, symbol="+")
        self.proposal_item = Points(17, COLOURS["proposal"], width=2, symbol="o")
        self.proposal_weak = False  # the proposal drawn is one auto-match refused (cyan, dashed)
        # the object being digitised, drawn on its own: a pick redraws it, never the stored objects
        self.digitising_item = Lines(COLOURS["selected"], width=3)
        self.digitising_vertices = Points(7, COLOURS["selected"], symbol="s")
        for item in (self.raster_item, self.outlines_item, self.selected_item, self.vertex_item, self.digitising_item,
                     self.digitising_vertices, self.curve_item, self.pick_item, self.proposal_item):
            self.add_mark(item)
        self.control_item = Points(11, COLOURS["control"], width=1.5, symbol="o")
        self.add_mark(self.control_item)
        self.control_selected_item = Points(19, COLOURS["selected"], width=2.5, symbol="o")
        self.add_mark(self.control_selected_item)
        self.control_labels: list[MarkLabel] = []
        self.labels: list[MarkLabel] = []

    def add_mark(self, item: QtWidgets.QGraphicsItem) -> None:
        """Draw ``item`` over the image (placed in view coordinates, above the marks added before it)."""
        item.setParentItem(self.canvas)

    def remove_mark(self, item: QtWidgets.QGraphicsItem) -> None:
        """Stop drawing ``item`` (one :meth:`add_mark` added)."""
        scene = item.scene()
        if scene is not None:
            scene.removeItem(item)

    def view_rect(self) -> QtCore.QRectF:
        """The part of the image shown, in view coordinates (pixel (i, j) on [i, i+1) × [j, j+1))."""
        return self.graphics.view_rect()

    # ------------------------------------------------------------------ image
    def set_image(self, display: np.ndarray | None) -> None:
        """Show an image (uint8/uint16, grey or RGB); keeps the current zoom when the size is unchanged."""
        previous = None if self.display is None else self.display.shape[:2]
        self.display = display
        self.image_item.set_array(display)
        if display is None:
            return
        if previous != display.shape[:2]:
            self._raster_version = -1  # drawn for another size
            self.raster_item.hide()
            self.fit()

    def image_size(self) -> tuple[int, int]:
        """(width, height) in pixels, (0, 0) without an image."""
        return (0, 0) if self.display is None else (self.display.shape[1], self.display.shape[0])

    # ------------------------------------------------------------------ zoom
    def fit(self) -> None:
        w, h = self.image_size()
        if w:
            self.graphics.set_range(QtCore.QRectF(0, 0, w, h), padding=0.02)

    def one_to_one(self, centre: tuple[float, float] | None = None) -> None:
        """One image pixel per screen pixel, around ``centre`` (pixels; default the view's centre)."""
        self.zoom_to(1.0, centre)

    def zoom_to(self, screen_per_pixel: float, centre: tuple[float, float] | None = None) -> None:
        """Set the zoom (screen pixels per image pixel) around ``centre`` (image pixels)."""
        rect = self.view_rect()
        if centre is None:
            cx, cy = rect.center().x(), rect.center().y()
        else:
            cx, cy = item_from_pixels(np.array(centre))[0]
        size = self.graphics.viewport().size()
        half_w = size.width() / screen_per_pixel / 2
        half_h = size.height() / screen_per_pixel / 2
        self.graphics.set_range(QtCore.QRectF(cx - half_w, cy - half_h, 2 * half_w, 2 * half_h), padding=0)

    def zoom_by(self, factor: float) -> None:
        """Zoom in (factor > 1) or out around the view's centre."""
        self.graphics.scale_about(1.0 / factor)

    def zoom_level(self) -> float:
        """Screen pixels per image pixel (horizontally)."""
        return self.graphics.scale_factor()

    def set_box_zoom(self, on: bool) -> None:
        self.graphics.box_zoom = bool(on)

    # ------------------------------------------------------------------ mouse
    def pixel_at_scene(self, scene_pos: QtCore.QPointF) -> tuple[float, float]:
        """The one scene → pixel conversion: through the image item's transform."""
        item = self.image_item.mapFromScene(scene_pos)
        return pixel_from_item(item.x(), item.y())

    def _inside(self, x: float, y: float) -> bool:
        w, h = self.image_size()
        return -0.5 <= x <= w - 0.5 and -0.5 <= y <= h - 0.5

    def _on_mouse_moved(self, scene_pos: QtCore.QPointF) -> None:
        x, y = self.pixel_at_scene(scene_pos)
        if self.display is None or not self._inside(x, y):
            self.graphics.set_cross(None)
            self.loupe.hide()
            self.hovered.emit(float("nan"), float("nan"))
            return
        vx, vy = item_from_pixels(np.array([x, y]))[0]
        self.graphics.set_cross(QtCore.QPointF(vx, vy))
        self._update_loupe(x, y)
        self.hovered.emit(x, y)

    def _on_mouse_clicked(self, scene_pos: QtCore.QPointF) -> None:
        """A left click without a drag (the view leaves out double clicks)."""
        if self.graphics.box_zoom:
            return
        x, y = self.pixel_at_scene(scene_pos)
        self.graphics.setFocus(QtCore.Qt.FocusReason.MouseFocusReason)
        if self.display is not None and self._inside(x, y):
            self.clicked.emit(x, y)

    def _fit_loupe(self) -> None:
        """Size the loupe for its magnification; in a small pane it shows fewer pixels around the cursor
        (at most half the viewport less the offset, so that it always fits beside the cursor)."""
        viewport = self.graphics.viewport()
        room = min(viewport.width(), viewport.height()) // 2 - LOUPE_OFFSET - 2
        self.loupe_radius = int(max(1, min(LOUPE_RADIUS, (room // self.loupe_scale - 1) // 2)))
        side_px = (2 * self.loupe_radius + 1) * self.loupe_scale + 2
        self.loupe.setFixedSize(side_px, side_px)

    def set_loupe_scale(self, scale: int) -> None:
        """Magnification of the loupe (screen pixels per image pixel; one of :data:`LOUPE_SCALES`)."""
        if scale not in LOUPE_SCALES:
            raise ValueError(f"loupe magnification {scale} is not one of {LOUPE_SCALES}")
        self.loupe_scale = int(scale)
        self._fit_loupe()
        self.loupe.hide()  # shown again, at the new size, when the cursor moves

    def loupe_position(self, cursor: QtCore.QPoint) -> QtCore.QPoint:
        """Top-left corner of the loupe (viewport pixels) for the cursor at ``cursor``: below right of it
        by :data:`LOUPE_OFFSET`, flipped to the other side where the viewport's edge is near, so that the
        cursor and the pixels around it stay visible."""
        viewport = self.graphics.viewport()
        w, h = self.loupe.width(), self.loupe.height()
        x = cursor.x() + LOUPE_OFFSET
        if x + w > viewport.width():
            x = cursor.x() - LOUPE_OFFSET - w
        y = cursor.y() + LOUPE_OFFSET
        if y + h > viewport.height():
            y = cursor.y() - LOUPE_OFFSET - h
        return QtCore.QPoint(max(x, 0), max(y, 0))

    def _update_loupe(self, x: float, y: float) -> None:
        if not self.loupe_enabled or self.display is None:
            self.loupe.hide()
            return
        import cv2  # here: not on the window's start path (about 0.1 s of CPU)

        self._fit_loupe()
        r, scale = self.loupe_radius, self.loupe_scale
        patch = cv2.getRectSubPix(self._grey_or_rgb8(), (2 * r + 1, 2 * r + 1), (float(round(x)), float(round(y))))
        big = cv2.resize(patch, None, fx=scale, fy=scale, interpolation=cv2.INTER_NEAREST)
        image = to_qimage(big)
        if image.format() == QtGui.QImage.Format.Format_Grayscale8:
            image = image.convertToFormat(QtGui.QImage.Format.Format_RGB888)
        painter = QtGui.QPainter(image)
        painter.setPen(QtGui.QPen(QtGui.QColor(*COLOURS["cursor"]), 1))
        # the exact cursor position inside the magnified patch (sub-pixel)
        cx = (x - round(x) + r + 0.5) * scale
        cy = (y - round(y) + r + 0.5) * scale
        painter.drawLine(QtCore.QPointF(cx, 0), QtCore.QPointF(cx, image.height()))
        painter.drawLine(QtCore.QPointF(0, cy), QtCore.QPointF(image.width(), cy))
        painter.end()
        self.loupe.setPixmap(QtGui.QPixmap.fromImage(image))
        vx, vy = item_from_pixels(np.array([x, y]))[0]
        cursor = self.graphics.mapFromScene(self.image_item.mapToScene(QtCore.QPointF(vx, vy)))
        self.loupe.move(self.loupe_position(cursor))
        self.loupe.show()

    def set_loupe_enabled(self, on: bool) -> None:
        self.loupe_enabled = bool(on)
        if not on:
            self.loupe.hide()

    def _grey_or_rgb8(self) -> np.ndarray:
        display = self.display
        if display.dtype != np.uint8:
            display = (display.astype(np.float32) * (255.0 / 65535.0)).astype(np.uint8)
        return display

    def leaveEvent(self, event: QtCore.QEvent) -> None:  # noqa: N802 (Qt's name)
        self.loupe.hide()
        self.graphics.set_cross(None)
        super().leaveEvent(event)

    # ------------------------------------------------------------------ marks
    def set_picks(self, pick: tuple[float, float] | None, proposal: tuple[float, float] | None,
                  curve: np.ndarray | None, weak: bool = False) -> None:
        """The temporary marks: this image's pick (red), the proposed conjugate (yellow; a ``weak`` one,
        which auto-match refused, cyan and dashed), the epipolar curve (orange, dashed)."""
        self.pick_item.set_points(item_from_pixels(np.array([pick])) if pick is not None else None)
        self.proposal_item.setPen(pen(COLOURS["weak proposal"], 2, dashed=True) if weak else
                                  pen(COLOURS["proposal"], 2))
        self.proposal_weak = weak
        self.proposal_item.set_points(item_from_pixels(np.array([proposal])) if proposal is not None else None)
        self.curve_item.set_points(item_from_pixels(curve) if curve is not None and len(curve) > 1 else None)

    def set_digitising(self, pixels: np.ndarray | None) -> None:
        """The vertices (N, 2) of the object being digitised, joined in order (None or none: nothing)."""
        view = None if pixels is None or not len(pixels) else item_from_pixels(np.asarray(pixels, float).reshape(-1, 2))
        self.digitising_item.set_points(view)
        self.digitising_vertices.set_points(view)

    #: Above this many outlines in view they are drawn with a thin, aliased pen (a wide antialiased pen
    #: costs Qt's stroker about a second per redraw of 10,000 outlines).
    THIN_ABOVE = 300
    #: Above this many outlines in (or near) the view, the pane shows the raster of all of them instead of
    #: stroking each (2,000 thin outlines cost Qt's stroker about 10 ms a redraw, 100,000 about 0.3 s).
    MAX_PATHS = 2000
    #: The raster's longer side at most (raster pixels; an image larger than this is drawn over at less
    #: than its own resolution).
    RASTER_SIDE = 2048
    #: Outlines this fraction of the view's size beyond its edges are stroked too: a pan shows them at once.
    MARGIN = 0.5
    #: The raster is built when the outlines have not changed for this long (ms).
    RASTER_WAIT_MS = 60

    def set_outlines(self, outlines: OutlineSet | None, side: int) -> None:
        """The stored objects' outlines (image ``side`` of ``outlines``: 0 left, 1 right), drawn at a level of
        detail: the ones in or near the view stroked one by one when there are at most :attr:`MAX_PATHS`,
        else all of them as one raster at (at most) image resolution, built off the GUI thread once per change
        of the set. Drawn again when the view moves (:meth:`_draw_outlines`) or this is called again."""
        self.outlines, self.outline_side = outlines, side
        self._draw_outlines()

    def outline_form(self) -> str:
        """How the stored outlines are drawn now: "paths" (stroked one by one), "raster" (with, while it is
        built again, the outlines stored since stroked over it) or "none"."""
        if self.raster_item.isVisible():
            return "raster"
        return "paths" if len(self.object_lines()) else "none"

    def _outlines_in_view(self) -> np.ndarray:
        """Indices of the outlines in or near the view (:attr:`MARGIN`)."""
        rect = self.view_rect()
        dx, dy = rect.width() * self.MARGIN, rect.height() * self.MARGIN
        return self.outlines.in_rect(self.outline_side, rect.left() - dx - PIXEL_CENTRE, rect.top() - dy - PIXEL_CENTRE,
                                     rect.right() + dx - PIXEL_CENTRE, rect.bottom() + dy - PIXEL_CENTRE)

    def _draw_outlines(self) -> None:
        """Stroke the outlines near the view, or show the raster when there are too many (built when stale)."""
        outlines = self.outlines
        if outlines is None or not len(outlines):
            self._set_lines(self.outlines_item, (), False)
            self.raster_item.hide()
            return
        near = self._outlines_in_view()
        if len(near) <= self.MAX_PATHS:
            thin = len(near) > self.THIN_ABOVE
            self.outlines_item.setPen(pen(COLOURS["object"], 1 if thin else 2))
            self._set_lines(self.outlines_item, outlines.lines(self.outline_side, near), thin)
            self.raster_item.hide()
            return
        added = None
        if self._raster_version != outlines.version:
            self._raster_timer.start()
            if self._raster_version >= 0:  # outlines stored since the raster: stroked over it meanwhile
                added = outlines.added_since(self._raster_version, self._raster_count)
        if added is not None and len(added) <= self.MAX_PATHS:
            self._set_lines(self.outlines_item, outlines.lines(self.outline_side, added), True)
        else:
            self._set_lines(self.outlines_item, (), True)
        self.raster_item.setVisible(self._raster_version >= 0)

    def _build_raster(self) -> None:
        """Draw the raster of every outline in a worker (one at a time; a stale one is built again)."""
        if self._raster_worker is not None or self.display is None or self.outlines is None:
            return
        from usvips.gui.qt import worker

        outlines, side = self.outlines.copy(), self.outline_side
        (w, h), colour, longest = self.image_size(), COLOURS["object"], self.RASTER_SIDE

        def job(progress, cancelled):
            mask = raster(outlines, side, w, h, longest)
            rgba = np.zeros(mask.shape + (4,), np.uint8)
            rgba[..., :3] = colour
            rgba[..., 3] = mask // 255 * RASTER_ALPHA
            return outlines.version, len(outlines), raster_scale(w, h, longest), rgba

        self._raster_worker = worker.Worker(job, "drawing the stored outlines")
        self._raster_worker.signals.finished.connect(self._raster_built)
        self._raster_worker.signals.failed.connect(self._raster_failed)
        worker.start(self._raster_worker)

    def _raster_built(self, result) -> None:
        self._raster_worker = None
        version, count, scale, rgba = result
        h, w = rgba.shape[:2]
        image = QtGui.QImage(rgba.data, w, h, 4 * w, QtGui.QImage.Format.Format_RGBA8888)
        self.raster_item.setPixmap(QtGui.QPixmap.fromImage(image))
        self.raster_item.setTransform(QtGui.QTransform.fromScale(1.0 / scale, 1.0 / scale))
        self._raster_version, self._raster_count = version, count
        self._draw_outlines()  # shown now, or built again when the outlines changed meanwhile

    def _raster_failed(self, message: str) -> None:
        self._raster_worker = None
        self._raster_version = -1

    def object_lines(self) -> np.ndarray:
        """The stored outline points stroked one by one now (view coordinates, NaN separators left out)."""
        points = self.outlines_item.points()
        return points[np.isfinite(points).all(axis=1)]

    @staticmethod
    def _set_lines(item: Lines, lines, thin: bool) -> None:
        item.set_points(item_from_pixels(lines), antialias=not thin)

    def set_selection_marks(self, selected: np.ndarray, vertices: np.ndarray,
                            labels: list[tuple[str, tuple[float, float], bool]], count: int) -> None:
        """What changes with the selection: the selected outlines (K, 2) pixels, NaN-separated, drawn over
        the others; vertex marks (M, 2) pixels; labels (text, pixel of the first vertex, selected)."""
        for label in self.labels:
            self.remove_mark(label)
        self.labels = []
        self.selected_item.set_points(item_from_pixels(selected), antialias=count <= self.THIN_ABOVE)
        self.vertex_item.set_points(item_from_pixels(vertices))
        for text, pixel, is_selected in labels:
            item = MarkLabel(text, COLOURS["selected" if is_selected else "label"], (0, 1), boxed=False)
            view = item_from_pixels(np.array([pixel]))[0]
            item.home = QtCore.QPointF(float(view[0]) + 4, float(view[1]) - 4)  # its point (view coordinates)
            item.setPos(item.home)
            self.add_mark(item)
            self.labels.append(item)
        self.layout_labels()

    #: above this many labels in view, they are not moved apart (the layout would cost a visible pause)
    MAX_LAID_OUT = 60

    def layout_labels(self) -> None:
        """Move the labels in view apart so that none covers another (:func:`usvips.gui.label_layout.
        stack_labels`, in screen pixels: labels keep their size on screen, so this is redone on a zoom), and
        left of the view's right edge (:func:`~usvips.gui.label_layout.keep_inside`)."""
        rect = self.view_rect()
        shown = [item for item in self.labels if rect.contains(item.home)]
        for item in self.labels:
            item.shift_by(0.0)
        if not shown or len(shown) > self.MAX_LAID_OUT:
            return
        boxes = [item.screen_rect(self.graphics) for item in shown]
        anchors = np.array([[box.left(), box.bottom()] for box in boxes])
        sizes = np.array([[box.width(), box.height()] for box in boxes])
        shifts = keep_inside(anchors[:, 0], sizes[:, 0], self.graphics.viewport().width())
        anchors[:, 0] += shifts
        offsets = stack_labels(anchors, sizes) if len(shown) > 1 else np.zeros(1)
        for item, shift, offset in zip(shown, shifts, offsets, strict=True):
            if offset or shift:
                item.shift_by(float(offset), float(shift))

    def layout_control_labels(self) -> None:
        """Move the target numbers in view apart so that none runs into another ("17" beside "8" never reads
        "178"): :func:`usvips.gui.label_layout.stack_labels` over their boxes in screen pixels, redone after a
        zoom or pan; beyond :attr:`MAX_LAID_OUT` in view each keeps its place (its dark box still sets it
        apart)."""
        rect = self.view_rect()
        shown = [label for label in self.control_labels if rect.contains(label.pos())]
        for label in self.control_labels:
            label.shift_by(0.0)
        if len(shown) < 2 or len(shown) > self.MAX_LAID_OUT:
            return
        boxes = [label.screen_rect(self.graphics) for label in shown]
        anchors = np.array([[box.left(), box.bottom()] for box in boxes])
        sizes = np.array([[box.width(), box.height()] for box in boxes])
        for label, offset in zip(shown, stack_labels(anchors, sizes, gap=3.0), strict=True):
            if offset:
                label.shift_by(float(offset))

    def set_control(self, marks: list[tuple[str, tuple[float, float]]], selected: str | None = None) -> None:
        """Measured control points of this image: (target number, pixel), drawn as green rings with numbers;
        the ``selected`` one (e.g. the row chosen in a table) in the selection colour, with a larger ring."""
        for label in self.control_labels:
            self.remove_mark(label)
        self.control_labels = []
        pixels = np.array([pixel for _, pixel in marks], float).reshape(-1, 2)
        self.control_item.set_points(item_from_pixels(pixels))
        chosen = [k for k, (name, _) in enumerate(marks) if name == selected]
        self.control_selected_item.set_points(item_from_pixels(pixels[chosen]) if chosen else None)
        self.selected_control = marks[chosen[0]][0] if chosen else None
        for (name, _), view in zip(marks, item_from_pixels(pixels), strict=True):
            text = MarkLabel(name, COLOURS["selected" if name == selected else "control"], (-0.3, 1.1))
            text.setPos(float(view[0]), float(view[1]))
            self.add_mark(text)
            self.control_labels.append(text)
        self.layout_control_labels()

    def centre_on(self, pixel: tuple[float, float]) -> None:
        """Pan so that ``pixel`` is in the middle, keeping the zoom."""
        self.zoom_to(self.zoom_level(), pixel)

    def in_view(self, pixel: tuple[float, float], margin: float = 0.1) -> bool:
        """Whether ``pixel`` is shown, at least ``margin`` (a fraction of the view) inside its edges."""
        rect = self.view_rect()
        x, y = item_from_pixels(np.array(pixel))[0]
        dx, dy = rect.width() * margin, rect.height() * margin
        return rect.left() + dx <= x <= rect.right() - dx and rect.top() + dy <= y <= rect.bottom() - dy

    def bring_into_view(self, pixel: tuple[float, float]) -> None:
        """Pan to ``pixel`` (keeping the zoom) when it is not well inside the view: a point proposed off
        the zoomed view is seen before it is accepted."""
        if not self.in_view(pixel):
            self.centre_on(pixel)
