"""The dome port end to end on the command line: a scene rendered behind decentred dome ports, its
calibration (``usvips render``, ``usvips calibrate water --housing dome-port``) recovering the decentring
within its sigmas, ``usvips plan`` with a dome port, and bad dome values refused on one line."""

from __future__ import annotations

import json

import pytest

from usvips.cli import main
from usvips.core.housing import DomePortHousing
from usvips.io.calibration_file import load_calibration
from usvips.locations import sample_project

DOMES = {"left": {"dx": 0.003, "dy": -0.002, "dz": 0.006, "r": 0.05, "t": 0.008, "n2": 1.49, "n3": 1.34},
         "right": {"dx": -0.002, "dy": 0.001, "dz": -0.004, "r": 0.05, "t": 0.008, "n2": 1.49, "n3": 1.34}}


@pytest.fixture(scope="module")
def rendered(tmp_path_factory):
    """rov_flatport's rig and stations, at half size, behind two decentred dome ports."""
    scene = json.loads((sample_project("rov_flatport") / "scene.json").read_text())
    scene.pop("video")
    scene["name"] = "dome_rig"
    scene["image"].update(width=320, height=240, supersample=1)
    for side in ("left", "right"):
        for key in ("f", "xp", "yp"):
            scene[side][key] /= 2
    scene["housing"] = {"kind": "dome-port", **DOMES}
    folder = tmp_path_factory.mktemp("dome")
    (folder / "scene.json").write_text(json.dumps(scene))
    assert main(["render", str(folder / "scene.json"), "--out", str(folder / "out")]) == 0
    return folder / "out"


def _within_three_sigma(calibration, truth: dict) -> None:
    cameras = next(pair["cameras"] for pair in truth["pairs"] if pair["medium"] == "water")
    for side, suffix in (("left", "l"), ("right", "r")):
        assert cameras[side]["housing"] == {"kind": "dome-port", **DOMES[side]}
        for name in ("dx", "dy", "dz"):
            estimate = calibration.parameters[f"{name}_{suffix}"]
            true = cameras[side]["housing"][name]
            assert abs(estimate.value - true) < 3 * estimate.sigma, (name, side, estimate, true)


@pytest.mark.slow
def test_a_rendered_dome_port_rig_calibrates_to_its_truth(rendered, tmp_path, capsys):
    truth = json.loads((rendered / "truth.json").read_text())
    calibration = load_calibration(rendered / "calibration.json")  # usvips render calibrated it as a user would
    assert isinstance(calibration.left.housing, DomePortHousing) and isinstance(calibration.right.housing,
                                                                                 DomePortHousing)
    _within_three_sigma(calibration, truth)
    # the same from the command line, the dome's radius and thickness known from the manufacturer
    out = tmp_path / "water.json"
    assert main(["calibrate", "water", "--base", str(rendered / "calibration_air.json"), "--housing", "dome-port",
                 "--control", str(rendered / "control.csv"), "--obs", str(rendered / "observations_water.csv"),
                 "--out", str(out), "--fix", "r=0.05", "--fix", "t=0.008", "--sigma-px", "0.3"]) == 0
    printed = capsys.readouterr().out
    assert "dome-port" in printed
    again = load_calibration(out)
    assert again.parameters["r"].status == "fixed" and again.left.housing.r == 0.05
    _within_three_sigma(again, truth)


def test_plan_a_rig_behind_dome_ports(capsys):
    assert main(["plan", "--focal-px", "900", "--image-size", "1280x960", "--baseline", "0.4", "--housing",
                 "dome-port", "--port", "dz=0.005", "--port", "r=0.06", "--range", "1:3:3", "--across=-0.3:0.3:3",
                 "--orientations", "4", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["ranges"][0]["range_m"] == 1.0


@pytest.mark.parametrize(("port", "message"), [
    ("dx=0.07", "parameter dx: the perspective centre must lie inside the dome"),
    ("g=0.05", "parameter --port: unknown 'g'; the dome-port housing takes dx, dy, dz, r, t, n2, n3"),
])
def test_bad_dome_values_are_one_line(capsys, port, message):
    assert main(["plan", "--focal-px", "900", "--image-size", "1280x960", "--baseline", "0.4", "--housing",
                 "dome-port", "--port", port, "--json"]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and message in err
