"""The σ check's bench row: it checks the project it builds (the stated σ of lengths picked with the
hand-click default hold), and carries the promise (≤ 10 s for 1,000 objects)."""

from usvips.bench import BENCH_MODULES, sigma_check


def test_the_row_checks_a_project_and_carries_the_promise():
    assert "sigma_check" in BENCH_MODULES
    (row,) = sigma_check.benchmarks(scale=0.05)
    assert row["n"] == 50 and row["target_s"] == sigma_check.TARGET_S == 10.0
    assert row["ours_s"] > 0 and row["baseline_s"] > 0 and row["met"] == (row["ours_s"] <= 10.0)
    assert 0.7 <= row["nees"] <= 1.5 and row["replicas"] == 40
