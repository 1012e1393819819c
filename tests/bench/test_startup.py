"""The start-up bench rows: CPU seconds of ``usvips --help`` and of a subcommand's, against a bare
interpreter started the same way, with the absolute promise (0.3 s of CPU) stated in the row."""

from usvips.bench import BENCH_MODULES, startup


def test_the_rows_name_what_they_time_and_carry_the_promise():
    assert "startup" in BENCH_MODULES
    rows = list(startup.benchmarks(scale=0.1))
    assert [r["name"] for r in rows] == ["start-up CPU: usvips --help", "start-up CPU: usvips project --help"]
    for row in rows:
        assert row["target_s"] == startup.TARGET_CPU_S == 0.3 and row["baseline"] == "python -c pass"
        assert row["ours_s"] > 0 and row["baseline_s"] > 0 and row["met"] == (row["cpu_s"] <= 0.3)
