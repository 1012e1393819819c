"""The bench row of "the window never freezes for more than 0.1 s while tracking": it is produced by the
``window_tracking`` area with the fields that say what was timed, against what, and the promise (its
timing is the bench's business, not a test's)."""

import pytest

from usvips.bench import BENCH_MODULES, BENCH_PATHS
from usvips.gui.qt import bench_tracking


def test_the_freeze_row_names_what_it_timed_its_baseline_and_the_promise():
    assert "window_tracking" in BENCH_MODULES and BENCH_PATHS["window_tracking"] == "usvips.gui.qt.bench_tracking"
    row = bench_tracking.freeze_row(scale=0.3)  # 12 frames of 1080p video
    assert row["name"] == bench_tracking.NAME and "freeze" in row["name"]
    assert row["target"] is None and row["target_s"] == bench_tracking.FREEZE_TARGET_S == 0.1
    assert row["met"] == (row["ours_s"] <= 0.1)
    assert row["baseline"].startswith("the same timer") and row["tick_ms"] == bench_tracking.TICK_MS == 5
    # the window tracked the object through the whole video (the fish stays in view), in a worker
    assert row["n"] == row["frames"] == 12
    assert row["ours_s"] > 0 and row["baseline_s"] > 0 and row["tracking_s"] > 0 and row["ticks"] > 0
    assert row["ratio"] == pytest.approx(row["ours_s"] / row["baseline_s"], rel=0.02)  # of the unrounded times
    assert set(row) >= {"name", "n", "ours_s", "baseline", "baseline_s", "ratio", "target", "target_s", "met",
                        "load_1min"}
