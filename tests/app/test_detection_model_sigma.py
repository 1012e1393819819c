"""Which keypoint sigma a model's lengths get: the description's [keypoint_sigma] table (image pixels) when
it has one; else its [stereo_sigma] by the fish's size when it has one; else its held-out [validation] sigma
(model input pixels) scaled to each image's pixels by the letterbox; else none (never assumed)."""

import shutil

import pytest

from usvips.app.detection_model import load_model
from usvips.locations import resources_folder

KEYS = ("snout", "fork")


STEREO = ('\n[stereo_sigma]\nbasis = "clips"\nleft = {snout = [0.8, 0.01], fork = [0.6, 0.04]}\n'
          'match = {snout = [0.7, 0.0], fork = [0.1, 0.02]}\n')


@pytest.fixture
def shipped(tmp_path):
    """The shipped model's files, its description without a [stereo_sigma] table."""
    folder = resources_folder() / "models"
    for path in folder.glob("fish-centre-pose.*"):
        shutil.copy(path, tmp_path / path.name)
    description = tmp_path / "fish-centre-pose.toml"
    text = description.read_text(encoding="utf-8")
    if "[stereo_sigma]" in text:
        description.write_text(text[:text.index("\n[stereo_sigma]")] + "\n", encoding="utf-8")
    return description


@pytest.mark.parametrize("size", [(640, 480), (1920, 1080), (480, 640), (256, 256)])
def test_validated_sigma_is_scaled_from_input_to_image_pixels(shipped, size):
    model = load_model(shipped)
    validated = dict(zip(model.description.keypoint_names, model.description.validated_keypoint_sigma, strict=True))
    width, height = model.description.input_width, model.description.input_height
    scale = min(width / size[0], height / size[1])
    sigmas = model.keypoint_sigma(KEYS, size)
    assert sigmas == pytest.approx({k: validated[k] / scale for k in KEYS})
    assert model.keypoint_sigma(KEYS) is None  # no image: no pixels to give it in
    assert "input pixels" in model.sigma_line(KEYS) and "held-out" in model.sigma_basis(KEYS)
    assert "rendered" in model.sigma_basis(KEYS)  # the shipped model's sigma says what it was measured on


def test_a_measured_table_wins_and_no_measure_gives_no_sigma(shipped):
    text = shipped.read_text(encoding="utf-8")
    shipped.write_text(text + '\n[keypoint_sigma]\nbasis = "reviews"\npx = {snout = 1.5, fork = 2.5}\n',
                       encoding="utf-8")
    model = load_model(shipped)
    assert model.keypoint_sigma(KEYS, (1920, 1080)) == {"snout": 1.5, "fork": 2.5}
    assert model.sigma_basis(KEYS) == "reviews"
    cut = text[:text.index("[validation]")]
    shipped.write_text(cut, encoding="utf-8")
    model = load_model(shipped)
    assert model.keypoint_sigma(KEYS, (1920, 1080)) is None
    assert "no measured pointing sigma" in model.sigma_line(KEYS, (1920, 1080))


def test_the_stereo_sigma_by_size_is_used_unless_reviews_measured_a_table(shipped):
    text = shipped.read_text(encoding="utf-8")
    shipped.write_text(text + STEREO, encoding="utf-8")
    model = load_model(shipped)
    assert model.stereo_sigma(KEYS) is not None and "by the fish's size" in model.sigma_line(KEYS)
    assert "clips" in model.sigma_basis(KEYS)
    shipped.write_text(text + STEREO + '\n[keypoint_sigma]\nbasis = "reviews"\npx = {snout = 1.5, fork = 2.5}\n',
                       encoding="utf-8")
    model = load_model(shipped)
    assert model.stereo_sigma(KEYS) is None and model.sigma_basis(KEYS) == "reviews"
