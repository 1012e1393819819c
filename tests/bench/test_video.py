"""The video bench rows (no timed assertions: the rows' shape and their verdicts)."""

from usvips.bench import BENCH_MODULES, video


def test_the_random_seek_row_carries_the_issues_promise_and_its_verdict():
    assert "video" in BENCH_MODULES
    rows = {row["name"]: row for row in video.benchmarks(0.01)}
    seek = rows["video: random seek, 1920x1080 H.264 (GOP 30, B-pyramid), per frame pair"]
    assert seek["target_s"] == video.SEEK_TARGET_PAIR_S == 0.080 and seek["target"] is None
    assert seek["met"] == (seek["per_pair_s"] <= 0.080)
    assert seek["ratio_met"] == (seek["ratio"] <= seek["ratio_target"] == 1.1)
    assert seek["per_pair_s"] > 0 and seek["cpu_per_pair_s"] > 0 and seek["load_1min"] >= 0
    assert 1 <= seek["mean_frames_from_key_frame"] <= video.GOP
