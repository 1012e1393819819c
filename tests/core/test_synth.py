"""Rendered targets land where the camera model says, in air and through housings."""

import numpy as np
import pytest

from tests.core.scenes import HOUSINGS
from usvips.core.camera import Camera, Exterior
from usvips.core.errors import InvalidParameterError
from usvips.core.housing import FlatPortHousing
from usvips.core.interior import Interior
from usvips.core.synth import Disc, Fish, Pipe, Rock, Seafloor, Water, render
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


def _rays_to(points):
    points = np.atleast_2d(np.asarray(points, float))
    return np.zeros_like(points), points / np.linalg.norm(points, axis=1, keepdims=True)


def test_a_fish_starts_at_its_snout_and_is_forked_at_its_fork():
    fish = Fish((-0.2, 0.0, -2.0), (0.2, 0.0, -2.0), up=(0.0, 1.0, 0.0), depth=0.1)
    length = fish.length
    assert length == pytest.approx(0.4)

    def point(u, b):  # fraction of the fork length along the body, body depths dorsal
        return np.array([-0.2 + u * length, b * 0.1, -2.0])

    probes = {(0.01, 0.0): True, (-0.01, 0.0): False, (0.5, 0.3): True, (0.5, 0.6): False, (0.98, 0.0): True,
              (1.02, 0.0): False, (1.1, 0.35): True, (1.1, -0.35): True, (1.25, 0.4): False}
    points = np.array([point(*k) for k in probes])
    t, value = fish.hit(*_rays_to(points))
    assert list(np.isfinite(t)) == list(probes.values())
    hit = np.isfinite(t)
    np.testing.assert_allclose(t[hit], np.linalg.norm(points[hit], axis=1), rtol=1e-12)
    assert np.all(value[hit] > 0)


def test_a_rendered_fish_ends_at_its_projected_snout_through_a_housing():
    camera = _camera(HOUSINGS["flat-port"])
    fish = Fish((-0.25, 0.05, -1.8), (0.15, 0.08, -1.85), up=(0.0, 1.0, 0.3))
    image = render(camera, objects=[fish], supersample=4, background=0.0).astype(float)
    snout, fork = camera.project(np.array([fish.snout, fish.fork])).require_ok().pixels
    along = (fork - snout) / np.linalg.norm(fork - snout)
    for offset, inside in ((-1.5, False), (1.5, True)):
        x, y = np.rint(snout + offset * along).astype(int)
        assert (image[y, x] > 50) == inside, (offset, image[y, x])
    x, y = np.rint(fork - 3 * along).astype(int)
    assert image[y, x] > 50  # just before the fork: the body
    x, y = np.rint(fork + 3 * along).astype(int)
    assert image[y, x] < 50  # just behind it: the notch between the tail lobes


def test_pipe_and_rock_are_hit_where_their_closed_forms_say():
    pipe = Pipe((-0.5, 0.0, -2.0), (0.5, 0.0, -2.0), radius=0.05)
    t, _ = pipe.hit(*_rays_to([[0.0, 0.0, -2.0], [0.6, 0.0, -2.0]]))
    assert t[0] == pytest.approx(2.0 - 0.05, rel=1e-12) and np.isinf(t[1])
    rock = Rock((0.0, 0.0, -3.0), semi_axes=(0.2, 0.1, 0.07))
    t, _ = rock.hit(*_rays_to([[0.0, 0.0, -3.0], [0.0, 0.3, -3.0]]))
    assert t[0] == pytest.approx(3.0 - 0.07, rel=1e-12) and np.isinf(t[1])
    with pytest.raises(InvalidParameterError, match="rock semi_axes"):
        Rock((0.0, 0.0, -3.0), semi_axes=(0.2, 0.0, 0.1))


def test_colour_water_absorbs_red_first_and_interlace_shifts_odd_rows():
    camera = _camera(HOUSINGS["air"])
    disc = Disc((0.0, 0.0, -4.0), (0.0, 0.0, 1.0), radius=0.4, cross_width=0.0)
    water = Water(attenuation=0.3, backscatter=0.0, blur=0.0, noise=0.0)
    rgb = render(camera, [disc], water=water, colour=True, supersample=1)
    assert rgb.shape == (H, W, 3)
    red, green, blue = rgb[H // 2, W // 2].astype(float)
    assert red < green and red < blue  # a white target looks blue-green through 4 m of water
    assert red == pytest.approx(230 * np.exp(-0.3 * 2.2 * 4.0), abs=1.5)
    floor = Seafloor((0.0, 0.0, -3.0), cell=0.05)
    plain = render(camera, floor=floor, supersample=1).astype(float)
    shifted = render(camera, floor=floor, supersample=1, interlace=3.0).astype(float)
    np.testing.assert_array_equal(shifted[0::2], plain[0::2])
    assert np.abs(shifted[1::2, 10:-10] - plain[1::2, 7:-13]).max() <= 1.0
    lit = render(camera, floor=floor, supersample=1, lighting=0.6).astype(float)
    assert lit[:20, :20].mean() / plain[:20, :20].mean() == pytest.approx(0.42, abs=0.05)
