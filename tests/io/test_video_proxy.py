"""Seek proxies: lossless all-intra copies that a seek decodes one frame of. Frames read through a proxy
are the recording's frames pixel for pixel (H.264 with B-frames, Motion-JPEG's full range, a chaptered
recording), seeks far from a key frame go through it, a cancelled build leaves nothing, and a proxy
of other files is not used."""

import errno
import os

import numpy as np
import pytest

from usvips.app.video_project import add_video, build_proxies, open_streams, plan_proxies
from usvips.core.errors import InputFileError
from usvips.core.synth.frame_numbers import frame_number, numbered_frame, panning_numbered_frame
from usvips.io import video_proxy
from usvips.io.video_proxy import (
    ENCODINGS,
    PROXY_FORMAT,
    attach_proxy,
    build_proxy,
    delete_proxy,
    encoding_for,
    proxy_path,
    proxy_state,
    read_stamp,
    related_proxies,
    stamp_path,
    verify_proxy,
)
from usvips.io.video_stream import VideoStream
from usvips.io.video_writer import encode_video
from usvips.store import Project

W, H = 160, 120
#: every codec/container this FFmpeg writes here, as the reader's own frame-exactness test has them
CONTAINERS = {"h264": ".mp4", "mpeg4": ".avi", "mjpeg": ".avi", "ffv1": ".mkv"}


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
        umask = os.umask(0o022)
        os.umask(umask)
        for made in (tmp_path / "proxies").iterdir():  # the proxy and its stamp: readable as any new file
            assert made.stat().st_mode & 0o777 == 0o666 & ~umask, made.name
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


def _recording(path, frames=40, base=0, gop=40, codec="h264"):
    encode_video(path, (panning_numbered_frame(base + i, W, H) for i in range(frames)), 25, codec, gop=gop, bframes=3)
    return path


def test_a_proxy_of_a_changed_recording_or_an_older_format_is_stale_never_used_and_replaced(tmp_path):
    folder = tmp_path / "proxies"
    path = _recording(tmp_path / "a.mp4")
    with VideoStream(path) as stream:
        assert proxy_state(folder, stream).state == "missing"
        out = build_proxy(stream, proxy_path(folder, stream))
        state = proxy_state(folder, stream)
        assert state.state == "fresh" and state.bytes == out.stat().st_size + stamp_path(out).stat().st_size
        assert read_stamp(out)["format"] == PROXY_FORMAT
    # the same number of frames, other pictures (a re-encoded or swapped file): stale, whatever its size
    _recording(path, base=500)
    with VideoStream(path) as changed:
        state = proxy_state(folder, changed)
        assert state.state == "stale" and "changed" in state.reason
        assert not attach_proxy(changed, folder) and not changed.has_proxy
        build_proxy(changed, proxy_path(folder, changed))  # replaced in place
        assert proxy_state(folder, changed).state == "fresh" and attach_proxy(changed, folder)
        assert frame_number(changed.frame(33)) == 533
    # a proxy of the older format (H.264 lossless in Matroska, no stamp) beside it, and a stamp of format 1
    legacy = folder / "a.0123456789ab.proxy.mkv"
    legacy.write_bytes(b"not a proxy any more")
    with VideoStream(path) as stream:
        assert legacy in related_proxies(folder, stream)
        current = proxy_path(folder, stream)
        current.write_bytes(b"\x00" * 100)  # overwritten or truncated
        state = proxy_state(folder, stream)
        assert state.state == "stale" and "damaged" in state.reason and not attach_proxy(stream, folder)
        stamp_path(current).unlink()  # a build that never finished has no stamp
        state = proxy_state(folder, stream)
        assert state.state == "stale" and "stamp" in state.reason and not attach_proxy(stream, folder)
        build_proxy(stream, current)
        assert not legacy.exists() and proxy_state(folder, stream).state == "fresh"


def test_a_stamp_of_another_proxy_format_is_stale(tmp_path, monkeypatch):
    folder = tmp_path / "proxies"
    path = _recording(tmp_path / "a.mp4")
    with VideoStream(path) as stream:
        monkeypatch.setattr(video_proxy, "PROXY_FORMAT", PROXY_FORMAT - 1)
        build_proxy(stream, proxy_path(folder, stream))
        monkeypatch.undo()
        state = proxy_state(folder, stream)
        assert state.state == "stale" and f"proxy format {PROXY_FORMAT - 1}" in state.reason
        assert not attach_proxy(stream, folder)


@pytest.mark.parametrize("failure, words", [(errno.ENOSPC, "the disk is full"), (errno.EROFS, "read-only")])
def test_a_full_disk_or_read_only_folder_is_one_line_and_leaves_no_partial_proxy(tmp_path, monkeypatch, failure,
                                                                                    words):
    folder = tmp_path / "proxies"
    path = _recording(tmp_path / "a.mp4")
    with VideoStream(path) as stream:
        out = proxy_path(folder, stream)

        def encode_until_the_disk_fails(stream, temporary, progress, cancelled):
            with open(temporary, "wb") as handle:
                handle.write(b"\x00" * 4096)  # part of a proxy, then the device refuses more
            raise OSError(failure, os.strerror(failure))

        monkeypatch.setattr(video_proxy, "_encode", encode_until_the_disk_fails)
        with pytest.raises(InputFileError) as raised:
            build_proxy(stream, out)
        message = str(raised.value)
        assert words in message and "\n" not in message and str(out) in message
        assert not out.exists() and list(folder.iterdir()) == []  # the partial file is gone, no stamp written
        assert proxy_state(folder, stream).state == "missing" and not attach_proxy(stream, folder)


def test_a_folder_that_cannot_be_written_is_named(tmp_path):
    path = _recording(tmp_path / "a.mp4")
    blocker = tmp_path / "proxies"
    blocker.write_text("a file where the proxies' folder should be")
    with VideoStream(path) as stream, pytest.raises(InputFileError, match="cannot write a seek proxy here"):
        build_proxy(stream, proxy_path(blocker, stream))


def test_a_proxy_that_decodes_to_other_pixels_is_refused_before_it_is_used(tmp_path):
    a, b = _recording(tmp_path / "a.mp4"), _recording(tmp_path / "b.mp4", base=300)
    with VideoStream(a) as first, VideoStream(b) as second:
        out = build_proxy(second, tmp_path / "b.proxy.nut")
        with pytest.raises(InputFileError, match="differs from the recording"):
            verify_proxy(first, out)


def test_deleting_a_proxy_frees_its_bytes_and_seeks_decode_the_original(tmp_path):
    folder = tmp_path / "proxies"
    path = _recording(tmp_path / "a.mp4", frames=60, gop=60)
    with VideoStream(path) as stream:
        out = build_proxy(stream, proxy_path(folder, stream))
        size = out.stat().st_size + stamp_path(out).stat().st_size
        assert delete_proxy(folder, stream) == size and not out.exists() and not stamp_path(out).exists()
        assert not attach_proxy(stream, folder) and frame_number(stream.frame(47)) == 47
        assert delete_proxy(folder, stream) == 0


def test_full_range_pictures_go_to_h264_lossless_the_rest_to_ut_video():
    assert encoding_for("yuv420p", 1) == encoding_for("yuv444p", 0) == "utvideo"
    assert encoding_for("yuvj420p", 2) == encoding_for("yuv420p", 2) == "h264 lossless"
    assert set(ENCODINGS) == {"utvideo", "h264 lossless"}


@pytest.mark.parametrize("codec", sorted(CONTAINERS))
def test_random_seeks_through_a_proxy_return_the_frame_asked_for_in_every_codec(tmp_path, codec):
    """The frame-exactness test of the reader (tests/io/test_video_stream.py), through a proxy: random
    seeks forwards and backwards, runs forwards and backwards, the same numbers and the same pixels as the
    original decoded without a proxy."""
    path = tmp_path / f"numbered{CONTAINERS[codec]}"
    encode_video(path, (numbered_frame(i, W, H) for i in range(120)), 25, codec, gop=50)
    with VideoStream(path) as plain, VideoStream(path) as seeking:
        build_proxy(plain, proxy_path(tmp_path / "proxies", plain))
        assert attach_proxy(seeking, tmp_path / "proxies")
        served = []
        original = seeking._proxy.picture
        seeking._proxy.picture = lambda index: served.append(index) or original(index)
        rng = np.random.default_rng(len(codec))
        order = [int(i) for i in rng.integers(0, 120, 60)] + list(range(119, 90, -1)) + list(range(10, 40))
        for n, index in enumerate(order):
            picture = seeking.frame(index)
            assert frame_number(picture) == index
            if n % 4 == 0:
                assert np.array_equal(picture, plain.frame(index))
        keys = plain.chapters[0].keyframe
        assert bool(served) == (not keys.all())  # inter codecs seek through the proxy; intra ones need not
