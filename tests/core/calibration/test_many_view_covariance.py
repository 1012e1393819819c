"""A calibration from many board views keeps the covariance of the rig's unknowns only (the views' poses are
eliminated by the Schur complement): points in the rig frame carry the calibration's part; a point in a
further view's object frame, whose pose covariance is not kept, is refused rather than given a sigma
without it."""

from __future__ import annotations

import numpy as np
import pytest

from tests.core.board_scenes import board, observe_views, random_rig, random_views
from usvips.core.calibration import CalibrationOptions, calibrate_air
from usvips.core.calibration.uncertainty import intersect_with_calibration
from usvips.core.errors import InvalidParameterError


def test_rig_frame_points_carry_the_calibration_and_a_views_object_frame_is_refused():
    rng = np.random.default_rng(12)
    control = board()
    rig = random_rig(rng)
    observations = observe_views(control, rig, random_views(control, rig, rng, 12), rng, 0.3)
    result = calibrate_air(control, observations, CalibrationOptions(sigma_px=0.3, image_size=rig.size,
                                                                    control_exact=True, snooping=False))
    calibration = result.calibration
    names = calibration.covariance[0]
    assert "f_l" in names and not any("@" in n for n in names)  # the views' poses eliminated
    pair = observations.pair(calibration.stations[3])
    rig_frame = intersect_with_calibration(calibration, pair.left, pair.right, calibration.stations[3], "rig")
    pointing = intersect_with_calibration(calibration, pair.left, pair.right, calibration.stations[3], "rig",
                                          include_calibration=False)
    assert rig_frame.ok.all()
    assert np.all(np.trace(rig_frame.covariance, axis1=1, axis2=2) > np.trace(pointing.covariance, axis1=1, axis2=2))
    with pytest.raises(InvalidParameterError, match="rig frame"):
        intersect_with_calibration(calibration, pair.left, pair.right, calibration.stations[3], "object")
    first = observations.pair(calibration.stations[0])
    assert intersect_with_calibration(calibration, first.left, first.right, calibration.stations[0], "object").ok.all()
