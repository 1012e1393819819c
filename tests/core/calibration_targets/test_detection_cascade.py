"""The detection cascade: stages tried in order until one succeeds (reduced and extended copies mapped back
to full-size pixels); chessboards whose outer squares the image cuts are found with the right corner
order; the reason words what was tried."""

import numpy as np
import pytest

from usvips.core.calibration_targets import cascade, kind
from usvips.core.calibration_targets.kinds.chessboard import square_contrast
from usvips.core.camera import Camera, Exterior
from usvips.core.interior import Interior
from usvips.core.synth.boards import BoardPose, board_pixels, render_board

W, H = 640, 480


def _camera(width=W, height=H, f=600.0) -> Camera:
    return Camera(Interior(f=f, xp=(width - 1) / 2, yp=(height - 1) / 2, k1=-0.03), Exterior(0, 0, 0), width=width,
                  height=height)


def _random_view(board, rng, camera=None, supersample=2):
    camera = camera or _camera()
    centre = board.control_points().xyz.mean(axis=0)[:2]
    middle = np.array([camera.width, camera.height]) / 2
    pose = BoardPose.facing(camera, centre, tuple(middle + rng.uniform(-30, 30, 2)), rng.uniform(0.4, 0.6),
                            tilt=rng.uniform(0.0, 0.6), tilt_direction=rng.uniform(0, 2 * np.pi),
                            spin=rng.uniform(-np.pi, np.pi))
    ids, pixels, ok = board_pixels(camera, board, pose)
    assert ok.all()
    return render_board(camera, board, pose, supersample=supersample), dict(zip(ids, pixels, strict=True))


def _max_error(detection, truth):
    return max(np.linalg.norm(detection.pixels[k] - truth[pid]) for k, pid in enumerate(detection.ids))


# ------------------------------------------------------------------------------------------ machinery
def _stage(name, answer, calls, **options):
    def search(image):
        calls.append((name, image.shape))
        return answer(image)
    return cascade.Stage(name, search, **options)


def test_the_cascade_stops_at_the_first_stage_that_finds_and_says_which():
    calls = []
    grey = np.zeros((100, 200), np.uint8)
    stages = [_stage("a", lambda image: None, calls), _stage("b", lambda image: np.array([[10.0, 20.0]]), calls),
              _stage("c", lambda image: np.array([[1.0, 1.0]]), calls)]
    found = cascade.run(stages, grey)
    assert [name for name, _ in calls] == ["a", "b"]
    assert found.stage.name == "b" and found.tried == ("a",)
    assert cascade.found_note(found) == ("found by b",)
    np.testing.assert_allclose(found.pixels, [[10.0, 20.0]])


def test_reduced_and_extended_searches_come_back_as_full_size_pixels():
    calls = []
    grey = np.zeros((400, 600), np.uint8)
    # a point at reduced pixel (x, y) of a factor-2 copy extended by 5 px is full-size ((x − 5) + 0.5)·2 − 0.5
    stages = [_stage("small only", lambda image: None, calls, minimum_side=1000),
              _stage("halved, extended", lambda image: np.array([[15.0, 25.0]]), calls, factor=2, pad=5)]
    found = cascade.run(stages, grey)
    assert calls == [("halved, extended", (200 + 10, 300 + 10))]
    np.testing.assert_allclose(found.pixels, [[20.5, 40.5]])
    assert cascade.tried_names(stages, grey) == ["halved, extended"]


def test_nothing_found_is_none_and_the_reason_counts_the_detectors():
    grey = np.zeros((50, 50), np.uint8)
    stages = [_stage(name, lambda image: None, []) for name in "abc"]
    assert cascade.run(stages, grey) is None
    reason = cascade.not_found("no board", stages, grey, "keep it in view")
    assert reason == "no board found by any of 3 detectors and settings (keep it in view)"


# ------------------------------------------------------------------------------------------ chessboard
def test_a_clean_chessboard_is_found_by_the_first_stage_alone():
    board = kind("chessboard")(9, 6, 0.02)
    image, truth = _random_view(board, np.random.default_rng(3))
    detection = board.detect(image)
    assert detection and detection.stage == cascade.tried_names(board.stages(image), image)[0]
    assert not detection.notes
    assert _max_error(detection, truth) < 0.3


@pytest.mark.parametrize("seed", range(6))
def test_a_chessboard_whose_outer_squares_are_cut_is_found_in_the_right_order(seed):
    """The image cut 6 px outside the outermost inner corners on every side: every outer square (those of
    corner 0 too) is cut, every inner corner in view."""
    board = kind("chessboard")(9, 6, 0.02)
    image, truth = _random_view(board, np.random.default_rng(100 + seed))
    pixels = np.array(list(truth.values()))
    x0, y0 = np.floor(pixels.min(axis=0) - 6).astype(int)
    x1, y1 = np.ceil(pixels.max(axis=0) + 6).astype(int)
    cut = np.ascontiguousarray(image[y0:y1 + 1, x0:x1 + 1])
    detection = board.detect(cut)
    assert detection, detection.reason
    moved = {pid: xy - (x0, y0) for pid, xy in truth.items()}
    assert _max_error(detection, moved) < 0.4


def test_the_square_colours_tell_the_order_and_its_half_turn_apart():
    board = kind("chessboard")(9, 6, 0.02)
    image, truth = _random_view(board, np.random.default_rng(7))
    grid = np.array([truth[str(k)] for k in range(54)]).reshape(6, 9, 2)
    right, turned = square_contrast(image, grid), square_contrast(image, grid[::-1, ::-1])
    assert right > 50 and turned == pytest.approx(-right)


def test_a_large_frame_is_searched_reduced_and_refined_at_full_size():
    board = kind("chessboard")(9, 6, 0.02)
    camera = _camera(2600, 1500, f=2400.0)
    image, truth = _random_view(board, np.random.default_rng(11), camera, supersample=1)
    detection = board.detect(image)
    stages = {stage.name: stage for stage in board.stages(image)}
    assert detection and stages[detection.stage].factor >= 2
    assert _max_error(detection, truth) < 0.5


def _searched_at_full_size_only(board):
    class FullSizeOnly(type(board)):
        def stages(self, grey):
            return [stage for stage in super().stages(grey) if "halved" not in stage.name]
    return FullSizeOnly(board.cols, board.rows, board.square)


@pytest.mark.parametrize("seed", range(4))
def test_a_1080p_frame_is_searched_halved_first_with_the_corners_of_a_full_size_search(seed):
    """A board filling a fair part of a 1080p frame: found on the frame halved (the first stage tried), and
    its corners, refined on the full image, those that the full-size search's refined corners are."""
    board = kind("chessboard")(9, 6, 0.02)
    camera = _camera(1920, 1080, f=1700.0)
    image, truth = _random_view(board, np.random.default_rng(40 + seed), camera, supersample=1)
    stages = board.stages(image)
    assert cascade.tried_names(stages, image)[0] == "findChessboardCornersSB on the frame halved"
    detection = board.detect(image)
    assert detection and detection.stage == "findChessboardCornersSB on the frame halved"
    full_size = _searched_at_full_size_only(board).detect(image)
    assert full_size and full_size.stage == "findChessboardCornersSB"
    assert np.abs(detection.pixels - full_size.pixels).max() < 0.01
    assert _max_error(detection, truth) < 0.5


def test_a_small_board_in_a_1080p_frame_missed_halved_is_found_at_full_size():
    board = kind("chessboard")(9, 6, 0.02)
    camera = _camera(1920, 1080, f=1700.0)
    centre = board.control_points().xyz.mean(axis=0)[:2]
    pose = BoardPose.facing(camera, centre, (900.0, 560.0), 4.0, tilt=0.2, tilt_direction=0.5, spin=0.1)
    ids, pixels, ok = board_pixels(camera, board, pose)
    image = render_board(camera, board, pose, supersample=2)
    halved = cascade.run(board.stages(image)[:1], image)
    assert halved is None  # squares of 8.5 px at full size, about 4 px halved: too small there
    detection = board.detect(image)
    assert detection and detection.stage == "findChessboardCornersSB"
    assert "found by findChessboardCornersSB" in detection.notes
    assert _max_error(detection, dict(zip(ids, pixels, strict=True))) < 0.3


def test_a_chessboard_not_in_view_names_what_was_tried():
    board = kind("chessboard")(9, 6, 0.02)
    clutter = np.clip(100 + 30 * np.random.default_rng(2).standard_normal((H, W)), 0, 255).astype(np.uint8)
    detection = board.detect(clutter)
    assert not detection
    assert f"found by any of {len(cascade.tried_names(board.stages(clutter), clutter))} detectors" in detection.reason
    assert "every inner corner must be in view" in detection.reason
