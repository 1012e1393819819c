"""The plan view's drawing of many objects at once (every vertex in one array, every 1σ ring in one
eigen-decomposition) against each object drawn on its own, over random objects of every kind, some
vertices without a 3-D point or a covariance."""

from types import SimpleNamespace

import numpy as np
import pytest

from usvips.core.errors import UsvipsError
from usvips.core.measurements import kind as measurement_kind
from usvips.gui.qt.plan_view import PlanView
from usvips.gui.workspace import Workspace
from usvips.store.records import Vertex

COUNTS = {"length": 2, "point": 1, "polygon": 4, "circle": 3, "arc": 4, "not a kind": 3}


def _one(stored, a, b):
    """One object's drawing, written out plainly: (label text, label position, outline, rings) or None."""
    located = [v for v in stored.vertices if v.xyz is not None]
    if not located:
        return None
    points = np.array([v.xyz for v in located], float)
    outline = points
    if len(located) == len(stored.vertices):
        try:
            outline = measurement_kind(stored.kind).outline(points)
        except UsvipsError:
            pass
    rings = []
    for vertex in located:
        if vertex.covariance is None:
            continue
        values, vectors = np.linalg.eigh(np.asarray(vertex.covariance)[np.ix_([a, b], [a, b])])
        ring = np.array(vertex.xyz)[[a, b]] + (PlanView.CIRCLE * np.sqrt(np.clip(values, 0, None))) @ vectors.T
        rings.append(np.vstack([ring, [[np.nan, np.nan]]]))
    return (f"{stored.id} {stored.attribute}".strip(), points[0, [a, b]],
            np.vstack([outline[:, [a, b]], [[np.nan, np.nan]]]), np.vstack(rings) if rings else np.zeros((0, 2)))


def test_many_objects_drawn_at_once_are_each_drawn_as_on_its_own(qtbot):
    rng = np.random.default_rng(5)
    objects = []
    for object_id in range(1, 301):
        kind = str(rng.choice(list(COUNTS)))
        vertices = []
        for _ in range(COUNTS[kind]):
            root = rng.normal(scale=1e-2, size=(3, 3))
            vertices.append(Vertex(0, 0, 0, 0, None if rng.random() < 0.1 else tuple(rng.normal(size=3)),
                                   None if rng.random() < 0.3 else root @ root.T))
        objects.append(SimpleNamespace(id=object_id, kind=kind, attribute="a" if object_id % 2 else "",
                                       vertices=vertices))
    view = PlanView(Workspace())
    qtbot.addWidget(view)
    drawn = 0
    for a, b in PlanView.VIEWS.values():
        for stored, part in zip(objects, view._parts_of(objects, a, b), strict=True):
            expected = _one(stored, a, b)
            assert (part is None) == (expected is None)
            if part is None:
                continue
            (text, position), outline, rings = part
            assert text == expected[0] and np.allclose(position, expected[1])
            assert np.allclose(outline, expected[2], equal_nan=True)
            assert rings.shape == expected[3].shape and np.allclose(rings, expected[3], equal_nan=True, atol=1e-12)
            drawn += 1
    assert drawn > 600
    assert view._parts_of([], 0, 1) == []


@pytest.mark.parametrize("kind", ["circle", "polygon"])
def test_kinds_with_their_own_outline_are_drawn_by_it(qtbot, kind):
    angles = np.linspace(0, 2 * np.pi, 5)[:-1]
    vertices = [Vertex(0, 0, 0, 0, (np.cos(t), np.sin(t), 2.0), np.eye(3) * 1e-4) for t in angles]
    view = PlanView(Workspace())
    qtbot.addWidget(view)
    stored = SimpleNamespace(id=1, kind=kind, attribute="", vertices=vertices)
    ((_, _), outline, rings), = view._parts_of([stored], 0, 1)
    closed = measurement_kind(kind).outline(np.array([v.xyz for v in vertices]))
    assert len(outline) == len(closed) + 1 and np.allclose(outline[:-1], closed[:, :2])
    assert rings.shape == (4 * 50, 2)


def test_a_screen_watch_cleared_by_the_collector_ignores_its_widget_s_last_events(qtbot):
    """A garbage collection clears a dead watch's attributes before Qt has destroyed its widget, whose last
    events (shown, a dock's visibility) must then raise nothing in the event loop (seen in this file)."""
    from PySide6 import QtWidgets

    from usvips.gui.qt.on_screen import ScreenWatch

    widget = QtWidgets.QWidget()
    qtbot.addWidget(widget)
    seen = []
    watch = ScreenWatch(widget, lambda: seen.append(1))
    widget.show()
    qtbot.waitUntil(lambda: seen == [1], timeout=5000)
    widget.hide()
    watch.__dict__.clear()  # what the collector's clearing of a cycle leaves
    widget.show()
    qtbot.wait(50)
    watch._on_visibility(True)
    assert seen == [1]
