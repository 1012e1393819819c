"""The outlines of a pair as flat arrays: what a pane asks of them (the outlines meeting a rectangle, their
polyline, the raster of all of them) agrees with each outline taken on its own, over many random sets."""

import numpy as np
import pytest

from usvips.gui.outline_set import OutlineSet, raster, raster_scale


def _random_set(rng, n: int) -> tuple[OutlineSet, dict]:
    counts = rng.integers(1, 6, size=n)
    closed = rng.random(n) < 0.4
    points = rng.uniform(0, 300, size=(counts.sum(), 4))
    ids = rng.permutation(10 * n)[:n] + 1
    outlines = OutlineSet()
    outlines.put(ids, counts, closed, points)
    each, start = {}, 0
    for i, c, shut in zip(ids, counts, closed, strict=True):
        mine = points[start:start + c]
        each[int(i)] = np.vstack([mine, mine[:1]]) if shut and c > 2 else mine
        start += c
    return outlines, each


@pytest.mark.parametrize("seed", range(20))
def test_lines_and_rectangles_agree_with_each_outline(seed):
    rng = np.random.default_rng(seed)
    outlines, each = _random_set(rng, int(rng.integers(1, 60)))
    gone = [int(i) for i in rng.choice(list(each), size=len(each) // 3, replace=False)]
    outlines.drop(gone)
    for i in gone:
        del each[i]
    again = int(rng.choice(list(each))) if each else None
    if again is not None:  # replaced: the new outline, at the end
        outlines.put([again], [2], [False], [[1, 2, 3, 4], [5, 6, 7, 8]])
        each[again] = np.array([[1, 2, 3, 4], [5, 6, 7, 8]], float)
    assert sorted(outlines.ids.tolist()) == sorted(each) and len(outlines) == len(each)
    for side in (0, 1):
        lines = outlines.lines(side)
        parts = np.split(lines, np.flatnonzero(np.isnan(lines[:, 0])) + 1)[:-1]
        for i, part in zip(outlines.ids, parts, strict=True):
            assert np.array_equal(part[:-1], each[int(i)][:, 2 * side:2 * side + 2])
            assert np.array_equal(outlines.outline(int(i), side), part[:-1])
        x0, y0 = rng.uniform(0, 200, 2)
        x1, y1 = x0 + rng.uniform(1, 100), y0 + rng.uniform(1, 100)
        meets = {int(outlines.ids[k]) for k in outlines.in_rect(side, x0, y0, x1, y1)}
        for i, pts in each.items():
            xy = pts[:, 2 * side:2 * side + 2]
            box_meets = xy[:, 0].min() <= x1 and xy[:, 0].max() >= x0 and xy[:, 1].min() <= y1 and xy[:, 1].max() >= y0
            assert (i in meets) == box_meets


def test_a_change_makes_a_new_version_and_a_copy_keeps_the_old():
    outlines = OutlineSet()
    outlines.put([1, 2], [2, 2], [False, False], np.arange(16.0).reshape(4, 4))
    copy, version = outlines.copy(), outlines.version
    outlines.drop([1])
    assert outlines.version > version and 1 not in outlines and 2 in outlines
    assert copy.version == version and 1 in copy and len(copy) == 2
    with pytest.raises(ValueError, match="do not match"):
        outlines.put([3], [3], [False], np.zeros((2, 4)))


@pytest.mark.parametrize("seed", range(10))
def test_the_raster_draws_every_outline_end_and_nothing_far_from_them(seed):
    rng = np.random.default_rng(seed)
    width, height = int(rng.integers(100, 900)), int(rng.integers(100, 700))
    n = int(rng.integers(1, 40))
    points = rng.uniform([0, 0, 0, 0], [width - 1, height - 1, width - 1, height - 1], size=(2 * n, 4))
    outlines = OutlineSet()
    outlines.put(np.arange(n), np.full(n, 2), np.zeros(n, bool), points)
    for side in (0, 1):
        mask = raster(outlines, side, width, height, max_side=512)
        s = raster_scale(width, height, 512)
        assert mask.shape == (round(height * s), round(width * s))
        xy = points[:, 2 * side:2 * side + 2]
        cells = np.clip(np.floor((xy + 0.5) * s).astype(int), 0, [mask.shape[1] - 1, mask.shape[0] - 1])
        # each end is drawn within a raster pixel of its own cell
        for cx, cy in cells:
            assert mask[max(cy - 1, 0):cy + 2, max(cx - 1, 0):cx + 2].any()
        # every pixel drawn lies within a pixel of some segment
        ys, xs = np.nonzero(mask)
        centres = (np.column_stack([xs, ys]) + 0.5) / s - 0.5
        a, b = xy[0::2], xy[1::2]
        d = b - a
        t = np.clip(((centres[:, None] - a) * d).sum(-1) / np.maximum((d * d).sum(-1), 1e-12), 0, 1)
        distance = np.linalg.norm(centres[:, None] - (a + t[..., None] * d), axis=-1).min(axis=1)
        assert np.all(distance <= 1.5 / s)


def test_the_outlines_added_since_a_version_are_known_until_one_is_dropped():
    outlines = OutlineSet()
    outlines.put([1, 2], [2, 2], [False, False], np.arange(16.0).reshape(4, 4))
    version, count = outlines.version, len(outlines)
    outlines.put([3], [2], [False], np.ones((2, 4)))
    outlines.put([4], [1], [False], np.ones((1, 4)))
    assert outlines.ids[outlines.added_since(version, count)].tolist() == [3, 4]
    outlines.put([2], [2], [False], np.zeros((2, 4)))  # replaced: no longer only additions
    assert outlines.added_since(version, count) is None
    assert len(outlines.added_since(outlines.version, len(outlines))) == 0
