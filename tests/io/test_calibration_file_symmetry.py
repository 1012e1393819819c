"""A calibration's covariance survives the round trip: written symmetric, read with a tolerance relative to
each entry's own scale (a covariance mixes px² with rad²)."""

import json

import numpy as np
import pytest

from tests.core.calibration_scenes import FLAT, NOISE_PX, control_frame, joined, observe, rig_at
from usvips.core.calibration.phases import CalibrationOptions, calibrate_air, calibrate_water
from usvips.core.errors import InputFileError
from usvips.io.calibration_file import calibration_from_dict, calibration_to_dict, load_calibration, save_calibration


@pytest.fixture(scope="module")
def water_joint():
    control = control_frame()
    air = joined([observe(rig_at(k), control.xyz, control.ids, f"a{k}", seed=10 + k) for k in range(3)])
    options = CalibrationOptions(sigma_px=NOISE_PX, image_size=(1280, 960))
    base = calibrate_air(control, air, options).calibration
    water = joined([observe(rig_at(k, FLAT), control.xyz, control.ids, f"w{k}", seed=20 + k) for k in range(3)])
    return calibrate_water(base, "flat-port", control, water, options).calibration


def test_a_multi_station_water_calibration_reads_back_what_it_wrote(water_joint, tmp_path):
    assert len(water_joint.stations) == 3
    names, matrix = water_joint.covariance
    path = tmp_path / "water.json"
    save_calibration(water_joint, path)
    written = np.array(json.loads(path.read_text())["covariance"]["matrix"])
    assert np.array_equal(written, written.T)
    loaded = load_calibration(path)
    assert loaded.covariance[0] == tuple(names)
    scale = np.sqrt(np.outer(np.diag(matrix), np.diag(matrix)))
    assert np.max(np.abs(loaded.covariance[1] - matrix) / scale) < 1e-12


def _with_matrix(calibration, matrix):
    data = calibration_to_dict(calibration)
    data["covariance"]["matrix"] = matrix.tolist()
    return data


def test_the_symmetry_tolerance_is_relative_to_each_entrys_scale(water_joint):
    names, matrix = water_joint.covariance
    matrix = 0.5 * (matrix + matrix.T)
    # rounding-sized asymmetry on the smallest entries (rad², m²) is accepted ...
    diagonal = np.sqrt(np.diag(matrix))
    rounding = 1e-14 * np.outer(diagonal, diagonal) * np.triu(np.ones_like(matrix), 1)
    calibration_from_dict(_with_matrix(water_joint, matrix + rounding))
    # ... a real disagreement between C_ij and C_ji, even on a small entry, is refused by name
    i, j = np.unravel_index(np.argmin(np.where(np.eye(len(names)) > 0, np.inf, np.abs(matrix))), matrix.shape)
    bad = matrix.copy()
    bad[i, j] += 1e-6 * diagonal[i] * diagonal[j]
    with pytest.raises(InputFileError, match="covariance.matrix: not symmetric"):
        calibration_from_dict(_with_matrix(water_joint, bad), "water.json")
