"""A small plot of grey-level histograms in plain Qt (the enhancement panel's): curves of normalised counts
over the grey levels, a grey-level axis below, a legend in the top-left corner. Plain Qt because the panel
is shown with the window, whose start does without pyqtgraph; no mouse interaction."""

from __future__ import annotations

import numpy as np
from PySide6 import QtCore, QtGui, QtWidgets

from usvips.gui.qt.marks import pen, polyline_path

#: screen pixels: around the plot, and the height of the axis below it
MARGIN, AXIS = 6, 18


class HistogramView(QtWidgets.QWidget):
    """Named curves (colour, width) of counts per grey level, each scaled to its largest count."""

    def __init__(self, curves: dict[str, tuple[tuple[int, int, int], float]],
                 parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(parent)
        self.styles = dict(curves)
        self._counts: dict[str, np.ndarray] = {name: np.zeros(0) for name in curves}

    def set_counts(self, name: str, counts: np.ndarray | None) -> None:
        """Show ``counts`` (one per grey level) as the curve ``name``, scaled to its largest; None: nothing."""
        self._counts[name] = np.zeros(0) if counts is None else np.asarray(counts, np.float64).ravel()
        self.update()

    def counts(self, name: str) -> np.ndarray:
        """The curve ``name`` as drawn: its counts divided by the largest (at least 1)."""
        counts = self._counts[name]
        return counts / max(counts.max(), 1.0) if len(counts) else counts

    def _plot_rect(self) -> QtCore.QRectF:
        return QtCore.QRectF(self.rect()).adjusted(MARGIN, MARGIN, -MARGIN, -MARGIN - AXIS)

    def paintEvent(self, event: QtGui.QPaintEvent) -> None:  # noqa: N802 (Qt's name)
        painter = QtGui.QPainter(self)
        painter.setRenderHint(QtGui.QPainter.RenderHint.Antialiasing, True)
        area = self._plot_rect()
        levels = max((len(c) for c in self._counts.values()), default=0) or 256
        text = self.palette().color(QtGui.QPalette.ColorRole.WindowText)
        painter.setPen(pen((text.red(), text.green(), text.blue())))
        painter.drawLine(area.bottomLeft(), area.bottomRight())
        for level in range(0, levels, 50 if levels <= 256 else max(1, levels // 5)):
            x = area.left() + area.width() * level / max(levels - 1, 1)
            painter.drawLine(QtCore.QPointF(x, area.bottom()), QtCore.QPointF(x, area.bottom() + 4))
            painter.drawText(QtCore.QRectF(x - 20, area.bottom() + 4, 40, AXIS - 4),
                             QtCore.Qt.AlignmentFlag.AlignHCenter | QtCore.Qt.AlignmentFlag.AlignTop, str(level))
        for name, (colour, width) in self.styles.items():
            shown = self.counts(name)
            if len(shown) < 2:
                continue
            x = area.left() + area.width() * np.arange(len(shown)) / (len(shown) - 1)
            y = area.bottom() - area.height() * shown
            painter.setPen(pen(colour, width))
            painter.drawPath(polyline_path(np.column_stack([x, y])))
        self._legend(painter, area)
        painter.end()

    def _legend(self, painter: QtGui.QPainter, area: QtCore.QRectF) -> None:
        metrics = painter.fontMetrics()
        y = area.top() + 5
        for name, (colour, width) in self.styles.items():
            middle = y + metrics.height() / 2
            painter.setPen(pen(colour, width))
            painter.drawLine(QtCore.QPointF(area.left() + 8, middle), QtCore.QPointF(area.left() + 28, middle))
            painter.setPen(self.palette().color(QtGui.QPalette.ColorRole.WindowText))
            painter.drawText(QtCore.QPointF(area.left() + 34, y + metrics.ascent()), name)
            y += metrics.height() + 2
