"""The EventMeasure/CheckEM frame columns of a vertex measured on a chaptered stereo video: FrameLeft and
FrameRight count within the chapter file named, Time is minutes from the recording's first frame and runs
on across chapters, PeriodTime is minutes since the period began (EventMeasure's convention, as its own
exports show: see :func:`usvips.app.video_project.eventmeasure_frame_columns`)."""

from types import SimpleNamespace

import numpy as np
import pytest

from usvips.app.video_project import add_video, eventmeasure_frame_columns
from usvips.core.synth.frame_numbers import numbered_frame
from usvips.io.video_stream import VideoStream
from usvips.io.video_writer import encode_video
from usvips.store import Project


@pytest.mark.parametrize("case", range(3))
def test_time_is_minutes_from_the_recording_start_across_chapters(tmp_path, case):
    rng = np.random.default_rng(case)
    fps = float(rng.choice([25.0, 29.97, 59.94]))
    counts = [int(c) for c in rng.integers(8, 20, 2)]
    offset = int(rng.integers(-3, 4))
    files = {}
    for side in ("left", "right"):
        files[side] = []
        first = 0
        for k, count in enumerate(counts):
            path = tmp_path / f"G{side[0].upper()}0{k + 1}0042.MP4"
            encode_video(path, [numbered_frame(first + i) for i in range(count)], fps, "h264", gop=10)
            files[side].append(path)
            first += count
    with Project.create(tmp_path / "p.usvips") as project:
        add_video(project, files["left"], files["right"], "drop")
        project.set_video_offset("drop", offset)
        project.add_period("drop", "bait", 3, sum(counts) - 1 - max(offset, 0))
        with VideoStream(files["left"]) as left:
            for frame in {counts[0] - 1, counts[0] + 2, 4}:
                partner = frame + offset
                if not 0 <= partner < sum(counts):
                    continue
                vertex = SimpleNamespace(video="drop", frame_left=frame, frame_right=partner,
                                         time_s=left.time_of(frame))
                file_left, frame_left, file_right, frame_right, time, period, period_time = \
                    eventmeasure_frame_columns(project, vertex)
                chapter = 0 if frame < counts[0] else 1
                assert (file_left, int(frame_left)) == (files["left"][chapter].name, frame - chapter * counts[0])
                right_chapter = 0 if partner < counts[0] else 1
                assert (file_right, int(frame_right)) == (files["right"][right_chapter].name,
                                                          partner - right_chapter * counts[0])
                assert float(time) == pytest.approx(frame / fps / 60, abs=1e-5)  # minutes, running on
                assert period == "bait" and float(period_time) == pytest.approx((frame - 3) / fps / 60, abs=1e-5)
                assert len(time.split(".")[1]) == 5  # EventMeasure writes 5 decimals
