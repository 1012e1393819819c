"""The figures bench row: its shape at a small scale, and that the far fish take the second-order part."""

from usvips.bench import BENCH_MODULES, figures


def test_the_figures_row_times_both_and_says_how_many_took_the_second_order_part():
    assert "figures" in BENCH_MODULES
    (row,) = figures.benchmarks(scale=0.01)
    assert row["n"] >= 95 and row["target"] == figures.TARGET_RATIO
    assert row["ours_s"] > 0 and row["baseline_s"] > 0 and row["whole_path_s"] > row["baseline_s"]
    assert 0.2 <= row["second_order_share"] <= 1.0
