"""USVIPS: a measurement workstation for underwater stereo imagery.

Layers (see ``shared/design/ARCHITECTURE.md``): ``usvips.core`` is pure computation (numpy, scipy,
OpenCV); ``usvips.io`` reads and writes files; ``usvips.store`` is the SQLite project; ``usvips.cli``
is the command line; ``usvips.gui`` is the PySide6 workstation. Nothing below the GUI imports Qt.
"""

__version__ = "0.1.0"
