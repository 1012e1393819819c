"""A calibration file's ``parameters`` and its cameras must hold the same values: the measurements are made
with the cameras, the calibration's uncertainty and a later phase's priors with the parameters."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from usvips.core.errors import InputFileError
from usvips.io.calibration_file import calibration_from_dict, calibration_to_dict, load_calibration

SAMPLES = Path(__file__).resolve().parents[2] / "sample_projects"
FILES = sorted(SAMPLES.glob("*/calibration*.json"))


def _data(path: Path) -> dict:
    return json.loads(path.read_text())


def test_the_samples_and_their_round_trips_agree():
    assert len(FILES) >= 4  # flat-port and dome-cover water calibrations, their air phases
    kinds = set()
    for path in FILES:
        calibration = load_calibration(path)
        kinds.add(_data(path)["housing"])
        again = calibration_from_dict(calibration_to_dict(calibration), "again.json")
        assert again.parameters == calibration.parameters
    assert {"flat-port", "dome-cover", "air"} <= kinds  # dome-cover's right housing follows the rig


@pytest.mark.parametrize("path", FILES, ids=lambda p: f"{p.parent.name}/{p.name}")
def test_every_parameter_edited_alone_is_refused_by_name(path):
    data = _data(path)
    rng = np.random.default_rng(len(data["parameters"]))
    for name, entry in data["parameters"].items():
        edited = json.loads(json.dumps(data))
        value = entry["value"]
        edited["parameters"][name]["value"] = value + rng.choice([-1, 1]) * rng.uniform(1e-5, 1e-2) * max(1, abs(value))
        with pytest.raises(InputFileError) as refused:
            calibration_from_dict(edited, str(path))
        message = str(refused.value)
        assert str(path) in message and "must hold the same values" in message
        named = f"parameters.{name}:" in message or f"{name}," in message or f"{name}:" in message
        assert named or (name.endswith("_r") and "relative_orientation" in message), message


@pytest.mark.parametrize("path", FILES, ids=lambda p: f"{p.parent.name}/{p.name}")
def test_a_camera_value_edited_without_its_parameter_is_refused(path):
    data = _data(path)
    places = [("cameras", side, part, key) for side in ("left", "right") for part in ("interior", "housing")
              for key in data["cameras"][side].get(part, {})]
    places += [("stations", i, None, key) for i, station in enumerate(data["stations"])
               for key in station if key != "label"]
    places += [("relative_orientation", None, None, key) for key in data["relative_orientation"]]
    accepted = []
    for section, first, part, key in places:
        edited = json.loads(json.dumps(data))
        holder = edited[section]
        holder = holder if first is None else holder[first]
        holder = holder if part is None else holder[part]
        holder[key] = holder[key] + 1e-3 * max(1.0, abs(holder[key]))
        try:
            calibration_from_dict(edited, str(path))
            accepted.append((section, first, part, key))
        except InputFileError as error:
            assert "must hold the same values" in str(error)
    # with a covariance the parameters hold the whole model: every value in the cameras is also there
    assert data.get("covariance") and accepted == []
