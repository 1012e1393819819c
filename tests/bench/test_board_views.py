"""The many-view calibration bench: its synthetic board views and its rows against OpenCV (no timed
assertions: the rows' arithmetic and that both sides solved the same corners)."""

import numpy as np
import pytest

from usvips.bench import calibration
from usvips.bench.board_views import COLUMNS, HEIGHT, ROWS, WIDTH, board_views


@pytest.mark.parametrize("kind", ["air", "flat-port", "dome-port"])
def test_board_views_are_the_models_pixels_inside_both_images(kind):
    scene = board_views(6, kind, noise=0.0, seed=3)
    assert len(scene.observations) == 6 * COLUMNS * ROWS
    assert len(scene.observations.pair_labels) == 6
    for pixels in (scene.observations.left, scene.observations.right):
        assert np.all((pixels > 0) & (pixels < [WIDTH, HEIGHT]))
    model = scene.model()
    computed, ok = model.evaluate(scene.truth)
    assert ok.all()
    assert np.max(np.abs(computed - model.observation_set.values)) < 1e-9  # noise 0: the model's own pixels


def test_a_many_view_row_compares_the_same_job_with_opencv():
    row = calibration._many_views(12, "air", 1.0, None)
    # the times are printed to the microsecond, the ratio from the unrounded times
    assert row["ratio"] == pytest.approx(row["ours_s"] / row["baseline_s"], rel=1e-3)
    assert row["met"] == (row["ratio"] <= 1.0)
    assert row["n"] == 12 * COLUMNS * ROWS * 4
    ours, opencv, truth = row["f_l"]
    # both recover the left focal length from the same corners (0.2 px noise, 12 views)
    assert abs(ours - truth) < 5.0 and abs(opencv - truth) < 5.0 and abs(ours - opencv) < 2.0
    assert 0.8 < row["sigma0"] < 1.2
