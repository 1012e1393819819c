"""What a panel or a controller of the window is handed instead of the window (free of Qt): the workspace
with its models, the messaging service and the runner of long work. A part of the window built from this
calls no window method, so it can be made and tested without one (see :mod:`usvips.gui.panel_registry`)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Protocol

from usvips.gui.messages import Messages
from usvips.gui.workspace import Workspace


class Jobs(Protocol):
    """Runs long work off the GUI thread (the window's is :class:`usvips.gui.qt.jobs.Jobs`, over a Qt pool)."""

    workers: set
    pool: Any

    @property
    def busy(self) -> bool: ...

    def run(self, job: Callable, label: str, on_done: Callable[[object], None],
            on_cancelled: Callable[[], None] | None = None) -> Any: ...

    def cancel_all(self) -> None: ...


@dataclass(frozen=True)
class WindowContext:
    """``workspace``: the open project and its models; ``messages``: what to say to the user
    (:class:`usvips.gui.messages.Messages`); ``jobs``: long work off the GUI thread with progress and cancel
    (:class:`usvips.gui.qt.jobs.Jobs`), None where a part runs none."""

    workspace: Workspace
    messages: Messages
    jobs: Jobs | None = None


__all__ = ["Jobs", "WindowContext"]
