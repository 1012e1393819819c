"""The window's dock panels, contributed rather than wired into the window: each panel module declares a
:class:`Panel` (its id, title, dock area, tab group and a factory taking a
:class:`~usvips.gui.window_context.WindowContext` — the workspace's models, the messaging service and the
jobs, never the window) and :func:`register`\\ s it when imported. The window builds one dock per registered
panel (:func:`panels`, in their ``order``), tabs the panels of one group together and lists each under
View; a panel's widget is made when its dock is first shown or the panel is asked for. Adding a panel = one
module with its declaration (named in :data:`BUILT_IN` for the window's own panels, or registered by
whoever imports it) and its test; the window is not edited.

A panel widget may define ``on_shown(visible)`` (called when its dock comes to the front or goes) and
``cleanup()`` (called when the window closes). Free of Qt: the window turns ``area`` into a dock area."""

from __future__ import annotations

import importlib
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from usvips.gui.window_context import WindowContext

#: where a panel's dock goes, in words (the window maps them to Qt's dock areas)
AREAS = ("left", "right", "top", "bottom")
#: the modules that declare the window's own panels (imported when the panels are first listed)
BUILT_IN = ("usvips.gui.qt.enhancement_panel", "usvips.gui.qt.calculator_panel", "usvips.gui.qt.planner_dock",
            "usvips.gui.qt.object_list", "usvips.gui.qt.observation_form", "usvips.gui.qt.plan_view",
            "usvips.gui.qt.log_panel", "usvips.gui.qt.qa_dock", "usvips.gui.qt.review_dock")


@dataclass(frozen=True)
class Panel:
    """A dock panel: ``id`` (the window's ``docks[id]`` and ``panels[id]``), ``title`` (the dock's title and
    its View menu entry; the saved layout knows the dock by it), ``area`` (one of :data:`AREAS`),
    ``factory(context)`` → the panel's widget, ``group`` (panels of one area and group are tabbed
    together; the first in ``order`` is in front), ``order`` (docks are added, tabbed and listed in this
    order), ``size`` (pixels across its area at first start: width for left/right, height for
    top/bottom; None: as the panel asks), ``length`` (pixels along its area at first start, where docks
    share it: height for left/right, width for top/bottom; None: an even share), ``at_start`` (made with
    the window, not when its dock is first shown: a panel that must hear everything from the start, such as
    the log)."""

    id: str
    title: str
    area: str
    factory: Callable[[WindowContext], Any]
    group: str = ""
    order: int = 100
    size: int | None = None
    length: int | None = None
    at_start: bool = False

    def __post_init__(self) -> None:
        if self.area not in AREAS:
            raise ValueError(f"panel {self.id!r}: area {self.area!r} is not one of {AREAS}")
        if not self.id.isidentifier():
            raise ValueError(f"panel id {self.id!r} is not a plain name (letters, digits, underscores)")


_PANELS: dict[str, Panel] = {}
_loaded = False


def register(panel: Panel) -> Panel:
    """Add ``panel`` (a module imported twice registers the same panel again); another panel with the same
    id or title is refused. Returns ``panel``."""
    known = _PANELS.get(panel.id)
    if known is not None and known.title != panel.title:
        raise ValueError(f"panel id {panel.id!r} is registered twice")
    clash = [p.id for p in _PANELS.values() if p.title == panel.title and p.id != panel.id]
    if clash:
        raise ValueError(f"panel {panel.id!r}: the title {panel.title!r} is panel {clash[0]!r}'s")
    _PANELS[panel.id] = panel
    return panel


def unregister(panel_id: str) -> None:
    """Take a panel out (the next window is built without it)."""
    _PANELS.pop(panel_id, None)


def panels() -> tuple[Panel, ...]:
    """Every registered panel, the built-in ones imported first, in ``order`` then id."""
    global _loaded
    if not _loaded:
        for module in BUILT_IN:
            importlib.import_module(module)
        _loaded = True
    return tuple(sorted(_PANELS.values(), key=lambda p: (p.order, p.id)))


__all__ = ["AREAS", "BUILT_IN", "Panel", "panels", "register", "unregister"]
