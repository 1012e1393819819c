"""Scale augmentation of the fish model's training frames: the zoomed image and its fish's keypoints stay in
register (a rendered spot's centroid lands where its keypoint goes, over many random zooms), fish cut by the
input's edge or shrunk below the finding size are no longer required, and random zooms keep their range."""

import numpy as np

from usvips.training.fish_augment import MIN_REQUIRED_PX, random_zoom, zoomed

SIZE = 128


def _spot(u: float, v: float, sigma: float = 2.5) -> np.ndarray:
    """A frame of the padding's grey with a bright Gaussian spot centred at (u, v) in corner-origin coordinates."""
    xs = np.arange(SIZE) + 0.5  # pixel centres in corner-origin coordinates
    spot = np.exp(-((xs[None, :] - u) ** 2 + (xs[:, None] - v) ** 2) / (2 * sigma**2))
    return np.repeat((114 + 140 * spot)[..., None], 3, axis=2).astype(np.uint8)


def _fish(points: list[tuple[float, float]]) -> dict:
    points = np.array(points, float)
    return {"keypoints": points, "visible": np.ones(len(points), bool), "in_frame": np.ones(len(points), bool),
            "box": (*points.min(axis=0), *points.max(axis=0)), "required": True}


def _centroid(image: np.ndarray) -> np.ndarray:
    weight = np.clip(image[..., 0].astype(float) - 114, 0, None)
    weight[weight < 0.2 * weight.max()] = 0
    xs = np.arange(SIZE) + 0.5
    return np.array([(weight.sum(axis=0) * xs).sum(), (weight.sum(axis=1) * xs).sum()]) / weight.sum()


def test_the_zoomed_image_and_its_keypoints_stay_in_register():
    rng = np.random.default_rng(11)
    errors = []
    for _ in range(40):
        scale = float(np.exp(rng.uniform(np.log(0.6), np.log(2.2))))
        u, v = rng.uniform(0.35 * SIZE, 0.65 * SIZE, 2)
        shift = tuple(rng.uniform(-8, 8, 2) + (1 - scale) * np.array([u, v]))  # the spot stays well inside
        image, (fish,) = zoomed(_spot(u, v), [_fish([(u, v), (u + 30, v)])], scale, shift)
        errors.append(np.hypot(*(_centroid(image) - fish["keypoints"][0])))
        np.testing.assert_allclose(fish["keypoints"][0], scale * np.array([u, v]) + shift)
    assert max(errors) < 0.15, max(errors)


def test_fish_cut_by_the_edge_or_too_small_are_not_required():
    image = np.full((SIZE, SIZE, 3), 90, np.uint8)
    whole = _fish([(60, 60), (90, 60)])
    out, (cut,) = zoomed(image, [whole], 2.0, (-130.0, -40.0))  # the snout goes to u = -10, the fork to 50
    assert not cut["required"] and not cut["in_frame"][0] and cut["in_frame"][1]
    _, (small,) = zoomed(image, [whole], 0.9 * MIN_REQUIRED_PX / 30, (0.0, 0.0))
    assert not small["required"] and small["in_frame"].all()
    _, (kept,) = zoomed(image, [whole], 1.1 * MIN_REQUIRED_PX / 30, (0.0, 0.0))
    assert kept["required"]
    assert (out[0, 0] == 90).all()  # magnified: the frame still covers the input


def test_random_zooms_keep_their_range_and_the_frame_placed():
    rng = np.random.default_rng(5)
    image = np.full((SIZE, SIZE, 3), 200, np.uint8)
    scales = []
    for _ in range(60):
        corners = _fish([(0.0, 0.0), (SIZE, SIZE)])
        out, (moved,) = random_zoom(image, [corners], (0.6, 2.2), rng)
        (u0, v0), (u1, v1) = moved["keypoints"]
        scale = (u1 - u0) / SIZE
        scales.append(scale)
        assert 0.6 <= scale <= 2.2
        if scale >= 1:  # the frame covers the whole input: no grey padding
            assert u0 <= 0 and v0 <= 0 and u1 >= SIZE and v1 >= SIZE and (out[1:-1, 1:-1] == 200).all()
        else:  # the frame lies inside the input, padded with grey 114 around
            assert u0 >= 0 and v0 >= 0 and u1 <= SIZE and v1 <= SIZE
            assert np.isin(out[1:-1, 1:-1, 0], (114, 200)).mean() > 0.9
    assert min(scales) < 0.8 and max(scales) > 1.6  # log-uniform over the range, both ends reached
