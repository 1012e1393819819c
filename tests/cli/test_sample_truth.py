"""Each rendered sample's committed calibration reproduces its truth.json: every estimated interior,
exterior and housing parameter within three of its reported sigmas (issue 13 item 5). The housing's
parameters are compared in the calibration's own names, which its kind computes from the true housings
(:meth:`Housing.calibration_values`)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from usvips.core import housing as housings
from usvips.core.camera import Exterior
from usvips.core.rig import relative_orientation
from usvips.io.calibration_file import load_calibration
from usvips.io.manifest import read_manifest
from usvips.io.scene import read_scene
from usvips.locations import sample_project

RENDERED = ("rov_flatport", "tank_system1")


def _truth_values(truth: dict, stations: tuple[str, ...]) -> dict[str, float]:
    """The true value of every parameter a water calibration of these stations estimates."""
    pairs = {p["label"]: p["cameras"] for p in truth["pairs"]}
    first = pairs[stations[0]]
    values = {}
    for side, suffix in (("left", "l"), ("right", "r")):
        values.update({f"{k}_{suffix}": v for k, v in first[side]["interior"].items()})
        values.update({f"{k}_{suffix}": v for k, v in first[side]["exterior"].items()})
    for station in stations[1:]:
        values.update({f"{k}_l@{station}": v for k, v in pairs[station]["left"]["exterior"].items()})
    built = []
    for side in ("left", "right"):
        housing = dict(first[side]["housing"])
        built.append(housings.kind(housing.pop("kind")).from_values(housing))
    relative = relative_orientation(Exterior(**first["left"]["exterior"]), Exterior(**first["right"]["exterior"]))
    values.update(type(built[0]).calibration_values(*built, relative.rotation, -relative.rotation @ relative.base))
    return values


@pytest.mark.parametrize("name", RENDERED)
def test_the_sample_calibration_reproduces_its_truth_within_three_sigma(name):
    sample = sample_project(name)
    calibration = load_calibration(sample / "calibration.json")
    truth = _truth_values(json.loads((sample / "truth.json").read_text()), calibration.stations)
    z = {}
    for parameter, estimate in calibration.parameters.items():
        if estimate.status == "fixed" or parameter not in truth:
            continue
        z[parameter] = (estimate.value - truth[parameter]) / estimate.sigma
    housing_names = set(type(calibration.left.housing).calibration_names)
    assert housing_names & set(z), "no housing parameter was compared"
    assert {f"f_{s}" for s in "lr"} <= set(z) and any("@" in p for p in z) or len(calibration.stations) == 1
    worst = max(z, key=lambda p: abs(z[p]))
    assert abs(z[worst]) < 3, f"{worst}: {z[worst]:.2f} sigma off its truth"
    # a parameter held fixed at a value other than its truth would be a silent error: only known values
    for parameter, estimate in calibration.parameters.items():
        if estimate.status == "fixed" and parameter in truth and parameter in housing_names:
            assert estimate.value == pytest.approx(truth[parameter], abs=1e-12), parameter


def test_rov_flatport_states_its_known_housing_values_and_calibrates_with_them():
    sample = sample_project("rov_flatport")
    manifest = read_manifest(sample)
    assert manifest.housing_known == {"t": (0.016, None), "n2": (1.65, None)}
    scene = read_scene(sample / "scene.json")
    assert {k: scene.housing(side).to_values()[k] for side in ("left", "right") for k in ("t", "n2")} == \
        {"t": 0.016, "n2": 1.65}
    calibration = load_calibration(sample / "calibration.json")
    assert calibration.parameters["t"].value == 0.016 and calibration.parameters["n2"].value == 1.65
    assert np.isclose(calibration.left.housing.t, 0.016)
