"""Whether a panel is on screen, and a call when it comes there: what lets a panel leave its work (a
survey's 10,000 rows, a plot of every object) until someone can see it.

Qt 6 keeps a dock's panel "visible" while its tab is behind another (``isVisible()`` is true, its visible
region empty), so ``isVisible()`` alone would make every tabbed panel do its work at once. A panel that is
on screen is visible *and* has a visible region; it comes on screen when it is shown (a closed dock opened)
or when its dock's tab is brought to the front (the dock's ``visibilityChanged``).
"""

from __future__ import annotations

from collections.abc import Callable

from PySide6 import QtCore, QtWidgets


def on_screen(widget: QtWidgets.QWidget) -> bool:
    """``widget`` is shown and not a tab behind another (nor covered whole by its parents)."""
    return widget.isVisible() and not widget.visibleRegion().isEmpty()


class ScreenWatch(QtCore.QObject):
    """Calls ``shown()`` each time ``widget`` comes on screen: when it is shown, and when the tab of the
    dock holding it comes to the front (the dock is found when the widget is first shown: panels are made
    before they are put in their docks)."""

    def __init__(self, widget: QtWidgets.QWidget, shown: Callable[[], None]) -> None:
        super().__init__(widget)
        self.widget, self._shown = widget, shown
        self._dock: QtWidgets.QDockWidget | None = None
        widget.installEventFilter(self)

    def eventFilter(self, watched: QtCore.QObject, event: QtCore.QEvent) -> bool:  # noqa: N802 (Qt's name)
        # getattr: a watch whose Python side a garbage collection has already cleared (its widget being
        # destroyed with it) may still be asked about that widget's last events
        if watched is getattr(self, "widget", None) and event.type() == QtCore.QEvent.Type.Show:
            self._find_dock()
            # laid out by the next turn of the event loop (a tab behind another is "shown" out of the window)
            QtCore.QTimer.singleShot(0, self, self._check)
        return False

    def _find_dock(self) -> None:
        if self._dock is not None:
            return
        parent = self.widget.parentWidget()
        while parent is not None and not isinstance(parent, QtWidgets.QDockWidget):
            parent = parent.parentWidget()
        if parent is not None:
            self._dock = parent
            parent.visibilityChanged.connect(self._on_visibility)

    def _on_visibility(self, visible: bool) -> None:
        shown = getattr(self, "_shown", None)
        if visible and shown is not None:
            shown()

    def _check(self) -> None:
        widget = getattr(self, "widget", None)
        shown = getattr(self, "_shown", None)
        if widget is not None and shown is not None and on_screen(widget):
            shown()
