"""The frame rule of a pair applied to a project: its active calibration, at its station or in the rig."""

import numpy as np
import pytest

from tests.core.calibration_scenes import FLAT, rig_at
from usvips.app.pair_geometry import pair_geometry
from usvips.core.errors import UsvipsError
from usvips.core.stereo_calibration import StereoCalibration
from usvips.io.calibration_file import calibration_to_dict
from usvips.store import Project


@pytest.fixture
def project(tmp_path):
    rig = rig_at(0, FLAT)
    calibration = StereoCalibration.from_cameras(rig.left, rig.right, "water", 0.3, station="s1")
    with Project.create(tmp_path / "p.usvips") as project:
        for label in ("s1", "dive"):
            project.add_pair(label)
        project.add_pair("bare")
        project.add_calibration("cal", calibration_to_dict(calibration), ("s1", "dive"))
        yield project


def test_a_calibrated_station_measures_in_the_object_frame_any_other_pair_in_the_rig_frame(project):
    station = pair_geometry(project, "s1")
    other = pair_geometry(project, "dive")
    assert (station.station, station.frame) == ("s1", "object")
    assert (other.station, other.frame) == (0, "rig")
    assert station.calibration_id == other.calibration_id
    assert "station s1, object frame" in station.description and "rig frame" in other.description
    # the rig frame has its origin at the left camera's perspective centre
    rig = other.calibration.rig(other.station, other.frame)
    np.testing.assert_allclose(rig.left.exterior.position, 0.0, atol=1e-12)


def test_a_pair_without_an_active_calibration_has_no_geometry(project):
    assert pair_geometry(project, "bare") is None


def test_a_damaged_stored_calibration_is_named_with_the_project_and_its_id(project):
    with project.transaction():
        project._db.execute("UPDATE calibrations SET json = ?", ('{"format": "other"}',))
    with pytest.raises(UsvipsError, match=r"p\.usvips calibration 1"):
        pair_geometry(project, "s1")
