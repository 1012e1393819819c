"""Rendered fish with truth: through every housing kind the true keypoints land on the drawn fish (the snout
at the tip of the body, the fork in the notch of the tail, the caudal tips at the lobes' ends), hidden
keypoints are reported hidden, and the frame is deterministic for a seed."""

from dataclasses import replace

import numpy as np
import pytest

from usvips.core import housing as housings
from usvips.core.synth.fish_scene import (
    BODY_PLANS,
    KEYPOINTS,
    REQUIRED_LENGTH,
    Occluder,
    SceneFish,
    random_camera,
    random_scene,
    random_shape,
    render_fish_scene,
)

SIZE = (320, 240)
BIG = (640, 480)  # fish of 90 px and more: the caudal lobes' ends are over a pixel wide


def _clear(scene, fish):
    """The scene with only ``fish``, no occluder, particles, blur or vignetting (noise stays: it is the same
    draw in both renders, so it cancels)."""
    return replace(scene, fish=tuple(fish), occluders=(), particles=0, blur=0.0, vignette=0.0)


def _mask(camera, scene, fish) -> np.ndarray:
    """The pixels the fish changes: the scene rendered with and without it."""
    with_fish, _ = render_fish_scene(camera, _clear(scene, [fish]))
    without, _ = render_fish_scene(camera, _clear(scene, []))
    return np.any(with_fish != without, axis=2)


def _distance_to(mask: np.ndarray, point: np.ndarray) -> float:
    ys, xs = np.nonzero(mask)
    return float(np.min(np.hypot(xs - point[0], ys - point[1])))


def _inside(mask: np.ndarray, point: np.ndarray) -> bool:
    x, y = np.rint(point).astype(int)
    return bool(mask[y, x])


@pytest.mark.parametrize("kind", housings.names())
def test_the_keypoints_land_on_the_drawn_fish_through_every_housing(kind):
    rng = np.random.default_rng(100 + housings.names().index(kind))
    checked = 0
    while checked < 3:
        camera = random_camera(rng, kind, BIG)
        scene = random_scene(rng, camera, fish=(1, 1), lengths=(0.4, 0.6), ranges=(1.0, 2.0))
        fish = scene.fish[0]
        _, (truth,) = render_fish_scene(camera, _clear(scene, [fish]))
        if not truth.visible.all():
            continue  # a keypoint outside the frame: draw another
        mask = _mask(camera, scene, fish)
        points = truth.keypoints
        for k, name in enumerate(KEYPOINTS):
            # (a pointed tip thinner than a pixel may leave its last pixel unchanged)
            assert _distance_to(mask, points[k]) <= 1.5, f"{kind}: {name} {points[k]} is not on the fish"
        snout, fork = points[0], points[1]
        axis = (fork - snout) / np.linalg.norm(fork - snout)
        size = np.linalg.norm(fork - snout)
        ahead = snout - axis * max(0.04 * size, 3.0)
        assert not _inside(mask, ahead), f"{kind}: the fish reaches beyond its snout"
        behind = snout + axis * 0.15 * size
        assert _inside(mask, behind), f"{kind}: the body does not lie behind the snout"
        tips = 0.5 * (points[2] + points[3])  # the middle of the notch's opening
        if np.linalg.norm(tips - fork) > 6.0 and np.linalg.norm(points[2] - points[3]) > 12.0:
            notch = fork + 0.35 * (tips - fork)
            assert not _inside(mask, notch), f"{kind}: the fork is not at the notch of the tail"
        checked += 1


def test_every_body_plan_is_drawn_and_the_plans_differ_in_depth():
    rng = np.random.default_rng(3)
    shapes = [random_shape(rng) for _ in range(300)]
    plans = {s.plan for s in shapes}
    assert plans == {p.name for p in BODY_PLANS}
    depth = {p: np.mean([s.depth for s in shapes if s.plan == p]) for p in plans}
    assert depth["elongate"] < depth["fusiform"] < depth["deep-bodied"]


def test_a_keypoint_behind_an_occluder_is_hidden_and_the_rest_visible():
    rng = np.random.default_rng(8)
    camera = random_camera(rng, "flat-port", SIZE)
    scene = random_scene(rng, camera, fish=(1, 1), lengths=(0.4, 0.4), ranges=(2.0, 2.0))
    fish = scene.fish[0]
    fish = SceneFish(fish.shape, (-0.2, 0.0, -2.0), (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), 0.4)
    _, (open_truth,) = render_fish_scene(camera, _clear(scene, [fish]))
    assert open_truth.visible.all() and open_truth.visible_fraction == 1.0 and open_truth.required
    snout = fish.keypoint_points()[0]
    occluder = Occluder(tuple(0.75 * snout), 0.03, (40.0, 90.0, 30.0), 1.0, 0.0, 1)
    _, (truth,) = render_fish_scene(camera, replace(_clear(scene, [fish]), occluders=(occluder,)))
    assert not truth.visible[0] and truth.visible[1:].all()
    assert 0.5 < truth.visible_fraction < 1.0
    assert not truth.required  # the snout is hidden: a detector need not find it
    np.testing.assert_allclose(truth.keypoints, open_truth.keypoints)


def test_a_fish_too_small_to_measure_is_not_required_but_still_unhidden():
    rng = np.random.default_rng(9)
    camera = random_camera(rng, "flat-port", SIZE)
    scene = random_scene(rng, camera, fish=(1, 1))
    shape = scene.fish[0].shape
    lengths = []
    for length in (0.02, 0.3):  # m at 2 m: a few pixels, and far more than the limit
        fish = SceneFish(shape, (-length / 2, 0.0, -2.0), (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), length)
        _, (truth,) = render_fish_scene(camera, _clear(scene, [fish]))
        assert truth.unhidden
        assert truth.required == (truth.length_pixels >= REQUIRED_LENGTH)
        assert truth.true_object().box == truth.box
        lengths.append(truth.length_pixels)
    assert lengths[0] < REQUIRED_LENGTH < lengths[1]


def test_a_frame_is_the_same_for_the_same_seed_and_renders_in_colour():
    rng = np.random.default_rng(5)
    camera = random_camera(rng, "dome-port", SIZE)
    scene = random_scene(rng, camera)
    first, truths = render_fish_scene(camera, scene)
    second, _ = render_fish_scene(camera, scene)
    assert first.shape == (SIZE[1], SIZE[0], 3) and first.dtype == np.uint8
    np.testing.assert_array_equal(first, second)
    assert len(truths) == len(scene.fish)
    other, _ = render_fish_scene(camera, replace(scene, seed=scene.seed + 1))
    assert np.any(other != first)
