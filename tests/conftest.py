"""Test-wide settings: Qt offscreen before any Qt import; reproducible property-based tests in CI."""

import gc
import os
import sys

import pytest
from hypothesis import settings

os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")

# CI replays the same examples every run (a red build must be reproducible); locally hypothesis explores.
settings.register_profile("ci", derandomize=True, deadline=None)
if os.environ.get("CI"):
    settings.load_profile("ci")


@pytest.fixture(autouse=True)
def _garbage_collected_when_due():
    """Once a test has run work in a worker, automatic collection is off and the GUI thread collects
    (usvips.gui.qt.gui_thread_gc); between tests, where no event loop runs, collect what is due here."""
    yield
    module = sys.modules.get("usvips.gui.qt.gui_thread_gc")
    if module is not None and not gc.isenabled():
        collector = module.collect_on_the_gui_thread()
        if collector is not None:
            collector.collect_due()
