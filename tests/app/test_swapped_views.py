"""Views whose left and right images look swapped: named when a minority of views has the disparity's
sign opposite to the rest's, both clearly away from zero; never on a rig whose disparities are all small
or when there is no clear majority."""

import numpy as np

from usvips.app.board_calibration import swapped_views
from usvips.core.calibration_targets import StereoView, TargetDetection

WIDTH = 640


def _view(label: str, disparity: float, rng) -> StereoView:
    ids = tuple(str(k) for k in range(12))
    left = rng.uniform(200, 400, (12, 2))
    right = left - [disparity, 0.0] + rng.normal(0, 0.5, (12, 2))
    return StereoView(label, TargetDetection(ids, left, np.ones(12), (WIDTH, 480)),
                      TargetDetection(ids, right, np.ones(12), (WIDTH, 480)))


def test_the_minority_with_the_opposite_disparity_is_named():
    rng = np.random.default_rng(0)
    views = [_view(f"v{k}", -60.0 if k in (2, 5) else rng.uniform(40, 80), rng) for k in range(8)]
    assert swapped_views(views) == ["v2", "v5"]


def test_nothing_is_named_without_a_clear_rig_or_majority():
    rng = np.random.default_rng(1)
    small = [_view(f"v{k}", rng.uniform(-5, 5), rng) for k in range(8)]  # disparities under 2 % of the width
    assert swapped_views(small) == []
    half = [_view(f"v{k}", 60.0 if k % 2 else -60.0, rng) for k in range(8)]
    assert swapped_views(half) == []
    assert swapped_views([_view("a", 60.0, rng), _view("b", -60.0, rng)]) == []
