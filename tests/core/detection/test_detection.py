"""Detections and model descriptions as plain data: what is impossible is refused with a clear error."""

import numpy as np
import pytest

from tests.core.detection.onnx_models import constant_output_model
from usvips.core.detection import Detection, Detector, Keypoint, ModelDescription
from usvips.core.detection.runner import OnnxDetector
from usvips.core.errors import InvalidParameterError


def test_a_detection_names_its_keypoints_and_refuses_an_unknown_one():
    detection = Detection((1.0, 2.0, 30.0, 20.0), "fish", 0.8, (Keypoint("snout", 3.0, 10.0, 0.9),
                                                               Keypoint("fork", 28.0, 11.0, 0.4)))
    assert detection.keypoint_names == ("snout", "fork")
    np.testing.assert_array_equal(detection.keypoint("fork").pixel, [28.0, 11.0])
    with pytest.raises(InvalidParameterError, match="no keypoint 'tail'; this detection has snout, fork"):
        detection.keypoint("tail")


@pytest.mark.parametrize("box", [(5.0, 0.0, 1.0, 2.0), (0.0, 3.0, 1.0, 2.0), (0.0, 0.0, np.nan, 1.0), (0.0, 1.0)])
def test_an_impossible_box_is_refused(box):
    with pytest.raises(InvalidParameterError, match="parameter box"):
        Detection(box, "fish", 0.5)


@pytest.mark.parametrize("change,parameter", [
    ({"input_width": 0}, "input_width"), ({"scale": 0.0}, "scale"), ({"std": (1.0, 0.0, 1.0)}, "std"),
    ({"channel_order": "RGBA"}, "channels"), ({"iou_threshold": 1.5}, "iou_threshold"),
    ({"keypoint_names": ("a", "a")}, "keypoints")])
def test_an_impossible_description_is_refused_naming_the_field(change, parameter):
    fields = dict(model="m.onnx", family="yolo-pose", input_width=64, input_height=64, class_names=("fish",),
                  keypoint_names=("snout", "fork"))
    with pytest.raises(InvalidParameterError, match=f"parameter {parameter}"):
        ModelDescription(**{**fields, **change})


def test_the_onnx_runner_is_a_detector():
    description = ModelDescription("m.onnx", "yolo-pose", 32, 32, ("fish",), ("snout",))
    assert isinstance(OnnxDetector(description, constant_output_model(np.zeros((1, 8, 2)), 32, 32)), Detector)
