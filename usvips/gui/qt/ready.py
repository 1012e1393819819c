"""The start-up probe: quit the workstation as soon as it is usable (``USVIPS_QUIT_WHEN_READY=1``).

A hidden switch for ``usvips bench`` (the window's start-up row, :mod:`usvips.bench.startup`) and for
anyone timing the start: with the environment variable ``USVIPS_QUIT_WHEN_READY`` set (to anything but
``0``), ``usvips open PROJECT`` starts as usual — the window shown, the project opened, its first image
pair read and drawn — and then quits, saying on stderr which pair it showed. Exit codes: 0 ready; 3
nothing was drawn within :data:`TIMEOUT_S` seconds; 4 the project did not open (the reason is printed on
stderr). Without a project it quits once the empty window is shown. A project that opens on a stereo
video is ready when its first frame pair is shown (the workspace shows it as a pair).
"""

from __future__ import annotations

import os
import sys

from PySide6 import QtCore, QtWidgets

#: the environment variable that asks for the probe
ENVIRONMENT = "USVIPS_QUIT_WHEN_READY"
#: how long the probe waits for the first pair (s) before giving up with exit code 3
TIMEOUT_S = 120.0


def wanted() -> bool:
    """Whether the probe is asked for (``USVIPS_QUIT_WHEN_READY`` set, and not to ``0``)."""
    return os.environ.get(ENVIRONMENT, "0").strip() not in ("", "0")


def _window() -> QtWidgets.QWidget | None:
    """The workstation window (the top-level widget holding a workspace)."""
    return next((w for w in QtWidgets.QApplication.topLevelWidgets() if hasattr(w, "workspace")), None)


def quit_when_ready(app: QtWidgets.QApplication, project_given: bool) -> None:
    """Arrange for ``app`` to quit once the window is usable: checked when the event loop starts (the
    window is built and the project opened by then, its first pair being read in a worker), then on the
    workspace's ``pair_changed`` (after every view has drawn the pair), then one repaint of the window."""

    def finish(code: int, why: str = "") -> None:
        if why:
            print(f"{ENVIRONMENT}: {why}", file=sys.stderr)
        window = _window()
        if window is not None and code == 0:
            window.repaint()  # the pair's pixels painted, not only handed to the views
            shown = window.workspace.pair
            print(f"{ENVIRONMENT}: ready, " + (f"pair {shown!r} shown" if shown else "no pair shown"), file=sys.stderr)
        app.exit(code)

    def drawn() -> None:
        window = _window()
        if window is not None:
            window.workspace.pair_changed.disconnect(drawn)
        QtCore.QTimer.singleShot(0, lambda: finish(0))

    def attach() -> None:
        window = _window()
        if window is None:
            finish(4, "no workstation window was shown")
        elif not project_given:
            finish(0)
        elif window.workspace.project is None:
            finish(4, "the project did not open (see the window's message)")
        elif window.workspace.images:
            finish(0)
        else:
            window.workspace.pair_changed.connect(drawn)

    QtCore.QTimer.singleShot(0, attach)
    QtCore.QTimer.singleShot(int(TIMEOUT_S * 1000), lambda: finish(3, f"no pair was drawn within {TIMEOUT_S:g} s"))
