"""The window's commands are declared once (usvips.gui.commands) and the menus, shortcuts and the key list
are built from that declaration: every key binding is unique where it works, every command is in a menu
(or a key of its own place), every handler names a method that exists, and the menu names are the
README's."""

import html
import re
from pathlib import Path

import pytest
from PySide6 import QtGui, QtWidgets

from usvips.gui import commands
from usvips.gui.commands import Command, Section, Submenu

ROOT = Path(__file__).resolve().parents[2]


def _portable(key: str) -> list[str]:
    """A declared key as every sequence Qt binds it to on this platform (a standard key may be several)."""
    if key.startswith("std:"):
        return [k.toString() for k in QtGui.QKeySequence.keyBindings(getattr(QtGui.QKeySequence.StandardKey, key[4:]))]
    return [QtGui.QKeySequence(key).toString()]


def test_every_key_binding_is_unique_where_it_works(qapp):
    """A key means one command: a window-wide key is bound once in the whole window; a key of the images
    (or of the object list) once among the keys that reach there (its own and the window's)."""
    bound: dict[str, list[tuple[str, str]]] = {}
    for command in commands.commands():
        for key in command.keys:
            for sequence in _portable(key):
                assert sequence, f"{command.id}: {key!r} is not a key Qt knows"
                bound.setdefault(sequence, []).append((command.id, command.scope))
    clashes = {key: ids for key, ids in bound.items()
               if len(ids) > 1 and (len({scope for _, scope in ids}) < len(ids) or "window" in {s for _, s in ids})}
    assert clashes == {}
    assert len(bound) > 40


def test_every_command_is_in_a_menu_of_the_menu_bar():
    """Each command is listed in a declared menu or submenu, except the object list's own key (in the
    list's context menu), and every submenu hangs in a declared menu."""
    menus = {name for name, _ in commands.MENUS} | {i.path for i in commands.ITEMS if isinstance(i, Submenu)}
    for item in commands.ITEMS:
        assert item.menu in menus if not isinstance(item, Command) or item.scope != "object list" else True, item
    unlisted = [c.id for c in commands.commands() if c.menu is None]
    assert unlisted == ["instants_of_listed"]
    ids = [c.id for c in commands.commands()]
    assert len(ids) == len(set(ids))


def test_the_window_builds_its_menus_and_keys_from_the_declaration(make_window):
    window = make_window()
    listed = {}

    def walk(menu: QtWidgets.QMenu) -> None:
        for action in menu.actions():
            if action.menu() is not None:
                walk(action.menu())
            elif not action.isSeparator():
                listed[id(action)] = action

    for action in window.menuBar().actions():
        walk(action.menu())
    for command in commands.commands():
        action = window.actions[command.id]
        assert action.text() == command.title
        assert (id(action) in listed) == (command.menu is not None), command.id
        bound = [k.toString() for k in action.shortcuts() if not k.isEmpty()]
        assert bound == [p[0] for p in map(_portable, command.keys) if p], command.id
    # the panels' docks are listed in View, where the declaration leaves a section for them
    assert any(isinstance(i, Section) and i.menu == "View" for i in commands.ITEMS)
    assert window.docks["log"].toggleViewAction() in window.menus["View"].actions()
    assert window.docks["qa"].toggleViewAction() not in window.menus["View"].actions()  # "QA panel" lists it
    # Help › Keys lists every command with keys, from the same declaration
    text = window.keys_text()
    assert all(html.escape(c.title.replace("&", "")) in text for c in commands.commands() if c.keys)
    dialog = window.show_keys()
    assert dialog.isVisible() and dialog.height() <= 720
    dialog.close()
    # an enablement condition is the window's: nothing to undo, Undo is disabled, and enabled after a step
    assert not window.actions["undo"].isEnabled()


def test_every_handler_names_a_method_its_owner_has(make_window):
    from usvips.gui.qt import detection_dialogs, exchange_dialogs, media_dialogs

    window = make_window()
    owners = {"window": window, "tracking": window.tracking, "media_dialogs": media_dialogs,
              "exchange_dialogs": exchange_dialogs, "detection_dialogs": detection_dialogs}
    for command in commands.commands():
        owner, _, method = command.handler.rpartition(".")
        assert callable(getattr(owners[owner], method, None)), command.handler


def test_a_dialog_modules_command_calls_its_function_with_the_context_and_a_parent(make_window, monkeypatch):
    """The dialog modules are imported when one of their commands is first run (not at start-up); the
    command still reaches the module's function, handed the window's context, the window as the parent
    widget of its dialogs, and the command's arguments."""
    from usvips.gui.qt import exchange_dialogs, media_dialogs

    window = make_window()
    called = []
    monkeypatch.setattr(media_dialogs, "add_video", lambda *args: called.append(("add_video", args)))
    monkeypatch.setattr(exchange_dialogs, "edit_deployment", lambda *args: called.append(("deployment", args)))
    window.actions["add_video"].trigger()
    window.actions["deployment"].trigger()
    assert called == [("add_video", (window.context, window)), ("deployment", (window.context, window))]


def test_the_menu_names_the_readme_gives_are_the_windows():
    """Each 'Menu → *Entry*' of the README (and 'Menu › Entry…' of the user guide) names a declared entry
    of that menu (the README may shorten a title to its first words)."""
    titles = {}
    for item in commands.ITEMS:
        if isinstance(item, (Command, Submenu)) and item.menu is not None:
            titles.setdefault(item.menu.split("/")[0], []).append(item.title.replace("&", ""))
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    named = [(menu, entry) for menu, first, rest in re.findall(
                 r"\b(File|Edit|View|Measure|Calibration|Help) → \*([^*]+)\*((?: / \*[^*]+\*)*)", readme)
             for entry in [first, *re.findall(r"\*([^*]+)\*", rest)]]
    guide = (ROOT / "docs" / "user-guide.md").read_text(encoding="utf-8")
    named += re.findall(r"\b(File|Edit|View|Measure|Calibration|Help) › ([A-Z][^*›\n]*?…)", guide)
    assert len(named) > 10
    for menu, entry in named:
        assert any(t.startswith(entry.strip()) for t in titles[menu]), (menu, entry, titles[menu])


def test_a_command_declared_wrongly_is_refused():
    with pytest.raises(ValueError, match="scope 'dock'"):
        Command("x", "X", "window.x", scope="dock")
    with pytest.raises(ValueError, match="condition 'project_open'"):
        Command("x", "X", "window.x", enabled_when="project_open")
    with pytest.raises(ValueError, match="not owner.method"):
        Command("x", "X", "x")
