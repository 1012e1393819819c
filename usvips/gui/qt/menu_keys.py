"""An open menu keeps its letters: while a menu is open over the images, a letter typed is the menu's
mnemonic, not an image key (I, T, P, S, L…).

Under X11 Qt asks the open menu (or, depending on the window manager, the focused image) whether it
overrides a shortcut; a menu says no for letters, so Qt finds the image key (whose context is "the
images and their children", still holding the focus under the menu) and triggers it: Alt+F then I listed
the instants instead of choosing *Add image pairs…*. The filter answers that override with yes while a
menu is open; Qt then hands the key to the menu."""

from __future__ import annotations

from PySide6 import QtCore, QtWidgets

#: modifiers with which a letter is still a menu's mnemonic
_PLAIN = (QtCore.Qt.KeyboardModifier.NoModifier, QtCore.Qt.KeyboardModifier.ShiftModifier,
          QtCore.Qt.KeyboardModifier.KeypadModifier)


class MenuKeysFirst(QtCore.QObject):
    """Install on the window's menus and on the widgets that hold the images' keyboard (:func:`install`)."""

    def eventFilter(self, watched: QtCore.QObject, event: QtCore.QEvent) -> bool:  # noqa: N802 (Qt's name)
        if event.type() == QtCore.QEvent.Type.ShortcutOverride and menu_open() \
                and event.modifiers() in _PLAIN and event.text().strip():
            event.accept()  # overridden: Qt delivers the key to the open menu
            return True
        return False


def install(window: QtWidgets.QMainWindow, image_widgets) -> MenuKeysFirst:
    """Let every menu of ``window``'s menu bar (and their submenus) keep its letters over the image keys
    of ``image_widgets``; returns the filter (owned by the window)."""
    keys = MenuKeysFirst(window)
    for widget in [*window.menuBar().findChildren(QtWidgets.QMenu), *image_widgets]:
        widget.installEventFilter(keys)
    return keys


def menu_open() -> bool:
    """A menu (or its submenu) is open."""
    return isinstance(QtWidgets.QApplication.activePopupWidget(), QtWidgets.QMenu)


__all__ = ["MenuKeysFirst", "install", "menu_open"]
