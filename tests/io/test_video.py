"""Video files: round trip, random access, and bad input named clearly (nothing partial left behind)."""

import cv2
import numpy as np
import pytest

from usvips.core.errors import InputFileError
from usvips.io.video import read_frame, read_frames, video_info, write_video


def _frames(n: int, colour: bool = True, seed: int = 0) -> list[np.ndarray]:
    rng = np.random.default_rng(seed)
    shape = (96, 128, 3) if colour else (96, 128)
    # smooth content (JPEG keeps it well) with a bright square moving one pixel per frame
    base = cv2.GaussianBlur(rng.integers(0, 255, shape, dtype=np.uint8), (0, 0), 3)
    frames = []
    for i in range(n):
        frame = base.copy()
        frame[20:40, 10 + 4 * i:30 + 4 * i] = 250
        frames.append(frame)
    return frames


@pytest.mark.parametrize("colour", [True, False])
def test_frames_come_back_in_order_and_close_to_what_was_written(tmp_path, colour):
    frames = _frames(6, colour)
    path = tmp_path / "clip.avi"
    assert write_video(path, frames, 10) == 6
    info = video_info(path)
    assert (info.frames, info.fps, info.width, info.height) == (6, 10.0, 128, 96)
    assert info.duration_s == pytest.approx(0.6)
    back = list(read_frames(path, grey=not colour))
    assert len(back) == 6
    for written, read in zip(frames, back, strict=True):
        assert read.shape == written.shape
        assert np.abs(read.astype(int) - written).mean() < 3.0  # Motion-JPEG at quality 95
    # the moving square tells the frames apart: random access returns the frame asked for
    for index in (0, 3, 5):
        frame = read_frame(path, index, grey=not colour)
        errors = [np.abs(frame.astype(int) - f).mean() for f in frames]
        assert int(np.argmin(errors)) == index


def test_writing_is_deterministic(tmp_path):
    frames = _frames(4)
    write_video(tmp_path / "a.avi", frames, 25)
    write_video(tmp_path / "b.avi", frames, 25)
    assert (tmp_path / "a.avi").read_bytes() == (tmp_path / "b.avi").read_bytes()


@pytest.mark.parametrize("frames, fps, name, message", [
    (lambda: _frames(2) + [np.zeros((50, 60, 3), np.uint8)], 10, "v.avi", "frame 2: 60 × 50 px"),
    (lambda: [np.zeros((10, 10), np.float32)], 10, "v.avi", "frame 0: expected uint8"),
    (lambda: _frames(2), 12.5, "v.avi", "whole number"),
    (lambda: _frames(2), 10, "v.mp4", "use the suffix .avi"),
    (lambda: [], 10, "v.avi", "no frames"),
])
def test_bad_frames_are_refused_and_leave_no_file(tmp_path, frames, fps, name, message):
    with pytest.raises(InputFileError, match=message):
        write_video(tmp_path / name, frames(), fps)
    assert list(tmp_path.iterdir()) == []


def test_unreadable_videos_are_named(tmp_path):
    with pytest.raises(InputFileError, match="no such video file"):
        video_info(tmp_path / "missing.avi")
    junk = tmp_path / "junk.avi"
    junk.write_text("not a video")
    with pytest.raises(InputFileError, match="junk.avi"):
        video_info(junk)
    path = tmp_path / "short.avi"
    write_video(path, _frames(3), 10)
    with pytest.raises(InputFileError, match="frame 5: the video ends before it"):
        read_frame(path, 5)
    with pytest.raises(InputFileError, match="frame indices start at 0"):
        read_frame(path, -1)
