"""The centre-pose layout (USVIPS's own fish model) decoded exactly from synthetic output tensors: centres at
the heatmap's local maxima, boxes from their extents, snout and fork moved to the pair of their heatmaps'
peaks that fits the centre and the regressed points, later keypoints to their own heatmap's nearest peak
within the box (or left at the displaced point when there is none), all mapped back through the letterbox."""

import numpy as np
import pytest

from usvips.core.detection import Letterbox, ModelDescription
from usvips.core.detection.kinds.centre_pose import PEAK_THRESHOLD, CentrePose, channel_count, channel_slices
from usvips.core.detection.registry import family
from usvips.core.errors import InvalidParameterError

INPUT = (64, 64)
GRID = 16  # stride 4
NAMES = ("snout", "fork")
IMAGE = (128, 96)  # letterboxed: scale 0.5, 8 input pixels of padding above and below


def _description(threshold=0.3, **changes):
    return ModelDescription("m.onnx", "centre-pose", *INPUT, ("fish",), NAMES, score_threshold=threshold, **changes)


def _maps():
    c = channel_slices(len(NAMES))
    maps = np.zeros((channel_count(len(NAMES)), GRID, GRID))
    maps[c["centre"]] = 0.01
    objects = [  # centre cell (column, row), score, offset, extent (l, u, r, d) cells, displacements (cells)
        ((5, 3), 0.9, (0.25, 0.5), (3.0, 1.0, 4.0, 1.5), [(-2.4, -0.2), (3.7, 0.9)]),
        ((10, 11), 0.6, (0.75, 0.125), (2.0, 2.0, 2.0, 2.0), [(-1.0, -0.5), (1.5, 1.25)])]
    for (j, i), score, offset, extent, displacement in objects:
        maps[0, i, j] = score
        maps[0, i, j + 1] = score * 0.8  # a neighbour lower than the peak: no second detection
        maps[c["centre_offset"], i, j] = offset
        maps[c["extent"], i, j] = extent
        maps[c["displacement"], i, j] = np.ravel(displacement)
    return maps, objects


def _expected_keypoint(letterbox, cell, displacement):
    u, v = (cell[0] + displacement[0]) * 4, (cell[1] + displacement[1]) * 4
    return np.array(letterbox.to_image(u, v))


def test_the_layout_has_its_documented_channels():
    c = channel_slices(4)
    assert channel_count(4) == 21 and c["centre"] == slice(0, 1) and c["centre_offset"] == slice(1, 3)
    assert c["extent"] == slice(3, 7) and c["displacement"] == slice(7, 15)
    assert c["keypoint_heat"] == slice(15, 19) and c["keypoint_offset"] == slice(19, 21)
    assert family("centre-pose") is CentrePose


def test_centres_boxes_and_displaced_keypoints_without_keypoint_peaks():
    maps, objects = _maps()
    c = channel_slices(len(NAMES))
    maps[c["keypoint_heat"]] = 0.05  # no peak reaches the threshold: keypoints stay where displaced
    letterbox = Letterbox.fit(IMAGE, INPUT)
    found = CentrePose.decode(maps[None], _description(), letterbox)
    assert [d.score for d in found] == pytest.approx([0.9, 0.6])
    for detection, ((j, i), _, offset, extent, displacement) in zip(found, objects, strict=True):
        cx, cy = (j + offset[0]) * 4, (i + offset[1]) * 4
        x0, y0 = letterbox.to_image(cx - extent[0] * 4, cy - extent[1] * 4)
        x1, y1 = letterbox.to_image(cx + extent[2] * 4, cy + extent[3] * 4)
        np.testing.assert_allclose(detection.box, (x0, y0, x1, y1), atol=1e-9)
        for point, shift in zip(detection.keypoints, displacement, strict=True):
            np.testing.assert_allclose(point.pixel, _expected_keypoint(letterbox, (j, i), shift), atol=1e-9)
            assert point.confidence == pytest.approx(0.05)
        assert detection.keypoint_names == NAMES and detection.class_name == "fish"


def test_snout_and_fork_move_to_the_pair_of_peaks_whose_midpoint_is_the_centre():
    maps, objects = _maps()
    c = channel_slices(len(NAMES))
    heat, offsets = maps[c["keypoint_heat"]], maps[c["keypoint_offset"]]
    # the first fish: centre (5.25, 3.5) cells; snout regressed at (2.6, 2.8), fork at (8.7, 3.9)
    heat[0, 3, 2] = 0.7  # a snout peak at (2.9, 3.1)
    offsets[:, 3, 2] = (0.9, 0.1)
    heat[0, 14, 0] = 0.99  # a stronger snout peak far outside both boxes: never taken
    heat[1, 3, 7] = 0.6  # the fork peak that puts the pair's midpoint on the centre: (7.6, 3.9)
    offsets[:, 3, 7] = (0.6, 0.9)
    heat[1, 4, 9] = 0.6  # a fork peak nearer the regressed fork, (9.0, 4.0), but off the centre: not taken
    letterbox = Letterbox.fit(IMAGE, INPUT)
    first = CentrePose.decode(maps[None], _description(), letterbox)[0]
    np.testing.assert_allclose(first.keypoint("snout").pixel, letterbox.to_image(2.9 * 4, 3.1 * 4), atol=1e-9)
    assert first.keypoint("snout").confidence == pytest.approx(0.7)
    np.testing.assert_allclose(first.keypoint("fork").pixel, letterbox.to_image(7.6 * 4, 3.9 * 4), atol=1e-9)
    assert first.keypoint("fork").confidence == pytest.approx(0.6)
    assert PEAK_THRESHOLD < 0.6


def test_keypoints_after_the_first_two_move_to_their_nearest_peak_inside_the_box():
    names = ("snout", "fork", "tail")
    c = channel_slices(3)
    maps = np.zeros((channel_count(3), GRID, GRID))
    maps[0, 5, 5] = 0.9
    maps[c["extent"], 5, 5] = (3.0, 2.0, 3.0, 2.0)
    maps[c["displacement"], 5, 5] = (-2.0, 0.0, 2.0, 0.0, 2.6, 0.4)
    maps[c["keypoint_heat"].start + 2, 5, 8] = 0.4  # nearer the regressed tail (7.6, 5.4)
    maps[c["keypoint_heat"].start + 2, 3, 6] = 0.9  # stronger but farther
    maps[c["keypoint_heat"].start + 2, 15, 15] = 0.99  # outside the box
    letterbox = Letterbox.fit(IMAGE, INPUT)
    description = ModelDescription("m.onnx", "centre-pose", *INPUT, ("fish",), names, score_threshold=0.3)
    (found,) = CentrePose.decode(maps[None], description, letterbox)
    np.testing.assert_allclose(found.keypoint("tail").pixel, letterbox.to_image(8 * 4, 5 * 4), atol=1e-9)
    assert found.keypoint("tail").confidence == pytest.approx(0.4)


def test_a_later_keypoint_shifts_with_its_nearer_paired_keypoint_before_it_snaps():
    names = ("snout", "fork", "tail")
    c = channel_slices(3)
    heat = c["keypoint_heat"].start
    maps = np.zeros((channel_count(3), GRID, GRID))
    maps[0, 5, 5] = 0.9
    maps[c["extent"], 5, 5] = (4.0, 2.0, 4.0, 2.0)
    maps[c["displacement"], 5, 5] = (-2.0, 0.0, 2.0, 0.0, 3.0, -1.0)  # all one cell short of the peaks in x
    maps[heat, 5, 2] = maps[heat + 1, 5, 8] = 0.8  # snout (2, 5) and fork (8, 5): midpoint on the centre
    maps[heat + 2, 4, 9] = 0.8  # the tail: the regressed (8, 4) shifted as the fork was, one cell right
    maps[heat + 2, 4, 7] = 0.8  # a decoy nearer the regressed tail, (7.6, 4)
    maps[c["keypoint_offset"], 4, 7] = (0.6, 0.0)
    letterbox = Letterbox.fit(IMAGE, INPUT)
    description = ModelDescription("m.onnx", "centre-pose", *INPUT, ("fish",), names, score_threshold=0.3)
    (found,) = CentrePose.decode(maps[None], description, letterbox)
    np.testing.assert_allclose(found.keypoint("fork").pixel, letterbox.to_image(8 * 4, 5 * 4), atol=1e-9)
    np.testing.assert_allclose(found.keypoint("tail").pixel, letterbox.to_image(9 * 4, 4 * 4), atol=1e-9)


def test_the_score_threshold_and_max_detections_apply():
    maps, _ = _maps()
    letterbox = Letterbox.fit(IMAGE, INPUT)
    assert len(CentrePose.decode(maps[None], _description(threshold=0.7), letterbox)) == 1
    assert CentrePose.decode(maps[None], _description(threshold=0.95), letterbox) == ()
    assert len(CentrePose.decode(maps[None], _description(max_detections=1), letterbox)) == 1


def test_a_wrong_output_or_description_is_named():
    maps, _ = _maps()
    letterbox = Letterbox.fit(IMAGE, INPUT)
    with pytest.raises(InvalidParameterError, match=r"\[1, 15, H, W\]"):
        CentrePose.decode(maps[None, :-1], _description(), letterbox)
    with pytest.raises(InvalidParameterError, match="exactly one class"):
        CentrePose.check(ModelDescription("m.onnx", "centre-pose", *INPUT, ("fish", "ray"), NAMES))
    with pytest.raises(InvalidParameterError, match="at least one keypoint"):
        CentrePose.check(ModelDescription("m.onnx", "centre-pose", *INPUT, ("fish",), ()))
