"""The workstation window (PySide6 + pyqtgraph). Nothing outside this package imports it, except the
``usvips open`` command, which starts it (see ``usvips.cli.open``).

``workspace``, ``calculator`` and ``signals`` are Qt-free models; ``pane``, ``panels``, ``main_window``
and ``worker`` are the Qt views and controllers over them.
"""
