"""Tracking holds OpenCV to one thread while it runs (its thread pool only spins between the tracker's small
calls) and gives the process its thread count back when the last track running ends — also when a track
fails, and when two tracks on two threads overlap."""

import threading

import cv2
import numpy as np
import pytest

from tests.core.test_tracking_paths import _clip
from usvips.core.tracking import track_vertex


@pytest.fixture
def three_threads():
    before = cv2.getNumThreads()
    cv2.setNumThreads(3)
    yield 3
    cv2.setNumThreads(before)


def test_a_track_runs_opencv_on_one_thread_and_gives_the_count_back(three_threads):
    stereo, frames, start, (left, right) = _clip(11)
    seen = []

    def counted(i):
        seen.append(cv2.getNumThreads())
        return frames(i)

    track = track_vertex(counted, stereo, start, left, right, start - 3, start + 3)
    assert len(track.frames) == 7 and set(seen) == {1}
    assert cv2.getNumThreads() == three_threads

    def broken(i):
        if i != start:
            raise RuntimeError("decoder crashed")
        return frames(i)

    with pytest.raises(RuntimeError, match="decoder crashed"):
        track_vertex(broken, stereo, start, left, right, start - 3, start + 3)
    assert cv2.getNumThreads() == three_threads


def test_overlapping_tracks_on_two_threads_keep_one_thread_until_the_last_ends(three_threads):
    stereo, frames, start, (left, right) = _clip(12)
    first_inside, second_done = threading.Event(), threading.Event()
    seen = []

    def waiting(i):
        first_inside.set()
        if i == start + 2:  # the second track starts and ends while this one runs
            assert second_done.wait(30)
            seen.append(cv2.getNumThreads())
        return frames(i)

    results = []
    worker = threading.Thread(target=lambda: results.append(
        track_vertex(waiting, stereo, start, left, right, start, start + 4)))
    worker.start()
    assert first_inside.wait(30)
    track_vertex(frames, stereo, start, left, right, start, start + 2)
    second_done.set()
    worker.join(60)
    assert seen == [1] and len(results) == 1 and np.array_equal(results[0].frames, np.arange(start, start + 5))
    assert cv2.getNumThreads() == three_threads
