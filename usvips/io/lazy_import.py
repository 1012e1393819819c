"""A module imported when it is first used, not when its importer is (the standard library's
:class:`importlib.util.LazyLoader` recipe).

For PyAV: the window imports the video readers with everything else, and ``import av`` (FFmpeg's codecs,
formats and every Cython module of the binding) is about a tenth of the window's start-up CPU, though a
project of image pairs never decodes a frame.
"""

from __future__ import annotations

import importlib.util
import sys
from types import ModuleType


def lazy_module(name: str) -> ModuleType:
    """The module ``name``: already imported, or put in ``sys.modules`` now and executed on its first
    attribute access (an ``import name`` elsewhere then shares it). A module that is not installed is
    the ``ModuleNotFoundError`` an import would raise, at once."""
    known = sys.modules.get(name)
    if known is not None:
        return known
    spec = importlib.util.find_spec(name)
    if spec is None or spec.loader is None:
        raise ModuleNotFoundError(f"No module named {name!r}", name=name)
    loader = importlib.util.LazyLoader(spec.loader)
    spec.loader = loader
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    loader.exec_module(module)
    return module
