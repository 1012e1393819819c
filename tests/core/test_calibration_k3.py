"""K3 in the calibration adjustment: fixed at 0 unless freed; older calibration files without it still load."""

import json
from pathlib import Path

import numpy as np

from tests.core.calibration_scenes import control_frame, observe, rig_at
from usvips.core.calibration.phases import CalibrationOptions, air_start
from usvips.io.calibration_file import load_calibration

SAMPLES = Path(__file__).resolve().parents[2] / "sample_projects"


def test_k3_is_fixed_at_zero_unless_freed():
    control = control_frame()
    observations = observe(rig_at(0), control.xyz, control.ids, "1", seed=1).observations
    _, parameters = air_start(control, observations)
    by_name = {p.name: p for p in parameters}
    for side in ("l", "r"):
        assert by_name[f"k3_{side}"].status == "fixed" and by_name[f"k3_{side}"].value == 0.0
    _, parameters = air_start(control, observations, CalibrationOptions(free=("k3",)))
    assert {p.name for p in parameters if p.status == "free"} >= {"k3_l", "k3_r"}


def test_calibration_files_without_k3_load_with_k3_zero(tmp_path):
    data = json.loads((SAMPLES / "rov_flatport" / "calibration.json").read_text())
    # as written before K3 existed (the sample itself is now re-rendered with it)
    for side in ("left", "right"):
        data["cameras"][side]["interior"].pop("k3", None)
        data["parameters"].pop(f"k3_{side[0]}", None)
    (tmp_path / "old.json").write_text(json.dumps(data))
    calibration = load_calibration(tmp_path / "old.json")
    assert calibration.left.interior.k3 == 0.0 and calibration.right.interior.k3 == 0.0


def test_an_old_calibration_still_carries_its_uncertainty_into_points():
    from usvips.core.calibration.uncertainty import intersect_with_calibration

    calibration = load_calibration(SAMPLES / "rov_flatport" / "calibration.json")
    assert calibration.parameters["k3_l"].status == "fixed" and calibration.parameters["k3_r"].value == 0.0
    rig = calibration.rig(0)
    point = np.array([[100.7, 101.0, -100.0]])
    left, right = rig.left.project(point).pixels, rig.right.project(point).pixels
    with_calibration = intersect_with_calibration(calibration, left, right)
    pointing = intersect_with_calibration(calibration, left, right, include_calibration=False)
    assert with_calibration.ok.all()
    assert np.trace(with_calibration.covariance[0]) > np.trace(pointing.covariance[0])
