"""Adding a stereo video reports both cameras' frame counts at add time, and a refusal names the file at
fault (the right camera's file for the right camera's fault)."""

import numpy as np
import pytest

from usvips.app.video_project import VideoError, inspect_video
from usvips.core.synth.frame_numbers import numbered_frame
from usvips.io.video_writer import encode_video


@pytest.mark.parametrize("seed", range(3))
def test_both_counts_are_reported_and_a_difference_is_a_warning(tmp_path, seed):
    rng = np.random.default_rng(seed)
    counts = {side: int(rng.integers(6, 16)) for side in ("left", "right")}
    if seed == 0:
        counts["right"] = counts["left"]
    for side, count in counts.items():
        encode_video(tmp_path / f"{side}.mp4", [numbered_frame(i) for i in range(count)], 25.0, "h264", gop=5)
    plan = inspect_video([tmp_path / "left.mp4"], [tmp_path / "right.mp4"], "dive")
    assert (plan.frame_count, plan.right_frame_count) == (counts["left"], counts["right"])
    differ = [w for w in plan.warnings if "frame counts differ" in w]
    if counts["left"] == counts["right"]:
        assert differ == []
    else:
        assert differ == [f"the cameras' frame counts differ: left {counts['left']} frames, right {counts['right']} "
                          "frames (a file cut short, or the cameras started and stopped apart: synchronise, then "
                          "frames past the shorter end have no partner)"]


@pytest.mark.parametrize("short", ["left", "right"])
def test_a_one_frame_file_is_blamed_on_its_own_side(tmp_path, short):
    for side in ("left", "right"):
        count = 1 if side == short else 8
        encode_video(tmp_path / f"{side}.mp4", [numbered_frame(i) for i in range(count)], 25.0, "h264", gop=5)
    with pytest.raises(VideoError) as raised:
        inspect_video([tmp_path / "left.mp4"], [tmp_path / "right.mp4"])
    assert str(raised.value).startswith(str(tmp_path / f"{short}.mp4"))
    assert "it has 1)" in str(raised.value)
