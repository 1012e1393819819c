"""Keypoints refined along the refractive epipolar curve, on rendered fish with truth: the model's keypoints
are the true images of snout and fork with independent noise in each image; after refinement the pair's
3-D snout and fork lie closer to the truth (the disparity noise that ruins the depth is gone)."""

import numpy as np
import pytest

from tests.core.scenes import HOUSINGS
from usvips.core.camera import Camera, Exterior
from usvips.core.detection import Detection, Keypoint
from usvips.core.detection.refine import refine_keypoint, refine_pair
from usvips.core.detection.stereo import StereoPair
from usvips.core.interior import Interior
from usvips.core.intersection import intersect
from usvips.core.rig import RelativeOrientation, StereoRig
from usvips.core.synth.objects import Fish
from usvips.core.synth.render import Seafloor, Water, render

W, H = 480, 360
SIGMA_PX = 2.0  # the model's pointing noise per image coordinate


def rig(housing: str) -> StereoRig:
    left = Camera(Interior(450.0, 240.0, 180.0, 1.0, k1=-0.05), Exterior(0.0, 0.0, 0.0, 0.0, 0.0, 0.0),
                  HOUSINGS[housing], W, H)
    return StereoRig.from_relative(left, left, RelativeOrientation(0.3, 0.0, 0.0, 0.0, -0.05, 0.0))


def scene(rng: np.random.Generator, stereo: StereoRig):
    """A fish 1.0-1.6 m away, seen side-on, over a textured seafloor; both images and the true pixels."""
    while True:
        z = -rng.uniform(1.0, 1.6)
        heading = rng.uniform(0, 2 * np.pi)
        axis = np.array([np.cos(heading), np.sin(heading), 0.0])
        snout = np.array([rng.uniform(-0.25, 0.05), rng.uniform(-0.15, 0.15), z])
        fish = Fish(tuple(snout), tuple(snout + rng.uniform(0.3, 0.45) * axis), up=(-axis[1], axis[0], 0.0),
                    brightness=rng.uniform(150, 200))
        body = np.array([fish.snout, fish.fork])
        left, right = stereo.left.project(body), stereo.right.project(body)
        margin = np.array([W, H]) - 25
        if all(p.ok.all() and np.all((p.pixels > 25) & (p.pixels < margin)) for p in (left, right)):
            break
    floor = Seafloor((0.0, 0.0, -2.2), (0.0, 0.0, 1.0), cell=0.02, seed=int(rng.integers(1000)))
    water = Water(attenuation=0.1, backscatter=30.0, blur=0.6, noise=1.5)
    images = [render(camera, floor=floor, water=water, objects=[fish], supersample=2, seed=int(rng.integers(1000)))
              for camera in (stereo.left, stereo.right)]
    return fish, images, left.pixels, right.pixels


def detection(pixels: np.ndarray) -> Detection:
    x0, y0 = pixels.min(axis=0) - 10
    x1, y1 = pixels.max(axis=0) + 10
    return Detection((x0, y0, x1, y1), "fish", 0.9,
                     tuple(Keypoint(n, float(x), float(y), 0.9) for n, (x, y) in zip(("snout", "fork"), pixels,
                                                                                    strict=True)))


@pytest.mark.parametrize("housing", ["flat-port", "dome-cover"])
def test_refinement_brings_the_pairs_3d_keypoints_closer_to_the_truth(housing):
    rng = np.random.default_rng(35 + len(housing))
    stereo = rig(housing)
    before, after, refined = [], [], 0
    for _ in range(8):
        fish, (left_image, right_image), left_true, right_true = scene(rng, stereo)
        left = left_true + rng.normal(0, SIGMA_PX, left_true.shape)
        right = right_true + rng.normal(0, SIGMA_PX, right_true.shape)
        pair = StereoPair(detection(left), detection(right), 0, 0, 0.0)
        result = refine_pair(left_image, right_image, pair, stereo, window=15, radius_px=4 * SIGMA_PX * 2)
        refined += sum(k.refined for k in result.keypoints)
        moved = np.array([result.pair.right.keypoint(n).pixel for n in ("snout", "fork")])
        truth = np.array([fish.snout, fish.fork])
        for pixels, out in ((right, before), (moved, after)):
            points = intersect([stereo.left, stereo.right], [left, pixels], SIGMA_PX).points
            out.extend(np.linalg.norm(points - truth, axis=1))
    before, after = np.array(before), np.array(after)
    assert refined >= 11  # most keypoints (of 16) found their match
    # what is left after refinement is the left keypoint's error carried along the fish's surface
    assert np.median(after) < 0.7 * np.median(before)
    assert np.mean(after) < 0.7 * np.mean(before)


def test_a_refused_match_keeps_the_models_point_and_says_why():
    stereo = rig("flat-port")
    blank = np.full((H, W), 120, np.uint8)
    left, right = Keypoint("snout", 200.0, 150.0, 0.9), Keypoint("snout", 150.0, 150.0, 0.9)
    step = refine_keypoint(blank, blank, stereo, left, right)
    assert not step.refined and step.after == step.before == (150.0, 150.0)
    assert step.reason
    far_off = refine_keypoint(blank, blank, stereo, left, Keypoint("snout", 150.0, 20.0, 0.9), radius_px=5.0)
    assert not far_off.refined and "passes no closer" in far_off.reason and far_off.off_curve
    assert not step.off_curve and not step.at_edge and not step.beyond_limit
    edge = refine_keypoint(blank, blank, stereo, Keypoint("snout", 200.0, 3.0, 0.9), Keypoint("snout", 150.0, 3.0, 0.9))
    assert not edge.refined and edge.at_edge and "edge" in edge.reason and not edge.off_curve
    right_edge = refine_keypoint(blank, blank, stereo, Keypoint("snout", 200.0, 150.0, 0.9),
                                 Keypoint("snout", W - 3.0, 150.0, 0.9))
    assert not right_edge.refined and right_edge.at_edge and "right image" in right_edge.reason


@pytest.mark.parametrize("housing", ["flat-port", "dome-cover"])
def test_a_move_beyond_the_keypoints_own_errors_is_not_taken(housing):
    """The TRUE keypoints (a model of 0.5 px sigma): unlimited, refinement moves some by several pixels (the
    patch at a snout or fork is half background with its own disparity) and the 3-D keypoints go wrong by
    that much; limited to 3√2 sigma, the moves beyond are refused with the reason, the model's point kept,
    and the 3-D error is no larger than without the limit."""
    rng = np.random.default_rng(70 + len(housing))
    stereo = rig(housing)
    limit = 3 * np.sqrt(2) * 0.5
    unlimited_error, limited_error, refused, largest = [], [], 0, 0.0
    for _ in range(8):
        fish, (left_image, right_image), left_true, right_true = scene(rng, stereo)
        pair = StereoPair(detection(left_true), detection(right_true), 0, 0, 0.0)
        truth = np.array([fish.snout, fish.fork])
        for limits, errors in ((None, unlimited_error), ({"snout": limit, "fork": limit}, limited_error)):
            result = refine_pair(left_image, right_image, pair, stereo, window=15, radius_px=16.0,
                                 max_shift_px=limits)
            moved = np.array([result.pair.right.keypoint(n).pixel for n in ("snout", "fork")])
            points = intersect([stereo.left, stereo.right], [left_true, moved], 0.5).points
            errors.extend(np.linalg.norm(points - truth, axis=1))
            if limits is None:
                largest = max([largest, *(k.shift_px for k in result.keypoints)])
            else:
                assert all(k.shift_px <= limit for k in result.keypoints)
                gone = [k for k in result.keypoints if k.reason.startswith("the match would move it")]
                refused += len(gone)
                assert all(k.after == k.before and k.score is not None and k.beyond_limit for k in gone)
                assert not any(k.beyond_limit for k in result.keypoints if k not in gone)
    assert largest > limit and refused >= 1  # the wrong moves exist, and the limit refuses them
    assert np.mean(limited_error) <= np.mean(unlimited_error) and np.max(limited_error) <= np.max(unlimited_error)
