"""Tracking a picked vertex through rendered stereo videos of a swimming, bending fish with known truth:
the tracks stay within half a pixel of the truth while the point is visible and stop, saying why, where
it leaves the frame, is occluded, has no frame, or the work is cancelled."""

import numpy as np
import pytest
from scipy.ndimage import map_coordinates

from tests.core.test_matching import H, W, rig
from usvips.core.errors import InvalidParameterError, UsvipsError
from usvips.core.synth.swimming import SwimmingFish
from usvips.core.tracking import CANCELLED, END, LEAVES, TrackSettings, track_vertex

FPS = 25.0
FLOOR = np.random.default_rng(5).uniform(40, 200, (300, 300))


def floor_seen(camera, s: int = 1):
    """The rays of ``camera``'s pixels (``s`` × ``s`` samples each, row-major) and the grey level of the
    textured floor 3 m away (z = −3 m) that each sees."""
    ys, xs = np.mgrid[0:camera.height * s, 0:camera.width * s]
    bundle = camera.rays(np.column_stack([(xs.ravel() + 0.5) / s - 0.5, (ys.ravel() + 0.5) / s - 0.5]))
    t = (-3.0 - bundle.origins[:, 2]) / bundle.directions[:, 2]
    hit = bundle.origins + t[:, None] * bundle.directions
    return bundle, map_coordinates(FLOOR, [(hit[:, 1] + 3.0) / 0.03, (hit[:, 0] + 3.0) / 0.03], order=3,
                                   mode="reflect")


def video(fish: SwimmingFish, housing: str = "flat-port", s: int = 2):
    """The rig and a frame source: frame i shows the fish at i / FPS s before a textured floor 3 m away."""
    stereo = rig(housing)
    cameras = [floor_seen(camera, s) for camera in (stereo.left, stereo.right)]
    cache = {}

    def frames(i: int) -> tuple[np.ndarray, np.ndarray]:
        if i not in cache:
            images = []
            for bundle, floor in cameras:
                t, grey = fish.at(i / FPS).hit(bundle.origins, bundle.directions)
                value = np.where(np.isfinite(t), grey, floor).reshape(H, s, W, s).mean(axis=(1, 3))
                images.append(np.clip(np.rint(value), 0, 255).astype(np.uint8))
            cache[i] = tuple(images)
        return cache[i]

    return stereo, frames


def truth(stereo, fish, frame, s, v=0.0):
    point = fish.body_point(frame / FPS, s, v)[None]
    return stereo.left.project(point).pixels[0], stereo.right.project(point).pixels[0]


def _edge_distance(pixel) -> float:
    return float(min(pixel[0], W - 1 - pixel[0], pixel[1], H - 1 - pixel[1]))


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_tracks_follow_the_truth_within_half_a_pixel_and_stop_where_the_point_leaves(seed):
    rng = np.random.default_rng(seed)
    housing = ["flat-port", "dome-cover", "flat-port"][seed - 1]
    fish = SwimmingFish(start=(rng.uniform(0.05, 0.15), rng.uniform(-0.06, 0.06), -rng.uniform(0.95, 1.1)),
                        heading=(1.0, 0.0, rng.uniform(-0.1, 0.1)), length=rng.uniform(0.3, 0.4),
                        speed=rng.uniform(0.2, 0.4), bend=rng.uniform(0.2, 0.6), beat_hz=rng.uniform(1.0, 2.0),
                        seed=seed)
    stereo, frames = video(fish, housing)
    # a point of the deep body, its window on the fish (a window over the outline is pulled by the background)
    s0, v0 = rng.uniform(0.25, 0.4) * fish.length, rng.uniform(-0.008, 0.008)
    start = 8
    left, right = truth(stereo, fish, start, s0, v0)
    settings = TrackSettings()
    track = track_vertex(frames, stereo, start, left, right, 0, 80, settings)
    errors = np.array([[np.linalg.norm(track.left[k] - t[0]), np.linalg.norm(track.right[k] - t[1])]
                       for k, f in enumerate(track.frames) for t in [truth(stereo, fish, f, s0, v0)]])
    assert errors.max() < 0.5, errors.max()
    assert len(track.frames) >= 10 and track.reason(+1) == LEAVES  # 80 frames carry it out of view
    margin = settings.window / 2 + 1
    for direction, end, why in track.stopped:
        assert why in (END, LEAVES)
        if why == LEAVES:
            # it stopped because the point's window would leave an image on the next frame, not earlier
            following = truth(stereo, fish, end + direction, s0, v0)
            assert min(_edge_distance(following[0]), _edge_distance(following[1])) < margin + 0.5
        else:
            assert end == 0
    assert np.all(track.scores > settings.min_score) and np.all(track.ray_rms_m < 0.005)


def _fish():
    return SwimmingFish(start=(0.1, 0.0, -1.3), length=0.35, speed=0.25, bend=0.4, seed=2)


def test_an_occluded_point_stops_the_track_before_the_occlusion():
    fish = _fish()
    stereo, frames = video(fish)
    left, right = truth(stereo, fish, 0, 0.12)

    def occluded(i):
        images = frames(i)
        if i < 6:
            return images
        covered = []
        for image, point in zip(images, truth(stereo, fish, i, 0.12), strict=True):
            image = image.copy()
            x, y = np.rint(point).astype(int)
            image[y - 15:y + 16, x - 15:x + 16] = 90  # a fin, a diver's hand: a blank patch over the point
            covered.append(image)
        return tuple(covered)

    track = track_vertex(occluded, stereo, 0, left, right, 0, 30)
    assert track.frames[-1] == 5 and track.reason(+1) in ("correlation too low", "lost")


def test_a_featureless_start_is_refused_by_name():
    fish = _fish()
    stereo, frames = video(fish)

    def blank(i):
        left, right = frames(i)
        left = left.copy()
        left[100:140, 20:60] = 120
        return left, right

    with pytest.raises(InvalidParameterError, match=r"left pixel: \(40\.0, 120\.0\) is on a featureless patch"):
        track_vertex(blank, stereo, 0, (40.0, 120.0), (10.0, 120.0), 0, 10)
    with pytest.raises(InvalidParameterError, match="too near the edge"):
        track_vertex(frames, stereo, 0, (3.0, 120.0), (20.0, 120.0), 0, 10)

    def striped(i):
        left, right = frames(i)
        left = left.copy()
        left[100:140, 20:60] = (120 + 60 * np.sin(np.arange(40) / 2.0)).astype(np.uint8)[None, :]
        return left, right

    with pytest.raises(InvalidParameterError, match="lies on an edge"):
        track_vertex(striped, stereo, 0, (40.0, 120.0), (10.0, 120.0), 0, 10)
    with pytest.raises(InvalidParameterError, match="window"):
        TrackSettings(window=8)


def test_a_missing_partner_frame_and_a_cancel_stop_the_track_with_their_reason():
    fish = _fish()
    stereo, frames = video(fish)
    left, right = truth(stereo, fish, 4, 0.12)

    def partial(i):
        if i > 7:
            raise UsvipsError(f"video dive: no right frame partners left frame {i}")
        return frames(i)

    track = track_vertex(partial, stereo, 4, left, right, 2, 20)
    assert list(track.frames) == [2, 3, 4, 5, 6, 7]
    assert track.reason(+1) == "video dive: no right frame partners left frame 8"
    calls, seen = [], []

    def cancel():
        calls.append(1)
        return len(calls) > 3

    track = track_vertex(frames, stereo, 4, left, right, 4, 20, cancel=cancel,
                         progress=lambda done, total: seen.append((done, total)))
    assert track.reason(+1) == CANCELLED and list(track.frames) == [4, 5, 6, 7]
    assert seen == [(1, 16), (2, 16), (3, 16)]
    with pytest.raises(InvalidParameterError, match="start"):
        track_vertex(frames, stereo, 30, left, right, 0, 20)


def test_a_right_track_that_leaves_the_epipolar_curve_stops_as_a_ray_rms_jump():
    fish = _fish()
    stereo, frames = video(fish)
    left, right = truth(stereo, fish, 0, 0.12)

    def shifted(i):
        images = frames(i)
        if i < 5:
            return images
        return images[0], np.roll(images[1], 6, axis=0)  # the right frame no longer the left's partner in y

    track = track_vertex(shifted, stereo, 0, left, right, 0, 20)
    assert track.reason(+1) == "ray RMS jumps" and track.frames[-1] == 4


@pytest.mark.parametrize("rms_jump, min_rms_m", [(4.0, 0.005), (1.05, 1e-6), (1.5, 1e-6)])
def test_the_ray_rms_of_several_frames_at_once_gives_the_track_of_frame_by_frame(monkeypatch, rms_jump, min_rms_m):
    """The ray RMS only stops a track, so it is computed for a batch of frames at once: the tracks, their
    scores and RMS values and where and why they stop are those of frame by frame (a batch of one), for
    stops by the RMS itself (tight jumps), by the epipolar curve and by the end."""
    import usvips.core.tracking as tracking

    fish = _fish()
    stereo, frames = video(fish)
    left, right = truth(stereo, fish, 6, 0.12)

    def shifted(i):
        images = frames(i)
        return images if i < 10 else (images[0], np.roll(images[1], 6, axis=0))

    settings = TrackSettings(rms_jump=rms_jump, min_rms_m=min_rms_m)
    reasons = set()
    for source in (frames, shifted):
        tracks = []
        for batch in (1, tracking.RMS_BATCH, 3):
            monkeypatch.setattr(tracking, "RMS_BATCH", batch)
            tracks.append(track_vertex(source, stereo, 6, left, right, 0, 16, settings))
        for track in tracks[1:]:
            assert track.stopped == tracks[0].stopped
            for name in ("frames", "left", "scores"):
                np.testing.assert_array_equal(getattr(track, name), getattr(tracks[0], name))
            # one pair intersected, or its stretch of curve back-projected, among several or alone: the
            # vectorised solves may round the last bit of the RMS and of the held right point
            np.testing.assert_allclose(track.right, tracks[0].right, rtol=0, atol=1e-9)
            np.testing.assert_allclose(track.ray_rms_m, tracks[0].ray_rms_m, rtol=1e-12, atol=0)
        reasons.update(why for _, _, why in tracks[0].stopped)
    assert "ray RMS jumps" in reasons  # the cases did stop on the RMS


def test_the_flow_split_at_its_finest_level_gives_the_whole_calls_points():
    """The pyramidal flow runs its coarser levels on the neighbourhood quartered and its two finest levels on
    small crops (tracking._pyramidal_lk): over random textures and motions (up to what the coarsest level
    follows, and past it) it loses the same points and finds the others where the whole
    ``cv2.calcOpticalFlowPyrLK`` does, within the flow's own convergence (0.003 px a step)."""
    import cv2

    import usvips.core.tracking as tracking

    rng = np.random.default_rng(17)
    criteria = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 40, 0.003)
    found, worst = 0, 0.0
    for _ in range(150):
        texture = cv2.GaussianBlur(rng.uniform(0, 255, (420, 420)), (0, 0), rng.uniform(1.0, 3.0))
        shift = rng.normal(0, 12, 2) if rng.uniform() < 0.8 else rng.uniform(-70, 70, 2)
        moved = cv2.warpAffine(texture, np.float32([[1, 0, shift[0]], [0, 1, shift[1]]]), (420, 420),
                               flags=cv2.INTER_CUBIC, borderMode=cv2.BORDER_REFLECT)
        before, after = (np.clip(np.rint(a), 0, 255).astype(np.uint8)[66:355, 66:355] for a in (texture, moved))
        start = np.float32(rng.uniform(136, 152, 2)).reshape(1, 1, 2)
        whole, status, _ = cv2.calcOpticalFlowPyrLK(before, after, start, None, winSize=(15, 15), maxLevel=3,
                                                    criteria=criteria)
        hoods = [tracking._neighbourhood(image, (144, 144), 144, 3) for image in (before, after)]
        split = tracking._pyramidal_lk(*hoods, start, (15, 15), 3, criteria)
        assert (split is not None) == bool(status[0, 0])
        if split is not None:
            found += 1
            worst = max(worst, float(np.abs(split - whole).max()))
    assert found > 100 and worst < 0.01


def test_tracks_through_the_split_flow_are_those_of_the_whole_flow(monkeypatch):
    """A whole track on rendered video with the split flow (the default) and with the whole
    ``cv2.calcOpticalFlowPyrLK`` at every step: the same frames, stops and scores, the same pixels within
    the flow's own convergence."""
    import cv2

    import usvips.core.tracking as tracking

    fish = _fish()
    stereo, frames = video(fish)
    left, right = truth(stereo, fish, 6, 0.12)
    split = track_vertex(frames, stereo, 6, left, right, 0, 20)

    def whole(before, after, start, size, levels, criteria):
        found, status, _ = cv2.calcOpticalFlowPyrLK(before.levels[0], after.levels[0], start, None, winSize=size,
                                                    maxLevel=levels, criteria=criteria)
        return found if found is not None and status[0, 0] else None

    monkeypatch.setattr(tracking, "_pyramidal_lk", whole)
    reference = track_vertex(frames, stereo, 6, left, right, 0, 20)
    assert split.stopped == reference.stopped and len(split.frames) > 8
    np.testing.assert_array_equal(split.frames, reference.frames)
    np.testing.assert_allclose(split.left, reference.left, atol=0.01)
    np.testing.assert_allclose(split.right, reference.right, atol=0.01)
    np.testing.assert_allclose(split.scores, reference.scores, atol=1e-3)
