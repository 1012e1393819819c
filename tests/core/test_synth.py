"""Rendered targets land where the camera model says, in air and through housings."""

import numpy as np
import pytest

from tests.core.scenes import HOUSINGS
from usvips.core.camera import Camera, Exterior
from usvips.core.housing import FlatPortHousing
from usvips.core.interior import Interior
from usvips.core.synth import Disc, Seafloor, Water, render
from usvips.core.targets import locate_disc

W, H = 400, 300


def _camera(housing):
    return Camera(Interior(520.0, 201.3, 148.7, 1.0, k1=-0.05), Exterior(0.0, 0.0, 0.0, 0.02, -0.03, 0.01),
                  housing, W, H)


def _targets():
    centres = [(x, y, -1.6 - 0.1 * (x + y)) for x in (-0.3, 0.0, 0.3) for y in (-0.2, 0.05, 0.25)]
    return [Disc(c, (0.0, 0.0, 1.0), radius=0.03, cross_width=0.006) for c in centres]


@pytest.mark.parametrize("name", ["air", "flat-port", "dome-cover"])
def test_rendered_target_centres_agree_with_the_back_projected_truth(name):
    camera = _camera(HOUSINGS[name])
    discs = _targets()
    image = render(camera, discs, supersample=4)  # a plain background: the test is of geometry
    truth = camera.project(np.array([d.centre for d in discs])).require_ok().pixels
    errors = []
    for expected in truth:
        found = locate_disc(image, expected + [1.0, -1.0], window=45)
        assert found, found.reason
        errors.append(np.hypot(*np.subtract(found.center, expected)))
    assert max(errors) < 0.1


def test_equal_indices_render_exactly_like_the_pinhole():
    discs = _targets()
    pinhole = render(_camera(HOUSINGS["air"]), discs, Seafloor((0, 0, -2.5)), supersample=2)
    same = render(_camera(FlatPortHousing(0.0, 0.0, 0.05, 0.01, 1.0, 1.0)), discs, Seafloor((0, 0, -2.5)),
                  supersample=2)
    assert np.abs(pinhole.astype(int) - same.astype(int)).max() <= 1


def test_water_degrades_contrast_and_rendering_is_reproducible():
    camera = _camera(HOUSINGS["flat-port"])
    clear = render(camera, _targets(), supersample=2)
    murky = render(camera, _targets(), water=Water(attenuation=0.8, backscatter=90, noise=3), supersample=2, seed=3)
    again = render(camera, _targets(), water=Water(attenuation=0.8, backscatter=90, noise=3), supersample=2, seed=3)
    assert np.array_equal(murky, again)
    assert np.percentile(murky, 99) - np.percentile(murky, 1) < np.percentile(clear, 99) - np.percentile(clear, 1)
