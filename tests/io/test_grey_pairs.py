"""The tracker's frame source: grey frame pairs decoded in two threads and ahead of the caller give the
same pixels as the plain path (``VideoStream.frame(i, grey=True)``, which is FFmpeg's grey conversion), in
any order — forward, backward across key frames, random — and stepping backward decodes each frame about
once instead of seeking from its key frame every step."""

import numpy as np
import pytest

from usvips.core.errors import UsvipsError
from usvips.core.synth.frame_numbers import panning_numbered_frame
from usvips.io.grey_pairs import GreyPairSource
from usvips.io.video_stream import VideoStream
from usvips.io.video_writer import encode_video

WIDTH, HEIGHT, FRAMES, GOP, OFFSET = 160, 96, 75, 12, 3


@pytest.fixture(scope="module")
def videos(tmp_path_factory):
    folder = tmp_path_factory.mktemp("grey-pairs")
    left, right = folder / "left.mp4", folder / "right.mp4"
    encode_video(left, (panning_numbered_frame(i, WIDTH, HEIGHT) for i in range(FRAMES)), 30, "h264", gop=GOP,
                 bframes=2)
    # the right camera: other pictures (its frames shifted by OFFSET), another GOP phase
    encode_video(right, (panning_numbered_frame(i + 7, WIDTH, HEIGHT)[::-1] for i in range(FRAMES)), 30, "h264",
                 gop=GOP + 5, bframes=3)
    with VideoStream(left) as a, VideoStream(right) as b:
        truth = ([a.frame(i, grey=True) for i in range(FRAMES)], [b.frame(i, grey=True) for i in range(FRAMES)])
    return left, right, truth


def partner(index: int) -> int:
    if not 0 <= index + OFFSET < FRAMES:
        raise UsvipsError(f"left frame {index} has no right partner")
    return index + OFFSET


def orders(rng) -> dict[str, list[int]]:
    last = FRAMES - 1 - OFFSET
    return {"forward": list(range(0, last + 1)), "backward": list(range(last, -1, -1)),
            "tracker": list(range(40, 9, -1)) + list(range(41, last + 1)),  # back from a start, then on
            "random": [int(i) for i in rng.integers(0, last + 1, 40)],
            "to and fro": [30, 29, 28, 29, 30, 31, 5, 4, 3, 2, 1, 0, 1, 2, 60, 59]}


@pytest.mark.parametrize("cache_bytes", [10**9, 4 * WIDTH * HEIGHT])  # whole GOPs kept, or 4 frames only
def test_the_same_pixels_as_the_plain_path_in_any_order(videos, cache_bytes):
    left_path, right_path, (left_truth, right_truth) = videos
    for name, order in orders(np.random.default_rng(cache_bytes % 1000)).items():
        with VideoStream(left_path) as left, VideoStream(right_path) as right, \
                GreyPairSource(left, right, partner, cache_bytes=cache_bytes) as frames:
            for index in order:
                one, other = frames(index)
                assert one.dtype == np.uint8 and one.shape == (HEIGHT, WIDTH), name
                assert np.array_equal(one, left_truth[index]), (name, index)
                assert np.array_equal(other, right_truth[index + OFFSET]), (name, index)


def test_a_missing_partner_reaches_the_caller_and_the_source_goes_on(videos):
    left_path, right_path, (left_truth, _) = videos
    last = FRAMES - 1 - OFFSET
    with VideoStream(left_path) as left, VideoStream(right_path) as right, \
            GreyPairSource(left, right, partner) as frames:
        for index in range(last - 3, last + 1):  # the prefetch of frame last + 1 finds no partner: silent
            frames(index)
        with pytest.raises(UsvipsError, match=f"left frame {last + 1} has no right partner"):
            frames(last + 1)
        assert np.array_equal(frames(12)[0], left_truth[12])


def test_stepping_backward_decodes_each_frame_about_once(videos):
    """Frame by frame backward through the whole video: without the kept blocks every step is a seek
    decoding from its key frame (about half a GOP); with them, each frame is decoded about once."""
    left_path, right_path, _ = videos
    with VideoStream(left_path) as left, VideoStream(right_path) as right:
        decoded = {id(left): 0, id(right): 0}
        for stream in (left, right):
            def counting(index, stream=stream, picture=stream.picture):
                decoded[id(stream)] += 1
                return picture(index)

            stream.picture = counting
        with GreyPairSource(left, right, partner) as frames:
            for index in range(FRAMES - 1 - OFFSET, -1, -1):
                frames(index)
    steps = FRAMES - OFFSET
    plain = sum(index - left.key_frame_before(index) + 1 for index in range(steps))  # a seek every step
    assert decoded[id(left)] <= steps + GOP + 2 < plain
    assert decoded[id(right)] <= steps + GOP + 5 + 2


def test_key_frame_before(videos):
    left_path, _, _ = videos
    with VideoStream(left_path) as video:
        keys = [video.key_frame_before(i) for i in range(FRAMES)]
        assert keys == [GOP * (i // GOP) for i in range(FRAMES)]


def test_one_stream_as_both_cameras_is_refused(videos):
    """A stream is decoded on one thread only: the same object for both cameras would be decoded on two."""
    with VideoStream(videos[0]) as stream, pytest.raises(UsvipsError, match="another VideoStream"):
        GreyPairSource(stream, stream)


def test_remembered_pairs_serve_a_second_pass_undecoded_within_the_budget(videos):
    left_path, right_path, (left_truth, right_truth) = videos
    pair_bytes = 2 * WIDTH * HEIGHT
    with VideoStream(left_path) as left, VideoStream(right_path) as right:
        decoded = []  # the left frames decoded
        def counting(index, picture=left.picture):
            decoded.append(index)
            return picture(index)

        left.picture = counting
        with GreyPairSource(left, right, partner, remember_bytes=30 * pair_bytes) as frames:
            passes = [list(range(40, 9, -1)), list(range(40, 60))]  # a first vertex's track; a second's
            for index in passes[0] + passes[1]:
                frames(index)
            assert set(range(10, 60)) <= set(decoded)
            decoded.clear()
            for order in passes:  # the next vertex
                for index in order:
                    one, other = frames(index)
                    assert np.array_equal(one, left_truth[index]) and np.array_equal(other, right_truth[index + OFFSET])
                    # the first 30 pairs returned (frames 40 down to 11) are kept, shared between calls: read-only
                    assert not (11 <= index <= 40 and (one.flags.writeable or other.flags.writeable))
    assert not set(decoded) & set(range(11, 41))  # the kept pairs were not decoded again …
    assert set(range(41, 60)) <= set(decoded)  # … the others were (beyond the budget)
