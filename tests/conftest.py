"""Test-wide settings: Qt offscreen before any Qt import, fixed seeds."""

import os

os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")
