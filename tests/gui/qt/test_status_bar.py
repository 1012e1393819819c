"""A long status message is drawn elided before the readouts, never under them; the whole text is kept."""

from PySide6 import QtWidgets


def test_a_long_message_stops_before_the_readouts_and_is_kept_whole(qtbot, make_window):
    window = make_window()
    qtbot.waitExposed(window)
    window.pixel_label.setText("left (123.4, 456.7) px  grey 128")
    window.point_label.setText("X 1.234 Y -0.456 Z 3.210 m")
    long = "object 12 was changed by ann at 09:41; " * 12
    window.show_message("warning", long)
    QtWidgets.QApplication.processEvents()
    bar = window.statusBar()
    assert bar.currentMessage() == long  # kept whole (the log and the hint line have it too)
    rect = bar.message_rect()
    readouts = min(w.x() for w in (window.point_label, window.pixel_label) if w.isVisible())
    assert 0 < rect.right() < readouts
    shown = bar.shown_message()
    assert shown.endswith("…") and bar.fontMetrics().horizontalAdvance(shown) <= rect.width()
    bar.grab()  # paints without error
    window.show_message("info", "stored object 3")
    assert bar.shown_message() == "stored object 3"
