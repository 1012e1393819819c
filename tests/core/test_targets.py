"""Sub-pixel pointing on rendered targets with known centres, noise, blur and haze."""

import cv2
import numpy as np
import pytest

from usvips.core.errors import InvalidParameterError
from usvips.core.targets import locate_cross, locate_disc

SUPERSAMPLE = 8


def render(shape, centres, kind="disc", radius=9.0, axes=(1.0, 0.8), angle=0.3, arm=2.5, blur=1.0, noise=2.0,
           haze=0.0, seed=0):
    """Targets at exact sub-pixel centres (pixel convention: pixel (r, c) is at x = c, y = r), as
    perspective would draw a tilted disc (an ellipse), with a cross inside, supersampled, blurred, hazy
    and noisy; 8-bit."""
    h, w = shape
    s = SUPERSAMPLE
    ys, xs = np.mgrid[0:h * s, 0:w * s]
    xs = (xs + 0.5) / s - 0.5
    ys = (ys + 0.5) / s - 0.5
    fine = np.full((h * s, w * s), 40.0)
    c, si = np.cos(angle), np.sin(angle)
    for cx, cy in centres:
        u = (xs - cx) * c + (ys - cy) * si
        v = -(xs - cx) * si + (ys - cy) * c
        inside = (u / (radius * axes[0])) ** 2 + (v / (radius * axes[1])) ** 2 <= 1
        if kind == "disc":
            fine[inside] = 220.0
            un, vn = u / axes[0], v / axes[1]  # the cross lies in the disc's plane: it is foreshortened too
            cross = inside & ((np.abs(un) < arm / 2) | (np.abs(vn) < arm / 2)) & (un**2 + vn**2 < (0.6 * radius) ** 2)
            fine[cross] = 30.0
        else:
            box = (np.abs(xs - cx) < radius) & (np.abs(ys - cy) < radius)
            fine[box] = 220.0
            fine[box & ((np.abs(xs - cx) < arm / 2) | (np.abs(ys - cy) < arm / 2))] = 30.0
    image = fine.reshape(h, s, w, s).mean(axis=(1, 3))
    if blur:
        image = cv2.GaussianBlur(image, (0, 0), blur)
    image = image * (1 - haze) + 120 * haze
    image += np.random.default_rng(seed).normal(0, noise, image.shape)
    return np.clip(np.rint(image), 0, 255).astype(np.uint8)


@pytest.mark.parametrize("noise, blur, haze", [(1.0, 0.8, 0.0), (3.0, 1.5, 0.3), (5.0, 2.0, 0.5)])
def test_disc_centres_to_a_tenth_of_a_pixel(noise, blur, haze):
    rng = np.random.default_rng(3)
    errors = []
    for k in range(20):
        centre = (40 + rng.uniform(-0.5, 0.5), 38 + rng.uniform(-0.5, 0.5))
        image = render((80, 80), [centre], noise=noise, blur=blur, haze=haze, angle=rng.uniform(0, 3),
                       axes=(1.0, rng.uniform(0.6, 1.0)), seed=k)
        click = (centre[0] + rng.uniform(-3, 3), centre[1] + rng.uniform(-3, 3))
        result = locate_disc(image, click)
        assert result, result.reason
        errors.append(np.hypot(result.center[0] - centre[0], result.center[1] - centre[1]))
    assert np.sqrt(np.mean(np.square(errors))) <= 0.1


def test_cross_centres_to_a_tenth_of_a_pixel():
    rng = np.random.default_rng(4)
    errors = []
    for k in range(20):
        centre = (40 + rng.uniform(-0.5, 0.5), 40 + rng.uniform(-0.5, 0.5))
        image = render((80, 80), [centre], kind="cross", radius=10, arm=3.0, noise=2.0, blur=0.8, seed=k)
        result = locate_cross(image, (centre[0] + 2, centre[1] - 2), arm_width=3.0)
        assert result, result.reason
        errors.append(np.hypot(result.center[0] - centre[0], result.center[1] - centre[1]))
    assert np.sqrt(np.mean(np.square(errors))) <= 0.1


def test_refusals_say_why():
    blank = np.full((80, 80), 90, np.uint8) + np.random.default_rng(0).integers(0, 3, (80, 80)).astype(np.uint8)
    assert "no target" in locate_disc(blank, (40, 40)).reason
    two = render((80, 80), [(33.0, 40.0), (50.0, 40.0)], radius=7)
    assert "two targets" in locate_disc(two, (41.5, 40.0)).reason
    edge = render((80, 80), [(40.0, 40.0)])
    assert "clipped" in locate_disc(edge, (10.0, 40.0)).reason
    big = render((120, 120), [(60.0, 60.0)], radius=14)
    assert "clipped" in locate_disc(big, (52.0, 60.0), window=31).reason
    assert "uniform" in locate_cross(np.full((80, 80), 50, np.uint8), (40, 40)).reason
    with pytest.raises(InvalidParameterError, match="click"):
        locate_disc(edge, (80.0, 10.0))
    with pytest.raises(InvalidParameterError, match="unsupported pixel type"):
        locate_disc(edge.astype(np.float32), (40.0, 40.0))


def test_sixteen_bit_and_colour_images():
    image = render((80, 80), [(40.3, 39.6)])
    assert np.hypot(*np.subtract(locate_disc(image.astype(np.uint16) * 257, (40, 40)).center, (40.3, 39.6))) < 0.1
    colour = np.repeat(image[:, :, None], 3, axis=2)
    assert np.hypot(*np.subtract(locate_disc(colour, (40, 40)).center, (40.3, 39.6))) < 0.1
