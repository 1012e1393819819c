"""The window's Qt code: every module that imports PySide6 or pyqtgraph lives here, and only here
(tests/test_architecture.py holds every other module of usvips to that, by folder)."""
