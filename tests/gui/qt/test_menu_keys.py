"""An open menu keeps its letters over the images: the focused image answers Qt's "override this
shortcut?" with yes while a menu is open (under X11 the menu does not take the focus, and Alt+F then I
listed the instants instead of choosing Add image pairs…), and with no while none is."""

from PySide6 import QtCore, QtGui, QtWidgets


def _overridden(graphics, key, text, modifiers=QtCore.Qt.KeyboardModifier.NoModifier) -> bool:
    """What Qt's shortcut map asks the focused widget first (as X11 delivers it)."""
    event = QtGui.QKeyEvent(QtCore.QEvent.Type.ShortcutOverride, key, modifiers, text)
    event.ignore()
    QtWidgets.QApplication.sendEvent(graphics, event)
    return event.isAccepted()


def test_a_letter_goes_to_the_open_menu_not_to_the_image_keys(qtbot, make_window):
    window = make_window()
    window.focus_images()
    graphics = window.panes["left"].graphics
    Key = QtCore.Qt.Key
    letters = [(Key.Key_I, "i"), (Key.Key_T, "t"), (Key.Key_S, "s"), (Key.Key_V, "v")]
    assert not any(_overridden(graphics, key, text) for key, text in letters)  # no menu: the image keys work
    file_menu = next(a.menu() for a in window.menuBar().actions() if a.text() == "&File")
    window.menuBar().setActiveAction(file_menu.menuAction())
    qtbot.waitUntil(lambda: QtWidgets.QApplication.activePopupWidget() is file_menu, timeout=5000)
    for asked in (graphics, file_menu):  # whichever Qt asks first (the window manager decides)
        assert all(_overridden(asked, key, text) for key, text in letters)  # the menu's mnemonics
    assert not _overridden(graphics, Key.Key_Z, "\x1a", QtCore.Qt.KeyboardModifier.ControlModifier)  # Ctrl+Z
    file_menu.close()
    qtbot.waitUntil(lambda: QtWidgets.QApplication.activePopupWidget() is None, timeout=5000)
    assert not _overridden(graphics, Key.Key_I, "i")
    # and the image key still does its work with no menu open
    window.activateWindow()
    qtbot.waitUntil(lambda: QtWidgets.QApplication.activeWindow() is window, timeout=5000)
    window.focus_images()
    qtbot.keyClick(graphics, Key.Key_I)
    assert "select one object to list its instants" in window.hint.text()
