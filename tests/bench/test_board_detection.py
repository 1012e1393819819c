"""The chessboard-detection benchmark (our cascade against OpenCV's bare detector on 1080p frames) and the
real-set comparison with OpenCV (views found, focal lengths, baseline, held-out distances), run here on a
rendered set of known truth (no timed assertions)."""

import numpy as np
import pytest

from tests.app.board_images import air_scene
from usvips.bench import board_detection, real_boards
from usvips.io.target_file import write_target


def test_without_real_sets_the_row_times_rendered_1080p_frames(monkeypatch, tmp_path):
    monkeypatch.setenv(board_detection.REAL_BOARDS, str(tmp_path))  # a folder holding no set
    (row,) = list(board_detection.benchmarks(scale=0.1))
    assert "rendered views" in row["name"] and row["n"] == 3 and row["found"] == 3
    assert row["baseline"].startswith("cv2.findChessboardCornersSB without flags") and row["target"] == 1.2
    assert row["met"] == (row["ratio"] <= row["target"])


def test_without_the_variable_the_committed_sets_are_used(monkeypatch):
    monkeypatch.delenv(board_detection.REAL_BOARDS, raising=False)
    sets = board_detection._real_sets()
    assert sets and all(folder.parent == board_detection.COMMITTED_SETS for folder in sets)
    assert all((folder / "SOURCE.md").is_file() for folder in sets)


def test_a_small_image_is_upscaled_to_1080p_keeping_its_aspect():
    grey = np.tile(np.arange(64, dtype=np.uint8), (48, 1))
    frame = board_detection.to_1080p(grey)
    assert frame.shape == (1080, 1920)
    assert frame[:, 1440:].std() < frame[:, :1440].std()  # the padding repeats the edge column


@pytest.fixture(scope="module")
def rendered_set(tmp_path_factory):
    folder = tmp_path_factory.mktemp("set")
    board, rig, pairs, _ = air_scene(folder, 10, seed=5)
    for k, (left, right) in enumerate(pairs):
        left.rename(folder / f"left{k:02d}.png")
        right.rename(folder / f"right{k:02d}.png")
    write_target(folder / "board.json", board)
    return folder, rig


def test_a_rendered_set_compares_with_opencv_in_the_same_run(rendered_set):
    folder, rig = rendered_set
    figures = real_boards.compare_set(folder)
    assert figures["images"] == 20 and figures["images_found_opencv"] == 20
    assert figures["images_found_ours_where_opencv_finds"] == 20 and figures["pairs_kept_ours"] == 10
    assert not figures["set_aside_ours"] and len(figures["held_out_views"]) == 2
    # ours recovers the rig; OpenCV's figures are its own, computed in the same run, and compared as ratios
    assert abs(figures["ours"]["f_l"] / rig.left.f - 1) < 0.01
    assert abs(figures["ours"]["baseline"] / np.linalg.norm(rig.relative.base) - 1) < 0.01
    for name, difference in figures["relative_difference"].items():
        assert difference == pytest.approx(figures["ours"][name] / figures["opencv"][name] - 1)
    assert 0 < figures["held_out_rms_relative_ours"] < 0.05 and 0 < figures["held_out_rms_relative_opencv"] < 1


def test_the_sets_are_the_folders_with_a_board_description(tmp_path):
    for name in ("b", "a", "notes"):
        (tmp_path / name).mkdir()
    for name in ("a", "b"):
        (tmp_path / name / "board.json").write_text("{}")
    assert [path.name for path in real_boards.sets_under(tmp_path)] == ["a", "b"]
