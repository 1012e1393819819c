"""``usvips calibrate water`` as done in a tank (issue 33, item 5), on the thesis's tank sample: both poses
fixed by ``--fix`` once crashed (internal error, exit 70); a wrong fixed water index (sigma0 23 px, a port
distance on its bound) exited 0 with a calibration ``intersect`` could not use — now refused by name."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from usvips.cli import main

SAMPLE = Path(__file__).resolve().parents[2] / "usvips" / "sample_projects" / "tank_1995"


@pytest.fixture(scope="module")
def base(tmp_path_factory):
    out = tmp_path_factory.mktemp("tank") / "air.json"
    assert main(["calibrate", "air", "--control", str(SAMPLE / "control_table3_1.csv"), "--obs",
                 str(SAMPLE / "air_pair1_table3_2.csv"), "--out", str(out)]) == 0
    return out


def _water(base: Path, out: Path, *extra: str) -> int:
    return main(["calibrate", "water", "--base", str(base), "--housing", "flat-port", "--control",
                 str(SAMPLE / "control_table3_1.csv"), "--obs", str(SAMPLE / "water_pair2_calibration_table3_5.csv"),
                 "--out", str(out), *extra])


def test_both_poses_fixed_give_a_calibration_not_an_internal_error(base, tmp_path, capsys):
    out = tmp_path / "water.json"
    assert _water(base, out, "--fix", "X0", "Y0", "Z0", "omega", "phi", "kappa") == 0, capsys.readouterr().err
    written = json.loads(out.read_text())
    assert written["phase"] == "water" and written["parameters"]["X0_l"]["status"] == "fixed"


def test_a_wrong_fixed_water_index_is_refused_by_name_and_nothing_written(base, tmp_path, capsys):
    out = tmp_path / "water.json"
    assert _water(base, out, "--fix", "n3=2.5") == 2
    error = capsys.readouterr().err.strip()
    assert len(error.splitlines()) == 1 and "physically impossible" in error, error
    assert "n3 = 2.5" in error or "g_" in error, error
    assert not out.exists()


@pytest.mark.parametrize("extra, message", [
    (["--glass-thickness", "-0.01"], "thickness: -0.01 is outside its physical range"),
    (["--n-water", "abc"], "--n-water: expected VALUE or VALUE:SIGMA"),
    (["--port-distance", "0.05:0"], "--port-distance: the sigma must be > 0"),
])
def test_bad_housing_geometry_is_one_line(base, tmp_path, capsys, extra, message):
    out = tmp_path / "water.json"
    assert _water(base, out, *extra) == 2
    error = capsys.readouterr().err.strip()
    assert len(error.splitlines()) == 1 and message in error, error
    assert not out.exists()
