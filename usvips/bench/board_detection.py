"""Benchmarks of chessboard detection on 1080p frames, cascade included, against OpenCV's bare detector;
and, for each real board set (those under ``$USVIPS_REAL_BOARDS``, else those committed with the tests,
``tests/data/real_boards``, in a source checkout), our calibration against OpenCV's
(:mod:`usvips.bench.real_boards`).

**Speed row.** The frames: the views of the real board set with the most pairs (its left images, each
upscaled to 1920 × 1080 by cubic interpolation, keeping the aspect and padding with the image's edge; the
row says so), or without a set, chessboards rendered at 1920 × 1080 in random poses. Per frame, our
detection (the kind's cascade, corner order, ``cornerSubPix``, quality and blur) and OpenCV's bare
``findChessboardCornersSB`` (no flags) are timed (best of repeats); the row's ratio is the median of the
per-frame ratios.

**Real-set rows** (one per set): the ratio is our held-out adjacent-distance RMS (relative) over
OpenCV's, target 1.0 (no worse than OpenCV); the row also holds the views found by each, and the focal
lengths' and baseline's relative differences; ``ours_s`` is the wall time of the whole comparison.
"""

from __future__ import annotations

import os
import time
from collections.abc import Iterator
from pathlib import Path

import cv2
import numpy as np

from usvips.bench import best_time
from usvips.core.calibration_targets import kind
from usvips.core.calibration_targets.kinds._board import to_grey8

FRAME = (1920, 1080)
#: the environment variable naming a folder of real board sets
REAL_BOARDS = "USVIPS_REAL_BOARDS"


def to_1080p(grey: np.ndarray) -> np.ndarray:
    """``grey`` scaled (cubic) to fit 1920 × 1080 with its aspect kept, the rest filled by its edge."""
    height, width = grey.shape
    scale = min(FRAME[0] / width, FRAME[1] / height)
    scaled = cv2.resize(grey, (int(round(width * scale)), int(round(height * scale))), interpolation=cv2.INTER_CUBIC)
    bottom, right = FRAME[1] - scaled.shape[0], FRAME[0] - scaled.shape[1]
    return cv2.copyMakeBorder(scaled, 0, bottom, 0, right, cv2.BORDER_REPLICATE)


def rendered_frames(count: int, seed: int = 0) -> tuple[object, list[np.ndarray]]:
    """A 9 × 6 chessboard (30 mm squares) rendered in ``count`` random poses at 1920 × 1080."""
    from usvips.core.camera import Camera, Exterior
    from usvips.core.interior import Interior
    from usvips.core.synth.boards import BoardPose, render_board

    board = kind("chessboard")(9, 6, 0.03)
    camera = Camera(Interior(f=1500.0, xp=959.5, yp=539.5, k1=-0.05), Exterior(0, 0, 0), width=FRAME[0],
                    height=FRAME[1])
    rng = np.random.default_rng(seed)
    centre = board.control_points().xyz.mean(axis=0)[:2]
    frames = []
    for _ in range(count):
        pose = BoardPose.facing(camera, centre, (rng.uniform(700, 1220), rng.uniform(400, 680)), rng.uniform(0.8, 1.4),
                                tilt=rng.uniform(0, 0.7), tilt_direction=rng.uniform(0, 2 * np.pi),
                                spin=rng.uniform(-np.pi, np.pi))
        frames.append(render_board(camera, board, pose, supersample=1, seed=int(rng.integers(1 << 30))))
    return board, frames


#: the real board sets committed with the tests (public, licensed: each folder's SOURCE.md; test data, not
#: shipped with the package), used when ``$USVIPS_REAL_BOARDS`` is not set and the bench runs at the root
#: of a source checkout (as ``.ci/run`` and the docs run it)
COMMITTED_SETS = Path("tests") / "data" / "real_boards"


def _real_sets() -> list[Path]:
    """The sets under ``$USVIPS_REAL_BOARDS``, else the committed ones (:data:`COMMITTED_SETS`)."""
    root = os.environ.get(REAL_BOARDS) or str(COMMITTED_SETS)
    if not Path(root).is_dir():
        return []
    from usvips.bench.real_boards import sets_under

    return list(sets_under(root))


def _real_frames(folder: Path, count: int) -> tuple[object, list[np.ndarray]]:
    from usvips.bench.real_boards import set_pairs
    from usvips.io.images import read_image
    from usvips.io.target_file import read_target

    board = read_target(folder / "board.json")
    lefts = [left for left, _ in set_pairs(folder)][:count]
    return board, [to_1080p(to_grey8(read_image(path))) for path in lefts]


def detection_row(board, frames: list[np.ndarray], source: str, repeats: int) -> dict:
    """Our detection against OpenCV's bare ``findChessboardCornersSB`` on each frame; median ratio."""
    pattern = (board.cols, board.rows)
    ours, bare, found = [], [], 0
    for frame in frames:
        found += bool(board.detect(frame))  # also warms caches
        ours.append(best_time(lambda frame=frame: board.detect(frame), repeats))
        bare.append(best_time(lambda frame=frame: cv2.findChessboardCornersSB(frame, pattern), repeats))
    ratios = np.array(ours) / np.array(bare)
    ratio = float(np.median(ratios))
    return {"name": f"chessboard {board.cols}x{board.rows} detection, cascade included, 1920x1080 grey ({source})",
            "n": len(frames), "ours_s": round(float(np.median(ours)), 6),
            "baseline": "cv2.findChessboardCornersSB without flags, same frames (median of per-frame ratios)",
            "baseline_s": round(float(np.median(bare)), 6), "ratio": round(ratio, 4), "target": 1.2,
            "met": bool(ratio <= 1.2), "found": found, "ratio_max": round(float(ratios.max()), 4)}


def real_set_row(folder: Path) -> dict:
    """One real set's calibration against OpenCV's (:func:`usvips.bench.real_boards.compare_set`)."""
    from usvips.bench.real_boards import compare_set

    start = time.perf_counter()
    figures = compare_set(folder)
    elapsed = time.perf_counter() - start
    ours, theirs = figures["held_out_rms_relative_ours"], figures["held_out_rms_relative_opencv"]
    ratio = ours / theirs if theirs > 0 else float("inf")
    return {"name": f"real board set {folder.name}: held-out adjacent distances, ours vs OpenCV",
            "n": figures["pairs"], "ours_s": round(elapsed, 3),
            "baseline": "OpenCV findChessboardCorners + calibrateCamera + stereoCalibrate, same run",
            "baseline_s": None, "ratio": round(ratio, 4), "target": 1.0, "met": bool(ratio <= 1.0), **figures}


def benchmarks(scale: float = 1.0) -> Iterator[dict]:
    count = max(3, int(round(8 * scale)))
    repeats = max(2, int(round(3 * scale)))
    sets = _real_sets()
    if sets:
        from usvips.bench.real_boards import set_pairs

        largest = max(sets, key=lambda folder: len(set_pairs(folder)))
        board, frames = _real_frames(largest, count)
        source = f"real set {largest.name}, upscaled to 1080p"
    else:
        board, frames = rendered_frames(count)
        source = "rendered views"
    yield detection_row(board, frames, source, repeats)
    for folder in sets:
        yield real_set_row(folder)
