"""The survey benchmark rows (no timed assertions: the rows' shape and their verdicts)."""

from usvips.bench import BENCH_MODULES, survey


def test_the_combination_row_states_its_absolute_target_and_verdict():
    assert "survey" in BENCH_MODULES
    rows = list(survey.benchmarks(0.01))
    combine = rows[0]
    assert combine["n"] == 20 and combine["target_s"] == survey.COMBINE_TARGET_S
    assert combine["met"] == (combine["ours_s"] <= combine["target_s"])
    assert combine["ours_s"] > 0 and combine["baseline_s"] > 0
