"""pyqtgraph, configured: every module of the window that draws a plot takes ``pg`` from here, so that the
global settings (row-major images as ARCHITECTURE.md has them, antialiased lines) are made once, when the
first plot is made — never at the window's start (importing pyqtgraph costs about half a second of CPU:
it makes every Qt type and enum; the stereo panes are plain Qt)."""

from __future__ import annotations

import pyqtgraph as pg

pg.setConfigOptions(imageAxisOrder="row-major", antialias=True)

__all__ = ["pg"]
