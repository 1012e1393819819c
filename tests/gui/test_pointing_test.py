"""The pointing test: the model estimates σ from clicks of a known σ on its rendered targets and leaves a
miss out; the dialog renders the targets in a worker, takes mouse clicks and the keyboard, and stores the
estimate for the annotator, after which the project's figures use it (the object list's figures are
computed again)."""

import numpy as np
from PySide6 import QtCore

from tests.gui.conftest import open_sample
from usvips.app.pointing_settings import pointing_in_use, stored_estimates
from usvips.core.pointing_test import CONDITIONS, FEATURES, HEIGHT, WIDTH
from usvips.gui.pointing_test_model import MISS_PX, PointingTestModel
from usvips.gui.qt import pointing_test_dialog


def test_the_model_estimates_the_clicks_sigma_and_leaves_misses_out():
    model = PointingTestModel(count=9, seed=3)
    assert {f for f, _, _ in model.plan} == set(FEATURES) and {c for _, c, _ in model.plan} == {
        c.name for c in CONDITIONS}
    trials = model.render()
    assert len(trials) == 9 and trials[0].image.shape == (HEIGHT, WIDTH)
    model.set_trials(trials)
    rng = np.random.default_rng(0)
    truths = []
    for k, trial in enumerate(trials):
        truths.append(trial.truth)
        if k == 4:
            assert model.click(trial.truth[0] + MISS_PX + 1, trial.truth[1]).startswith("missed")
            continue
        model.place(*(np.array(trial.truth) + rng.normal(0, 0.6, 2)))
        model.move(0.25, 0.0)
        model.move(-0.25, 0.0)
        assert "px from the" in model.confirm()
    assert model.finished and len(model.clicks) == 8 and len(model.misses) == 1
    estimate = model.estimate()
    assert estimate.method == "pointing test" and estimate.n == 8
    assert estimate.low_px <= 0.6 <= estimate.high_px
    lines = model.summary()
    assert lines[0].startswith("your pointing σ") and any("1 miss" in line for line in lines)


def test_the_dialog_by_mouse_and_keyboard_stores_the_estimate(qtbot, make_window, sample_copy):
    window = make_window()
    open_sample(qtbot, window, sample_copy("tank_system1"), "measure1")
    dialog = pointing_test_dialog.PointingTestDialog(window.context, window.annotator, count=4, seed=1)
    qtbot.addWidget(dialog)
    dialog.show()
    qtbot.waitUntil(lambda: dialog.model.current is not None, timeout=60000)
    for k in range(4):
        truth = np.array(dialog.model.current.truth)
        if k % 2 == 0:  # by mouse: a click at the truth's screen point, 0.2 px off
            x, y = (truth + [0.2, 0.0] + 0.5) * pointing_test_dialog.ZOOM
            qtbot.mouseClick(dialog.canvas, QtCore.Qt.MouseButton.LeftButton, pos=QtCore.QPoint(round(x), round(y)))
        else:  # by keyboard: the cross-hair walked there from the centre, then Enter
            dialog.model.place(*np.round(truth))
            for _ in range(2):
                qtbot.keyClick(dialog, QtCore.Qt.Key.Key_Right)
            qtbot.keyClick(dialog, QtCore.Qt.Key.Key_Return)
    assert dialog.model.finished and len(dialog.model.clicks) == 4
    assert dialog.store.isEnabled() and "your pointing σ" in dialog.result.text()
    before = window.workspace.cache.known_figures(window.workspace.cache.ids()[0]) if window.workspace.cache.ids() \
        else None
    dialog.store.click()
    project = window.workspace.project
    (stored,) = stored_estimates(project)
    assert stored.annotator == window.annotator and stored.in_use and "pointing test: 4 clicks" in stored.note
    assert (window.annotator, "hand click") in pointing_in_use(project)
    if before is not None:  # the figures known before are forgotten: computed again with the estimate
        assert window.workspace.cache.known_figures(window.workspace.cache.ids()[0]) is not before
