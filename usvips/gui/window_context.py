"""What a panel or a controller of the window is handed instead of the window (free of Qt): the workspace
with its models, the messaging service and the runner of long work. A part of the window built from this
calls no window method, so it can be made and tested without one (see :mod:`usvips.gui.panel_registry`)."""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
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
class Navigation:
    """What a dialog may ask the window to show, each a plain callable (the window's are its own methods;
    a test passes recorders): ``open_project(path)`` opens a project file or sample folder (False when it
    could not), ``show_pair(label)`` reads and shows an image pair, ``pairs_changed()`` relists the pairs,
    ``videos_changed(project)`` relists the videos, ``show_video(label, after)`` shows a video's first
    frame and calls ``after()`` once it is shown (False when it could not), ``hint(text, level)`` sets the
    line above the images without logging it again, ``show_review()`` opens review mode on the unreviewed
    objects, ``media_resolved(stored_paths)`` says that those media files were accepted or relocated, so
    that the media warning no longer names them (None where a part cannot)."""

    open_project: Callable[[str | Path], bool]
    show_pair: Callable[[str], None]
    pairs_changed: Callable[[], None]
    videos_changed: Callable[[Any], None]
    show_video: Callable[[str, Callable[[], None] | None], bool]
    hint: Callable[[str, str], None]
    show_review: Callable[[], None] | None = None
    media_resolved: Callable[[Sequence[str]], None] | None = None


@dataclass(frozen=True)
class WindowContext:
    """``workspace``: the open project and its models; ``messages``: what to say to the user
    (:class:`usvips.gui.messages.Messages`); ``jobs``: long work off the GUI thread with progress and cancel
    (:class:`usvips.gui.qt.jobs.Jobs`), None where a part runs none; ``navigation``: what a dialog may ask
    the window to show (:class:`Navigation`), None where a part asks nothing; ``settings``: where choices are
    kept between sessions (the window's ``QSettings``: ``value(key, default)``, ``setValue(key, value)``);
    ``panes``: the stereo panes by side ("left", "right") for a tool that draws on the images."""

    workspace: Workspace
    messages: Messages
    jobs: Jobs | None = None
    navigation: Navigation | None = None
    settings: Any | None = None
    panes: Mapping[str, Any] | None = None

    def start_folder(self, name: str = "") -> str:
        """Where a file dialog opens: the open project's folder (else the home folder), with ``name``."""
        project = self.workspace.project
        folder = project.path.parent if project is not None else Path.home()
        return str(folder / name) if name else str(folder)

    def need_project(self):
        """The open project, or None after saying that one must be opened or created first."""
        project = self.workspace.project
        if project is None:
            self.messages.error("open or create a project first (File › New project…)")
        return project


__all__ = ["Jobs", "Navigation", "WindowContext"]
