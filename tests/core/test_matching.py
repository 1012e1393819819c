"""Conjugate matching on rendered stereo pairs through refractive housings, with known truth."""

import numpy as np
import pytest

from tests.core.scenes import HOUSINGS
from usvips.core.camera import Camera, Exterior
from usvips.core.errors import InvalidParameterError
from usvips.core.interior import Interior
from usvips.core.matching import epipolar_curve, epipolar_curve_at, match_along_curve
from usvips.core.rig import RelativeOrientation, StereoRig

W, H = 320, 240
PLANE_Z = -1.8  # a textured seafloor facing the cameras


CELL = 0.025  # metres: a random value every 2.5 cm, smoothly (cubic) interpolated
GRID = np.random.default_rng(5).uniform(40, 200, (200, 200))


def texture(x, y):
    """A dense, non-repeating, band-limited texture on the seafloor (grey levels)."""
    from scipy.ndimage import map_coordinates

    return map_coordinates(GRID, [(y + 2.5) / CELL, (x + 2.5) / CELL], order=3, mode="reflect")


def render(camera: Camera, textured: bool = True) -> np.ndarray:
    s = 2
    ys, xs = np.mgrid[0:H * s, 0:W * s]
    pixels = np.column_stack([(xs.ravel() + 0.5) / s - 0.5, (ys.ravel() + 0.5) / s - 0.5])
    bundle = camera.rays(pixels)
    t = (PLANE_Z - bundle.origins[:, 2]) / bundle.directions[:, 2]
    hit = bundle.origins + t[:, None] * bundle.directions
    values = texture(hit[:, 0], hit[:, 1]) if textured else np.full(len(hit), 120.0)
    image = values.reshape(H * s, W * s).reshape(H, s, W, s).mean(axis=(1, 3))
    return np.clip(np.rint(image), 0, 255).astype(np.uint8)


def rig(housing_name: str, distortion: bool = True) -> StereoRig:
    interior = Interior(300.0, 160.0, 120.0, 1.0, k1=-0.05 if distortion else 0.0)
    left = Camera(interior, Exterior(0.0, 0.0, 0.0, 0.0, 0.0, 0.0), HOUSINGS[housing_name], W, H)
    return StereoRig.from_relative(left, left, RelativeOrientation(0.3, 0.0, 0.0, 0.0, -0.05, 0.0))


def true_conjugate(stereo: StereoRig, pixel) -> np.ndarray:
    bundle = stereo.left.rays(np.array([pixel]))
    t = (PLANE_Z - bundle.origins[0, 2]) / bundle.directions[0, 2]
    return stereo.right.project((bundle.origins[0] + t * bundle.directions[0])[None]).pixels[0]


@pytest.mark.parametrize("name", ["flat-port", "dome-cover"])
def test_the_epipolar_curve_passes_through_the_true_conjugate(name):
    stereo = rig(name)
    for pixel in ([200.0, 90.0], [230.5, 160.25], [280.0, 200.0]):
        curve = epipolar_curve(stereo.left, stereo.right, pixel, near=0.5, far=6.0, samples=400)
        assert curve.distance_to(true_conjugate(stereo, pixel)) < 0.05


@pytest.mark.parametrize("name", ["flat-port", "dome-cover"])
def test_the_curve_at_given_depths_is_the_curve_sampled_there(name):
    stereo = rig(name)
    seen = []
    for pixel in ([200.0, 90.0], [5.0, 3.0], [318.0, 238.0]):  # the corners: samples the right camera misses
        whole = epipolar_curve(stereo.left, stereo.right, pixel, near=0.4, far=9.0, samples=120)
        at = epipolar_curve_at(stereo.left, stereo.right, np.array(pixel), np.geomspace(0.4, 9.0, 120))
        np.testing.assert_array_equal(at.pixels, whole.pixels)
        np.testing.assert_array_equal(at.depths, whole.depths)
        seen.append(len(at.depths))
    assert 0 < seen[0] and min(seen) < 120
    few = epipolar_curve_at(stereo.left, stereo.right, np.array([200.0, 90.0]), np.array([0.7, 1.1]))
    np.testing.assert_allclose(few.pixels, epipolar_curve(stereo.left, stereo.right, [200.0, 90.0], near=0.7, far=1.1,
                                                          samples=2).pixels, atol=1e-9)


def test_without_refraction_or_distortion_the_curve_is_a_line_and_with_a_port_it_is_not():
    def bend(stereo):
        curve = epipolar_curve(stereo.left, stereo.right, [300.0, 230.0], near=0.3, far=20.0)
        p = curve.pixels
        direction = (p[-1] - p[0]) / np.linalg.norm(p[-1] - p[0])
        offsets = (p - p[0]) @ np.array([-direction[1], direction[0]])
        return np.max(np.abs(offsets))

    assert bend(rig("air", distortion=False)) < 1e-6
    assert bend(rig("flat-port", distortion=False)) > 2.0  # pixels, near the corner of the frame


@pytest.mark.parametrize("name", ["flat-port", "dome-cover"])
def test_matching_finds_the_true_conjugate_within_a_third_of_a_pixel(name):
    stereo = rig(name)
    left, right = render(stereo.left), render(stereo.right)
    errors = []
    for pixel in ([220.0, 100.0], [200.0, 130.0], [250.3, 80.7], [270.0, 150.0]):
        curve = epipolar_curve(stereo.left, stereo.right, pixel, near=0.5, far=6.0, samples=300)
        result = match_along_curve(left, right, pixel, curve, window=21)
        assert result, result.reason
        errors.append(np.linalg.norm(np.subtract(result.pixel, true_conjugate(stereo, pixel))))
    assert max(errors) < 0.3


def test_a_textureless_patch_is_refused_and_bad_arguments_raise():
    stereo = rig("flat-port")
    flat = render(stereo.left, textured=False)
    curve = epipolar_curve(stereo.left, stereo.right, [160.0, 120.0])
    result = match_along_curve(flat, flat, [160.0, 120.0], curve)
    assert not result and "textureless" in result.reason
    with pytest.raises(InvalidParameterError, match="window"):
        match_along_curve(flat, flat, [160.0, 120.0], curve, window=8)
    with pytest.raises(InvalidParameterError, match="too close to the edge"):
        match_along_curve(flat, flat, [2.0, 120.0], curve)
    with pytest.raises(InvalidParameterError, match="far"):
        epipolar_curve(stereo.left, stereo.right, [10.0, 10.0], near=2.0, far=1.0)


def test_a_repetitive_pattern_is_reported_as_ambiguous():
    stereo = rig("air", distortion=False)
    ys, xs = np.mgrid[0:H, 0:W]
    stripes = (120 + 80 * np.sin(2 * np.pi * xs / 12.0)).astype(np.uint8)
    curve = epipolar_curve(stereo.left, stereo.right, [160.0, 120.0], near=0.3, far=20.0)
    result = match_along_curve(stripes, stripes, [160.0, 120.0], curve, window=11)
    assert result.ambiguous and not result and "ambiguous" in result.reason


def test_a_refused_match_still_proposes_its_best_candidate_marked_weak_with_its_score():
    stereo = rig("flat-port")
    left, right = render(stereo.left), render(stereo.right)
    pixel = [220.0, 100.0]
    truth = true_conjugate(stereo, pixel)
    curve = epipolar_curve(stereo.left, stereo.right, pixel, near=0.5, far=6.0, samples=300)
    # a faint texture (contrast below the textureless limit): refused, but the best candidate is the truth
    faint_left = (120 + (left.astype(float) - left.mean()) * 0.05).astype(np.uint8)
    faint_right = (120 + (right.astype(float) - right.mean()) * 0.05).astype(np.uint8)
    faint = match_along_curve(faint_left, faint_right, pixel, curve)
    assert not faint and faint.weak and "textureless" in faint.reason
    assert np.linalg.norm(np.subtract(faint.proposal, truth)) < 1.0
    assert faint.describe().startswith(f"weak proposal (correlation {faint.score:.2f}): textureless")
    # a right image drowned in noise: the best correlation is low, proposed weak with its score
    noisy_right = np.clip(right + np.random.default_rng(1).normal(0, 90, right.shape), 0, 255).astype(np.uint8)
    low = match_along_curve(left, noisy_right, pixel, curve, window=11)
    assert not low and low.weak and low.score < 0.5 and "below 0.50" in low.reason and low.proposal is not None
    # a confident match is not weak; the same match under a stricter score is
    strong = match_along_curve(left, right, pixel, curve, window=21)
    assert strong and not strong.weak and strong.describe() == f"proposed match (correlation {strong.score:.2f})"
    strict = match_along_curve(left, right, pixel, curve, window=21, min_score=0.9999)
    assert not strict and strict.weak and strict.proposal == strong.proposal
    with pytest.raises(InvalidParameterError, match="min_score"):
        match_along_curve(left, right, pixel, curve, min_score=1.5)


def test_an_ambiguous_match_is_a_weak_proposal_and_a_blank_patch_has_none():
    stereo = rig("air", distortion=False)
    ys, xs = np.mgrid[0:H, 0:W]
    stripes = (120 + 80 * np.sin(2 * np.pi * xs / 12.0)).astype(np.uint8)
    curve = epipolar_curve(stereo.left, stereo.right, [160.0, 120.0], near=0.3, far=20.0)
    result = match_along_curve(stripes, stripes, [160.0, 120.0], curve, window=11)
    assert result.weak and result.proposal is not None and "ambiguous" in result.describe()
    flat = render(stereo.left, textured=False)
    blank = match_along_curve(flat, flat, [160.0, 120.0], curve)
    assert blank.proposal is None and not blank.weak and blank.describe().startswith("no candidate: textureless")
