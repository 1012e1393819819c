"""The window's start before Qt is imported (``usvips open`` calls :func:`before_qt` first).

Two things that cost CPU at every start and buy nothing there:

* **PySide's import hook.** Once PySide6 is imported, every module an import statement names is looked at
  by PySide's ``__feature__`` switch, which reads that module's whole source (``inspect.getsource``) to see
  whether it mentions PySide6 — about 0.2 ms of CPU a module, each module once. The window's Qt-free models
  (:data:`MODELS`: the ones its Qt modules name) imported *before* Qt bring their app, core, store and io
  modules with them unread; only the models themselves are read again, when a Qt module names them (about
  0.02 s of the start: 179 → 97 modules read on the ``tank_system1`` sample).
* **Automatic garbage collection.** The modules, the window's widgets and the opened project live as long as
  the program; the automatic collector would scan them again and again while they are made. Collection is
  off from here until the window is shown with its project open, when what was made is frozen
  (:func:`usvips.gui.qt.gui_thread_gc.keep_long_lived`) and the GUI thread's collector takes over.

Qt-free, so that it can run before Qt; a module missing from :data:`MODELS` only costs its reading.
"""

from __future__ import annotations

import gc
import importlib

#: the Qt-free modules the window's Qt modules import (their own imports come with them)
MODELS = ("usvips.gui.workspace", "usvips.gui.window_context", "usvips.gui.panel_registry", "usvips.gui.commands",
          "usvips.gui.pick_tool", "usvips.gui.object_cache", "usvips.gui.object_overlay", "usvips.gui.outline_set",
          "usvips.gui.label_layout", "usvips.gui.view_options", "usvips.gui.lazy_panels", "usvips.gui.messages",
          "usvips.gui.video_model", "usvips.gui.video_modules", "usvips.gui.track_model",
          "usvips.gui.qa_model", "usvips.gui.review_model", "usvips.gui.species_choice",
          "usvips.app.opening", "usvips.app.quality", "usvips.app.live_changes", "usvips.io.species_list",
          "usvips.locations")


def before_qt() -> None:
    """Switch automatic collection off for the start and import :data:`MODELS` (see the module docstring)."""
    gc.disable()
    for name in MODELS:
        importlib.import_module(name)
