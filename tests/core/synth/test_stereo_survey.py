"""Rendered stereo survey clips: both images of a frame show the same fish through a random rig of the
housing kind, the truth in each image is the fish's points projected through that camera, and the fish swim
on from frame to frame without changing size."""

import numpy as np
import pytest

from usvips.core import housing as housings
from usvips.core.synth.stereo_survey import BASELINE_M, survey_clip


@pytest.mark.parametrize("seed", [7, 8, 9, 10])
def test_each_images_truth_is_the_fishs_points_through_its_camera(seed):
    clip = survey_clip(seed, (320, 240), frames=2, step=5)
    assert clip.kind == housings.names()[seed % len(housings.names())]
    assert BASELINE_M[0] <= np.linalg.norm(clip.rig.right.exterior.position - clip.rig.left.exterior.position) \
        <= BASELINE_M[1]
    first, second = clip.frames
    for frame in clip.frames:
        assert frame.left.shape == frame.right.shape == (240, 320, 3)
        for left, right in zip(frame.left_truth, frame.right_truth, strict=True):
            assert np.allclose(left.points, right.points)  # one fish, seen by both cameras
            for camera, truth in ((clip.rig.left, left), (clip.rig.right, right)):
                projected = camera.project(truth.points)
                seen = projected.ok
                assert np.allclose(projected.pixels[seen], truth.keypoints[seen], atol=1e-6)
    for a, b in zip(first.left_truth, second.left_truth, strict=True):
        assert a.length == pytest.approx(b.length)
        moved = np.linalg.norm(b.points[0] - a.points[0])
        assert 0.1 * 5 / 25 * 0.99 <= moved <= 0.6 * 5 / 25 * 1.01  # 0.1-0.6 m/s for 5 frames at 25 fps


def test_a_clip_is_the_same_for_its_seed():
    a, b = survey_clip(3, (160, 120), frames=1), survey_clip(3, (160, 120), frames=1)
    assert np.array_equal(a.frames[0].left, b.frames[0].left) and np.array_equal(a.frames[0].right, b.frames[0].right)
    assert not np.array_equal(a.frames[0].left, a.frames[0].right)
