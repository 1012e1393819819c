"""The tracker's fast path against the plain one: the neighbourhoods cropped and reduced once a frame and
kept while the point stays near their centre, the flow's levels split onto small crops, the correlation by
OpenCV and the right point held on a stretch of the epipolar curve give the tracks of the whole
``cv2.calcOpticalFlowPyrLK`` about the point at every step, numpy's correlation and the whole curve — over
random rendered clips, within the flow's own convergence."""

import cv2
import numpy as np
import pytest

import usvips.core.tracking as tracking
from tests.core.test_matching import rig
from tests.core.test_tracking import truth, video
from usvips.core.errors import InvalidParameterError
from usvips.core.intersection import intersect_traced, trace
from usvips.core.matching import epipolar_curve_at
from usvips.core.synth.swimming import SwimmingFish
from usvips.core.tracking import TrackSettings, track_vertex

CRITERIA = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 40, 0.003)


def whole_flow(previous, following, point, settings, motion=None):
    """The flow as it was first written: both frames cropped about the point itself (``_reach`` px) at every
    step, the whole pyramidal call forward and backward."""
    after = tracking._neighbourhood(following, previous.centre, tracking._reach(settings) + tracking.SLACK,
                                    settings.levels)
    x0, y0 = previous.corner
    half, size = tracking._reach(settings), (settings.window, settings.window)
    before, bx, by = tracking._crop(previous.levels[0], point[0] - x0, point[1] - y0, half)
    ahead_image, _, _ = tracking._crop(after.levels[0], point[0] - x0, point[1] - y0, half)
    if before.shape != ahead_image.shape:
        return None, np.inf, after
    corner = np.array([x0 + bx, y0 + by], float)
    start = (point - corner).astype(np.float32).reshape(1, 1, 2)
    ahead, status, _ = cv2.calcOpticalFlowPyrLK(before, ahead_image, start, None, winSize=size,
                                                maxLevel=settings.levels, criteria=CRITERIA)
    if ahead is None or not status[0, 0]:
        return None, np.inf, after
    back, status, _ = cv2.calcOpticalFlowPyrLK(ahead_image, before, ahead, None, winSize=size,
                                               maxLevel=settings.levels, criteria=CRITERIA)
    if back is None or not status[0, 0]:
        return None, np.inf, after
    fb = float(np.linalg.norm(back.reshape(2) - start.reshape(2)))
    return ahead.reshape(2).astype(np.float64) + corner, fb, after


def numpy_ncc(a, b):
    a, b = a - a.mean(), b - b.mean()
    denominator = float(np.sqrt((a * a).sum() * (b * b).sum()))
    return float((a * b).sum() / denominator) if denominator > 0 else 0.0


def _clip(seed):
    rng = np.random.default_rng(seed)
    fish = SwimmingFish(start=(rng.uniform(0.05, 0.15), rng.uniform(-0.05, 0.05), -rng.uniform(0.95, 1.2)),
                        heading=(1.0, 0.0, rng.uniform(-0.1, 0.1)), length=rng.uniform(0.3, 0.4),
                        speed=rng.uniform(0.2, 0.5), bend=rng.uniform(0.2, 0.6), beat_hz=rng.uniform(1.0, 2.0),
                        seed=seed)
    stereo, frames = video(fish, ["flat-port", "dome-cover"][seed % 2])
    s, v = rng.uniform(0.2, 0.45) * fish.length, rng.uniform(-0.008, 0.008)
    start = int(rng.integers(4, 10))
    return stereo, frames, start, truth(stereo, fish, start, s, v)


def _assert_same(ours, reference):
    assert ours.stopped == reference.stopped and len(ours.frames) >= 8
    np.testing.assert_array_equal(ours.frames, reference.frames)
    np.testing.assert_allclose(ours.left, reference.left, atol=0.01)
    np.testing.assert_allclose(ours.right, reference.right, atol=0.01)
    np.testing.assert_allclose(ours.scores, reference.scores, atol=1e-3)
    np.testing.assert_allclose(ours.ray_rms_m, reference.ray_rms_m, rtol=0.05, atol=1e-5)


@pytest.mark.parametrize("seed", [11, 12, 13])
def test_the_fast_path_gives_the_tracks_of_the_plain_one(monkeypatch, seed):
    stereo, frames, start, (left, right) = _clip(seed)
    ours = track_vertex(frames, stereo, start, left, right, 0, start + 24)
    with monkeypatch.context() as plain:  # (no stretch decides: the whole curve holds every frame's point)
        plain.setattr(tracking, "_flow", whole_flow)
        plain.setattr(tracking, "_ncc", numpy_ncc)
        plain.setattr(tracking, "_hold_many", lambda rig, traced, right, *rest: [None] * len(right))
        reference = track_vertex(frames, stereo, start, left, right, 0, start + 24)
    _assert_same(ours, reference)
    with monkeypatch.context() as recropped:  # every step crops both frames again about the point
        recropped.setattr(tracking, "SLACK", 0)
        _assert_same(track_vertex(frames, stereo, start, left, right, 0, start + 24), ours)


def test_a_neighbourhood_is_the_frame_cropped_about_its_centre_and_reduced():
    frame = np.random.default_rng(2).integers(0, 256, (240, 320), dtype=np.uint8)
    hood = tracking._neighbourhood(frame, (100, 60), 40, 3)
    assert hood.corner == (60, 20) and hood.centre == (100, 60)
    assert len(hood.levels) == 1 + tracking.KEPT_LEVELS
    np.testing.assert_array_equal(hood.levels[0], frame[20:101, 60:141])
    np.testing.assert_array_equal(hood.levels[1], cv2.pyrDown(frame[20:101, 60:141]))
    np.testing.assert_array_equal(hood.levels[2], cv2.pyrDown(cv2.pyrDown(frame[20:101, 60:141])))
    edge = tracking._neighbourhood(frame, (5, 230), 40, 1)  # clipped by the frame's edges, one level kept
    assert edge.corner == (0, 190) and edge.levels[0].shape == (50, 46) and len(edge.levels) == 2
    lazy = tracking._neighbourhood(frame, (100, 60), 40)  # the crop alone until the flow asks for more
    assert len(lazy.levels) == 1 and np.shares_memory(lazy.levels[0], frame)  # (a view: a step may read no more)
    assert tracking._levels(lazy, 5) is lazy.levels and len(lazy.levels) == 1 + tracking.KEPT_LEVELS
    assert not np.shares_memory(lazy.levels[0], frame)  # copied before it was reduced
    np.testing.assert_array_equal(lazy.levels[0], hood.levels[0])
    np.testing.assert_array_equal(lazy.levels[2], hood.levels[2])


def test_the_correlation_is_numpys_normalised_cross_correlation():
    rng = np.random.default_rng(4)
    for _ in range(200):
        a = rng.integers(0, 256, (15, 15)).astype(np.float32)
        b = np.clip(np.rint(a * rng.uniform(-2, 2) + rng.normal(0, rng.uniform(1, 80), a.shape)), 0, 255)
        assert tracking._ncc(a, b.astype(np.float32)) == pytest.approx(numpy_ncc(a, b.astype(np.float32)), abs=1e-5)
    flat = np.full((15, 15), 90, np.float32)
    assert tracking._ncc(flat, a) == 0.0 and tracking._ncc(a, flat) == 0.0 and tracking._ncc(flat, flat) == 0.0
    assert tracking._ncc(a, a) == pytest.approx(1.0, abs=1e-6) and tracking._ncc(a, 255 - a) == pytest.approx(-1.0)


@pytest.mark.parametrize("housing", ["flat-port", "dome-cover"])
def test_the_right_point_is_held_where_the_whole_curve_holds_it(housing):
    """Looked for on a stretch of the curve about the depth held before, the nearest point is the whole
    curve's, wherever that stretch starts (the whole curve decides where the stretch's answer is at its end)."""
    stereo = rig(housing)
    depths = np.geomspace(0.3, 12.0, 400)
    rng = np.random.default_rng(8)
    used = 0
    for _ in range(40):
        left = rng.uniform([20, 20], [300, 220])
        whole = tracking._hold(stereo, left, np.zeros(2), depths, None)
        if whole is None:
            continue
        curve = epipolar_curve_at(stereo.left, stereo.right, left, depths)
        right = curve.pixels[rng.integers(len(curve.pixels))] + rng.normal(0, 2, 2)
        whole = tracking._hold(stereo, left, right, depths, None)
        for around in (whole[2], whole[2] + int(rng.integers(-6, 7)), whole[2] + 40, 0, 399):
            held, off, index = tracking._hold(stereo, left, right, depths, int(np.clip(around, 0, 399)))
            np.testing.assert_allclose(held, whole[0], atol=1e-9)
            assert off == pytest.approx(whole[1], abs=1e-9) and index == whole[2]
        used += 1
    assert used > 20


@pytest.mark.parametrize("housing", ["flat-port", "dome-cover"])
def test_the_right_points_of_a_batch_of_frames_are_held_where_the_whole_curve_holds_them(housing):
    """Held for many frames at once on stretches about each pair's intersection, the nearest points are the
    whole curve's wherever a stretch decides, and the stretches decide for nearly every pair near its curve."""
    stereo = rig(housing)
    depths = np.geomspace(0.3, 12.0, 400)
    rng = np.random.default_rng(9)
    lefts, rights = [], []
    while len(lefts) < 60:
        left = rng.uniform([20, 20], [300, 220])
        curve = epipolar_curve_at(stereo.left, stereo.right, left, depths)
        if len(curve.pixels) > 40:
            lefts.append(left)
            rights.append(curve.pixels[rng.integers(20, len(curve.pixels) - 20)] + rng.normal(0, 1.5, 2))
    lefts, rights = np.array(lefts), np.array(rights)
    traced = (trace(stereo.left, lefts), trace(stereo.right, rights))
    met = intersect_traced(traced)
    holds = tracking._hold_many(stereo, traced[0], rights, met.points, met.ok, depths)
    decided = 0
    for left, right, hold in zip(lefts, rights, holds, strict=True):
        if hold is None:
            continue
        whole = tracking._hold(stereo, left, right, depths, None)
        np.testing.assert_allclose(hold[0], whole[0], atol=1e-9)
        assert hold[1] == pytest.approx(whole[1], abs=1e-9) and hold[2] == whole[2]
        decided += 1
    assert decided >= 55
    assert tracking._hold_many(stereo, traced[0], rights, met.points, np.zeros(60, bool), depths) == [None] * 60


@pytest.mark.parametrize("housing", ["flat-port", "dome-cover"])
def test_stretches_cut_by_the_curves_ends_are_held_where_the_whole_curve_holds_them(housing):
    """Pairs whose depth lies near the last depth sample have stretches shorter than the rest (cut at the
    curve's end); held in one batch with whole stretches, each is the whole curve's where it decides."""
    stereo = rig(housing)
    depths = np.geomspace(0.3, 12.0, 400)
    rng = np.random.default_rng(10)
    lefts, rights, cut = [], [], 0
    while len(lefts) < 60:
        left = rng.uniform([20, 20], [300, 220])
        curve = epipolar_curve_at(stereo.left, stereo.right, left, depths)
        if len(curve.pixels) < 40 or curve.depths[-1] != depths[-1]:
            continue
        near_end = len(lefts) % 2 == 0
        last = len(curve.pixels) - 1
        index = last - int(rng.integers(0, 4)) if near_end else int(rng.integers(20, last - 19))
        lefts.append(left)
        rights.append(curve.pixels[index] + rng.normal(0, 0.3, 2))
    lefts, rights = np.array(lefts), np.array(rights)
    traced = (trace(stereo.left, lefts), trace(stereo.right, rights))
    met = intersect_traced(traced)
    holds = tracking._hold_many(stereo, traced[0], rights, met.points, met.ok, depths)
    for i, (left, right, hold) in enumerate(zip(lefts, rights, holds, strict=True)):
        if hold is None:
            continue
        whole = tracking._hold(stereo, left, right, depths, None)
        np.testing.assert_allclose(hold[0], whole[0], atol=1e-9)
        assert hold[1] == pytest.approx(whole[1], abs=1e-9) and hold[2] == whole[2]
        cut += i % 2 == 0 and hold[2] > len(depths) - tracking.CURVE_STRETCH - 2
    assert cut >= 20  # the cut stretches did decide


def test_the_nearest_points_of_many_polylines_are_each_ones_own():
    """:func:`_nearest_on_many` against the nearest point found segment by segment in plain arithmetic."""
    rng = np.random.default_rng(4)
    curves = np.cumsum(rng.normal(0, 3, (50, 18, 2)), axis=1)
    curves[5, 7] = curves[5, 6]  # a segment of no length
    points = curves[:, 9] + rng.normal(0, 4, (50, 2))
    held, off, k = tracking._nearest_on_many(curves, points)
    for curve, point, h, o, j in zip(curves, points, held, off, k, strict=True):
        best = (np.inf, None, None)
        for i, (a, b) in enumerate(zip(curve[:-1], curve[1:], strict=True)):
            ab = b - a
            length2 = float(ab @ ab)
            t = 0.0 if length2 == 0 else min(max(float((point - a) @ ab) / length2, 0.0), 1.0)
            candidate = a + t * ab
            distance = float(np.hypot(*(candidate - point)))
            if distance < best[0]:
                best = (distance, candidate, i)
        assert o == pytest.approx(best[0], abs=1e-9) and j == best[2]
        np.testing.assert_allclose(h, best[1], atol=1e-9)
    single = tracking._nearest_on(curves[3], points[3])
    np.testing.assert_array_equal(single[0], held[3])
    assert single[1:] == (off[3], k[3])


def test_a_track_holds_its_right_points_a_batch_of_frames_at_a_time(monkeypatch):
    """The hold back-projects a batch's stretches of curve in one call: a track of 24 frames asks for a
    batched hold once a batch (:data:`~usvips.core.tracking.RMS_BATCH` frames), not once a frame, and the
    whole curve almost never."""
    stereo, frames, start, (left, right) = _clip(12)
    batches, whole = [], []
    many, single = tracking._hold_many, tracking._hold
    monkeypatch.setattr(tracking, "_hold_many", lambda *a: batches.append(len(a[2])) or many(*a))
    monkeypatch.setattr(tracking, "_hold", lambda *a: whole.append(1) or single(*a))
    track = track_vertex(frames, stereo, start, left, right, start, start + 24)
    assert len(track.frames) - 1 == sum(batches) >= 20
    assert len(batches) <= -(-len(track.frames) // tracking.RMS_BATCH) + 1 and len(whole) <= 2


def test_the_depths_of_the_epipolar_curve_are_checked_before_any_frame_is_read():
    asked = []

    def frames(i):
        asked.append(i)
        raise AssertionError("no frame should be read")

    stereo, _, _, (left, right) = _clip(11)
    with pytest.raises(InvalidParameterError, match="far: must exceed near"):
        track_vertex(frames, stereo, 0, left, right, 0, 5, near=2.0, far=1.0)
    with pytest.raises(InvalidParameterError, match="near"):
        track_vertex(frames, stereo, 0, left, right, 0, 5, near=-1.0)
    assert asked == [] and TrackSettings().levels == 3


def test_a_right_point_leaving_a_right_image_smaller_than_the_left_stops_the_track_as_leaving():
    """A right camera of fewer columns than the left: a texture drifting right takes the right point out of
    its image while the left point is still well inside the left image, and the track stops there, as
    leaving the frame (each point is checked against its own image's size)."""
    from usvips.core.camera import Camera, Exterior
    from usvips.core.housing import AirHousing
    from usvips.core.interior import Interior
    from usvips.core.rig import RelativeOrientation, StereoRig
    from usvips.core.tracking import LEAVES

    width, narrow, height, disparity = 640, 480, 360, 60
    texture = cv2.GaussianBlur(np.random.default_rng(21).uniform(0, 255, (height + 200, width + 800)), (0, 0), 2.0)
    texture = cv2.normalize(texture, None, 20, 235, cv2.NORM_MINMAX).astype(np.uint8)

    def frames(i: int) -> tuple[np.ndarray, np.ndarray]:
        x0 = 400 - 6 * i  # the scene drifts right by 6 px a frame
        return (np.ascontiguousarray(texture[100:100 + height, x0:x0 + width]),
                np.ascontiguousarray(texture[100:100 + height, x0 + disparity:x0 + disparity + narrow]))

    f = 1.2 * width
    interior = Interior(f, (width - 1) / 2, (height - 1) / 2, 1.0)
    left_camera = Camera(interior, Exterior(0, 0, 0, 0, 0, 0), AirHousing(), width, height)
    right_camera = Camera(interior, Exterior(0, 0, 0, 0, 0, 0), AirHousing(), narrow, height)
    stereo = StereoRig.from_relative(left_camera, right_camera, RelativeOrientation(disparity * 2.0 / f, 0, 0, 0, 0, 0))
    track = track_vertex(frames, stereo, 0, (400.0, 180.0), (340.0, 180.0), 0, 40, near=0.5, far=20.0)
    margin = TrackSettings().window / 2 + 1
    assert track.reason(+1) == LEAVES
    last_left, last_right = track.left[-1], track.right[-1]
    assert last_right[0] <= narrow - 1 - margin and last_right[0] + 6 > narrow - 1 - margin  # the next step leaves
    assert last_left[0] < width - 1 - margin - 50  # the left point was far from its edge


def _drifting_clip(seed: int, frames: int = 36, jumps: bool = True):
    """A textured plane drifting past an in-air rig (the right image the left one shifted by the disparity):
    a random velocity with random accelerations (px per frame) and, with ``jumps``, sudden moves of tens of
    px; the frame source, the rig, the start frame and pixels, and the truth: each frame's offset of the
    plane (a point p on frame i is p + offset[i] on the plane)."""
    from usvips.core.camera import Camera, Exterior
    from usvips.core.housing import AirHousing
    from usvips.core.interior import Interior
    from usvips.core.rig import RelativeOrientation, StereoRig

    rng = np.random.default_rng(seed)
    width, height, disparity = 480, 360, int(rng.integers(20, 60))
    texture = cv2.GaussianBlur(rng.uniform(0, 255, (height + 500, width + 600)), (0, 0), rng.uniform(1.0, 3.0))
    texture = cv2.normalize(texture, None, 20, 235, cv2.NORM_MINMAX).astype(np.uint8)
    velocity, offset, offsets = rng.normal(0, 4, 2), np.array([250.0, 250.0]), []
    for _ in range(frames):
        offsets.append(offset.copy())
        velocity = velocity + rng.normal(0, 1.5, 2)
        jump = rng.normal(0, 25, 2) if jumps and rng.uniform() < 0.08 else 0.0
        offset = np.clip(offset + velocity + jump, 5, 490)

    def view(i, shift):
        move = np.float32([[1, 0, -offsets[i][0] - shift], [0, 1, -offsets[i][1]]])
        return cv2.warpAffine(texture, move, (width, height), flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_REFLECT)

    pairs = [(view(i, 0), view(i, disparity)) for i in range(frames)]
    f = 1.2 * width
    camera = Camera(Interior(f, (width - 1) / 2, (height - 1) / 2, 1.0), Exterior(0, 0, 0, 0, 0, 0), AirHousing(),
                    width, height)
    stereo = StereoRig.from_relative(camera, camera, RelativeOrientation(disparity * 2.0 / f, 0, 0, 0, 0, 0))
    start = (float(rng.uniform(200, 280)), float(rng.uniform(150, 210)))
    return (lambda i: pairs[i]), stereo, int(rng.integers(0, frames)), start, disparity, np.array(offsets)


def _track_drifting(frames, stereo, start, point, disparity, count):
    return track_vertex(frames, stereo, start, point, (point[0] - disparity, point[1]), 0, count - 1, near=0.5,
                        far=20.0)


def test_steps_started_from_the_last_move_track_as_far_and_as_true_as_the_whole_pyramid(monkeypatch):
    """The flow first runs its finest level alone from the point's last move (tracking._predicted_flow) and
    falls back to the whole pyramid where that fails, or where the step it gives stops the track: over random
    drifts with accelerations and sudden jumps, the tracks reach as many frames as with the pyramid at every
    step, and where both track a frame they agree within the flow's convergence and lie on the truth."""
    reached, reached_whole, worst_gap, worst_error = 0, 0, 0.0, 0.0
    for seed in range(24):
        frames, stereo, start, point, disparity, offsets = _drifting_clip(100 + seed)
        ours = _track_drifting(frames, stereo, start, point, disparity, len(offsets))
        with monkeypatch.context() as whole:
            whole.setattr(tracking, "_predicted_flow", lambda *args: None)
            reference = _track_drifting(frames, stereo, start, point, disparity, len(offsets))
        reached, reached_whole = reached + len(ours.frames), reached_whole + len(reference.frames)
        common, mine, theirs = np.intersect1d(ours.frames, reference.frames, return_indices=True)
        worst_gap = max(worst_gap, float(np.abs(ours.left[mine] - reference.left[theirs]).max()))
        on_plane = ours.left + offsets[ours.frames]
        worst_error = max(worst_error, float(np.abs(on_plane - on_plane[ours.frames == start]).max()))
    # (a step's point agrees with the pyramid's within its convergence, not bit for bit, so a later step near
    # a threshold may go either way: a few frames' slack; without the redo, 6 % of the frames are lost)
    assert reached >= 0.98 * reached_whole and reached_whole > 24 * 12
    assert worst_gap < 0.01 and worst_error < 1.0


def test_a_smooth_drift_is_followed_without_the_pyramid_and_a_jump_with_it(monkeypatch):
    """On a steady drift the steps after the first few need no pyramid (the speed-up is real); a sudden move
    the last move cannot predict is found by the pyramid, and the track goes on, on the truth."""
    calls = []
    whole = tracking._pyramidal_lk
    monkeypatch.setattr(tracking, "_pyramidal_lk", lambda *args: calls.append(1) or whole(*args))
    frames, stereo, start, point, disparity, offsets = _drifting_clip(7, frames=40, jumps=False)
    count = len(offsets)
    steady = _track_drifting(frames, stereo, 0, point, disparity, count)
    assert len(steady.frames) == count and len(calls) <= 0.2 * (4 * (count - 1))  # two cameras, both ways

    jumped = offsets.copy()
    jumped[20:] += (30.0, -20.0)  # the plane jumps between frames 19 and 20
    moved = _drifting_source(frames, offsets, jumped)
    calls.clear()
    track = _track_drifting(moved, stereo, 0, point, disparity, count)
    assert len(track.frames) == count and calls  # the pyramid found the jump
    on_plane = track.left + jumped[track.frames]
    assert np.abs(on_plane - on_plane[0]).max() < 0.1


def _drifting_source(frames, offsets, wanted):
    """``frames`` (a drifting clip) with frame i shifted so that the plane's offset is ``wanted[i]``."""
    def source(i):
        dx, dy = offsets[i] - wanted[i]
        move = np.float32([[1, 0, dx], [0, 1, dy]])
        return tuple(cv2.warpAffine(image, move, image.shape[::-1], flags=cv2.INTER_LINEAR,
                                    borderMode=cv2.BORDER_REFLECT) for image in frames(i))
    return source
