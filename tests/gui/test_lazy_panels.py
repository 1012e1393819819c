"""The lazy mapping of the window's panels: every declared id a key, each panel made once, when read."""

import pytest

from usvips.gui.lazy_panels import LazyPanels


def test_each_panel_is_made_once_when_first_read():
    made = []
    panels = LazyPanels(["a", "b"], lambda panel_id: made.append(panel_id) or f"widget {panel_id}")
    assert list(panels) == ["a", "b"] and len(panels) == 2 and "b" in panels and "c" not in panels
    assert made == [] and panels.built() == {}
    assert panels["b"] == "widget b" and panels["b"] == "widget b"
    assert made == ["b"] and panels.is_built("b") and not panels.is_built("a")
    assert panels.built() == {"b": "widget b"}
    with pytest.raises(KeyError):
        panels["c"]
    assert made == ["b"]
