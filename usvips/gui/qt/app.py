"""Start the workstation: a QApplication, the main window, optionally a project opened in it.

Unexpected errors in Qt handlers are caught by :mod:`usvips.gui.qt.error_report`.
"""

from __future__ import annotations

import sys
from pathlib import Path

from PySide6 import QtWidgets

from usvips.gui.qt.error_report import install_error_handler
from usvips.gui.qt.gui_thread_gc import collect_on_the_gui_thread, keep_long_lived


def application() -> QtWidgets.QApplication:
    app = QtWidgets.QApplication.instance() or QtWidgets.QApplication(sys.argv[:1])
    app.setOrganizationName("USVIPS")
    app.setApplicationName("usvips")
    return app


def run(project: str | Path | None = None, pair: str | None = None) -> int:
    """Show the main window (opening ``project``, a ``*.usvips`` file or a sample directory, on ``pair``)
    and run the event loop; returns the exit code."""
    app = application()
    install_error_handler()
    collect_on_the_gui_thread()
    from usvips.gui.qt.main_window import MainWindow  # the window's modules only when a window is shown

    window = MainWindow()
    window.show()
    if project is not None:
        window.open_path(project, pair)
    keep_long_lived()  # the modules, the window and the project made so far: no collection scans them again
    return app.exec()
