"""Frame-exact reading (PyAV): videos whose frames carry their own number, read back after random seeks
forwards and backwards, for every codec/container this FFmpeg writes; chapters as one stream; variable
frame rate, duplicated and dropped frames reported; bad input named in one line."""

import av
import numpy as np
import pytest

from usvips.core.errors import InputFileError
from usvips.core.synth.frame_numbers import frame_number, numbered_frame, panning_numbered_frame
from usvips.io import video_stream
from usvips.io.video import write_video
from usvips.io.video_stream import Picture, VideoStream, grey_table
from usvips.io.video_writer import CODECS, encode_video, encoders_available

WIDTH, HEIGHT = 160, 120


def numbered(i: int) -> np.ndarray:
    return numbered_frame(i, WIDTH, HEIGHT)


def number_of(frame: np.ndarray) -> int:
    return frame_number(frame)


CONTAINERS = {"h264": ".mp4", "mpeg4": ".avi", "mjpeg": ".avi", "ffv1": ".mkv"}


def test_every_codec_this_ffmpeg_writes_is_tested():
    assert set(encoders_available()) <= set(CONTAINERS)
    assert "h264" in encoders_available()  # PyAV's wheels carry libx264; the H.264 tests below need it
    assert set(CONTAINERS) == set(CODECS)


@pytest.mark.parametrize("codec", sorted(CONTAINERS))
def test_random_seeks_return_the_frame_asked_for(tmp_path, codec):
    path = tmp_path / f"numbered{CONTAINERS[codec]}"
    # long GOP for inter codecs: one key frame every 50 frames, B-frames in between
    encode_video(path, (numbered(i) for i in range(120)), 25, codec, gop=50)
    rng = np.random.default_rng(hash(codec) % 2**32)
    with VideoStream(path) as video:
        assert video.frame_count == 120 and (video.width, video.height) == (WIDTH, HEIGHT)
        assert video.fps == pytest.approx(25)
        assert video.report.clean, video.report.summary()
        order = list(rng.integers(0, 120, 60)) + list(range(119, 90, -1)) + list(range(10, 40))
        for index in order:
            assert number_of(video.frame(int(index))) == index
        assert video.frame_at(video.time_of(77)) == 77
        assert video.time_of(50) == pytest.approx(2.0)


@pytest.mark.parametrize("codec, suffix", [("h264", ".mp4"), ("h264", ".mkv"), ("mpeg4", ".avi")])
def test_seeks_that_skip_unneeded_b_frames_stay_frame_exact(tmp_path, codec, suffix):
    """Panning footage gets B-frames (pyramids of them in H.264); a seek skips the non-reference ones
    before its target undecoded. Frames and pixels are those of a decode that skips nothing."""
    path = tmp_path / f"panning{suffix}"
    encode_video(path, (panning_numbered_frame(i, WIDTH, HEIGHT) for i in range(150)), 30, codec, gop=40,
                 bframes=3)
    rng = np.random.default_rng(len(suffix) + len(codec))
    with VideoStream(path) as skipping, VideoStream(path) as plain:
        plain.skip_unneeded = False
        order = [int(i) for i in rng.integers(0, 150, 40)] + list(range(60, 90)) + list(range(149, 120, -3))
        for index in order:
            picture = skipping.frame(index)
            assert number_of(picture) == index
            if index % 5 == 0:
                assert np.array_equal(picture, plain.frame(index))
    with av.open(str(path)) as container:  # the file really has frames shown out of order
        pts = [p.pts for p in container.demux(video=0) if p.pts is not None]
    assert pts != sorted(pts)


def _encode_plainly(path, encoder: str, count: int, gop: int, bframes: int) -> None:
    """Numbered frames straight through PyAV, into containers our writer does not offer (MPEG-TS/PS)."""
    with av.open(str(path), "w") as container:
        stream = container.add_stream(encoder, rate=25)
        stream.width, stream.height, stream.pix_fmt = WIDTH, HEIGHT, "yuv420p"
        stream.options = {"g": str(gop), "bf": str(bframes)}
        for i in range(count):
            for packet in stream.encode(av.VideoFrame.from_ndarray(numbered(i), format="rgb24")):
                container.mux(packet)
        for packet in stream.encode():
            container.mux(packet)


@pytest.mark.parametrize("encoder, suffix", [("libx264", ".ts"), ("mpeg2video", ".ts"), ("mpeg2video", ".mpg"),
                                             ("libx264", ".mkv")])
def test_seeks_in_byte_seeked_containers_stay_frame_exact(tmp_path, encoder, suffix):
    """MPEG transport and program streams have no index: FFmpeg seeks them by byte position and lands just
    after the key frame asked for, where the decoder cannot make the target (and AV1's decoders mark
    frames a skipping seek loses). The stream notices that the key frame never came, seeks one key frame
    earlier from then on, and still returns every frame asked for; an indexed file keeps its fast seeks."""
    path = tmp_path / f"numbered{suffix}"
    _encode_plainly(path, encoder, 90, gop=15, bframes=2)
    rng = np.random.default_rng(len(encoder) + len(suffix))
    with VideoStream(path) as video:
        assert video.frame_count == 90
        order = [int(i) for i in rng.integers(0, 90, 40)] + [0, 1, 2, 89, 88, 15, 14, 16, 30, 3]
        for index in order:
            assert number_of(video.frame(index)) == index
        assert (video._keys_back > 0) == (suffix != ".mkv")


def test_opencv_written_motion_jpeg_is_read_exactly(tmp_path):
    path = tmp_path / "opencv.avi"
    write_video(path, (numbered(i) for i in range(40)), 10)
    with VideoStream(path) as video:
        assert video.frame_count == 40
        for index in (39, 0, 17, 16, 18, 5):
            assert number_of(video.frame(index)) == index
        grey = video.frame(3, grey=True)
        assert grey.shape == (HEIGHT, WIDTH)


def test_a_chaptered_recording_reads_as_one_stream(tmp_path):
    paths = [tmp_path / "GX010042.MP4", tmp_path / "GX020042.MP4", tmp_path / "GX030042.MP4"]
    bounds = [(0, 45), (45, 90), (90, 110)]
    for path, (a, b) in zip(paths, bounds, strict=True):
        encode_video(path, (numbered(i) for i in range(a, b)), 30, "h264", gop=30)
    with VideoStream(paths) as video:
        assert video.frame_count == 110
        assert [c.first for c in video.chapters] == [0, 45, 90]
        np.testing.assert_allclose(np.diff(video.times_s), 1 / 30, atol=1e-4)  # time continues across files
        for index in (44, 45, 46, 89, 90, 3, 109, 60, 44):
            assert number_of(video.frame(index)) == index
        # stepping forward across the file boundary
        assert [number_of(video.frame(i)) for i in range(40, 50)] == list(range(40, 50))
    with pytest.raises(InputFileError, match=r"GX020042.MP4x: no such video file \(a missing chapter"):
        VideoStream([paths[0], tmp_path / "GX020042.MP4x"])


def test_variable_frame_rate_is_detected_and_frames_are_numbered_by_timestamp(tmp_path):
    rng = np.random.default_rng(3)
    times = np.cumsum(rng.uniform(0.025, 0.06, 80))
    path = tmp_path / "vfr.mkv"
    encode_video(path, (numbered(i) for i in range(80)), 25, "ffv1", times_s=times)
    with VideoStream(path) as video:
        assert video.report.variable_frame_rate
        assert "variable frame rate" in video.report.summary()
        np.testing.assert_allclose(video.times_s, times - times[0], atol=1.5e-3)
        for index in rng.permutation(80)[:30]:
            assert number_of(video.frame(int(index))) == index
            # the frame shown at a time between two frames is the earlier one
            t = video.time_of(int(index)) + 0.4 * (times[min(index + 1, 79)] - times[index])
            assert video.frame_at(t) == index


@pytest.mark.parametrize(("codec", "bframes"), [("h264", 0), ("h264", 2), ("ffv1", 0)])
def test_a_frame_whose_timestamp_repeats_the_one_before_is_still_its_own_picture(tmp_path, codec, bframes):
    """Two or three frames with one timestamp (a capture that stamped a frame twice), key frames among them
    or not: each frame number gives its own picture whether it is reached by a seek, by stepping on, or
    after going past and back."""
    rng = np.random.default_rng(7)
    for case in range(4):
        times = np.arange(40) / 25.0
        repeated = sorted(rng.choice(np.arange(1, 40), size=case + 1, replace=False))
        if case == 3:  # three frames with one timestamp
            repeated = [*repeated[:-1], int(repeated[0]) + 1] if repeated[0] < 38 else repeated
        for k in repeated:
            times[k] = times[k - 1]
        path = tmp_path / f"stamped_twice_{case}.mkv"
        encode_video(path, (numbered(i) for i in range(40)), 25, codec, times_s=times, gop=10, bframes=bframes)
        order = [int(i) for i in rng.permutation(40)]
        with VideoStream(path) as video:
            assert set(video.report.duplicated) >= set(repeated)
            assert [number_of(video.frame(i)) for i in order] == order
            assert [number_of(video.frame(i)) for i in range(40)] == list(range(40))
        for k in repeated:
            with VideoStream(path) as video:  # a fresh decoder's first seek
                assert number_of(video.frame(k)) == k
                assert number_of(video.frame(k - 1)) == k - 1 and number_of(video.frame(k)) == k


def test_duplicated_and_dropped_frames_are_reported(tmp_path):
    content = [0, 1, 2, 3, 3, 4, 5, 6, 7, 8]  # frame 4 repeats frame 3
    intra = tmp_path / "duplicated.avi"  # Motion-JPEG at constant quality: the same bytes, found at opening
    encode_video(intra, (numbered(i) for i in content), 10, "mjpeg")
    with VideoStream(intra) as video:
        assert video.report.duplicated == (4,) and not video.report.dropped
        assert "1 duplicated frame(s), first at frame 4" in video.report.summary()
    inter = tmp_path / "duplicated.mp4"  # H.264 codes the repeat as a predicted frame: only decoding finds it
    encode_video(inter, (numbered(i) for i in [*content, *range(9, 119)]), 10, "h264", gop=50)
    with VideoStream(inter) as video:
        assert video.report.clean
        calls = []
        video.scan_pictures(lambda done, total: calls.append((done, total)))
        assert video.report.duplicated == (4,) and calls == [(100, 120)]
    times = np.array([0, 1, 2, 3, 6, 7, 8, 9, 10, 12]) / 25  # 2 missing before frame 4, 1 before frame 9
    dropped = tmp_path / "dropped.mkv"
    encode_video(dropped, (numbered(i) for i in range(10)), 25, "ffv1", times_s=times)
    with VideoStream(dropped) as video:
        assert video.report.dropped == ((4, 2), (9, 1))
        assert not video.report.variable_frame_rate and not video.report.duplicated
        assert "3 dropped frame(s)" in video.report.summary()


def test_soundtrack_is_read_as_one_mono_signal(tmp_path):
    rate = 16000
    signal = np.sin(2 * np.pi * 440 * np.arange(rate) / rate) * 0.5
    path = tmp_path / "sound.mkv"
    encode_video(path, (numbered(i) for i in range(25)), 25, "ffv1", audio=(signal, rate))
    with VideoStream(path) as video:
        samples, got_rate = video.audio()
    assert got_rate == rate and abs(len(samples) - rate) < 64
    assert np.abs(samples[: rate // 2] - signal[: rate // 2]).max() < 1e-3
    silent = tmp_path / "silent.mkv"
    encode_video(silent, (numbered(i) for i in range(5)), 25, "ffv1")
    with VideoStream(silent) as video:
        assert video.audio() is None


def test_bad_input_is_named_in_one_line(tmp_path):
    junk = tmp_path / "junk.mp4"
    junk.write_bytes(b"this is not a video at all" * 10)
    with pytest.raises(InputFileError, match="junk.mp4: not a video"):
        VideoStream(junk)
    with pytest.raises(InputFileError, match="missing.mp4: no such video file"):
        VideoStream(tmp_path / "missing.mp4")
    path = tmp_path / "short.mkv"
    encode_video(path, (numbered(i) for i in range(5)), 25, "ffv1")
    small = tmp_path / "small.mkv"
    encode_video(small, (numbered(i)[:60, :80] for i in range(5)), 25, "ffv1")
    with VideoStream(path) as video:
        for bad in (5, -1, 100):
            with pytest.raises(InputFileError, match=rf"frame {bad} is out of range: the video has frames 0 to 4"):
                video.frame(bad)
        with pytest.raises(InputFileError, match="outside the video"):
            video.frame_at(3.0)
    with pytest.raises(InputFileError, match=r"small.mkv: chapter is 80 × 60 px"):
        VideoStream([path, small])
    for message in ("codec 'xvid'", "go in"):
        with pytest.raises(InputFileError, match=message):
            encode_video(tmp_path / "x.mov", [numbered(0)], 25, "xvid" if "codec" in message else "mjpeg")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["junk.mp4", "short.mkv", "small.mkv"]


def test_gopro_chapters_must_be_one_recording_in_order_with_none_missing():
    from pathlib import Path

    from usvips.io.pairing import check_chapters

    check_chapters([Path("GX010042.MP4"), Path("GX020042.MP4"), Path("GX030042.MP4")], "--left")
    check_chapters([Path("dive_b.mp4"), Path("dive_a.mp4")], "--left")  # other names: the order given
    for files, message in [(("GX010042.MP4", "GX030042.MP4"), "chapter GX020042.MP4 is missing before it"),
                           (("GH020042.MP4", "GH010042.MP4"), "chapters out of order"),
                           (("GX010042.MP4", "GX020043.MP4"), "chapters of different recordings")]:
        with pytest.raises(InputFileError, match=message):
            check_chapters([Path(f) for f in files], "--left")


@pytest.mark.parametrize("pixel_format", ["yuv420p", "yuvj420p", "yuv422p", "yuvj422p", "yuv444p", "yuvj444p",
                                          "nv12", "nv21", "gray"])
def test_grey_from_the_luma_plane_equals_ffmpegs_grey_conversion(pixel_format):
    """The fast grey (a table look-up of the luma plane) gives exactly the pixels of the old path
    (FFmpeg's scaler to ``gray``), for random pictures of many sizes and every colour range."""
    rng = np.random.default_rng(sum(map(ord, pixel_format)))
    for width, height in [(1920, 1080), (642, 362), (98, 34), (33, 17), *map(tuple, rng.integers(8, 400, (6, 2)))]:
        for color_range in (0, 1, 2):
            frame = av.VideoFrame(int(width), int(height), pixel_format)
            for plane in frame.planes:
                values = np.frombuffer(plane, np.uint8)
                values[:] = rng.integers(0, 256, values.size)
            frame.color_range = color_range
            fast, old = Picture(frame).grey(), frame.to_ndarray(format="gray")
            assert fast.dtype == np.uint8 and fast.shape == old.shape == (height, width)
            assert np.array_equal(fast, old), (pixel_format, width, height, color_range)


@pytest.mark.parametrize("codec", ["h264", "mjpeg", "ffv1"])
def test_decoded_frames_in_grey_are_the_pixels_of_the_scaler(tmp_path, codec):
    """Frames as decoders return them (limited-range H.264, full-range Motion JPEG, FFV1) read in grey by
    the fast path and by FFmpeg's scaler are identical, and the stream's grey frames are the fast ones."""
    path = tmp_path / f"panning{CONTAINERS[codec]}"
    encode_video(path, (panning_numbered_frame(i, WIDTH, HEIGHT) for i in range(40)), 30, codec, gop=10, bframes=2)
    with VideoStream(path) as video:
        for index in (0, 7, 23, 39, 12):
            picture = video.picture(index)
            old = picture._frame.to_ndarray(format="gray")
            assert np.array_equal(picture.array(grey=True), old)
            assert np.array_equal(video.frame(index, grey=True), old)


def test_formats_without_an_8_bit_luma_plane_keep_the_scaler():
    assert grey_table("rgb24", 0) is None and grey_table("yuv420p10le", 1) is None
    frame = av.VideoFrame.from_ndarray(np.random.default_rng(5).integers(0, 256, (30, 40, 3), dtype=np.uint8),
                                       format="rgb24")
    assert np.array_equal(Picture(frame).grey(), frame.to_ndarray(format="gray"))


@pytest.mark.parametrize("rate", [30.0, 30000 / 1001, 24.0, 60000 / 1001, 25.0])
def test_a_constant_rate_in_whole_milliseconds_is_not_called_variable(tmp_path, rate):
    """Matroska and WebM time frames in whole milliseconds: 30 fps becomes intervals of 33, 34, 33 ms. That
    one-tick spread is rounding: the stream is constant, at its own rate (to the container's precision),
    with no frame called dropped or duplicated; a spread of two ticks and more still is a variable rate."""
    count = 75
    path = tmp_path / "constant.mkv"
    encode_video(path, (numbered(i) for i in range(count)), rate, "ffv1", times_s=np.arange(count) / rate)
    with VideoStream(path) as video:
        assert video.report.clean, video.report.summary()
        assert video.fps == pytest.approx(rate, rel=1e-3)
    jitter = np.arange(count) / rate + np.tile([0.0, 0.004], (count + 1) // 2)[:count]
    path = tmp_path / "jitter.mkv"
    encode_video(path, (numbered(i) for i in range(count)), rate, "ffv1", times_s=jitter)
    with VideoStream(path) as video:
        assert video.report.variable_frame_rate


def test_grey_is_looked_up_in_blocks_that_opencv_keeps_on_the_calling_thread(monkeypatch):
    """Each table look-up of a frame's luma covers fewer than SERIAL_LUT_PIXELS pixels (OpenCV shares a larger
    one over its thread pool) and the blocks cover the frame once: the pixels of the scaler, also for a frame
    narrower or wider than a block's rows divide evenly."""
    blocks = []
    look_up = video_stream.cv2.LUT

    def recorded(src, table, dst=None):
        blocks.append(src.shape)
        return look_up(src, table, dst=dst)

    monkeypatch.setattr(video_stream.cv2, "LUT", recorded)
    rng = np.random.default_rng(9)
    for width, height in [(1920, 1080), (3840, 2160), (1000, 263), (40, 30)]:
        blocks.clear()
        frame = av.VideoFrame(width, height, "yuv420p")
        for plane in frame.planes:
            values = np.frombuffer(plane, np.uint8)
            values[:] = rng.integers(0, 256, values.size)
        assert np.array_equal(Picture(frame).grey(), frame.to_ndarray(format="gray"))
        assert all(rows * columns < video_stream.SERIAL_LUT_PIXELS for rows, columns in blocks)
        assert sum(rows for rows, _ in blocks) == height and {columns for _, columns in blocks} == {width}
