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
