"""A detector measured on held-out rendered fish: frames of :mod:`usvips.core.synth.fish_scene` through every
housing kind in turn, each drawn from its own seed, matched against their truth by
:mod:`usvips.core.detection.validation` (recall, precision, keypoint errors, pointing σ)."""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np

from usvips.core import housing as housings
from usvips.core.detection.detection import Detector
from usvips.core.detection.validation import ValidationFigures, match_image
from usvips.core.synth.fish_scene import random_camera, random_scene, render_fish_scene


def validation_frame(seed: int, size: tuple[int, int] = (640, 480)) -> tuple[np.ndarray, list]:
    """The frame (BGR) of one held-out seed and its fish's truth: the housing kind is the seed's turn
    among the kinds, the camera and scene drawn from the seed."""
    kinds = housings.names()
    rng = np.random.default_rng(seed)
    camera = random_camera(rng, kinds[seed % len(kinds)], size)
    return render_fish_scene(camera, random_scene(rng, camera))


def measure_on_rendered_fish(detector: Detector, seeds: Iterable[int], size: tuple[int, int] = (640, 480),
                             scale: float = 1.0, tolerance: float = 0.2) -> ValidationFigures:
    """The figures of ``detector`` on the frames of ``seeds`` (``size`` pixels); keypoint errors are
    multiplied by ``scale`` (e.g. the model's letterbox scale, to state them in its input pixels)."""
    figures = ValidationFigures()
    for seed in seeds:
        image, truths = validation_frame(int(seed), size)
        match_image(detector.detect(image), [t.true_object() for t in truths], figures, tolerance=tolerance,
                    scale=scale)
    return figures
