"""The window's status bar: a message never runs under the readouts on its right.

Qt's own status bar draws a temporary message across its whole width, under the permanent widgets (the
3-D point and pixel readouts, the progress bar): a long message was unreadable there. This one draws it
elided (…) to the room left of the first visible permanent widget; :meth:`currentMessage` keeps the whole
text (the hint line above the images and the log show it whole too)."""

from __future__ import annotations

from PySide6 import QtCore, QtGui, QtWidgets

#: pixels between the message and the first readout
GAP_PX = 12


class StatusBar(QtWidgets.QStatusBar):
    """A :class:`QStatusBar` whose temporary message is elided before the permanent widgets."""

    def __init__(self, parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(parent)
        self._permanent: list[QtWidgets.QWidget] = []

    def addPermanentWidget(self, widget: QtWidgets.QWidget, stretch: int = 0) -> None:  # noqa: N802 (Qt's name)
        self._permanent.append(widget)
        super().addPermanentWidget(widget, stretch)

    def message_rect(self) -> QtCore.QRect:
        """Where the message is drawn: from the left margin to the first visible permanent widget."""
        right = min((w.x() for w in self._permanent if w.isVisible() and w.width() > 0), default=self.width())
        return QtCore.QRect(6, 0, max(0, right - GAP_PX - 6), self.height())

    def shown_message(self) -> str:
        """The message as drawn: on one line, elided to :meth:`message_rect`."""
        text = " ".join(self.currentMessage().split())
        return self.fontMetrics().elidedText(text, QtCore.Qt.TextElideMode.ElideRight, self.message_rect().width())

    def paintEvent(self, event: QtGui.QPaintEvent) -> None:  # noqa: N802 (Qt's name)
        if not self.currentMessage():
            super().paintEvent(event)
            return
        painter = QtGui.QPainter(self)
        painter.setPen(self.palette().color(QtGui.QPalette.ColorRole.WindowText))
        align = QtCore.Qt.AlignmentFlag
        flags = align.AlignLeft | align.AlignVCenter | QtCore.Qt.TextFlag.TextSingleLine
        painter.drawText(self.message_rect(), int(flags), self.shown_message())
        painter.end()
