"""Stereo views from image pairs: the same id is the same physical point in both cameras; every pair that
cannot be used is named with its image and reason (the one loop's rules: blur, near-duplicates); a missing
file is an error; progress and cancel."""

import numpy as np
import pytest

from usvips.app.target_views import detect_views
from usvips.core.calibration_targets import kind, stereo_observations
from usvips.core.camera import Camera, Exterior
from usvips.core.errors import InputFileError
from usvips.core.interior import Interior
from usvips.core.synth.boards import BoardPose, board_pixels, render_board
from usvips.io.images import write_image

W, H = 480, 360


def _rig():
    interior = Interior(f=520.0, xp=239.5, yp=179.5, k1=-0.03)
    left = Camera(interior, Exterior(0.0, 0.0, 0.0), width=W, height=H)
    right = Camera(interior, Exterior(0.08, 0.0, 0.0, 0.0, 0.08, 0.0), width=W, height=H)
    return left, right


@pytest.fixture(scope="module")
def pairs(tmp_path_factory):
    folder = tmp_path_factory.mktemp("pairs")
    board = kind("charuco")("5X5_100", 7, 5, 0.025, 0.018)
    left, right = _rig()
    rng = np.random.default_rng(5)
    made, truth = [], []
    for k in range(3):
        pose = BoardPose.facing(left, (0.0875, 0.0625), (rng.uniform(250, 290), rng.uniform(160, 200)),
                                rng.uniform(0.5, 0.6), tilt=rng.uniform(0, 0.4), tilt_direction=rng.uniform(0, 6),
                                spin=rng.uniform(-3, 3))
        paths = []
        for side, camera in (("L", left), ("R", right)):
            path = folder / f"{side}{k}.png"
            write_image(path, render_board(camera, board, pose, supersample=2, seed=k))
            paths.append(path)
        made.append(tuple(paths))
        truth.append({side: dict(zip(*board_pixels(camera, board, pose)[:2], strict=True))
                      for side, camera in (("left", left), ("right", right))})
    blank = folder / "blank.png"
    write_image(blank, np.full((H, W), 90, np.uint8))
    small = folder / "small.png"
    write_image(small, np.full((H // 2, W // 2), 90, np.uint8))
    broken = folder / "broken.png"
    broken.write_bytes(b"not an image")
    return board, made, truth, {"blank": blank, "small": small, "broken": broken, "missing": folder / "none.png"}


def test_views_pair_the_same_physical_points(pairs):
    board, made, truth, _ = pairs
    found = detect_views(board, made)
    assert len(found.views) == 3 and not found.set_aside
    assert [view.label for view in found.views] == ["L0", "L1", "L2"]
    for view, true in zip(found.views, truth, strict=True):
        for side in ("left", "right"):
            detection = getattr(view, side)
            errors = [np.linalg.norm(detection.pixels[k] - true[side][pid]) for k, pid in enumerate(detection.ids)]
            assert max(errors) < 0.5
    observations = stereo_observations(list(found.views))
    assert len(observations.ids) == sum(len(view.common_ids()) for view in found.views)
    assert "3 of 3 pairs" in found.summary()


def test_each_unusable_pair_is_named_with_its_image_and_reason(pairs):
    board, made, _, bad = pairs
    good = made[0]
    found = detect_views(board, [good, (made[1][0], bad["blank"]), (bad["broken"], made[2][1]),
                                 (bad["broken"], bad["blank"]), (made[2][0], bad["small"])],
                         labels=["a", "b", "c", "d", "e"])
    assert [view.label for view in found.views] == ["a"]
    reasons = dict(found.set_aside)
    assert "right image blank.png: no ChArUco corner found" in reasons["b"]
    assert "seen by the left camera only" in reasons["b"]
    assert "broken.png" in reasons["c"] and "seen by the right camera only" in reasons["c"]
    assert "broken.png" in reasons["d"] and "blank.png" in reasons["d"]
    assert "240 × 180 px, the earlier right images 480 × 360" in reasons["e"]
    assert all(reason.startswith(f"view {label}: ") and "\n" not in reason for label, reason in found.set_aside)


def test_too_few_common_points_are_named(pairs):
    board, made, _, _ = pairs
    found = detect_views(board, [made[0]], minimum_points=1000)
    assert not found.views and "at least 1000 needed" in found.set_aside[0][1]


def test_progress_and_cancel(pairs):
    board, made, _, _ = pairs
    seen = []
    detect_views(board, made, progress=lambda done, total: seen.append((done, total)))
    assert seen == [(k, 6) for k in range(1, 7)]
    calls = []

    def cancelled():
        calls.append(1)
        return len(calls) > 3

    with pytest.raises(InterruptedError, match="after 1 of 3 pairs"):
        detect_views(board, made, cancelled=cancelled)
    assert len(calls) == 4


def test_labels_must_match_the_pairs(pairs):
    board, made, _, _ = pairs
    with pytest.raises(Exception, match="one distinct label per pair"):
        detect_views(board, made, labels=["x", "x", "y"])


def test_a_missing_image_file_is_an_error_naming_it_before_anything_is_detected(pairs):
    board, made, _, bad = pairs
    calls = []
    with pytest.raises(InputFileError, match="none.png: no such image file"):
        detect_views(board, [made[0], (bad["missing"], made[2][1])],
                     progress=lambda done, total: calls.append(done))
    assert calls == []


def test_image_pairs_follow_the_video_rules_a_repeated_pair_is_a_near_duplicate(pairs):
    board, made, _, _ = pairs
    found = detect_views(board, [made[0], made[0], made[2]], labels=["a", "again", "c"])
    assert [view.label for view in found.views] == ["a", "c"]
    assert dict(found.set_aside)["again"] == ("view again: a near-duplicate of view a (every shared point within 3 px "
                                              "in both cameras)")
    assert found.detected.duplicates == 1 and found.detected.scanned == 3 and len(found.blur) == 2
