"""The video machinery the window uses, imported when first used rather than at the window's start (its
start-up: ``tests/gui/qt/test_start_imports.py``). Each function imports its module where it is called, not
lazily at the top of a module, so that any thread may be the first to ask: the import lock guards it."""

from __future__ import annotations

from types import ModuleType


def video_project() -> ModuleType:
    """:mod:`usvips.app.video_project`."""
    from usvips.app import video_project as module

    return module


def video_proxy() -> ModuleType:
    """:mod:`usvips.io.video_proxy`."""
    from usvips.io import video_proxy as module

    return module


def video_stream() -> ModuleType:
    """:mod:`usvips.io.video_stream`."""
    from usvips.io import video_stream as module

    return module
