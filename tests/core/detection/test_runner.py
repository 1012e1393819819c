"""The ONNX runner on OpenCV's DNN module, with a model built in the test (a fixed YOLO-pose output table):
the detections come back in the image's pixels whatever the image's size and the model's input size."""

import numpy as np
import pytest

from tests.core.detection.onnx_models import constant_output_model
from tests.core.detection.yolo_tables import random_truth, table
from usvips.core.detection import Letterbox, ModelDescription
from usvips.core.detection.runner import OnnxDetector
from usvips.core.errors import InvalidParameterError


@pytest.mark.parametrize("input_size,image_size,channels_first", [((320, 320), (640, 480), True),
                                                                  ((256, 192), (500, 700), False)])
def test_a_model_runs_on_an_image_and_its_detections_are_in_image_pixels(input_size, image_size, channels_first):
    rng = np.random.default_rng(11)
    description = ModelDescription("m.onnx", "yolo-pose", *input_size, ("fish",), ("snout", "fork"),
                                   channel_order="BGR" if channels_first else "RGB")
    letterbox = Letterbox.fit(image_size, input_size)
    truth = random_truth(rng, 4, image_size, 2, 1)
    model = constant_output_model(table(rng, truth, description, letterbox, channels_first), *input_size)
    detector = OnnxDetector(description, model)
    found = detector.detect(rng.integers(0, 255, (image_size[1], image_size[0], 3), dtype=np.uint8))
    assert len(found) == 4
    for t in truth:
        d = min(found, key=lambda d: abs(d.score - t["score"]))
        np.testing.assert_allclose(d.box, t["box"], atol=0.01)  # the table passes through float32
        np.testing.assert_allclose([[k.x, k.y] for k in d.keypoints], t["keypoints"][:, :2], atol=0.01)


def test_the_input_is_letterboxed_and_normalised_as_described():
    description = ModelDescription("m.onnx", "yolo-pose", 64, 64, ("fish",), ("snout",), scale=0.5,
                                   mean=(10.0, 20.0, 30.0), std=(2.0, 4.0, 5.0), channel_order="RGB")
    detector = OnnxDetector(description, constant_output_model(np.zeros((1, 8, 3)), 64, 64))
    image = np.zeros((32, 64, 3), np.uint8)
    image[:] = (100, 150, 200)  # B, G, R
    blob, letterbox = detector.blob(image)
    assert blob.shape == (1, 3, 64, 64) and (letterbox.pad_x, letterbox.pad_y) == (0, 16)
    np.testing.assert_allclose(blob[0, :, 32, 32], [(100 - 10) / 2, (75 - 20) / 4, (50 - 30) / 5])
    np.testing.assert_allclose(blob[0, :, 0, 32], [(57 - 10) / 2, (57 - 20) / 4, (57 - 30) / 5])  # 114 grey
    grey, _ = detector.blob(np.full((32, 64), 100, np.uint8))
    np.testing.assert_allclose(grey[0, :, 32, 32], [20.0, 7.5, 4.0])


def _reference_blob(description: ModelDescription, image: np.ndarray) -> np.ndarray:
    """The input as the description defines it, step by step in numpy (float32): letterboxed, channels in the
    model's order, (pixel · scale − mean) / std, laid out (1, 3, H, W)."""
    size = (description.input_width, description.input_height)
    boxed = Letterbox.fit((image.shape[1], image.shape[0]), size).apply(image, size, description.pad_value)
    if description.channel_order == "RGB":
        boxed = boxed[:, :, ::-1]
    values = (boxed.astype(np.float32) * np.float32(description.scale) - np.asarray(description.mean, np.float32)) \
        / np.asarray(description.std, np.float32)
    return values.transpose(2, 0, 1)[None]


def test_the_input_is_the_same_bits_as_the_described_normalisation_over_many_random_cases():
    rng = np.random.default_rng(35)
    model = constant_output_model(np.zeros((1, 8, 3)), 64, 64)
    for case in range(60):
        plain = case % 3 == 0  # the usual YOLO normalisation: 1/255, no mean, unit std
        description = ModelDescription(
            "m.onnx", "yolo-pose", int(rng.integers(16, 97)), int(rng.integers(16, 97)), ("fish",), ("snout",),
            scale=1 / 255 if plain else float(rng.uniform(0.001, 2.0)),
            mean=(0.0, 0.0, 0.0) if plain else tuple(rng.uniform(-50, 50, 3)),
            std=(1.0, 1.0, 1.0) if plain else tuple(rng.uniform(0.1, 80, 3)),
            channel_order=str(rng.choice(["RGB", "BGR"])), pad_value=int(rng.integers(0, 256)))
        detector = OnnxDetector(description, model)
        image = rng.integers(0, 256, (int(rng.integers(20, 300)), int(rng.integers(20, 300)), 3), dtype=np.uint8)
        blob, _ = detector.blob(image)
        assert blob.dtype == np.float32 and blob.flags["C_CONTIGUOUS"]
        np.testing.assert_array_equal(blob, _reference_blob(description, image))


def test_bytes_that_are_no_model_and_an_image_that_is_no_image_are_clear_errors():
    description = ModelDescription("bad.onnx", "yolo-pose", 64, 64, ("fish",), ("snout",))
    with pytest.raises(InvalidParameterError, match="OpenCV cannot read the ONNX model 'bad.onnx'"):
        OnnxDetector(description, b"not a model")
    detector = OnnxDetector(description, constant_output_model(np.zeros((1, 8, 3)), 64, 64))
    with pytest.raises(InvalidParameterError, match="8-bit"):
        detector.detect(np.zeros((10, 10, 3), np.float32))
