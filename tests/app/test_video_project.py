"""The EventMeasure/CheckEM frame columns of a vertex measured on a chaptered stereo video: FrameLeft and
FrameRight count within the chapter file named, Time is minutes from the recording's first frame and runs
on across chapters, PeriodTime is minutes since the period began (EventMeasure's convention, as its own
exports show: see :func:`usvips.app.video_project.eventmeasure_frame_columns`)."""

from pathlib import Path
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


def test_the_full_media_check_runs_away_from_the_project_finds_every_damage_and_stops_when_cancelled(tmp_path):
    from usvips.app.video_project import Cancelled, verify_media

    rng = np.random.default_rng(12)
    files = []
    for n in range(6):
        files.append(tmp_path / f"clip{n}.mp4")
        files[-1].write_bytes(rng.integers(0, 256, int(rng.integers(1, 3_000_000)), dtype=np.uint8).tobytes())
    with Project.create(tmp_path / "p.usvips") as project:
        project.add_video("v", [(f, 10, 25.0) for f in files[:3]], [(f, 10, 25.0) for f in files[3:]], 25.0, 30,
                          (64, 48))
        records = project.media_records()
    assert verify_media(records) == []
    damaged = {}
    for path in rng.choice(files, 3, replace=False):
        data = bytearray(path.read_bytes())
        data[int(rng.integers(0, len(data)))] ^= 0x5A  # one byte anywhere: only the whole hash sees it
        path.write_bytes(bytes(data))
        damaged[path.name] = "contents differ"
    files[0].rename(tmp_path / "gone.mp4")
    damaged[files[0].name] = "missing"
    found = dict(verify_media(records))
    assert {Path(k).name for k in found} == set(damaged)
    assert all(damaged[Path(k).name] in v for k, v in found.items())
    calls = []
    with pytest.raises(Cancelled):
        verify_media(records, lambda done, total: calls.append(done), cancelled=lambda: len(calls) >= 2,
                     chunk=1 << 16)
    assert len(calls) == 2  # nothing more was read once cancelled


def test_adding_a_pair_refuses_a_damaged_jpeg_and_stores_nothing(tmp_path):
    import cv2

    from usvips.app.video_project import add_image_pairs
    from usvips.core.errors import InputFileError

    rng = np.random.default_rng(13)
    picture = cv2.GaussianBlur((rng.random((120, 160, 3)) * 255).astype(np.uint8), (0, 0), 2)
    good = cv2.imencode(".jpg", picture)[1].tobytes()
    (tmp_path / "left.jpg").write_bytes(good[:len(good) // 2] + b"\xff\xd9")
    (tmp_path / "right.jpg").write_bytes(good)
    with Project.create(tmp_path / "p.usvips") as project:
        with pytest.raises(InputFileError, match="left.jpg: the JPEG's compressed data is damaged"):
            add_image_pairs(project, [("a", tmp_path / "left.jpg", tmp_path / "right.jpg")])
        assert project.pairs() == []
