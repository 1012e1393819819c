"""``usvips render --target T --housing …`` (issue 33, item 6): board views through a housing from the
command line; every bad argument one line, exit 2, nothing written."""

from __future__ import annotations

import json

import pytest

from usvips.cli import main
from usvips.core.calibration_targets.kinds.chessboard import Chessboard
from usvips.io.target_file import write_target


@pytest.fixture()
def board(tmp_path):
    path = tmp_path / "board.json"
    write_target(path, Chessboard(5, 4, 0.04))
    return path


SMALL = ["--views", "1", "--image-size", "320x240", "--supersample", "1", "--distance", "0.9", "1.2"]


def test_board_views_through_a_flat_port(tmp_path, board, capsys):
    out = tmp_path / "tank"
    assert main(["render", "--target", str(board), "--housing", "flat-port", "--housing-value", "g=0.05", "n3=1.0",
                 *SMALL, "--out", str(out)]) == 0
    assert "rendered 1 view pairs" in capsys.readouterr().out
    truth = json.loads((out / "truth.json").read_text())
    assert truth["housing"]["left"]["g"] == pytest.approx(0.05) and truth["housing"]["left"]["n3"] == 1.0
    assert (out / "left" / "view_000.png").exists() and (out / "observations.csv").exists()


@pytest.mark.parametrize("extra, message", [
    (["--housing-value", "g=abc"], "--housing-value: expected NAME=VALUE"),
    (["--housing-value", "zz=1"], "zz: is not a parameter of the flat-port housing"),
    (["--housing-value", "g=-1"], "g"),
    (["--image-size", "big"], "--image-size: expected WIDTHxHEIGHT"),
    (["--views", "-1"], "--views"),
    (["--tilt", "40", "10"], "--tilt"),
    (["--distance", "0.01", "0.02"], "does not fit"),
    (["--calibration", "missing.json"], "missing.json"),
])
def test_bad_arguments_are_one_line(tmp_path, board, capsys, extra, message):
    out = tmp_path / "out"
    code = main(["render", "--target", str(board), "--housing", "flat-port", *SMALL, *extra, "--out", str(out)])
    error = capsys.readouterr().err.strip()
    assert code == 2 and len(error.splitlines()) == 1 and message in error, error
    assert not out.exists()


def test_a_scene_and_a_target_together_are_refused(tmp_path, board, capsys):
    assert main(["render", "scene.json", "--target", str(board), "--out", str(tmp_path / "o")]) == 2
    assert "not both" in capsys.readouterr().err
