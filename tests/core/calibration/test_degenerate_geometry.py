"""Degenerate geometry is named, through the core and as one line with exit status 2 from the command
line: coplanar control for the DLT start (either phase), a zero or tiny baseline, a housing no ray can
cross, too few points for the free parameters, a calibration file whose covariance is not a covariance."""

from __future__ import annotations

import json

import numpy as np
import pytest

from tests.core.calibration_scenes import FLAT, HEIGHT, LEFT, NOISE_PX, RIGHT, WIDTH, control_frame, observe, rig_at
from usvips.cli import main
from usvips.core.calibration import CalibrationOptions, calibrate_air, calibrate_water
from usvips.core.calibration.phases import require_physical
from usvips.core.camera import Camera
from usvips.core.errors import DegenerateGeometryError
from usvips.core.housing import AirHousing
from usvips.core.observations import ControlPoints
from usvips.core.rig import RelativeOrientation, StereoRig
from usvips.io.calibration_file import calibration_to_dict
from usvips.io.tables import write_control, write_observations

FIXED_GLASS = {"t": 0.016, "n2": 1.65}


@pytest.fixture(scope="module")
def control():
    return control_frame()


@pytest.fixture(scope="module")
def air(control):
    pair = observe(rig_at(0), control.xyz, control.ids, "a", seed=1)
    return calibrate_air(control, pair.observations, CalibrationOptions(sigma_px=NOISE_PX))


@pytest.fixture(scope="module")
def water_obs(control):
    return observe(rig_at(0, FLAT), control.xyz, control.ids, "w", seed=2).observations


def _tiny_rig(baseline: float) -> StereoRig:
    pose = rig_at(0).left.exterior
    return StereoRig.from_relative(Camera(LEFT, pose, AirHousing(), WIDTH, HEIGHT),
                                   Camera(RIGHT, pose, AirHousing(), WIDTH, HEIGHT),
                                   RelativeOrientation(baseline, 0.0, 0.0, 0.0, 0.0, 0.0))


def test_coplanar_control_in_phase_2_is_a_planar_target_and_images_it_cannot_explain_are_refused(control, air,
                                                                                                 water_obs):
    """Phase 2 with the interior known takes a planar target (a board in a tank, issue 33: it was refused
    as coplanar); a 'flat' control that the images of a 3-D field cannot fit is refused by name as physically
    impossible (residuals far above phase 1's), never written as usable."""
    flat = ControlPoints(control.ids, control.xyz * [1, 1, 0])
    result = calibrate_water(air.calibration, "flat-port", flat, water_obs, CalibrationOptions(fix_values=FIXED_GLASS))
    with pytest.raises(DegenerateGeometryError, match="physically impossible"):
        require_physical(result, air.calibration, "nothing written")


@pytest.mark.parametrize("baseline", [0.0, 0.001, 0.005])
def test_a_zero_or_tiny_baseline_is_named(control, baseline):
    """1 and 5 mm at 2.6 m: an intersection angle of 0.02-0.1°, below the 1:200 a depth needs."""
    pair = observe(_tiny_rig(baseline), control.xyz, control.ids, "a", seed=4)
    with pytest.raises(DegenerateGeometryError, match="zero or tiny baseline"):
        calibrate_air(control, pair.observations, CalibrationOptions(sigma_px=NOISE_PX))


def test_a_usable_baseline_is_not_refused(control):
    pair = observe(_tiny_rig(0.05), control.xyz, control.ids, "a", seed=4)  # 1:52 at 2.6 m
    assert calibrate_air(control, pair.observations, CalibrationOptions(sigma_px=NOISE_PX))


@pytest.mark.parametrize("housing, fixed, what", [
    ("dome-cover", {"c": 0.5}, "perspective centre must lie inside the cover sphere"),  # camera outside its dome
    ("flat-port", {"g": -0.05, **FIXED_GLASS}, "in front of the camera"),               # port behind the camera
])
def test_a_housing_no_ray_can_cross_is_named(control, air, water_obs, housing, fixed, what):
    with pytest.raises(DegenerateGeometryError, match=f"housing lets no ray through.*{what}"):
        calibrate_water(air.calibration, housing, control, water_obs, CalibrationOptions(fix_values=fixed))


def test_too_few_points_for_the_free_parameters_are_named(control):
    few = observe(rig_at(0), control.xyz, control.ids, "a", seed=5).observations.take(range(6))
    # 6 points, 24 pixel coordinates; 18 interior (f xp yp sy k1 k2 p1 p2 k3, both cameras) + 12 exterior
    with pytest.raises(DegenerateGeometryError, match="24 observations cannot determine 30 unknowns"):
        calibrate_air(control, few, CalibrationOptions(free=("k2", "p1", "p2", "k3", "sy")))


def _one_line_exit_2(argv, capsys, *words):
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "Traceback" not in err, err
    for word in words:
        assert word in err, err


def test_the_command_line_names_each_with_exit_2(tmp_path, control, air, capsys):
    write_control(tmp_path / "control.csv", control)
    write_control(tmp_path / "flat.csv", ControlPoints(control.ids, control.xyz * [1, 1, 0]))
    write_observations(tmp_path / "tiny.csv", observe(_tiny_rig(0.001), control.xyz, control.ids, "a",
                                                      seed=4).observations)
    water = observe(rig_at(0, FLAT), control.xyz, control.ids, "w", seed=2).observations
    write_observations(tmp_path / "water.csv", water)
    write_observations(tmp_path / "few.csv", water.take(range(6)))
    (tmp_path / "air.json").write_text(json.dumps(calibration_to_dict(air.calibration)))
    base = ["calibrate", "air", "--control", str(tmp_path / "control.csv"), "--out", str(tmp_path / "c.json")]
    _one_line_exit_2(base + ["--obs", str(tmp_path / "tiny.csv")], capsys, "zero or tiny baseline")
    _one_line_exit_2(base + ["--obs", str(tmp_path / "few.csv"), "--free", "k2", "--free", "p1", "--free", "p2",
                             "--free", "k3"], capsys, "cannot determine")
    water_argv = ["calibrate", "water", "--base", str(tmp_path / "air.json"), "--obs", str(tmp_path / "water.csv"),
                  "--out", str(tmp_path / "w.json")]
    _one_line_exit_2(water_argv + ["--housing", "flat-port", "--control", str(tmp_path / "flat.csv"),
                                   "--fix", "t=0.016", "--fix", "n2=1.65"], capsys, "physically impossible")
    _one_line_exit_2(water_argv + ["--housing", "flat-port", "--control", str(tmp_path / "control.csv"),
                                   "--fix", "t=0.016", "--fix", "n2=1.65", "--fix", "g=-0.05"], capsys,
                     "lets no ray through")
    assert not (tmp_path / "c.json").exists() and not (tmp_path / "w.json").exists()  # nothing half-written
    # a calibration file whose covariance has a negative eigenvalue (a correlation of 2 between two
    # parameters; every variance positive) is refused by name
    data = calibration_to_dict(air.calibration)
    matrix = np.array(data["covariance"]["matrix"])
    matrix[0, 1] = matrix[1, 0] = 2.0 * np.sqrt(matrix[0, 0] * matrix[1, 1])
    data["covariance"]["matrix"] = matrix.tolist()
    (tmp_path / "bad.json").write_text(json.dumps(data))
    _one_line_exit_2(water_argv[:2] + ["--base", str(tmp_path / "bad.json")] + water_argv[4:]
                     + ["--housing", "flat-port", "--control", str(tmp_path / "control.csv")], capsys,
                     "bad.json", "not positive semi-definite")
