"""``usvips open [PROJECT]``: the workstation window (also what ``usvips`` with no arguments runs).

The one place outside ``usvips.gui`` that reaches into it: the import is deferred so that every other
command starts without loading Qt (declared in the import-linter contracts of pyproject.toml).

Hidden switch: with ``USVIPS_QUIT_WHEN_READY=1`` in the environment the window quits as soon as it is
usable (shown, the project opened, its first pair drawn): the start-up probe ``usvips bench`` times
(:mod:`usvips.gui.qt.ready`).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from usvips.core.errors import InputFileError, InvalidParameterError


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser("open", help="the workstation window, optionally on a project or sample")
    parser.add_argument("project", nargs="?", help="a project file (*.usvips), a sample directory or a "
                        "survey on a server (postgresql://…)")
    parser.add_argument("--pair", help="the image pair to show first (default: the one shown last, or the first)")
    parser.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    from usvips.store.location import is_server_location

    if args.project is not None and not is_server_location(args.project) and not Path(args.project).exists():
        raise InputFileError(args.project, "no such project file or sample directory")
    if args.pair and args.project is None:
        raise InvalidParameterError("--pair", "needs a project to open")
    from usvips.gui import start

    start.before_qt()  # no collection while starting; the window's Qt-free modules imported first
    from usvips.gui.qt import ready
    from usvips.gui.qt.app import application
    from usvips.gui.qt.app import run as run_window

    if ready.wanted():  # the start-up probe of ``usvips bench`` (USVIPS_QUIT_WHEN_READY=1, see gui/ready.py)
        ready.quit_when_ready(application(), args.project is not None)
    return run_window(args.project, args.pair)
