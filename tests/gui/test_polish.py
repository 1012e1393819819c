"""What a newcomer meets first: the empty window says how to begin (New project first); no two entries
of a menu share a mnemonic; the hint line wraps a long error instead of cutting it; file dialogs start in
the open project's folder."""

import re
from pathlib import Path

from PySide6 import QtWidgets


def _mnemonic(text: str) -> str | None:
    found = re.search(r"&([^&])", text.replace("&&", ""))
    return found.group(1).lower() if found else None


def test_the_empty_window_says_how_to_begin(make_window):
    window = make_window()
    text = window.statusBar().currentMessage()
    assert text.index("New project") < text.index("Open sample")


def test_no_two_entries_of_a_menu_share_a_mnemonic(make_window):
    window = make_window()
    menus = [a.menu() for a in window.menuBar().actions() if a.menu() is not None]
    menus += [a.menu() for m in list(menus) for a in m.actions() if a.menu() is not None]
    assert len(menus) > 5
    for menu in menus:
        letters = [_mnemonic(a.text()) for a in menu.actions() if not a.isSeparator()]
        letters = [x for x in letters if x is not None]
        assert len(letters) == len(set(letters)), (menu.title(), sorted(letters))
    bar = [_mnemonic(a.text()) for a in window.menuBar().actions()]
    assert len(bar) == len(set(bar))


def test_the_view_menu_lists_each_panel_once(make_window):
    """The View menu held both "QA panel" (Ctrl+Shift+Q) and the QA dock's own toggle "QA", and "Review
    mode" beside "Review": a panel with its own command is listed once, the other panels by their toggle."""
    window = make_window()
    view = next(a.menu() for a in window.menuBar().actions() if a.text().replace("&", "") == "View")
    texts = [a.text().replace("&", "") for a in view.actions() if not a.isSeparator()]
    assert "QA panel" in texts and "Review mode" in texts and "Objects" in texts and "Log" in texts
    assert "QA" not in texts and "Review" not in texts, texts


def test_a_long_error_wraps_on_the_hint_line_and_dialogs_start_in_the_project(make_window, sample_copy, qtbot):
    window = make_window()
    window.resize(1366, 768)
    long = "the calibration was not made active: " + "pair 'x' is 600 × 440 px but ... " * 12
    window.show_message("error", long)
    assert window.hint.text() == long and window.hint.wordWrap()
    assert window.start_folder() == str(Path.home())
    directory = sample_copy("tank_system1")
    assert window.open_path(directory)
    qtbot.waitUntil(lambda: window.workspace.pair is not None and not window.busy, timeout=10000)
    assert Path(window.start_folder("x.csv")) == directory / "x.csv"
    assert isinstance(window.hint, QtWidgets.QLabel)
