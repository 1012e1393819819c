"""Shipping the fish model at another input size: the fully convolutional network's ONNX file, its declared
sizes set for the new input, runs on OpenCV's DNN module and gives the same maps as the file it came from."""

import cv2
import numpy as np
import onnx

from usvips.locations import resources_folder
from usvips.training.ship_fish_model import resized_model

MODEL = resources_folder() / "models" / "fish-centre-pose.onnx"


def _declared(model: bytes) -> tuple[list[int], list[int]]:
    graph = onnx.load_from_string(model).graph
    return ([d.dim_value for d in graph.input[0].type.tensor_type.shape.dim],
            [d.dim_value for d in graph.output[0].type.tensor_type.shape.dim])


def test_a_resized_model_declares_its_new_input_and_gives_the_same_maps():
    original = MODEL.read_bytes()
    resized = resized_model(original, 384)
    inputs, outputs = _declared(resized)
    assert inputs[2:] == [384, 384] and outputs[2:] == [96, 96]
    blob = np.random.default_rng(1).uniform(0, 1, (1, 3, 384, 384)).astype(np.float32)
    maps = []
    for model in (original, resized):
        net = cv2.dnn.readNetFromONNX(np.frombuffer(model, np.uint8))
        net.setInput(blob)
        maps.append(net.forward())
    assert maps[1].shape == (1, 21, 96, 96)
    np.testing.assert_allclose(maps[1], maps[0], atol=1e-5)
    assert _declared(resized_model(resized, 256))[0][2:] == [256, 256]


def test_measuring_a_shipped_model_again_replaces_its_validation_table_and_keeps_the_others(tmp_path):
    """ship_fish_model appends the [validation] it measured; a description that has one already (the shipped
    model measured anew) loses the old one first, or the file would define the table twice."""
    from usvips.io.model_description import read_model_description
    from usvips.training.description_tables import without_table

    shipped = MODEL.with_suffix(".toml").read_text()
    assert shipped.count("[validation]") == 1
    text = without_table(shipped, "validation") + '\n[validation]\nrecall = 0.5\nsource = "measured again"\n'
    assert text.count("[validation]") == 1 and "[stereo_sigma]" in text and "[frame_correlation]" in text
    path = tmp_path / "fish-centre-pose.toml"
    path.write_text(text)
    again = read_model_description(path)
    before = read_model_description(MODEL.with_suffix(".toml"))
    assert again.stereo_sigma == before.stereo_sigma
    assert without_table(text, "no such table") == text
