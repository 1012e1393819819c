"""USVIPS's own fish model, as shipped in resources/models: it runs from its description alone on OpenCV's
DNN module (no PyTorch) and, on held-out rendered frames with seeds neither its training nor its reported
figures used, finds fish and points at snout and fork as well as its description states (within the
sampling spread of a dozen frames)."""

import tomllib

from usvips.core.detection.letterbox import Letterbox
from usvips.core.synth.fish_scene import KEYPOINTS
from usvips.core.synth.fish_validation import measure_on_rendered_fish
from usvips.io.model_description import load_detector
from usvips.locations import resources_folder

MODEL = resources_folder() / "models" / "fish-centre-pose.toml"
SIZE = (640, 480)


def test_the_shipped_model_is_small_and_describes_its_measured_sigma():
    detector = load_detector(MODEL)
    d = detector.description
    assert (MODEL.parent / d.model).stat().st_size <= 10 * 2**20
    assert d.family == "centre-pose" and d.keypoint_names == KEYPOINTS
    documented = tomllib.loads(MODEL.read_text())["validation"]
    assert d.validated_keypoint_sigma == tuple(documented["keypoint_sigma"])


def test_the_shipped_model_meets_its_documented_figures_on_fresh_rendered_frames():
    detector = load_detector(MODEL)
    d = detector.description
    documented = tomllib.loads(MODEL.read_text())["validation"]
    scale = Letterbox.fit(SIZE, (d.input_width, d.input_height)).scale_x
    figures = measure_on_rendered_fish(detector, range(30_000_000, 30_000_012), SIZE, scale=scale)
    assert figures.found + figures.missed >= 20
    assert figures.recall >= documented["recall"] - 0.15
    assert figures.precision >= documented["precision"] - 0.15
    for name, median in zip(KEYPOINTS[:2], documented["median_error"][:2], strict=True):
        assert figures.median_error(name) <= 1.5 * median + 0.3, name
