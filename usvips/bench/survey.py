"""Benchmarks of measuring a survey: tracking a pick through a stereo video, combining an object's
instants, the QA of a survey's objects.

The tracking row tracks one vertex pair through 100 frame pairs of 1920 × 1080 H.264 (a textured plane
drifting across the view of an in-air rig, so the right image is the left one shifted by the disparity),
decoding included, against the bare decode of the same frame pairs (the floor, ``decoding_s``) through the
same frame source (:class:`usvips.io.grey_pairs.GreyPairSource`: both cameras decoded at once and ahead of
the tracker, grey read from the luma plane); ``tracking_s`` is tracking's own share (ours − the floor; with
the prefetch, tracking overlaps decoding, so it is what tracking adds to the wall time). ``before_s`` times
the frame source of the previous session (the tracker waiting for each pair, grey by FFmpeg's scaler) in the
same run. Tracking and the bare decode run alternately :data:`TRACK_REPEATS` times each (``repeats``),
every run timed in wall and CPU seconds; ``ours_s`` and ``decoding_s`` are the best wall times. ``backward_s``
tracks the same frames from the last to the first (each step back would be a seek from its key frame; the
source decodes each block from its key frame once and keeps it), beside ``backward_before_s``, the previous
source going backward. ``cpu_s`` is the process's CPU time (user + system, every thread) of a forward
tracking run and ``decoding_cpu_s`` that of a bare decode, the best of the runs; ``cpu_ratio`` their ratio,
which a loaded machine blurs less than the wall times'.
``ratio_target``/``ratio_met``: issue 37's promise, tracking within 1.1 × the bare decode, judged on the
CPU times (``ratio_judged_on``: the wall times of a shared machine swing by more than the 10 % at stake);
``wall_ratio_met`` says the same of the best wall times. The wall ratio reads a few hundredths above the CPU
ratio even on a quiet machine: the two decoders keep both cores nearly busy, so the tracker's work adds to
the wall time more than its share of the CPU (docs/benchmarks.md).
The cameras of those runs are in air; ``flat_port_cpu_s``/``flat_port_cpu_ratio``/``flat_port_ratio_met``
give the same forward track with the cameras behind flat ports (:data:`FLAT_PORT`), as an underwater rig
has them: the frames are the same, but the hold to the epipolar curve traces it through the port (a batch of
frames' stretches of curve at a time; ``flat_port_frames_tracked`` says the track went as far).
``load_1min`` is the machine's load average when the row started (the machine is shared).

The QA row times :func:`usvips.app.quality.check` over objects whose figures are already computed (the
window's figure cache holds them; computing figures is timed by the figure rows of other areas)."""

from __future__ import annotations

import os
import resource
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

import cv2
import numpy as np

from usvips.app.quality import Checked, Place, check, species_maxima
from usvips.bench import best_time
from usvips.core.camera import Camera, Exterior
from usvips.core.housing import AirHousing, FlatPortHousing
from usvips.core.interior import Interior
from usvips.core.measurements import measure
from usvips.core.measurements.instants import combine_figure
from usvips.core.observation_record import ObservationRecord, Species
from usvips.core.rig import RelativeOrientation, StereoRig
from usvips.core.tracking import track_vertex
from usvips.io.grey_pairs import GreyPairSource
from usvips.io.video_stream import PairReader, VideoStream
from usvips.io.video_writer import encode_video

#: absolute targets (s) of the issue: 20 instants combined, per object
COMBINE_TARGET_S = 0.020
#: the QA of a survey of 10,000 objects (s)
QA_TARGET_S = 0.5
QA_OBJECTS = 10_000
#: tracking one vertex pair through 100 frames of 1080p H.264, decoding included (s)
TRACK_TARGET_S = 1.5
#: ... and against decoding those frames alone (issue 37: tracking at the decoder's speed)
TRACK_TARGET_RATIO = 1.1
#: runs of tracking and of the bare decode, alternately, whose best times the row gives
TRACK_REPEATS = 4
#: the tracking row's flat port: inner face 16 mm in front of the camera centre, 12 mm of glass (n 1.5), water
FLAT_PORT = FlatPortHousing(0.0, 0.0, 0.016, 0.012, 1.5, 1.34)


def _wall_and_cpu(work) -> tuple[float, float]:
    """The wall time (s) and the CPU time (user + system, s, every thread of this process) that ``work()``
    takes."""
    start, wall = resource.getrusage(resource.RUSAGE_SELF), time.perf_counter()
    work()
    wall = time.perf_counter() - wall
    end = resource.getrusage(resource.RUSAGE_SELF)
    return wall, end.ru_utime - start.ru_utime + end.ru_stime - start.ru_stime


def _absolute(name: str, n: int, ours: float, baseline: float, baseline_name: str, target_s: float) -> dict:
    return {"name": name, "n": n, "ours_s": round(ours, 6), "baseline": baseline_name,
            "baseline_s": round(baseline, 6), "ratio": round(ours / baseline, 2) if baseline > 0 else None,
            "target": None, "target_s": target_s, "met": bool(ours <= target_s)}


def _tracking_row(scale: float) -> dict:
    width, height, frames = (1920, 1080, 100) if scale >= 1 else (640, 360, 20)
    disparity, drift = 60, (3.0, 1.0)
    texture = cv2.GaussianBlur(np.random.default_rng(3).uniform(0, 255, (height + 400, width + 600)), (0, 0), 2.5)
    texture = cv2.normalize(texture, None, 20, 235, cv2.NORM_MINMAX).astype(np.uint8)

    def view(i: int, shift: int) -> np.ndarray:
        x0, y0 = int(100 + drift[0] * i + shift), int(100 + drift[1] * i)
        return np.repeat(texture[y0:y0 + height, x0:x0 + width, None], 3, axis=2)

    f = 1.2 * width
    interior = Interior(f, (width - 1) / 2, (height - 1) / 2, 1.0)
    left_camera = Camera(interior, Exterior(0.0, 0.0, 0.0, 0.0, 0.0, 0.0), AirHousing(), width, height)
    relative = RelativeOrientation(disparity * 2.0 / f, 0.0, 0.0, 0.0, 0.0, 0.0)
    rig = StereoRig.from_relative(left_camera, left_camera, relative)
    # the same cameras behind flat ports (what an underwater rig tracks through: every frame's epipolar curve
    # is traced through the port); the frames are the same, only the hold to the curve costs more
    port_camera = Camera(interior, left_camera.exterior, FLAT_PORT, width, height)
    port_rig = StereoRig.from_relative(port_camera, port_camera, relative)
    with tempfile.TemporaryDirectory(prefix="usvips-bench-track-") as folder:
        paths = [Path(folder) / "left.mp4", Path(folder) / "right.mp4"]
        for path, shift in zip(paths, (0, disparity), strict=True):
            encode_video(path, (view(i, shift) for i in range(frames)), 30, "h264", gop=30, bframes=2, quality=20)
        start = (width / 2, height / 2)

        tracked: list = []

        def track(frames, backward: bool, through=rig) -> None:
            """From the first frame forward to the last, or from the last backward to the first."""
            begin = frames_count - 1 if backward else 0
            tracked[:] = [track_vertex(frames, through, begin, start, (start[0] - disparity, start[1]), 0,
                                       frames_count - 1, near=0.5, far=20.0)]

        def run(track_it: bool, backward: bool = False, through=rig) -> None:
            with VideoStream(paths[0]) as left, VideoStream(paths[1]) as right, GreyPairSource(left, right) as frames:
                if track_it:
                    track(frames, backward, through)
                else:
                    for i in range(frames_count):
                        frames(i)

        def run_as_before(backward: bool = False) -> None:
            """The frame source of the previous session: both cameras decoded together, the tracker waiting
            for each pair, grey by FFmpeg's scaler, every step backward a seek from its key frame."""
            with VideoStream(paths[0]) as left, VideoStream(paths[1]) as right:
                reader = PairReader(left, right)
                try:
                    def frames(i: int) -> tuple[np.ndarray, np.ndarray]:
                        a, b = reader.pictures(i, i)
                        return a._frame.to_ndarray(format="gray"), b._frame.to_ndarray(format="gray")

                    track(frames, backward)
                finally:
                    reader.close()

        frames_count = frames
        load = os.getloadavg()[0]
        run(True)
        run(False)
        # tracking and the bare decode alternately, each timed in wall and CPU seconds: a change of the
        # machine's load meets both; the best of each kind of time is kept
        samples: dict[bool, list[tuple[float, float]]] = {True: [], False: []}
        port_samples: list[tuple[float, float]] = []
        for _ in range(TRACK_REPEATS if scale >= 1 else 2):
            for track_it in (True, False):
                samples[track_it].append(_wall_and_cpu(lambda track_it=track_it: run(track_it)))
            port_samples.append(_wall_and_cpu(lambda: run(True, through=port_rig)))
        ours, cpu = (min(kind) for kind in zip(*samples[True], strict=True))
        floor, floor_cpu = (min(kind) for kind in zip(*samples[False], strict=True))
        port_cpu = min(cpu_s for _, cpu_s in port_samples)
        port_frames = len(tracked[0].frames)
        run(True)
        forward = tracked[0]
        before = best_time(run_as_before, 2)
        backward = best_time(lambda: run(True, backward=True), 2)
        backward_frames = len(tracked[0].frames)
        backward_before = best_time(lambda: run_as_before(backward=True), 1)
    row = _absolute(f"track one vertex pair through {frames} frames of {width}x{height} H.264, decoding included",
                    frames, ours, floor, "decoding the same frame pairs (the floor)", TRACK_TARGET_S)
    row["decoding_s"] = round(floor, 6)
    row["tracking_s"] = round(max(ours - floor, 0.0), 6)
    row["decoding_share"] = round(min(floor / ours, 1.0), 3) if ours > 0 else None
    row["before_s"] = round(before, 6)
    row["speed_up_over_before"] = round(before / ours, 2) if ours > 0 else None
    row["cpu_s"] = round(cpu, 3)
    row["decoding_cpu_s"] = round(floor_cpu, 3)
    row["cpu_ratio"] = round(cpu / floor_cpu, 3) if floor_cpu > 0 else None
    row["repeats"] = len(samples[True])
    row["ratio_target"] = TRACK_TARGET_RATIO
    row["ratio_judged_on"] = "cpu"
    row["ratio_met"] = bool(cpu <= TRACK_TARGET_RATIO * floor_cpu)
    row["flat_port_cpu_s"] = round(port_cpu, 3)
    row["flat_port_cpu_ratio"] = round(port_cpu / floor_cpu, 3) if floor_cpu > 0 else None
    row["flat_port_ratio_met"] = bool(port_cpu <= TRACK_TARGET_RATIO * floor_cpu)
    row["flat_port_frames_tracked"] = port_frames
    row["wall_ratio_met"] = bool(ours <= TRACK_TARGET_RATIO * floor)
    row["load_1min"] = round(load, 2)
    row["frames_tracked"] = len(forward.frames)
    row["stopped"] = forward.reason(+1)
    row["backward_s"] = round(backward, 6)
    row["backward_before_s"] = round(backward_before, 6)
    row["backward_frames_tracked"] = backward_frames
    return row


def benchmarks(scale: float = 1.0) -> Iterator[dict]:
    yield _tracking_row(scale)
    rng = np.random.default_rng(1)
    sigmas = rng.uniform(0.002, 0.008, 20)
    values = 0.4 + rng.normal(0, 0.01, 20) + rng.normal(0, sigmas)
    labels = [f"frame {i}" for i in range(20)]

    def ours() -> object:
        return combine_figure(values, sigmas, 0.002, labels=labels, calibrations=[1] * 20)

    def baseline() -> object:
        return np.average(values, weights=1 / sigmas ** 2)

    ours()  # warm scipy's lazy imports
    yield _absolute("combine 20 instants of a length (random effects, leave-one-out residuals)", 20,
                    best_time(ours, 20), best_time(baseline, 20), "numpy's weighted mean of the 20 values",
                    COMBINE_TARGET_S)

    species = [Species("Sparidae", "Pagrus", "auratus", max_length_m=0.4), Species("Labridae", "Achoerodus", "gouldii")]
    records = [ObservationRecord.of(s) for s in species] + [None]
    measured = []
    for k in range(50):  # 50 distinct measurements, some breaking rules, shared by the survey's objects
        ends = np.array([[0.0, 0.0, -2.0 - 0.2 * k], [0.2 + 0.01 * k, 0.0, -2.0 - 0.2 * k]])
        measured.append(measure("length", ends, np.eye(6) * (1e-6 * (1 + k)), ray_rms_m=0.001 * k, range_m=0.2 * k))
    n = QA_OBJECTS if scale >= 1 else max(100, int(QA_OBJECTS * scale))
    survey = [Checked(str(i), "length", measured[i % 50], records[i % 3], Place(f"pair p{i // 100}", f"p{i // 100}"))
              for i in range(n)]
    maxima = species_maxima(species)

    def qa() -> object:
        return check(survey, species=maxima)

    def bare() -> object:
        return [(c.measurement.ray_rms_m, c.measurement.range_m, c.measurement.main.relative_precision)
                for c in survey]

    qa()
    yield _absolute(f"QA of a survey of {n} objects (ray RMS, precision, range, species maximum)", n,
                    best_time(qa, 3), best_time(bare, 3), "reading each object's RMS, range and precision",
                    QA_TARGET_S)
