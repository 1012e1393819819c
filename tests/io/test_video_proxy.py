"""Seek proxies: lossless all-intra copies that a seek decodes one frame of. Frames read through a proxy
are the recording's frames pixel for pixel (H.264 with B-frames, Motion-JPEG's full range, a chaptered
recording), seeks far from a key frame go through it, a cancelled build leaves nothing, and a proxy
of other files is not used."""

import numpy as np
import pytest

from usvips.app.video_project import add_video, build_proxies, open_streams, plan_proxies
from usvips.core.synth.frame_numbers import frame_number, panning_numbered_frame
from usvips.io.video_proxy import attach_proxy, build_proxy, proxy_path
from usvips.io.video_stream import VideoStream
from usvips.io.video_writer import encode_video
from usvips.store import Project

W, H = 160, 120


@pytest.mark.parametrize("codec, suffixes", [("h264", [".mp4"]), ("mjpeg", [".avi"]), ("h264", [".mp4", ".mp4"])])
def test_frames_through_the_proxy_are_the_recordings_pixel_for_pixel(tmp_path, codec, suffixes):
    files, first = [], 0
    for k, suffix in enumerate(suffixes):
        files.append(tmp_path / f"GX0{k + 1}0042{suffix}")
        encode_video(files[-1], (panning_numbered_frame(first + i, W, H) for i in range(60)), 30, codec, gop=40,
                     bframes=3)
        first += 60
    with VideoStream(files) as plain, VideoStream(files) as seeking:
        progress = []
        out = build_proxy(plain, proxy_path(tmp_path / "proxies", plain), lambda d, t: progress.append((d, t)))
        assert progress and progress[-1][1] == plain.frame_count
        assert attach_proxy(seeking, tmp_path / "proxies") and seeking.has_proxy
        served = []
        original = seeking._proxy.picture
        seeking._proxy.picture = lambda index: served.append(index) or original(index)
        rng = np.random.default_rng(len(suffixes))
        order = [int(i) for i in rng.integers(0, plain.frame_count, 30)] + list(range(20, 45)) + [119, 0, 61]
        order = [i for i in order if i < plain.frame_count]
        for index in order:
            picture = seeking.frame(index)
            assert frame_number(picture) == index
            assert np.array_equal(picture, plain.frame(index))
        keys = np.concatenate([c.keyframe for c in plain.chapters])
        # seeks far from a key frame went through the proxy; an all-intra source (Motion-JPEG) never needs it
        assert not keys[served].any() and bool(served) == (not keys.all())
        with VideoStream(out) as proxy:  # the proxy itself: every frame a key frame, the same pixels
            assert proxy.frame_count == plain.frame_count and all(c.keyframe.all() for c in proxy.chapters)
            for index in (0, 17, plain.frame_count - 1, 33):
                assert np.array_equal(proxy.frame(index), plain.frame(index))


def test_a_cancelled_build_leaves_nothing_and_a_proxy_of_other_files_is_not_used(tmp_path):
    path = tmp_path / "a.mp4"
    encode_video(path, (panning_numbered_frame(i, W, H) for i in range(60)), 30, "h264", gop=30)
    with VideoStream(path) as stream:
        out = proxy_path(tmp_path / "proxies", stream)
        with pytest.raises(InterruptedError):
            build_proxy(stream, out, cancelled=lambda: True)
        assert not out.exists() and not any((tmp_path / "proxies").iterdir())
        build_proxy(stream, out)
    encode_video(path, (panning_numbered_frame(i, W, H) for i in range(61)), 30, "h264", gop=30)  # re-recorded
    with VideoStream(path) as changed:
        assert not attach_proxy(changed, tmp_path / "proxies") and not changed.has_proxy


def test_a_projects_video_seeks_through_its_proxies_once_built(tmp_path):
    for side, base in (("left", 0), ("right", 1000)):
        encode_video(tmp_path / f"{side}.mp4", (panning_numbered_frame(base + i, W, H) for i in range(50)), 25,
                     "h264", gop=50)
    with Project.create(tmp_path / "p.usvips") as project:
        add_video(project, [tmp_path / "left.mp4"], [tmp_path / "right.mp4"], "dive")
        plan = plan_proxies(project, "dive")
        assert len(plan) == 2
        written = build_proxies(plan)
        assert all(p.parent == tmp_path / "proxies" for p in written) and plan_proxies(project, "dive") == []
        _, left, right = open_streams(project, "dive")
        with left, right:
            assert left.has_proxy and right.has_proxy
            assert frame_number(left.frame(37)) == 37 and frame_number(right.frame(12)) == 1012
