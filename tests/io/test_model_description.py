"""Model description files: a user's ONNX model with its own input size and layout runs from its
description alone; every bad field is one clear line naming the file and the key."""

import json

import numpy as np
import pytest

from tests.core.detection.onnx_models import constant_output_model
from tests.core.detection.yolo_tables import random_truth, table
from usvips.core.detection import Letterbox
from usvips.core.errors import InputFileError
from usvips.io.model_description import load_detector, read_model_description

GOOD = """
[model]
file = "fish-pose.onnx"
family = "yolo-pose"
input_width = 320
input_height = 256

[normalisation]
scale = 0.00392156862745098
mean = [0.0, 0.0, 0.0]
std = [1.0, 1.0, 1.0]
channels = "RGB"

[output]
classes = ["fish", "shark"]
keypoints = ["snout", "fork"]
keypoint_values = 3
score_threshold = 0.3
iou_threshold = 0.5
"""


def test_a_users_model_runs_from_its_description_alone(tmp_path):
    path = tmp_path / "fish-pose.toml"
    path.write_text(GOOD)
    description = read_model_description(path)
    assert (description.input_width, description.input_height, description.class_names) == (320, 256,
                                                                                           ("fish", "shark"))
    rng = np.random.default_rng(2)
    letterbox = Letterbox.fit((900, 500), (320, 256))
    truth = random_truth(rng, 3, (900, 500), 2, 2)
    (tmp_path / "fish-pose.onnx").write_bytes(constant_output_model(table(rng, truth, description, letterbox, False),
                                                                     320, 256))
    found = load_detector(path).detect(np.zeros((500, 900, 3), np.uint8))
    assert sorted(round(d.score, 5) for d in found) == sorted(round(t["score"], 5) for t in truth)
    for t in truth:
        d = min(found, key=lambda d: abs(d.score - t["score"]))
        np.testing.assert_allclose(d.keypoint("fork").pixel, t["keypoints"][1, :2], atol=0.01)


def test_json_holds_the_same_keys(tmp_path):
    path = tmp_path / "m.json"
    path.write_text(json.dumps({"model": {"file": "m.onnx", "family": "yolo-pose", "input_width": 640,
                                          "input_height": 640},
                                "output": {"classes": ["fish"], "keypoints": ["snout", "fork"], "objectness": True}}))
    description = read_model_description(path)
    assert description.channel_order == "RGB" and description.scale == pytest.approx(1 / 255)
    assert description.objectness and not read_model_description(_good(tmp_path)).objectness


def _good(folder):
    path = folder / "good.toml"
    path.write_text(GOOD)
    return path


@pytest.mark.parametrize("old,new,message", [
    ('input_width = 320', 'input_width = 0', "model.input_width: expected a whole number from 1"),
    ('input_width = 320\n', '', "model.input_width: missing"),
    ('family = "yolo-pose"', 'family = "detr"', "model.family: unknown model family 'detr'; known: yolo-pose"),
    ('std = [1.0, 1.0, 1.0]', 'std = [1.0, 0.0, 1.0]', "normalisation.std: expected 3 finite numbers > 0"),
    ('mean = [0.0, 0.0, 0.0]', 'mean = [0.0, 0.0]', "normalisation.mean: expected 3 finite numbers"),
    ('channels = "RGB"', 'channels = "RGBA"', "normalisation.channels: expected one of RGB, BGR"),
    ('scale = 0.00392156862745098', 'scale = -1', "normalisation.scale: expected a finite number > 0"),
    ('keypoints = ["snout", "fork"]', 'keypoints = ["snout", "snout"]', "output.keypoints: names repeat"),
    ('classes = ["fish", "shark"]', 'classes = "fish"', "output.classes: expected a list of names"),
    ('keypoint_values = 3', 'keypoint_values = 1', "output.keypoint_values: the yolo-pose layout has 2 or 3"),
    ('keypoint_values = 3', 'keypoint_values = 3\nobjectness = "yes"', "output.objectness: expected true or false"),
    ('score_threshold = 0.3', 'score_threshold = 1.5', r"output.score_threshold: expected a finite number in \[0, 1\]"),
    ('iou_threshold = 0.5', 'iou = 0.5', "output.iou: unknown key"),
    ('[output]', '[outputs]', "outputs: unknown section"),
    ('[model]', '[model', "not valid TOML"),
])
def test_every_bad_field_is_one_line_naming_the_file_and_the_key(tmp_path, old, new, message):
    path = tmp_path / "bad.toml"
    assert old in GOOD
    path.write_text(GOOD.replace(old, new))
    with pytest.raises(InputFileError, match=message) as caught:
        read_model_description(path)
    assert str(caught.value).startswith(str(path)) and "\n" not in str(caught.value)


def test_a_missing_or_unreadable_model_file_is_named(tmp_path):
    path = tmp_path / "m.toml"
    path.write_text(GOOD)
    with pytest.raises(InputFileError, match="model.file: no such file"):
        load_detector(path)
    (tmp_path / "fish-pose.onnx").write_bytes(b"garbage")
    with pytest.raises(InputFileError, match="fish-pose.onnx: OpenCV cannot read the ONNX model"):
        load_detector(path)
    with pytest.raises(InputFileError, match="no such file"):
        read_model_description(tmp_path / "none.toml")
    (tmp_path / "m.yaml").write_text("a: 1")
    with pytest.raises(InputFileError, match="unknown description format '.yaml'"):
        read_model_description(tmp_path / "m.yaml")


def test_the_measured_keypoint_sigma_is_read_and_checked(tmp_path):
    path = tmp_path / "fish-pose.toml"
    path.write_text(GOOD + '\n[keypoint_sigma]\nbasis = "validation, 400 rendered fish"\n'
                    'px = {snout = 1.1, fork = 1.7}\n')
    description = read_model_description(path)
    assert description.measured_sigma("snout") == 1.1 and description.measured_sigma("fork") == 1.7
    assert description.keypoint_sigma_basis == "validation, 400 rendered fish"
    path.write_text(GOOD)
    assert read_model_description(path).measured_sigma("snout") is None
    for bad, key in (("px = {tail = 1.0}", "keypoint_sigma.px.tail"),
                     ("px = {snout = -1.0}", "keypoint_sigma.px.snout"), ("px = 2.0", "keypoint_sigma.px"),
                     ("basis = 3", "keypoint_sigma.basis")):
        path.write_text(GOOD + f"\n[keypoint_sigma]\n{bad}\n")
        with pytest.raises(InputFileError, match=key.replace(".", r"\.")):
            read_model_description(path)


def test_the_stereo_sigma_by_size_is_read_and_checked(tmp_path):
    path = tmp_path / "fish-pose.toml"
    path.write_text(GOOD + '\n[stereo_sigma]\nbasis = "40 rendered clips"\n'
                    'left = {snout = [0.8, 0.01], fork = [0.6, 0.04]}\n'
                    'match = {snout = [0.85, 0.0], fork = [0.7, 0.007]}\nunmatched = {fork = [2.0, 0.01]}\n')
    stereo = read_model_description(path).stereo_sigma
    assert stereo.basis == "40 rendered clips" and stereo.left["fork"](100.0) == pytest.approx(np.hypot(0.6, 4.0))
    assert stereo.match["snout"].a == 0.85 and stereo.unmatched["fork"].a == 2.0 and "snout" not in stereo.unmatched
    path.write_text(GOOD)
    assert read_model_description(path).stereo_sigma is None
    for bad, key in (('left = {tail = [1.0, 0.0]}\nmatch = {tail = [1.0, 0.0]}', "stereo_sigma.left.tail"),
                     ('left = {snout = [0.0, 0.0]}\nmatch = {snout = [1.0, 0.0]}', "stereo_sigma.left.snout"),
                     ('left = {snout = [1.0, -0.1]}\nmatch = {snout = [1.0, 0.0]}', "stereo_sigma.left.snout"),
                     ('left = {snout = [1.0, 0.1]}\nmatch = {snout = [1.0]}', "stereo_sigma.match.snout"),
                     ('left = {snout = [1.0, 0.1]}\nmatch = {fork = [1.0, 0.0]}', "stereo_sigma.match"),
                     ('left = {snout = [1.0, 0.1]}', "stereo_sigma.match"),
                     ('basis = 3\nleft = {snout = [1.0, 0.1]}\nmatch = {snout = [1.0, 0.0]}', "stereo_sigma.basis")):
        path.write_text(GOOD + f"\n[stereo_sigma]\n{bad}\n")
        with pytest.raises(InputFileError, match=key.replace(".", r"\.")):
            read_model_description(path)


def test_the_frame_correlation_is_read_and_checked(tmp_path):
    path = tmp_path / "fish-pose.toml"
    path.write_text(GOOD + '\n[frame_correlation]\nlength = 0.42\nbasis = "62 fish on 40 rendered clips"\n')
    description = read_model_description(path)
    assert description.frame_correlation == 0.42
    assert description.frame_correlation_basis == "62 fish on 40 rendered clips"
    path.write_text(GOOD)
    assert read_model_description(path).frame_correlation is None
    for bad, key, words in (("length = 1.0", "frame_correlation.length", "below 1"),
                            ("length = -0.1", "frame_correlation.length", "in \\[0, 1\\]"),
                            ('length = "0.4"', "frame_correlation.length", "finite number"),
                            ("length = nan", "frame_correlation.length", "finite number"),
                            ('basis = "x"', "frame_correlation.length", "missing"),
                            ("length = 0.4\nbasis = 2", "frame_correlation.basis", "a text"),
                            ("length = 0.4\nfish = 2", "frame_correlation.fish", "unknown key")):
        path.write_text(GOOD + f"\n[frame_correlation]\n{bad}\n")
        with pytest.raises(InputFileError, match=f"{key.replace('.', chr(92) + '.')}: .*{words}"):
            read_model_description(path)
