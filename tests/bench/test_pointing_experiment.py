"""The pointing experiment's rows (docs/pointing.md): every feature in every water condition; the least-
squares locator reaches the Cramér–Rao bound it is compared with; the noise floor grows with turbidity,
and so does the offset of a fish's visible fork from its true point (blur fills the notch)."""

from usvips.bench import BENCH_MODULES, pointing_experiment
from usvips.core.pointing_test import CONDITIONS, FEATURES


def test_the_rows_measure_each_point_in_each_water():
    assert "pointing_experiment" in BENCH_MODULES
    rows = list(pointing_experiment.benchmarks(scale=0.25))
    assert len(rows) == len(FEATURES) * len(CONDITIONS)
    by = {(r["name"].split(": ")[1].split(",")[0], r["name"].rsplit(", ", 1)[1].split()[0]): r for r in rows}
    for row in rows:
        assert 0.6 < row["located_px"] / row["crlb_px"] < 1.6
    for feature in FEATURES:
        floors = [by[(feature, c.name)]["crlb_px"] for c in CONDITIONS]
        assert floors == sorted(floors)
    forks = [by[("fish fork", c.name)]["edge_offset_mean_px"] for c in CONDITIONS]
    assert forks == sorted(forks) and forks[0] > 0
    assert "edge_offset_mean_px" not in by[("target centre", "clear")]
