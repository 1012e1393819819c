"""The video model without a window: stepping within the synchronised frames, time codes, the bounded
cache, prefetch order, and the frame source returning the frame pair asked for."""

import numpy as np
import pytest

from usvips.app.video_project import add_video
from usvips.core.errors import InvalidParameterError
from usvips.core.synchronisation import SyncEstimate
from usvips.core.synth.frame_numbers import frame_number, numbered_frame
from usvips.gui.video_model import (
    FrameCache,
    FrameSource,
    VideoNavigator,
    cache_bytes,
    format_timecode,
    parse_position,
    prefetch_order,
    rgb_pair,
    sync_decision,
)
from usvips.io.video_writer import encode_video
from usvips.store import Project


@pytest.mark.parametrize("offset, first, last", [(3, 0, 96), (-5, 5, 99), (0, 0, 99)])
def test_the_navigator_stays_on_frames_with_a_partner(offset, first, last):
    nav = VideoNavigator("v", 100, 100, offset, 25.0)
    assert (nav.first, nav.last) == (first, last)
    assert nav.home() == first and nav.end() == last
    nav.go(50)
    assert nav.step(1) == 51 and nav.step(-nav.jump) == 41 and nav.partner == 41 + offset
    assert nav.step(10_000) == last and nav.step(-10_000) == first
    nav.marks = {10, 60, 80}
    nav.go(60)
    assert nav.next_mark(1) == 80 and nav.next_mark(-1) == 10
    nav.rate = 0.5
    assert nav.play_interval_ms() == 80


def test_positions_typed_by_a_person():
    assert parse_position("1234", 25) == 1234
    assert parse_position("12.5s", 25) == 312 or parse_position("12.5s", 25) == 313
    assert parse_position("01:02.000", 10) == 620
    assert parse_position("1:00:00.5", 2) == 7201
    times = np.array([0.0, 0.03, 0.1, 0.2])
    assert parse_position("0.15s", 10, times) == 2  # variable frame rate: by presentation time
    with pytest.raises(InvalidParameterError, match="type a frame number"):
        parse_position("frame ten", 25)
    assert format_timecode(62.5) == "01:02.500" and format_timecode(3725.25) == "1:02:05.250"


def test_the_cache_is_bounded_and_keeps_the_recently_used():
    frame = np.zeros((108, 192, 3), np.uint8)
    pair = (frame, frame.copy(), 0, 0.0)
    budget = cache_bytes(192, 108, 5, bytes_per_pixel=3)  # RGB arrays
    cache = FrameCache(budget)
    for i in range(5):
        cache.put(i, pair)
    cache.get(0)  # used: kept
    cache.put(5, pair)
    assert 0 in cache and 1 not in cache and len(cache) == 5 and cache.used <= budget
    assert cache_bytes(1920, 1080, 48) == 48 * 2 * 1920 * 1080 * 3 // 2  # YUV 4:2:0: about 0.3 GB at 1080p
    with pytest.raises(InvalidParameterError):
        FrameCache(0)


def test_prefetch_goes_ahead_in_the_direction_of_travel():
    assert prefetch_order(10, 0, 99, 1, ahead=3, behind=1) == [11, 12, 13, 9]
    assert prefetch_order(10, 0, 99, -1, ahead=3, behind=1) == [7, 8, 9, 11]  # backwards: one seek, then forwards
    assert prefetch_order(98, 0, 99, 1, ahead=3, behind=0) == [99]


def test_the_frame_source_returns_the_synchronised_pair(tmp_path):
    for side, base in (("left", 0), ("right", 1000)):
        encode_video(tmp_path / f"{side}.mp4", [numbered_frame(base + i) for i in range(40)], 25, "h264", gop=20)
    with Project.create(tmp_path / "p.usvips") as project:
        add_video(project, [tmp_path / "left.mp4"], [tmp_path / "right.mp4"], "v")
        project.set_video_offset("v", 4)
        source = FrameSource(project, "v")
        nav = source.navigator()
        assert (nav.first, nav.last, nav.offset) == (0, 35, 4)
        for frame in (30, 2, 17, 18, 35):
            left, right, partner, time_s = source.pair(frame)
            assert (frame_number(left), frame_number(right), partner) == (frame, 1004 + frame, frame + 4)
            assert time_s == pytest.approx(frame / 25)
        # the cache holds pictures in the decoder's YUV 4:2:0 (half of RGB) that show the same pixels
        first = source.pictures(12)
        pair_bytes = first[0].nbytes + first[1].nbytes  # YUV planes, rows padded by the decoder
        assert cache_bytes(160, 120, 1) <= pair_bytes < cache_bytes(160, 120, 1, bytes_per_pixel=3)
        cache = FrameCache(3 * pair_bytes)
        cache.put(12, first)
        for frame in (13, 14, 5):
            cache.put(frame, source.pictures(frame))
        assert 12 not in cache and 5 in cache and cache.used == 3 * pair_bytes
        left, right, partner, _ = rgb_pair(cache.get(14))
        fresh_left, fresh_right, _, _ = source.pair(14)
        assert np.array_equal(left, fresh_left) and np.array_equal(right, fresh_right) and partner == 18
        source.close()


def test_the_seek_proxies_size_on_disk_is_estimated_before_asking():
    from usvips.gui.video_model import format_bytes, proxy_disk_bytes

    low, high = proxy_disk_bytes(30 * 60, 1920, 1080)  # a minute of 1080p at 30 fps, both cameras
    assert 2 * 2.3e9 < low < high < 2 * 4.6e9  # io.video_proxy: 2.5–4.5 GB a camera-minute
    assert proxy_disk_bytes(0, 1920, 1080) == (0, 0)
    assert [format_bytes(n) for n in (512, 93 * 1024, int(2.44 * 2**30), 812 * 2**20)] == [
        "512 bytes", "93 KiB", "2.4 GiB", "812 MiB"]


@pytest.mark.parametrize(("offset", "confidence", "window", "beyond", "action"), [
    (4.1, 0.95, (-10, 10), None, "store"),
    (4.1, 0.2, (-10, 10), None, "ask"),
    (10.0, 0.95, (-10, 10), None, "refuse"),   # at the edge, however confident
    (-9.6, 0.2, (-10, 10), None, "refuse"),    # rounds to the edge: never offered, not even asked
    (3.0, 0.99, (-5, 5), 12.0, "refuse"),      # the flash seen outside the window
    (4.0, 0.9, None, None, "store"),           # no window known: judged by its confidence
])
def test_an_estimate_at_the_edge_of_its_window_is_refused_not_offered(offset, confidence, window, beyond, action):
    estimate = SyncEstimate(offset, 25.0, "flash", confidence, window=window, beyond=beyond)
    decided, why = sync_decision(estimate)
    assert decided == action
    if action == "refuse":
        assert why == estimate.edge_problem() and "window" in why
    elif action == "ask":
        assert "confidence" in why
    else:
        assert why is None


def test_a_video_session_stores_offsets_periods_and_taken_pairs_without_a_window(tmp_path):
    """The synchronisation flow as a model: an offset typed or estimated is stored and the navigator made
    anew at the same frame (marks, rate and jump kept, the event says so); the decision on an estimate
    comes in words; a period is parsed and stored or refused by name; a taken pair is planned, and a
    refused one leaves no file behind."""
    from usvips.core.errors import UsvipsError
    from usvips.gui.video_model import VideoSession
    from usvips.store.project import Vertex

    for side, base in (("left", 0), ("right", 1000)):
        encode_video(tmp_path / f"{side}.mp4", [numbered_frame(base + i) for i in range(40)], 25, "h264", gop=20)
    with Project.create(tmp_path / "p.usvips") as project:
        add_video(project, [tmp_path / "left.mp4"], [tmp_path / "right.mp4"], "v")
        project.add_object("point", [Vertex(1.0, 2.0, 3.0, 4.0, None, None, None, None, "v", 12, 12, 0.48)])
        session = VideoSession(project, "v")
        heard = []
        session.offset_changed.connect(heard.append)
        nav = session.navigator
        assert nav.marks == {12} and nav.offset == 0
        nav.go(20)
        nav.rate, nav.jump = 2.0, 25
        new = session.store_offset(4, {"method": "by hand"})
        assert new is session.navigator and new is not nav and heard == [4]
        assert (new.offset, new.frame, new.last, new.marks, new.rate, new.jump) == (4, 20, 35, {12}, 2.0, 25)
        assert project.video("v").offset_frames == 4 and session.source.video.offset_frames == 4
        assert session.source.pair(20)[2] == 24  # the source decodes at the new offset
        with pytest.raises(UsvipsError):
            session.store_offset(400, {"method": "by hand"})  # refused by the project: nothing changed
        assert session.navigator is new and project.video("v").offset_frames == 4 and heard == [4]
        # decisions in words
        sure = session.sync_outcome(SyncEstimate(-3.1, 25.0, "flash", 0.95, window=(-10, 10)))
        assert (sure.action, sure.level, sure.question) == ("store", "info", None) and "stored" in sure.text
        doubtful = session.sync_outcome(SyncEstimate(-3.1, 25.0, "flash", 0.2, window=(-10, 10)))
        assert doubtful.action == "ask" and "not stored" in doubtful.text and "Store -3 frames" in doubtful.question
        edge = session.sync_outcome(SyncEstimate(10.0, 25.0, "flash", 0.95, window=(-10, 10)))
        assert edge.action == "refuse" and edge.question is None and "window" in edge.text
        session.store_estimate(SyncEstimate(-3.1, 25.0, "flash", 0.95, window=(-10, 10)))
        assert project.video("v").offset_frames == -3 and project.video("v").offset_estimate["method"] == "flash"
        # periods
        assert session.mark_period("bait arrives 10 26") == ("bait arrives", 10, 26)
        with pytest.raises(UsvipsError, match=r"period '26': type a name, then the first and last frame"):
            session.mark_period("26")
        with pytest.raises(UsvipsError):
            session.mark_period("late 30 20")
        assert project.periods("v") == [("bait arrives", 10, 26)]
        # a taken pair: planned (label, frame, offset, folder); a refused one removes its files
        label, frame, offset, folder = session.plan_taken_pair("cube")
        assert (label, frame, offset) == ("cube", session.navigator.frame, -3)
        written = [tmp_path / "a.png", tmp_path / "b.png"]
        for path in written:
            path.write_bytes(b"not a picture")
        with pytest.raises(UsvipsError):
            session.add_taken_pair("cube", tuple(written), "water")
        assert not any(path.exists() for path in written)
        session.close()
