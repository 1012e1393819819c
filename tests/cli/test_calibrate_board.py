"""``usvips calibrate air|water --target TARGET --images …|--left-images/--right-images|--project/--video``:
the views are found in rendered board images, the counts and the coverage printed, the calibration written;
a pair without the board is named and skipped; bad combinations and a video with no usable instant are one
line, exit 2, nothing written."""

from __future__ import annotations

import json

import cv2
import numpy as np
import pytest

from tests.app.board_images import SIZE, air_scene, board_poses, render_pairs
from usvips.app.video_project import add_video
from usvips.cli import main
from usvips.io.images import write_image
from usvips.io.target_file import write_target
from usvips.io.video_writer import encode_video
from usvips.store import Project

VIEWS = 6


@pytest.fixture(scope="module")
def scene(tmp_path_factory):
    folder = tmp_path_factory.mktemp("cli_boards")
    board, rig, pairs, rng = air_scene(folder, VIEWS, seed=7)
    water_rig = rig.in_water("flat-port", rng)
    render_pairs(folder, water_rig, board, board_poses(water_rig, board, rng, VIEWS, (0.7, 1.0)), "w")
    write_target(folder / "board.json", board)
    blank = folder / "aLblank.png"
    write_image(blank, np.full((SIZE[1], SIZE[0]), 100, np.uint8))
    return folder, rig, pairs, blank


def _one_line_exit_2(capsys, argv, pattern):
    import re

    assert main(argv) == 2
    error = capsys.readouterr().err.strip()
    assert "\n" not in error and "Traceback" not in error and re.search(pattern, error), error


def test_air_from_image_pairs_with_a_pair_without_the_board(scene, capsys):
    folder, rig, pairs, blank = scene
    images = [str(p) for pair in pairs for p in pair] + [str(blank), str(pairs[0][1])]
    out = folder / "air.json"
    assert main(["calibrate", "air", "--target", str(folder / "board.json"), "--images", *images,
                 "--out", str(out), "--report", str(folder / "air_report.json"), "--holdout", "0.3"]) == 0
    text = capsys.readouterr().out
    assert f"the target is found in both images of {VIEWS} of {VIEWS + 1} pairs" in text
    assert "view aLblank:" in text and "% of the image covered" in text
    assert "validation:" in text and "held out" in text and f"wrote {out}" in text
    assert "honesty on held-out views" in text
    report = json.loads((folder / "air_report.json").read_text())
    assert report["validation"]["honesty"]["reprojection_dof"] > 0 and report["estimation"]["estimator"] == "huber"
    written = json.loads(out.read_text())
    assert written["source"]["target"] == str(folder / "board.json") and len(written["source"]["images"]) == 14
    assert abs(written["parameters"]["f_l"]["value"] / rig.left.f - 1) < 0.01


def test_globs_pair_in_name_order_and_phase_two_from_them(scene, capsys):
    folder, _, _, _ = scene
    air = folder / "glob_air.json"
    assert main(["calibrate", "air", "--target", str(folder / "board.json"), "--left-images",
                 str(folder / "aL[0-9]*.png"), "--right-images", str(folder / "aR*.png"), "--out", str(air)]) == 0
    assert f"found in both images of {VIEWS} of {VIEWS} pairs" in capsys.readouterr().out
    water = folder / "glob_water.json"
    assert main(["calibrate", "water", "--base", str(air), "--housing", "flat-port", "--target",
                 str(folder / "board.json"), "--left-images", str(folder / "wL*.png"), "--right-images",
                 str(folder / "wR*.png"), "--out", str(water)]) == 0
    assert f"found in both images of {VIEWS} of {VIEWS} pairs" in capsys.readouterr().out
    written = json.loads(water.read_text())
    assert written["phase"] == "water" and written["housing"] == "flat-port"  # phase 2, however many views
    assert written["source"]["base"] == str(air)


@pytest.mark.parametrize("extra, pattern", [
    (["--images", "a.png"], "--images: 1 images given; give them in pairs"),
    (["--left-images", "nothing*.png", "--right-images", "nothing*.png"], "--left-images: no file matches"),
    (["--left-images", "x*.png"], "--right-images: the left and the right images are given together"),
    (["--video", "cal"], "--video: needs the project"),
    (["--images", "a.png", "b.png", "--obs", "o.csv"], "--images: give the observations either as --obs"),
    ([], "--obs: give the observations"),
])
def test_bad_combinations_are_one_line(scene, capsys, extra, pattern):
    folder, _, _, _ = scene
    _one_line_exit_2(capsys, ["calibrate", "air", "--target", str(folder / "board.json"), *extra,
                              "--out", str(folder / "bad.json")], pattern)
    assert not (folder / "bad.json").exists()


def test_images_need_a_target(scene, capsys, tmp_path):
    folder, _, pairs, _ = scene
    (tmp_path / "c.csv").write_text("id,X,Y,Z\n1,0,0,0\n")
    _one_line_exit_2(capsys, ["calibrate", "air", "--control", str(tmp_path / "c.csv"), "--images",
                              str(pairs[0][0]), str(pairs[0][1]), "--out", str(tmp_path / "o.json")],
                     "--images: finding the views needs the target")


def test_no_pair_with_the_board_is_one_line(scene, capsys, tmp_path):
    folder, _, _, blank = scene
    _one_line_exit_2(capsys, ["calibrate", "air", "--target", str(folder / "board.json"), "--images", str(blank),
                              str(blank), "--out", str(tmp_path / "o.json")], "none of the 1 pairs")
    assert not (tmp_path / "o.json").exists()


def test_a_video_with_no_usable_instant_is_one_line(scene, capsys, tmp_path):
    folder, _, _, _ = scene
    frames = [np.full((SIZE[1], SIZE[0], 3), 100, np.uint8)] * 4
    files = {}
    for side in ("left", "right"):
        files[side] = tmp_path / f"{side}.mkv"
        encode_video(files[side], frames, 25.0, "ffv1")
    project = tmp_path / "p.usvips"
    with Project.create(project) as p:
        add_video(p, [files["left"]], [files["right"]], "cal")
    _one_line_exit_2(capsys, ["calibrate", "air", "--target", str(folder / "board.json"), "--project", str(project),
                              "--video", "cal", "--every", "1", "--out", str(tmp_path / "o.json")],
                     "video 'cal': no usable instant")
    assert not (tmp_path / "o.json").exists()


def test_air_from_a_project_video(scene, capsys, tmp_path):
    folder, rig, pairs, _ = scene
    frames = {"left": [], "right": []}
    for left, right in pairs:
        for side, path in (("left", left), ("right", right)):
            grey = cv2.imread(str(path), cv2.IMREAD_GRAYSCALE)
            frames[side].append(cv2.cvtColor(grey, cv2.COLOR_GRAY2RGB))
    files = {}
    for side in ("left", "right"):
        files[side] = tmp_path / f"{side}.mkv"
        encode_video(files[side], frames[side], 25.0, "ffv1")
    project = tmp_path / "p.usvips"
    with Project.create(project) as p:
        add_video(p, [files["left"]], [files["right"]], "cal")
    out = tmp_path / "air.json"
    assert main(["calibrate", "air", "--target", str(folder / "board.json"), "--project", str(project),
                 "--video", "cal", "--every", "1", "--max-views", "10", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert f"{VIEWS} instants scanned" in text and "views chosen" in text and f"wrote {out}" in text
    written = json.loads(out.read_text())
    assert written["source"]["video"] == "cal" and all(s["label"].startswith("cal-") for s in written["stations"])
    assert abs(written["parameters"]["f_l"]["value"] / rig.left.f - 1) < 0.01


@pytest.mark.parametrize("option", ["--out", "--report"])
@pytest.mark.parametrize("how", ["images", "globs"])
def test_an_output_onto_an_input_image_is_refused_before_anything_is_written(scene, capsys, tmp_path, option, how):
    folder, _, pairs, _ = scene
    victim = pairs[1][0]
    before = victim.read_bytes()
    if how == "images":
        source = ["--images", *[str(p) for pair in pairs for p in pair]]
    else:
        source = ["--left-images", str(folder / "aL[0-9]*.png"), "--right-images", str(folder / "aR[0-9]*.png")]
    outputs = {"--out": str(tmp_path / "cal.json"), "--report": str(tmp_path / "report.json")}
    outputs[option] = str(folder / ".." / folder.name / victim.name)  # the same file by another path
    argv = ["calibrate", "air", "--target", str(folder / "board.json"), *source,
            *[item for pair in outputs.items() for item in pair]]
    _one_line_exit_2(capsys, argv, rf"the output is an input of this command.* \(set it with {option}; --force "
                                   r"replaces it\)$")
    assert victim.read_bytes() == before and not (tmp_path / "cal.json").exists()
    assert "found in both images" not in capsys.readouterr().out  # refused before detection


def test_a_missing_image_is_one_line_naming_it(scene, capsys, tmp_path):
    folder, _, pairs, _ = scene
    images = [str(p) for pair in pairs for p in pair] + [str(pairs[0][0]), str(folder / "gone.png")]
    _one_line_exit_2(capsys, ["calibrate", "air", "--target", str(folder / "board.json"), "--images", *images,
                              "--out", str(tmp_path / "cal.json")], r"gone\.png: no such image file")
    assert not (tmp_path / "cal.json").exists()


def test_views_with_swapped_images_are_named(scene, capsys, tmp_path):
    folder, _, pairs, _ = scene
    swapped = [(right, left) if k in (1, 3) else (left, right) for k, (left, right) in enumerate(pairs)]
    images = [str(p) for pair in swapped for p in pair]
    _one_line_exit_2(capsys, ["calibrate", "air", "--target", str(folder / "board.json"), "--images", *images,
                              "--out", str(tmp_path / "cal.json")],
                     r"views aR1, aR3: the left and right images look swapped")
    assert not (tmp_path / "cal.json").exists()
