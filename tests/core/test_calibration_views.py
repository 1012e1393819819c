"""View quality and selection: blur, tilt and scale read from detections, near-duplicates, the diverse
subset and the coverage advice, over many random synthetic board views (truth known)."""

import numpy as np
import pytest

from tests.core.board_views import (
    HEIGHT,
    WIDTH,
    board,
    board_pose,
    detection,
    intrinsics,
    project,
    render,
    stereo_view,
)
from usvips.core import calibration_views as views
from usvips.core.calibration_targets import StereoView
from usvips.core.errors import InvalidParameterError
from usvips.core.observations import ControlPoints

FOCAL = 300.0


def random_view(rng, label, k=None, tilt=None, offset=None, distance=None, noise=0.0):
    k = intrinsics(FOCAL) if k is None else k
    tilt = rng.uniform(0, np.radians(50)) if tilt is None else tilt
    offset = tuple(rng.uniform(-0.25, 0.25, 2)) if offset is None else offset
    distance = rng.uniform(0.6, 1.4) if distance is None else distance
    r, t = board_pose(rng, distance, tilt, rng.uniform(0, np.pi), offset, rng.uniform(-0.3, 0.3))
    return stereo_view(k, r, t, label, noise=noise, rng=rng), (r, t)


# ---------------------------------------------------------------------------------------------- blur
def test_edge_width_sharp_blurred_and_independent_of_contrast():
    rng = np.random.default_rng(3)
    k = intrinsics(FOCAL)
    for _ in range(8):
        r, t = board_pose(rng, rng.uniform(0.6, 1.0), rng.uniform(0, 0.7), rng.uniform(0, np.pi),
                          tuple(rng.uniform(-0.1, 0.1, 2)), rng.uniform(-0.5, 0.5))
        truth = detection(project(k, r, t, board().xyz))
        sharp = render(k, r, t)
        width = views.edge_width(sharp, truth)
        assert 1.2 < width < 3.0
        # brightness and contrast do not change the width (to the rounding of a dimmer image)
        dim = np.clip(np.rint(sharp * 0.4 + 60), 0, 255).astype(np.uint8)
        assert views.edge_width(dim, truth) == pytest.approx(width, rel=0.15)
        blurred = views.edge_width(render(k, r, t, blur=2.0), truth)
        moved = views.edge_width(render(k, r, t, motion=9), truth)
        assert blurred > views.MAX_EDGE_WIDTH_PX and blurred > 2 * width
        assert moved > views.MAX_EDGE_WIDTH_PX


def test_edge_width_of_nothing_is_nan_and_half_checked():
    flat = np.full((HEIGHT, WIDTH), 100, np.uint8)
    points = detection(np.array([[100.0, 100.0], [150.0, 120.0]]))
    assert np.isnan(views.edge_width(flat, points))
    assert np.isnan(views.edge_width(flat, detection(np.empty((0, 2)))))
    with pytest.raises(InvalidParameterError, match="half"):
        views.edge_width(flat, points, half=1)


# ---------------------------------------------------------------------------------------------- geometry
def test_tilt_and_scale_over_random_poses():
    """With the true focal length, the tilt is exact (to the corners' noise); with a focal length 30 %
    off (or the default guess) within 12°; the scale is the pixels per metre at the board's centre."""
    rng = np.random.default_rng(11)
    k = intrinsics(FOCAL)
    target = board()
    errors, guessed, ratios = [], [], []
    for _ in range(200):
        tilt = rng.uniform(0, np.radians(60))
        r, t = board_pose(rng, rng.uniform(0.5, 1.5), tilt, rng.uniform(0, np.pi),
                          tuple(rng.uniform(-0.3, 0.3, 2)), rng.uniform(0, 2 * np.pi))
        px = project(k, r, t, target.xyz) + rng.normal(0, 0.05, (len(target), 2))
        geometry = views.view_geometry(detection(px), target, focal_px=FOCAL)
        errors.append(np.degrees(geometry.tilt - tilt))
        off = views.view_geometry(detection(px), target, focal_px=FOCAL * rng.choice([0.7, 1.3]))
        guessed.append(np.degrees(off.tilt - tilt))
        centre = r @ target.xyz.mean(axis=0) + t
        ratios.append(geometry.scale * np.linalg.norm(centre) / FOCAL)
        normal = r[:, 2]
        if np.degrees(tilt) > 10 and abs(abs(normal[0]) - abs(normal[1])) > 0.05:  # not a diagonal tilt
            assert geometry.tilt_axis == ("vertical" if abs(normal[0]) >= abs(normal[1]) else "horizontal")
    assert np.max(np.abs(errors)) < 1.0
    assert np.max(np.abs(guessed)) < 12.0
    # σ1 of the local map is f / range up to the off-axis stretch (1 / cos of the ray's angle, < 1.2 here)
    assert 0.97 < np.min(ratios) and np.max(ratios) < 1.2


def test_three_d_field_tilt_from_resection():
    rng = np.random.default_rng(5)
    k = intrinsics(FOCAL)
    xyz = np.column_stack([rng.uniform(0, 0.3, 40), rng.uniform(0, 0.2, 40), rng.uniform(0, 0.05, 40)])
    field = ControlPoints(tuple(f"t{i}" for i in range(40)), xyz)
    _, _, axes = np.linalg.svd(xyz - xyz.mean(axis=0))
    for _ in range(50):
        tilt = rng.uniform(0, np.radians(50))
        r, t = board_pose(rng, rng.uniform(0.8, 1.5), tilt, rng.uniform(0, np.pi), (0, 0), 0.0, field)
        px = project(k, r, t, xyz)
        geometry = views.view_geometry(detection(px, field.ids), field, focal_px=FOCAL)
        true = np.arccos(abs((r @ axes[2])[2]))
        assert abs(geometry.tilt - true) < np.radians(1.0)


def test_cells_cover_the_hull():
    size = (WIDTH, HEIGHT)
    # a square over the image's upper-left quarter covers the cells of that quarter (8 × 6 grid)
    corners = np.array([[0, 0], [WIDTH / 2 - 1, 0], [WIDTH / 2 - 1, HEIGHT / 2 - 1], [0, HEIGHT / 2 - 1.0]])
    cells = views.covered_cells(corners, size, (8, 6))
    assert cells == frozenset(r * 8 + c for r in range(3) for c in range(4))
    assert views.covered_cells(np.empty((0, 2)), size) == frozenset()
    with pytest.raises(InvalidParameterError, match="grid"):
        views.covered_cells(corners, size, (0, 6))


# ---------------------------------------------------------------------------------------------- duplicates
def test_duplicates_within_a_few_pixels_in_both_cameras():
    rng = np.random.default_rng(7)
    for i in range(100):
        view, _ = random_view(rng, f"v{i}")
        jitter = rng.uniform(0.2, 0.4 * views.DUPLICATE_PX)
        near = StereoView("near", detection(view.left.pixels + rng.normal(0, jitter / 3, view.left.pixels.shape)
                                            .clip(-jitter, jitter), view.left.ids),
                          detection(view.right.pixels + jitter, view.right.ids))
        assert views.is_duplicate(view, near)
        # moved by more than the tolerance in one camera only: not a duplicate
        step = views.DUPLICATE_PX * rng.uniform(1.5, 5)
        moved = StereoView("moved", view.left, detection(view.right.pixels + [step, 0], view.right.ids))
        assert not views.is_duplicate(view, moved)
    with pytest.raises(InvalidParameterError, match="tolerance_px"):
        views.is_duplicate(view, view, 0)


def test_drop_duplicates_keeps_one_of_each_group():
    rng = np.random.default_rng(8)
    distinct = [random_view(rng, f"d{i}", offset=(0.2 * (i % 3) - 0.2, 0.15 * (i // 3) - 0.15))[0]
                for i in range(9)]
    pool = []
    for view in distinct:
        for j in range(int(rng.integers(1, 5))):
            shift = rng.uniform(-0.5, 0.5, 2)
            pool.append(StereoView(f"{view.label}.{j}", detection(view.left.pixels + shift, view.left.ids),
                                   detection(view.right.pixels + shift, view.right.ids)))
    order = rng.permutation(len(pool))
    kept, dropped = views.drop_duplicates([pool[i] for i in order])
    assert sorted(v.label.split(".")[0] for v in kept) == sorted(v.label for v in distinct)
    assert len(kept) + len(dropped) == len(pool)
    assert all(a.label.split(".")[0] == b.label.split(".")[0] for a, b in dropped)


# ---------------------------------------------------------------------------------------------- selection
def test_selection_finds_the_rare_views_among_many_alike():
    """A pool of many near-alike views (centre, face-on, one distance) and a few that add something (a
    corner of the image, a strong tilt each way, nearer): a selection under a small cap takes every rare
    one, whatever the order."""
    rng = np.random.default_rng(13)
    for trial in range(10):
        common = [random_view(rng, f"c{i}", tilt=rng.uniform(0, 0.08), offset=tuple(rng.uniform(-0.03, 0.03, 2)),
                              distance=rng.uniform(1.0, 1.1))[0] for i in range(80)]
        rare = [random_view(rng, "upper-left", tilt=0.05, offset=(-0.3, -0.2), distance=1.3)[0],
                random_view(rng, "lower-right", tilt=0.05, offset=(0.25, 0.25), distance=1.3)[0]]
        for label, direction in (("turned", 0.5 * np.pi), ("tipped", 0.0)):
            r, t = board_pose(rng, 1.0, np.radians(45), direction, (0, 0), 0.0)
            rare.append(stereo_view(intrinsics(FOCAL), r, t, label))
        rare.append(random_view(rng, "near", tilt=0.05, offset=(0, 0), distance=0.5)[0])
        pool = common + rare
        pool = [pool[i] for i in rng.permutation(len(pool))]
        chosen = views.select_views(pool, 8, board(), focal_px=FOCAL)
        labels = {v.label for v in chosen}
        assert len(chosen) == 8
        assert {"upper-left", "lower-right", "turned", "tipped", "near"} <= labels, (trial, labels)
        # the original order is kept
        assert [v.label for v in chosen] == [v.label for v in pool if v.label in labels]


def test_selection_covers_more_than_random_subsets():
    rng = np.random.default_rng(17)
    wins = []
    for _ in range(12):
        pool = [random_view(rng, f"v{i}", offset=tuple(rng.uniform(-0.3, 0.3, 2)))[0] for i in range(120)]
        chosen = views.select_views(pool, 12, board(), focal_px=FOCAL)
        ours = views.coverage(chosen, board(), focal_px=FOCAL)
        for _ in range(5):
            subset = [pool[i] for i in rng.choice(len(pool), 12, replace=False)]
            theirs = views.coverage(subset, board(), focal_px=FOCAL)
            wins.append(ours.left.covered + ours.right.covered >= theirs.left.covered + theirs.right.covered)
    assert np.mean(wins) > 0.9


def test_selection_small_pool_cap_and_blur_tie_break():
    rng = np.random.default_rng(19)
    pool = [random_view(rng, f"v{i}")[0] for i in range(5)]
    assert views.select_views(pool, 10) == pool
    twins = [pool[0], StereoView("twin", pool[0].left, pool[0].right)]
    assert [v.label for v in views.select_views(twins, 1, blur=[3.0, 2.0])] == ["twin"]
    assert [v.label for v in views.select_views(twins, 1, blur=[2.0, 3.0])] == [pool[0].label]
    with pytest.raises(InvalidParameterError, match="max_views"):
        views.select_views(pool, 0)
    with pytest.raises(InvalidParameterError, match="blur"):
        views.select_views(pool, 2, blur=[1.0])


# ---------------------------------------------------------------------------------------------- coverage
def test_coverage_advice_names_what_is_missing():
    rng = np.random.default_rng(23)
    # face-on views, all at one distance, all in the right half of the images: every complaint
    right_half = [random_view(rng, f"r{i}", tilt=rng.uniform(0, 0.1), distance=1.2,
                              offset=(rng.uniform(0.15, 0.3), rng.uniform(-0.25, 0.25)))[0] for i in range(6)]
    report = views.coverage(right_half, board(), focal_px=FOCAL)
    text = "\n".join(report.advice)
    assert "only 6 views: film at least 15" in text
    assert "nothing in the upper left, left and lower left of the left image" in text
    assert "nothing in the upper left, left and lower left of the right image" in text
    assert "tilt the board more" in text
    assert "vary the distance" in text
    assert report.left.counts.shape == (6, 8) and report.left.counts[:, :2].sum() == 0
    # tilted about one axis only
    turned = []
    for i in range(20):
        r, t = board_pose(rng, rng.uniform(0.6, 1.4), np.radians(40), np.pi / 2, tuple(rng.uniform(-0.3, 0.3, 2)))
        turned.append(stereo_view(intrinsics(FOCAL), r, t, f"t{i}"))
    assert any("tilt the board up and down too" in a for a in views.coverage(turned, board(), focal_px=FOCAL).advice)


def test_coverage_of_a_good_diverse_set_has_no_complaint():
    rng = np.random.default_rng(29)
    good = []
    for i, (gx, gy) in enumerate((x, y) for x in (-0.33, -0.15, 0.0, 0.15, 0.33) for y in (-0.25, 0.0, 0.25)):
        for direction in (0.0, np.pi / 2):
            r, t = board_pose(rng, rng.uniform(0.55, 1.3), np.radians(35), direction, (gx, gy), 0.0)
            good.append(stereo_view(intrinsics(FOCAL), r, t, f"g{i}{direction:.0f}"))
    report = views.coverage(good, board(), focal_px=FOCAL)
    assert report.advice == ()
    assert report.left.covered > 0.8 and report.right.covered > 0.8
    assert 30 < report.left.largest_tilt_deg < 40
    assert report.left.distance_ratio > 1.3
    assert report.summary()[0] == f"{len(good)} views"
