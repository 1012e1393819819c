"""The bench row of "the window stays responsive while detecting (longest freeze ≤ 0.1 s)": produced by the
``window_detection`` area with the fields that say what was timed, against what, and the promise (its timing
is the bench's business, not a test's)."""

import pytest

from usvips.bench import areas
from usvips.gui.qt import bench_detection


def test_the_detect_freeze_row_names_what_it_timed_its_baseline_and_the_promise():
    assert areas()["window_detection"] == "usvips.gui.qt.bench_detection"
    row = bench_detection.freeze_row(scale=0.01)  # 3 frames of 1080p video
    assert "freeze" in row["name"] and "Detect" in row["name"]
    assert row["target"] is None and row["target_s"] == bench_detection.FREEZE_TARGET_S == 0.1
    assert row["met"] == (row["ours_s"] <= 0.1)
    assert row["baseline"].startswith("the same timer") and row["tick_ms"] == 5
    # the window detected on every frame in its worker and stored the shipped model's proposals
    assert row["n"] == row["frames"] == 3 and row["proposals"] >= 1
    assert row["ours_s"] > 0 and row["baseline_s"] > 0 and row["detect_s"] > 0 and row["ticks"] > 0
    assert 0 < row["gui_cpu_s"] <= row["ours_s"] + 0.01  # the GUI thread's CPU between two ticks is within its gap
    assert row["ratio"] == pytest.approx(row["ours_s"] / row["baseline_s"], rel=0.02)
    assert set(row) >= {"name", "n", "ours_s", "baseline", "baseline_s", "ratio", "target", "target_s", "met",
                        "load_1min"}
