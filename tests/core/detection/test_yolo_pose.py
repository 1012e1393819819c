"""The YOLO-pose family's decoder on synthetic output tables with known truth: every box and keypoint
recovered through the letterbox, the suppression keeping the best of overlapping boxes."""

import numpy as np
import pytest

from tests.core.detection.yolo_tables import random_truth, row, table
from usvips.core.detection import Letterbox, ModelDescription
from usvips.core.detection.registry import family, names
from usvips.core.errors import InvalidParameterError

NAMES = ("snout", "fork", "upper caudal", "lower caudal")


def describe(classes=("fish",), keypoints=NAMES, values=3, width=640, height=640, objectness=False):
    return ModelDescription("m.onnx", "yolo-pose", width, height, classes, keypoints, keypoint_values=values,
                            objectness=objectness)


def test_the_registry_knows_the_yolo_pose_family_and_names_the_known_ones_for_an_unknown_one():
    assert "yolo-pose" in names()
    with pytest.raises(InvalidParameterError, match="unknown model family 'yolo-x'; known: yolo-pose"):
        family("yolo-x")


@pytest.mark.parametrize("channels_first", [True, False])
@pytest.mark.parametrize("classes", [("fish",), ("fish", "shark", "ray")])
@pytest.mark.parametrize("objectness", [False, True])
def test_boxes_and_keypoints_are_recovered_exactly_through_the_letterbox(channels_first, classes, objectness):
    rng = np.random.default_rng(7 + len(classes) + channels_first + 10 * objectness)
    for trial in range(20):
        size = (int(rng.integers(300, 1920)), int(rng.integers(200, 1080)))
        description = describe(classes, width=int(rng.choice([320, 640])), height=int(rng.choice([256, 640])),
                               objectness=objectness)
        letterbox = Letterbox.fit(size, (description.input_width, description.input_height))
        truth = random_truth(rng, int(rng.integers(1, 8)), size, len(NAMES), len(classes))
        found = family("yolo-pose").decode(table(rng, truth, description, letterbox, channels_first), description,
                                           letterbox)
        assert len(found) == len(truth), trial
        assert [d.score for d in found] == sorted((d.score for d in found), reverse=True)
        for t in sorted(truth, key=lambda t: -t["score"]):
            d = found[[abs(d.score - t["score"]) < 1e-12 for d in found].index(True)]  # objectness × class
            np.testing.assert_allclose(d.box, t["box"], atol=1e-9)
            assert d.class_name == classes[t["class"]]
            assert d.keypoint_names == NAMES
            np.testing.assert_allclose([[k.x, k.y, k.confidence] for k in d.keypoints], t["keypoints"], atol=1e-9)


def test_suppression_keeps_the_best_of_overlapping_boxes_of_one_class_and_both_of_two_classes():
    description = describe(("fish", "shark"), ("snout", "fork"))
    letterbox = Letterbox.fit((640, 640), (640, 640))
    points = np.array([[110.0, 120.0, 0.9], [180.0, 125.0, 0.8]])
    box = np.array([100.0, 100.0, 200.0, 150.0])
    rows = [row(box, 0, 0.6, points, letterbox, 2), row(box + 4, 0, 0.8, points + [4, 4, 0], letterbox, 2),
            row(box + 2, 1, 0.7, points, letterbox, 2), row(box + 300, 0, 0.3, points + 300, letterbox, 2)]
    found = family("yolo-pose").decode(np.array(rows).T[None], description, letterbox)
    assert [(d.class_name, round(d.score, 6)) for d in found] == [("fish", 0.8), ("shark", 0.7), ("fish", 0.3)]
    np.testing.assert_allclose(found[0].box, box + 4, atol=1e-9)
    assert found[0].keypoint("fork").x == pytest.approx(184.0)


def test_two_values_per_keypoint_give_each_keypoint_the_detection_score():
    description = describe(keypoints=("snout", "fork"), values=2)
    letterbox = Letterbox.fit((800, 600), (640, 640))
    points = np.array([[110.0, 120.0, 0.0], [180.0, 125.0, 0.0]])
    found = family("yolo-pose").decode(row(np.array([100.0, 100, 200, 150]), 0, 0.7, points, letterbox, 1, 2)
                                       [:, None][None], description, letterbox)
    assert [k.confidence for k in found[0].keypoints] == [pytest.approx(0.7)] * 2
    assert found[0].keypoint("snout").y == pytest.approx(120.0)


def test_an_output_that_does_not_fit_the_description_is_one_clear_error():
    description = describe()
    with pytest.raises(InvalidParameterError, match=r"shape \(1, 9, 50\).*\[1, 17, N\] or \[1, N, 17\]"):
        family("yolo-pose").decode(np.zeros((1, 9, 50)), description, Letterbox.fit((640, 640), (640, 640)))
    with pytest.raises(InvalidParameterError, match=r"\[1, 18, N\].*objectness, 1 class"):
        family("yolo-pose").decode(np.zeros((1, 17, 50)), describe(objectness=True),
                                   Letterbox.fit((640, 640), (640, 640)))


def test_nothing_above_the_threshold_is_no_detection():
    description = describe(keypoints=("snout", "fork"))
    assert family("yolo-pose").decode(np.zeros((1, 11, 30)), description, Letterbox.fit((64, 64), (64, 64))) == ()


def test_the_letterbox_undo_inverts_the_letterbox_and_centres_the_image():
    rng = np.random.default_rng(3)
    for _ in range(50):
        size = (int(rng.integers(10, 4000)), int(rng.integers(10, 3000)))
        box = Letterbox.fit(size, (int(rng.integers(32, 1280)), int(rng.integers(32, 1280))))
        x, y = rng.uniform(-0.5, size[0] - 0.5, 20), rng.uniform(-0.5, size[1] - 0.5, 20)
        back = box.to_image(*box.to_input(x, y))
        np.testing.assert_allclose(back, [x, y], atol=1e-9)
        # the image's outer edges land on the resized region's edges
        np.testing.assert_allclose(box.to_input(-0.5, -0.5), [box.pad_x, box.pad_y], atol=1e-9)
        np.testing.assert_allclose(box.to_input(size[0] - 0.5, size[1] - 0.5),
                                   [box.pad_x + box.resized[0], box.pad_y + box.resized[1]], atol=1e-9)


def test_a_square_output_reads_as_channels_first():
    description = describe(keypoints=("snout", "fork"))  # C = 11
    letterbox = Letterbox.fit((640, 640), (640, 640))
    points = np.array([[110.0, 120.0, 0.9], [180.0, 125.0, 0.8]])
    rows = [row(np.array([100.0, 100, 200, 150]), 0, 0.9, points, letterbox, 1)] + [np.zeros(11)] * 10
    found = family("yolo-pose").decode(np.array(rows).T[None], description, letterbox)
    assert len(found) == 1 and found[0].keypoint("fork").x == pytest.approx(180.0)
