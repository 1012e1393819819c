"""Where to hold the board next: over many random sets of views, the suggestion targets the largest gap —
the part of the image no view covers, the tilt axis no view has, the distance that never changes."""

import numpy as np
import pytest

from tests.core.board_views import HEIGHT, WIDTH, board, board_pose, detection, intrinsics, project
from usvips.core.calibration_targets import StereoView
from usvips.core.calibration_views import view_geometry
from usvips.core.next_pose import suggest

TARGET = board()
K = intrinsics()


def _view(label, rotation, translation):
    """The same detection in both cameras (a rig of no baseline: the two images agree, so the test knows
    which part of either image is empty)."""
    found = detection(project(K, rotation, translation, TARGET.xyz))
    return StereoView(label, found, found, {})


def _quadrant(pixel):
    return int(pixel[0] >= WIDTH / 2), int(pixel[1] >= HEIGHT / 2)


@pytest.mark.parametrize("seed", range(12))
def test_the_suggestion_fills_the_empty_quarter(seed):
    rng = np.random.default_rng(seed)
    empty = (int(rng.integers(2)), int(rng.integers(2)))
    views = []
    while len(views) < 10:
        offset = (rng.uniform(-0.45, 0.45), rng.uniform(-0.35, 0.35))
        rotation, translation = board_pose(rng, rng.uniform(0.9, 1.3), np.radians(rng.uniform(0, 40)),
                                           rng.uniform(0, 2 * np.pi), offset)
        view = _view(str(len(views)), rotation, translation)
        pixels = view.left.pixels
        inside = (pixels.min(axis=0) > 0).all() and (pixels.max(axis=0) < (WIDTH - 1, HEIGHT - 1)).all()
        # the board may not reach into the empty quarter (by a margin of a cell)
        reaches = [(_quadrant(p) == empty) for p in pixels] + [
            (abs(p[0] - WIDTH / 2) < 45 or abs(p[1] - HEIGHT / 2) < 45) and _quadrant(p) == empty for p in pixels]
        if inside and not any(reaches):
            views.append(view)
    suggestion = suggest(views, TARGET)
    assert suggestion.gap == "area"
    assert _quadrant(suggestion.pixel) == empty
    assert suggestion.region in suggestion.text()
    cells = set().union(*(view_geometry(v.left, TARGET).cells for v in views))
    cols = 8
    assert suggestion.cell[1] * cols + suggestion.cell[0] not in cells


def _covering_views(rng, tilt_direction, distances=(0.45, 0.6)):
    """Views all over the image, each tilted 25–40° about one axis (tilt_direction 0: about the image's x
    axis, so tipped up or down)."""
    views = []
    for row in (-0.3, 0.0, 0.3):
        for column in (-0.4, -0.15, 0.15, 0.4):
            rotation, translation = board_pose(rng, rng.uniform(*distances), np.radians(rng.uniform(25, 40)),
                                               tilt_direction + rng.choice([0, np.pi]), (column, row))
            views.append(_view(f"{row},{column}", rotation, translation))
    return views


@pytest.mark.parametrize("seed", range(6))
def test_a_missing_tilt_axis_is_suggested(seed):
    rng = np.random.default_rng(100 + seed)
    about_x = bool(seed % 2)
    views = _covering_views(rng, 0.0 if about_x else np.pi / 2, (0.35, 0.6))
    axes = {view_geometry(v.left, TARGET).tilt_axis for v in views}
    assert len(axes) == 1  # the scene tilts about one axis only
    suggestion = suggest(views, TARGET)
    assert suggestion.gap == "tilt"
    assert suggestion.tilt_axis != axes.pop()


@pytest.mark.parametrize("seed", range(6))
def test_one_distance_only_asks_for_another(seed):
    rng = np.random.default_rng(200 + seed)
    views = _covering_views(rng, 0.0, (0.5, 0.52)) + _covering_views(rng, np.pi / 2, (0.5, 0.52))
    suggestion = suggest(views, TARGET)
    assert suggestion.gap == "distance"
    low, high = suggestion.sizes_px
    assert suggestion.size_px > 1.05 * high or suggestion.size_px < 0.95 * low
    assert "nearer" in suggestion.text() or "farther" in suggestion.text()


def test_no_views_no_suggestion():
    assert suggest([], TARGET) is None
