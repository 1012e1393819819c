"""An open menu keeps its letters: while a menu is open over the images, a letter typed is the menu's
mnemonic, not an image key (I, T, P, S, L…).

Under X11 an open menu does not take the keyboard focus from the window, so Qt asks the focused image
whether it overrides a shortcut, finds the image key (whose context is "the images and their children")
and triggers it: Alt+F then I listed the instants instead of choosing *Add image pairs…*. The filter
answers that override for the focused image while a menu is open; Qt then hands the key to the menu."""

from __future__ import annotations

from PySide6 import QtCore, QtWidgets

#: modifiers with which a letter is still a menu's mnemonic
_PLAIN = (QtCore.Qt.KeyboardModifier.NoModifier, QtCore.Qt.KeyboardModifier.ShiftModifier,
          QtCore.Qt.KeyboardModifier.KeypadModifier)


class MenuKeysFirst(QtCore.QObject):
    """Install on the widgets that hold the images' keyboard (the panes' views)."""

    def eventFilter(self, watched: QtCore.QObject, event: QtCore.QEvent) -> bool:  # noqa: N802 (Qt's name)
        if event.type() == QtCore.QEvent.Type.ShortcutOverride and menu_open() \
                and event.modifiers() in _PLAIN and event.text().strip():
            event.accept()  # overridden: Qt delivers the key to the open menu
            return True
        return False


def menu_open() -> bool:
    """A menu (or its submenu) is open."""
    return isinstance(QtWidgets.QApplication.activePopupWidget(), QtWidgets.QMenu)


__all__ = ["MenuKeysFirst", "menu_open"]
