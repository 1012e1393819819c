"""The calibration and intersection command line: real runs and bad input."""

import json

import numpy as np
import pytest

from tests.core.calibration_scenes import FLAT, NOISE_PX, control_frame, observe, rig_at
from usvips.cli import main
from usvips.io.tables import write_control, write_observations


@pytest.fixture()
def files(tmp_path):
    control = control_frame()
    write_control(tmp_path / "control.csv", control)
    write_observations(tmp_path / "air.csv", observe(rig_at(0), control.xyz, control.ids, "1", seed=1).observations)
    water = observe(rig_at(0, FLAT), control.xyz, control.ids, "1", seed=2).observations
    write_observations(tmp_path / "water.csv", water)
    rng = np.random.default_rng(8)
    points = np.column_stack([rng.uniform(0, 1.4, 30), rng.uniform(0, 1.4, 30), rng.uniform(-0.7, 0, 30)])
    check = observe(rig_at(0, FLAT), points, [f"P{i}" for i in range(30)], "1", seed=3)
    write_observations(tmp_path / "check.csv", check.observations, with_pair=False)
    return tmp_path, points


def test_two_phases_and_intersection_from_the_command_line(files, capsys):
    d, points = files
    assert main(["calibrate", "air", "--control", str(d / "control.csv"), "--obs", str(d / "air.csv"),
                 "--out", str(d / "air.json"), "--report", str(d / "air_report.json"),
                 "--sigma-px", str(NOISE_PX), "--image-size", "1280x960"]) == 0
    report = json.loads((d / "air_report.json").read_text())
    for key in ("sigma0_px", "rms_px", "parameters", "correlations_over_0_95", "condition_number", "suspects",
                "converged"):
        assert key in report
    assert report["converged"] and report["parameters"]["f_l"]["sigma"] > 0
    assert main(["calibrate", "water", "--base", str(d / "air.json"), "--housing", "flat-port",
                 "--control", str(d / "control.csv"), "--obs", str(d / "water.csv"), "--out", str(d / "water.json"),
                 "--fix", "t=0.016", "--fix", "n2=1.65", "--prior", "n3=1.34:0.01", "--sigma-px", str(NOISE_PX),
                 "--report", str(d / "water_report.json")]) == 0
    water_report = json.loads((d / "water_report.json").read_text())
    assert water_report["parameters"]["t"] == {"value": 0.016, "sigma": None, "status": "fixed"}
    assert water_report["parameters"]["n2"]["status"] == "fixed"  # a repeated --fix adds, not replaces
    assert main(["intersect", "--calibration", str(d / "water.json"), "--obs", str(d / "check.csv"),
                 "--out", str(d / "points.csv")]) == 0
    lines = (d / "points.csv").read_text().splitlines()
    assert lines[0] == "id,X,Y,Z,sX,sY,sZ"
    rows = [line.split(",") for line in lines[1:]]
    xyz = np.array([[float(v) for v in row[1:4]] for row in rows])
    truth = points[[int(row[0][1:]) for row in rows]]
    sigmas = np.array([[float(v) for v in row[4:7]] for row in rows])
    assert np.all(np.abs(xyz - truth) < 5 * sigmas + 1e-4)
    # the rig frame: the left perspective centre is the origin
    assert main(["intersect", "--calibration", str(d / "water.json"), "--obs", str(d / "check.csv"),
                 "--out", str(d / "rig.csv"), "--frame", "rig"]) == 0
    first = (d / "rig.csv").read_text().splitlines()[1].split(",")
    assert float(first[3]) < -1.5  # in front of the camera, along its -z axis


@pytest.mark.parametrize("edit, message", [
    (lambda d: (d / "air.csv").write_text("id,xl,yl,xr,yr\n1,2,x,4,5\n"), "line 2: column yl: 'x' is not a number"),
    (lambda d: (d / "air.csv").write_text("id,xl,yl,xr,yr\n1,2,3,4,5\n1,2,3,4,5\n"), "duplicate id '1'"),
    (lambda d: (d / "air.csv").write_text("id,xl,yl,xr,yr\nNOPE,2,3,4,5\n"), "id 'NOPE' has no control point"),
    (lambda d: (d / "control.csv").unlink(), "no such file"),
    (lambda d: (d / "air.csv").write_text("id,xl,yl\n1,2,3\n"), "missing column(s) xr, yr"),
])
def test_bad_input_is_one_line_exit_2_and_no_output(files, capsys, edit, message):
    d, _ = files
    edit(d)
    code = main(["calibrate", "air", "--control", str(d / "control.csv"), "--obs", str(d / "air.csv"),
                 "--out", str(d / "out.json"), "--report", str(d / "report.json")])
    err = capsys.readouterr().err
    assert code == 2
    assert message in err and err.count("\n") == 1 and "Traceback" not in err
    assert not (d / "out.json").exists() and not (d / "report.json").exists()


def test_too_few_points_and_bad_options(files, capsys):
    d, _ = files
    text = (d / "air.csv").read_text().splitlines()
    (d / "few.csv").write_text("\n".join(text[:5]) + "\n")
    assert main(["calibrate", "air", "--control", str(d / "control.csv"), "--obs", str(d / "few.csv"),
                 "--out", str(d / "out.json")]) == 2
    assert "at least 6" in capsys.readouterr().err
    assert main(["calibrate", "air", "--control", str(d / "control.csv"), "--obs", str(d / "air.csv"),
                 "--out", str(d / "out.json"), "--prior", "n2=abc"]) == 2
    assert "NAME=VALUE:SIGMA" in capsys.readouterr().err
    assert not (d / "out.json").exists()
    assert main(["intersect", "--calibration", str(d / "missing.json"), "--obs", str(d / "check.csv"),
                 "--out", str(d / "p.csv")]) == 2
    assert "no such calibration file" in capsys.readouterr().err


@pytest.mark.parametrize("extra, message", [
    (["--free", "k2", "--fix", "k2"], "k2 is both freed and fixed"),
    (["--free", "k2", "--prior", "k2=0:0.1"], "k2 is both freed and given a prior"),
    (["--image-size", "0x0"], "--image-size.*no image"),
    (["--report", "SAME"], "--report.*same file as --out"),
])
def test_contradictory_options_are_refused_by_name(tmp_path, capsys, extra, message):
    import re
    from pathlib import Path

    sample = Path(__file__).resolve().parents[2] / "sample_projects" / "tank_1995"
    out = tmp_path / "air.json"
    extra = [str(out) if item == "SAME" else item for item in extra]
    code = main(["calibrate", "air", "--control", str(sample / "control_table3_1.csv"), "--obs",
                 str(sample / "air_pair1_table3_2.csv"), "--out", str(out), *extra])
    assert code == 2 and not out.exists()
    error = capsys.readouterr().err.strip()
    assert len(error.splitlines()) == 1 and re.search(message, error)


def test_intersect_warns_in_one_line_of_points_whose_rays_miss(tmp_path, capsys):
    """The command's summary names the first point whose rays miss beyond the pointing sigma, with how
    many such points there are and how many chance alone would give; the exit status stays 0."""
    from usvips.bench.scaling import CALIBRATION, write_observations
    from usvips.io.calibration_file import load_calibration

    obs = tmp_path / "obs.csv"
    write_observations(load_calibration(CALIBRATION), 5, obs, seed=2)
    lines = obs.read_text().splitlines()
    fields = lines[3].split(",")
    fields[2] = f"{float(fields[2]) - 40:.4f}"
    lines[3] = ",".join(fields)
    obs.write_text("\n".join(lines) + "\n")
    assert main(["intersect", "--calibration", str(CALIBRATION), "--obs", str(obs), "--out",
                 str(tmp_path / "points.csv")]) == 0
    out = capsys.readouterr().out
    warning = [line for line in out.splitlines() if line.startswith("warning:")]
    assert len(warning) == 1
    assert "1 of 5 points' rays miss more than a 0.5 px pointing sigma explains" in warning[0]
    assert f"point '{fields[0]}' (line 4)" in warning[0]
