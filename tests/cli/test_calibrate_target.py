"""``usvips calibrate air|water --target`` with board views, and ``--holdout``'s validation."""

from __future__ import annotations

import json

import numpy as np
import pytest

from tests.core.board_scenes import board, observe_views, random_rig, random_views
from usvips.cli import main
from usvips.io.tables import write_observations

NOISE = 0.3


@pytest.fixture()
def views(tmp_path):
    rng = np.random.default_rng(41)
    target = board()
    rig = random_rig(rng)
    write_observations(tmp_path / "air.csv", observe_views(target, rig, random_views(target, rig, rng, 12), rng, NOISE))
    water = rig.in_water("flat-port", rng)
    write_observations(tmp_path / "water.csv", observe_views(target, water, random_views(target, water, rng, 12,
                                                                                         (0.5, 1.0)), rng, NOISE, "w"))
    # the board of board_scenes (9 x 6 inner corners, 30 mm) as a target file, written by the command line
    assert main(["target", "describe", "chessboard", "--cols", "9", "--rows", "6", "--square", "30",
                 "--out", str(tmp_path / "board.json")]) == 0
    return tmp_path, rig


def test_a_board_calibrates_in_both_phases_with_validation(views, capsys):
    d, rig = views
    size = f"{rig.size[0]}x{rig.size[1]}"
    assert main(["calibrate", "air", "--target", str(d / "board.json"), "--obs", str(d / "air.csv"),
                 "--out", str(d / "air.json"), "--report", str(d / "air_report.json"), "--sigma-px", str(NOISE),
                 "--image-size", size, "--holdout", "0.25", "--seed", "2"]) == 0
    out = capsys.readouterr().out
    assert "validation: 9 views fitted, 3 held out" in out and "OpenCV stereoCalibrate" in out
    report = json.loads((d / "air_report.json").read_text())
    assert report["control_blunders"] == [] and len(report["stations"]) == 9
    held = report["validation"]["held_out"]
    assert len(held["views"]) == 3 and 0.7 * NOISE < held["rms_px"] < 1.4 * NOISE
    assert json.loads((d / "air.json").read_text())["source"]["target"] == str(d / "board.json")
    assert main(["calibrate", "water", "--base", str(d / "air.json"), "--housing", "flat-port",
                 "--target", str(d / "board.json"), "--obs", str(d / "water.csv"), "--out", str(d / "water.json"),
                 "--sigma-px", str(NOISE), "--holdout", "0.25"]) == 0
    out = capsys.readouterr().out
    assert "validation: 9 views fitted, 3 held out" in out and "OpenCV" not in out
    assert main(["intersect", "--calibration", str(d / "water.json"), "--obs", str(d / "water.csv"),
                 "--out", str(d / "points.csv"), "--frame", "rig"]) == 0


@pytest.mark.parametrize("extra, message", [
    (["--holdout", "1.5"], "--holdout: .*between 0 and 1"),
    (["--holdout", "0.9"], "leaves 1 to calibrate from"),
])
def test_bad_holdout_is_one_line_exit_2(views, capsys, extra, message):
    import re

    d, _ = views
    code = main(["calibrate", "air", "--target", str(d / "board.json"), "--obs", str(d / "air.csv"),
                 "--out", str(d / "out.json"), *extra])
    error = capsys.readouterr().err.strip()
    assert code == 2 and len(error.splitlines()) == 1 and re.search(message, error), error
    assert not (d / "out.json").exists()


@pytest.mark.parametrize("text, message", [
    (None, "no such file"),
    ("{not json", "not valid JSON"),
    ('{"format": "usvips-target", "version": 1, "kind": "chessboard", "cols": 9, "rows": 6, "square": 0}',
     "square"),
])
def test_a_bad_target_file_is_named(tmp_path, capsys, text, message):
    if text is not None:
        (tmp_path / "t.json").write_text(text)
    (tmp_path / "obs.csv").write_text("id,xl,yl,xr,yr\n1,2,3,4,5\n")
    code = main(["calibrate", "air", "--target", str(tmp_path / "t.json"), "--obs", str(tmp_path / "obs.csv"),
                 "--out", str(tmp_path / "out.json")])
    error = capsys.readouterr().err.strip()
    assert code == 2 and "t.json" in error and message in error and len(error.splitlines()) == 1


def test_a_calibration_never_overwrites_its_own_inputs_or_an_older_calibration_unasked(views, capsys):
    d, rig = views
    observations = (d / "air.csv").read_bytes()
    base = ["calibrate", "air", "--target", str(d / "board.json"), "--obs", str(d / "air.csv"),
            "--sigma-px", str(NOISE), "--no-snooping"]
    for victim in ("air.csv", "board.json"):
        assert main([*base, "--out", str(d / victim)]) == 2
        assert "is an input of this command" in capsys.readouterr().err
    assert (d / "air.csv").read_bytes() == observations
    assert main([*base, "--out", str(d / "air.json")]) == 0
    first = (d / "air.json").read_bytes()
    assert main([*base, "--out", str(d / "air.json")]) == 2  # an older calibration is replaced only when asked
    assert "USVIPS calibration" in capsys.readouterr().err and (d / "air.json").read_bytes() == first
    assert main([*base, "--out", str(d / "air.json"), "--force"]) == 0
    assert (d / "air.json.bak").read_bytes() == first
