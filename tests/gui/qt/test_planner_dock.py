"""The precision planner dock: the map over the current pair, computed off the GUI thread, cancellable."""

import numpy as np

from tests.gui.conftest import open_sample
from usvips.core.planner import default_grid, precision_map


def test_the_dock_maps_the_current_pair_as_the_planner_does(qtbot, make_window, sample_copy):
    window = make_window()
    open_sample(qtbot, window, sample_copy("rov_flatport"), "measure1")
    dock = window.planner
    assert dock.compute_button.isEnabled()
    dock.orientations.setValue(3)
    dock.compute()
    assert dock.cancel_button.isEnabled()
    qtbot.waitUntil(lambda: dock.result is not None, timeout=60000)
    assert dock.progress.value() == 100 and not dock.cancel_button.isEnabled()
    calibration = window.workspace.geometry.calibration
    across, ranges = default_grid(calibration)
    expected = precision_map(calibration, across, ranges, 0.3, orientations=3)
    np.testing.assert_array_equal(dock.result.visible, expected.visible)
    np.testing.assert_allclose(dock.result.length_rms, expected.length_rms, rtol=1e-12)
    assert "mm" in dock.status.text()


def test_cancel_stops_the_work(qtbot, make_window, sample_copy):
    window = make_window()
    open_sample(qtbot, window, sample_copy("rov_flatport"), "measure1")
    dock = window.planner
    dock.orientations.setValue(40)
    dock.compute()
    dock.cancel()
    qtbot.waitUntil(lambda: dock.worker is None, timeout=60000)
    assert dock.result is None and dock.status.text() == "cancelled"
    assert dock.compute_button.isEnabled()
