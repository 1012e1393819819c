"""Views of a board from a rendered stereo calibration video stored in a project: the synchronised pair
(stored offset), blurred and repeated instants rejected, the detections where the truth projects, the
coverage, a cancel that stops the decoding, and a video with no usable instant."""

import threading

import cv2
import numpy as np
import pytest

from tests.core.board_views import (
    HEIGHT,
    WIDTH,
    SectorChessboard,
    board,
    board_pose,
    intrinsics,
    project,
    render,
    right_pose,
)
from usvips.app.calibration_video import scan_video
from usvips.app.video_project import VideoError, add_video
from usvips.core.errors import InvalidParameterError
from usvips.io.video_writer import encode_video
from usvips.store import Project

FOCAL = 300.0


def _blank() -> np.ndarray:
    return np.full((HEIGHT, WIDTH), 140, np.uint8)


def _rgb(grey: np.ndarray) -> np.ndarray:
    return cv2.cvtColor(grey, cv2.COLOR_GRAY2RGB)


def _film(tmp_path, seed: int, offset: int):
    """A stereo video of 36 instants: 10 diverse poses, the board held still for 8, 6 motion-blurred,
    4 without the board, 8 diverse poses. Right frame i + offset shows left frame i's instant. Returns the
    project path, the poses (None: no board) and the blurred and still instants."""
    rng = np.random.default_rng(seed)
    k = intrinsics(FOCAL)

    def diverse():
        return board_pose(rng, rng.uniform(0.6, 1.1), rng.uniform(0, np.radians(45)), rng.uniform(0, np.pi),
                          tuple(rng.uniform(-0.15, 0.15, 2)), rng.uniform(-0.3, 0.3))

    poses = [diverse() for _ in range(10)]
    still = diverse()
    poses += [still] * 8
    poses += [diverse() for _ in range(6)]
    poses += [None] * 4
    poses += [diverse() for _ in range(8)]
    blurred = set(range(18, 24))
    lefts, rights = [], []
    for i, pose in enumerate(poses):
        motion = 11 if i in blurred else 0
        if pose is None:
            lefts.append(_rgb(_blank()))
            rights.append(_rgb(_blank()))
        else:
            lefts.append(_rgb(render(k, *pose, motion=motion)))
            rights.append(_rgb(render(k, *right_pose(*pose), motion=motion)))
    if offset > 0:
        rights = [_rgb(_blank())] * offset + rights
    elif offset < 0:
        lefts = [_rgb(_blank())] * -offset + lefts
        poses = [None] * -offset + poses
        blurred = {b - offset for b in blurred}
    files = {}
    for side, frames in (("left", lefts), ("right", rights)):
        files[side] = tmp_path / f"{side}.mkv"
        encode_video(files[side], frames, 25.0, "ffv1")
    path = tmp_path / "p.usvips"
    with Project.create(path) as project:
        add_video(project, [files["left"]], [files["right"]], "cal")
        project.set_video_offset("cal", offset)
    still_frames = set(range(10, 18)) if offset >= 0 else {f - offset for f in range(10, 18)}
    return path, poses, blurred, still_frames


def _truth_error(pixels, truth):
    """Largest distance (px) to the truth, for the corner order as found or turned by 180°
    (the test-local detector does not resolve a symmetric board's order)."""
    return min(np.abs(pixels - truth).max(), np.abs(pixels[::-1] - truth).max())


@pytest.mark.parametrize("seed,offset", [(1, 2), (2, -3)])
def test_scan_keeps_sharp_distinct_instants_of_both_cameras(tmp_path, seed, offset):
    path, poses, blurred, still = _film(tmp_path, seed, offset)
    k = intrinsics(FOCAL)
    reports = []
    with Project.open(path) as store:
        result = scan_video(store, "cal", SectorChessboard(), every=1, max_views=40, focal_px=FOCAL,
                            progress=lambda fraction, message: reports.append(fraction))
    frames = [v.source["frame"] for v in result.views]
    assert frames == sorted(frames) and len(frames) >= 10
    assert not set(frames) & blurred
    assert len(set(frames) & still) == 1  # the board held still: one view, the rest are duplicates
    assert result.duplicates >= 7
    assert result.blurred >= 1 and result.seen <= result.scanned - 4  # blurred ones found are rejected
    for view in result.views:
        frame = view.source["frame"]
        assert view.source["right_frame"] == frame + offset
        assert view.label == f"cal-{frame}"
        r, t = poses[frame]
        # the instant is paired right (the detector itself is good to about half a pixel here)
        assert _truth_error(view.left.pixels, project(k, r, t, board().xyz)) < 1.0
        assert _truth_error(view.right.pixels, project(k, *right_pose(r, t), board().xyz)) < 1.0
    assert max(result.blur) <= 4.0
    assert reports == sorted(reports) and reports[-1] == pytest.approx(1.0)
    assert result.coverage.views == len(result.views)
    assert result.summary()[0].startswith(f"{result.scanned} instants scanned")
    # every instant not chosen is set aside with its reason (the same loop and rules as image pairs)
    reasons = dict(result.set_aside)
    assert len(reasons) + len(result.views) == result.scanned
    assert sum("near-duplicate of view" in reason for reason in reasons.values()) == result.duplicates
    assert all(reasons[f"cal-{frame}"].startswith(f"view cal-{frame}: ") for frame in blurred)


def test_cap_and_every(tmp_path):
    path, _, _, _ = _film(tmp_path, 3, 0)
    with Project.open(path) as store:
        capped = scan_video(store, "cal", SectorChessboard(), every=1, max_views=5)
        sparse = scan_video(store, "cal", SectorChessboard(), every=4)
        with pytest.raises(InvalidParameterError, match="every"):
            scan_video(store, "cal", SectorChessboard(), every=0)
    assert len(capped.views) == 5
    assert sparse.scanned == 9 and all(v.source["frame"] % 4 == 0 for v in sparse.views)


class _Counting(SectorChessboard):
    def __init__(self):
        super().__init__()
        self.calls = 0

    def detect(self, image):
        self.calls += 1
        return super().detect(image)


def test_cancel_stops_the_decoding(tmp_path):
    path, _, _, _ = _film(tmp_path, 4, 1)
    target = _Counting()
    stop = threading.Event()
    with Project.open(path) as store:
        with pytest.raises(InterruptedError, match="cancelled"):
            scan_video(store, "cal", target, every=1, progress=lambda fraction, message: stop.set(),
                       cancel=stop)
        assert target.calls == 2  # one instant, both cameras, and not one frame more
        # a callable works too
        target.calls = 0
        with pytest.raises(InterruptedError):
            scan_video(store, "cal", target, every=1, cancel=lambda: target.calls >= 6)
        assert target.calls == 6


def test_a_video_with_no_usable_instant_is_one_clear_line(tmp_path):
    files = {}
    for side in ("left", "right"):
        files[side] = tmp_path / f"{side}.mkv"
        encode_video(files[side], [_rgb(_blank())] * 6, 25.0, "ffv1")
    with Project.create(tmp_path / "p.usvips") as store:
        add_video(store, [files["left"]], [files["right"]], "empty")
        with pytest.raises(VideoError) as error:
            scan_video(store, "empty", SectorChessboard(), every=1)
    message = str(error.value)
    assert "\n" not in message
    assert message.startswith("video 'empty': no usable instant among 6")
    assert "found in 0 left and 0 right frames" in message
