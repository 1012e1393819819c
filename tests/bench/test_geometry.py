"""The geometry benchmark times our intersection and back-projection against OpenCV on the same points,
and reports how close both come to the truth (no timed assertions)."""

import pytest

from usvips.bench import geometry


def test_rows_time_both_housings_against_opencv_on_points_that_reach_the_truth():
    rows = list(geometry.benchmarks(scale=0.01))  # 1,000 points
    assert [row["name"].split(":")[0] for row in rows] == [
        "intersection (flat-port)", "back-projection (flat-port)",
        "intersection (dome-cover)", "back-projection (dome-cover)"]
    for row in rows:
        assert row["n"] == 1000
        # the times are printed rounded to the microsecond, the ratio from the unrounded times
        rounding = (1 + row["ratio"]) * 1e-6 / row["baseline_s"] + 1e-4
        assert row["ratio"] == pytest.approx(row["ours_s"] / row["baseline_s"], abs=rounding)
        assert row["met"] == (row["ratio"] <= row["target"])
    intersections, projections = rows[0::2], rows[1::2]
    assert all(row["baseline"] == "cv2.triangulatePoints (pinhole pair)" for row in intersections)
    assert all(row["max_error_m"] < 1e-9 for row in intersections)  # noise-free pixels: the true points
    assert all(row["max_error_px"] < 1e-6 for row in projections)  # back to the pixels traced from
    assert [row["axial"] for row in projections] == [True, False]
