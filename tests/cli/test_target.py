"""``usvips target describe|print|detect``: files written, images reported, bad input one line (exit 2)."""

import json

import numpy as np
import pytest

from usvips.cli import main
from usvips.core.calibration_targets import kind
from usvips.core.camera import Camera, Exterior
from usvips.core.interior import Interior
from usvips.core.synth.boards import BoardPose, render_board
from usvips.io.images import write_image


def test_describe_writes_metres_from_millimetres(tmp_path, capsys):
    out = tmp_path / "board.json"
    assert main(["target", "describe", "chessboard", "--cols", "9", "--rows", "6", "--square", "24",
                 "--out", str(out)]) == 0
    data = json.loads(out.read_text())
    assert data == {"format": "usvips-target", "version": 1, "kind": "chessboard", "cols": 9, "rows": 6,
                    "square": 0.024}
    assert "54 points" in capsys.readouterr().out


def test_describe_every_kind(tmp_path):
    control = tmp_path / "control.csv"
    control.write_text("id,X,Y,Z\n" + "".join(f"{k},{x:.3f},{y:.3f},{z:.3f}\n" for k, (x, y, z) in
                                              enumerate(np.random.default_rng(0).uniform(-0.3, 0.3, (10, 3)))))
    commands = [
        ["charuco", "--dictionary", "5X5_100", "--cols", "8", "--rows", "6", "--square", "30", "--marker", "22"],
        ["marker-grid", "--dictionary", "APRILTAG_36h11", "--cols", "5", "--rows", "4", "--marker", "40",
         "--separation", "10"],
        ["circle-grid", "--cols", "4", "--rows", "11", "--spacing", "20", "--diameter", "15", "--asymmetric"],
        ["chessboard", "--cols", "8", "--rows", "6", "--square", "24", "--upright"],
        ["target-field", "--control", str(control), "--size", "30", "--mark", "disc"],
    ]
    for k, command in enumerate(commands):
        out = tmp_path / f"t{k}.json"
        assert main(["target", "describe", *command, "--out", str(out)]) == 0
        assert json.loads(out.read_text())["kind"] == command[0]
    field = json.loads((tmp_path / "t4.json").read_text())
    assert len(field["points"]) == 10 and field["mark"] == "disc" and field["size"] == pytest.approx(0.03)


@pytest.mark.parametrize(("arguments", "words"), [
    (["chessboard", "--cols", "9", "--rows", "6", "--square", "0"], "square"),
    (["chessboard", "--cols", "8", "--rows", "6", "--square", "24"], "--upright"),
    (["chessboard", "--cols", "9", "--rows", "6", "--square", "24", "--marker", "5"], "--marker: not an option"),
    (["charuco", "--dictionary", "4X4_50", "--cols", "12", "--rows", "10", "--square", "30", "--marker", "20"],
     "4X4_50 has 50 markers"),
    (["charuco", "--dictionary", "4X4_50", "--cols", "5", "--rows", "4", "--square", "30", "--marker", "30"],
     "smaller than the square"),
    (["charuco", "--cols", "5", "--rows", "4", "--square", "30", "--marker", "20"], "dictionary: missing"),
    (["hexboard", "--cols", "5"], "unknown target kind"),
    (["target-field", "--size", "30"], "--control"),
])
def test_describe_refuses_bad_input_in_one_line(tmp_path, capsys, arguments, words):
    out = tmp_path / "t.json"
    assert main(["target", "describe", *arguments, "--out", str(out)]) == 2
    error = capsys.readouterr().err
    assert words in error and error.count("\n") == 1
    assert not out.exists()


def test_print_writes_a_pdf(tmp_path, capsys):
    board = tmp_path / "board.json"
    main(["target", "describe", "charuco", "--dictionary", "5X5_100", "--cols", "8", "--rows", "6", "--square", "30",
          "--marker", "22", "--out", str(board)])
    pdf = tmp_path / "board.pdf"
    assert main(["target", "print", str(board), "--out", str(pdf)]) == 0
    assert pdf.read_bytes().startswith(b"%PDF")
    assert "print at 100 %" in capsys.readouterr().out
    (tmp_path / "newer.json").write_text(json.dumps({**json.loads(board.read_text()), "version": 9}))
    assert main(["target", "print", str(tmp_path / "newer.json"), "--out", str(tmp_path / "x.pdf")]) == 2
    assert "newer than this USVIPS reads" in capsys.readouterr().err


def test_detect_reports_each_image(tmp_path, capsys):
    board = kind("charuco")("5X5_100", 7, 5, 0.025, 0.018)
    target = tmp_path / "board.json"
    main(["target", "describe", "charuco", "--dictionary", "5X5_100", "--cols", "7", "--rows", "5", "--square", "25",
          "--marker", "18", "--out", str(target)])
    camera = Camera(Interior(f=520.0, xp=239.5, yp=179.5), Exterior(0, 0, 0), width=480, height=360)
    pose = BoardPose.facing(camera, (0.0875, 0.0625), (240, 180), 0.5, tilt=0.3, spin=2.0)
    seen, empty = tmp_path / "seen.png", tmp_path / "empty.png"
    write_image(seen, render_board(camera, board, pose, supersample=2, colour=True))
    write_image(empty, np.full((360, 480), 90, np.uint8))
    capsys.readouterr()
    assert main(["target", "detect", str(target), str(seen), str(empty)]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].startswith(f"{seen}: 24/24 points, mean quality") and ", found by CharucoDetector" in lines[0]
    assert lines[1].startswith(f"{empty}: not found: no ChArUco corner found")
    assert lines[2] == "found in 1 of 2 images"
    assert main(["target", "detect", str(target), str(tmp_path / "missing.png")]) == 2
    assert "missing.png" in capsys.readouterr().err


@pytest.mark.parametrize("value", ["1e308", "nan", "0", "20000"])
def test_a_board_size_out_of_range_is_said_in_the_millimetres_it_was_given_in(tmp_path, capsys, value):
    assert main(["target", "describe", "chessboard", "--cols", "9", "--rows", "6", "--square", value,
                 "--out", str(tmp_path / "t.json")]) == 2
    err = capsys.readouterr().err
    assert "--square: must be a length in millimetres" in err and "metres are expected" not in err
    assert not (tmp_path / "t.json").exists()
