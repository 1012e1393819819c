"""Benchmarks of the video reader at 1920 × 1080 H.264 as cameras write it (one key frame a second, B-frame
pyramids, panning footage), per frame *pair* (both cameras), against a bare PyAV decode loop timed in the
same run; and the frame cache's memory at 1080p and 4K.

- step forward: the workstation shows a step from its prefetch cache (decoded ahead in a worker): what the
  user waits for is the cached pair's conversion to RGB (target 30 ms a pair), provided the decoder keeps
  ahead, which the sustained decode rate per pair shows;
- random seek: a decode from the preceding key frame, skipping the non-reference frames before the target
  (``target_s``: 80 ms a pair from the original on a quiet machine, issue 27 item 5; the ratio against the
  same seek decoding every frame is ``ratio_target``/``ratio_met``; ``load_1min`` is the load average,
  ``cpu_per_pair_s`` the CPU time of a pair's seek, both cameras, which load hardly changes).
  Its floor is the bare decoder's time per frame × the frames between the key frame and the target (half
  a GOP on average): the row reports both. A further row compares the decoder's
  set-up (slice threads, the file kept open) with the previous one (frame threads, reopened per seek);
- random seek through seek proxies (io/video_proxy: lossless all-intra Ut Video, one frame decoded).
"""

from __future__ import annotations

import os
import resource
import tempfile
from collections.abc import Iterator
from pathlib import Path

import av
import numpy as np

from usvips.bench import best_time, ratio_row
from usvips.core.synth.frame_numbers import frame_number, panning_numbered_frame
from usvips.io.video_proxy import attach_proxy, build_proxy, proxy_path
from usvips.io.video_stream import THREAD_TYPE, PairReader, VideoStream
from usvips.io.video_writer import encode_video

#: frame pairs the workstation's cache holds by default at 1080p (gui/video_model.CACHE_BYTES)
CACHE_PAIRS = 48
#: bytes a cached pixel takes: pictures are cached as decoded (YUV 4:2:0), converted to RGB when shown
CACHED_BYTES_PER_PIXEL = 1.5
GOP = 30
#: a random seek of the original 1080p H.264, per frame pair, on a quiet machine (s; issue 27, item 5)
SEEK_TARGET_PAIR_S = 0.080


def _cache_mib(width: int, height: int, pairs: int, bytes_per_pixel: float) -> float:
    return round(pairs * 2 * width * height * bytes_per_pixel / 2**20, 1)


def benchmarks(scale: float = 1.0) -> Iterator[dict]:
    frames = max(int(round(90 * scale)), 60)
    with tempfile.TemporaryDirectory(prefix="usvips-bench-video-") as folder:
        path = Path(folder) / "clip_1080p.mp4"
        encode_video(path, (panning_numbered_frame(i, 1920, 1080) for i in range(frames)), 30, "h264", gop=GOP,
                     bframes=3, quality=23)
        steps = min(20, frames - 1)

        with VideoStream(path) as left, VideoStream(path) as right:
            reader = PairReader(left, right)
            def ours_decode() -> None:
                for stream in (left, right):
                    stream.close()
                for i in range(steps + 1):
                    left.picture(i)
                    right.picture(i)

            def bare_decode() -> None:
                for _ in range(2):
                    with av.open(str(path)) as container:
                        container.streams.video[0].thread_type = "AUTO"
                        for k, _frame in enumerate(container.decode(video=0)):
                            if k == steps:
                                break

            row = ratio_row("video: decode ahead (prefetch), 1920x1080 H.264, per frame pair", steps + 1,
                            ours_decode, bare_decode, "bare PyAV decode loop, two streams", 1.3, repeats=2)
            per_pair = row["ours_s"] / (steps + 1)
            row.update(per_pair_s=round(per_pair, 5), note="sustained decode rate behind the prefetch")
            yield row

            pictures = [(left.picture(i), right.picture(i)) for i in range(4)]

            def ours_show() -> None:
                for a, b in pictures:
                    a.array()
                    b.array()

            row = ratio_row("video: step shown from the prefetch cache (YUV to RGB), per frame pair", len(pictures),
                            ours_show, bare_decode, "bare PyAV decode loop, two streams", None, repeats=3)
            per_pair = row["ours_s"] / len(pictures)
            row.update(per_pair_s=round(per_pair, 5), target_pair_s=0.030, met_absolute=bool(per_pair <= 0.030),
                       cache_pairs_1080p=CACHE_PAIRS,
                       cache_mib_1080p=_cache_mib(1920, 1080, CACHE_PAIRS, CACHED_BYTES_PER_PIXEL),
                       cache_pairs_4k=CACHE_PAIRS // 4,
                       cache_mib_4k=_cache_mib(3840, 2160, CACHE_PAIRS // 4, CACHED_BYTES_PER_PIXEL),
                       cache_mib_1080p_if_rgb=_cache_mib(1920, 1080, CACHE_PAIRS, 3))
            yield row

            load = round(os.getloadavg()[0], 2)
            rng = np.random.default_rng(0)
            targets = [int(t) for t in rng.integers(0, frames, 8)]
            keys = np.flatnonzero(left.chapters[0].keyframe)
            behind = [t - int(keys[keys <= t][-1]) + 1 for t in targets]

            def seek(skip: bool) -> None:
                for stream in (left, right):
                    stream.skip_unneeded = skip
                for t in targets:
                    for stream in (left, right):
                        stream.reset_decoder()  # no running decoder to continue from: a true seek every time
                    a, b = reader.pictures(t, t)  # both cameras at once, as the workstation decodes them
                    if frame_number(a.array()) != t or frame_number(b.array()) != t:
                        raise AssertionError(f"frame {t} not returned")

            row = ratio_row("video: random seek, 1920x1080 H.264 (GOP 30, B-pyramid), per frame pair", len(targets),
                            lambda: seek(True), lambda: seek(False),
                            "same seek decoding every frame from the key frame", 1.1, repeats=2)
            per_pair = row["ours_s"] / len(targets)
            # the floor: what the bare decoder needs for the frames between key frame and target
            per_frame = best_time(bare_decode, 2) / (2 * (steps + 1))
            # the seeks' CPU time (both cameras, this process): what load does not blur; on two free cores
            # the wall time of a pair is about half of it (the cameras decode side by side)
            cpu_before = resource.getrusage(resource.RUSAGE_SELF)
            seek(True)
            cpu_after = resource.getrusage(resource.RUSAGE_SELF)
            cpu_pair = (cpu_after.ru_utime - cpu_before.ru_utime + cpu_after.ru_stime - cpu_before.ru_stime
                        ) / len(targets)
            # the promise (27, item 5): a random seek from the original ≤ 80 ms a pair on a quiet
            # machine; the ratio (skipping against not skipping) stays as ``ratio_target``/``ratio_met``
            row.update(target=None, target_s=SEEK_TARGET_PAIR_S, met=bool(per_pair <= SEEK_TARGET_PAIR_S),
                       ratio_target=1.1, ratio_met=row["met"], load_1min=load,
                       per_pair_s=round(per_pair, 5), cpu_per_pair_s=round(cpu_pair, 5),
                       mean_frames_from_key_frame=round(float(np.mean(behind)), 1),
                       bare_decode_per_frame_s=round(per_frame, 5),
                       floor_pair_s_without_skipping=round(2 * per_frame * float(np.mean(behind)), 5))
            yield row
            for stream in (left, right):
                stream.skip_unneeded = True

            # what the decoder's set-up costs a seek: frame threads and a file reopened for every seek (as
            # before) against slice threads and the file kept open (now)
            def seek_as_before() -> None:
                for stream in (left, right):
                    stream.thread_type = "AUTO"
                try:
                    for t in targets:
                        for stream in (left, right):
                            stream._close_container()  # reopened by the seek
                        reader.pictures(t, t)
                finally:
                    for stream in (left, right):
                        stream.thread_type = THREAD_TYPE
                        stream._close_container()

            row = ratio_row("video: random seek, slice threads and the file kept open vs frame threads and a "
                            "reopened file, per frame pair", len(targets), lambda: seek(True), seek_as_before,
                            "frame-threaded decoder reopened for every seek (the previous way)", 1.0, repeats=2)
            row.update(per_pair_s=round(row["ours_s"] / len(targets), 5),
                       before_pair_s=round(row["baseline_s"] / len(targets), 5))
            yield row

            # the same seeks through lossless all-intra proxies (built here, not timed: a background job)
            folder = Path(folder) / "proxies"
            build_proxy(left, proxy_path(folder, left))  # left and right are the same file here
            for stream in (left, right):
                attach_proxy(stream, folder)
            for stream in (left, right):  # open the proxies' containers once, as a session does
                stream.frame(targets[0])
            plain_seek = row["ours_s"]
            row = ratio_row("video: random seek through seek proxies, 1920x1080, per frame pair", len(targets),
                            lambda: seek(True), bare_decode, "bare PyAV decode loop, two streams", None, repeats=2)
            row.update(ratio_to_seek_without_proxy=round(row["ours_s"] / plain_seek, 4))
            per_pair = row["ours_s"] / len(targets)
            row.update(per_pair_s=round(per_pair, 5), target_pair_s=0.150, met_absolute=bool(per_pair <= 0.150),
                       proxy_mb_per_frame=round(proxy_path(folder, left).stat().st_size / frames / 1e6, 2),
                       note="lossless all-intra copy (Ut Video): pixels identical, one frame decoded per seek")
            yield row
            reader.close()
