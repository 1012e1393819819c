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


@pytest.mark.parametrize("seed", range(4))
def test_a_damaged_file_is_refused_at_add_time_naming_it(tmp_path, seed):
    import av

    rng = np.random.default_rng(seed)
    for side in ("left", "right"):
        encode_video(tmp_path / f"{side}.mp4", [numbered_frame(i) for i in range(10)], 25.0, "h264", gop=5)
    damaged = str(rng.choice(["left", "right"]))
    path = tmp_path / f"{damaged}.mp4"
    with av.open(str(path)) as container:
        packets = [(p.pos, p.size) for p in container.demux(video=0) if p.size]
    data = bytearray(path.read_bytes())
    position, size = packets[-1]  # the last frame's bytes overwritten: the file's index still lists it
    data[position:position + size] = rng.integers(0, 256, size, dtype=np.uint8).tobytes()
    path.write_bytes(bytes(data))
    with pytest.raises(VideoError, match=rf"^{path} \({damaged}\) is damaged: frame 9 cannot be decoded"):
        inspect_video([tmp_path / "left.mp4"], [tmp_path / "right.mp4"])
