"""The window's model of an object's tracks (Qt-free), on rendered videos of a swimming, bending fish with
known truth: tracks of every vertex, a correction that picks the track up again after an occlusion, the
frames chosen for instants, the marks of the timeline."""

import numpy as np
import pytest

from tests.core.test_tracking import truth, video
from usvips.core.errors import UsvipsError
from usvips.core.synth.swimming import SwimmingFish
from usvips.core.tracking import END, Track, check_trackable, track_vertex
from usvips.gui.track_model import TrackModel, merge_correction

POINTS = (0.25, 0.5)  # the tracked body points, fractions of the fork length from the snout


def textured_point(stereo, fish, images, frame, s):
    """A body point (arc length, offset across the body; m) near ``s`` on the deep body whose windows are
    textured in both images (as a user picks a point with texture to track, not a plain patch or a stripe)."""
    for ds in (0.0, 0.01, -0.01, 0.02, -0.02, 0.03, -0.03, 0.04, -0.04):
        for v in (0.0, 0.004, -0.004, 0.008, -0.008):
            try:
                for image, pixel in zip(images, truth(stereo, fish, frame, s + ds, v), strict=True):
                    check_trackable(image, pixel)
            except UsvipsError:
                continue
            return s + ds, v
    raise AssertionError(f"no textured point near {s:.3f} m along the fish")


def _track(frames, start, first, last, seed=0):
    n = last - first + 1
    rng = np.random.default_rng(seed)
    return Track(np.arange(first, last + 1), rng.normal(size=(n, 2)), rng.normal(size=(n, 2)), np.ones((n, 2)),
                 np.zeros(n), start, ((-1, first, "lost"), (1, last, END)))


def test_a_correction_keeps_the_old_track_up_to_it_and_the_new_one_beyond():
    old = _track(None, 10, 4, 16, seed=1)
    later = _track(None, 20, 20, 30, seed=2)  # re-picked after a gap (the old track stopped at 16)
    merged = merge_correction(old, later)
    assert list(merged.frames) == list(range(4, 17)) + list(range(20, 31)) and merged.start == 10
    assert np.array_equal(merged.left[:13], old.left) and np.array_equal(merged.left[13:], later.left)
    assert merged.reason(-1) == "lost" and merged.reason(+1) == END
    inside = _track(None, 12, 12, 25, seed=3)  # a correction inside the track replaces it from there on
    merged = merge_correction(old, inside)
    assert list(merged.frames) == list(range(4, 26))
    assert np.array_equal(merged.left[8:], inside.left) and np.array_equal(merged.left[:8], old.left[:8])
    backward = _track(None, 6, 0, 6, seed=4)
    merged = merge_correction(old, backward)  # before the object's frame: replaced backward from there
    assert list(merged.frames) == list(range(0, 17))
    assert np.array_equal(merged.left[:7], backward.left) and np.array_equal(merged.left[7:], old.left[3:])
    assert merged.reason(-1) == "lost" and merged.reason(+1) == END


@pytest.mark.parametrize("seed", range(1, 9))
def test_tracks_of_every_vertex_follow_the_truth_and_a_correction_picks_up_after_an_occlusion(seed):
    rng = np.random.default_rng(seed)
    fish = SwimmingFish(start=(rng.uniform(0.18, 0.24), rng.uniform(-0.03, 0.03), -rng.uniform(0.95, 1.1)),
                        heading=(1.0, 0.0, rng.uniform(-0.1, 0.1)), length=rng.uniform(0.3, 0.4),
                        speed=rng.uniform(0.1, 0.15), bend=rng.uniform(0.2, 0.5), seed=seed)
    stereo, frames = video(fish)
    start, hidden = 4, (9, 12)  # a fin covers the second vertex on frames 9 to 12

    def occluded(i):
        images = frames(i)
        if not hidden[0] <= i <= hidden[1]:
            return images
        covered = []
        for image, point in zip(images, truth(stereo, fish, i, *points[1]), strict=True):
            image = image.copy()
            x, y = np.rint(point).astype(int)
            image[y - 10:y + 11, x - 10:x + 11] = 90
            covered.append(image)
        return tuple(covered)

    points = [textured_point(stereo, fish, frames(start), start, p * fish.length) for p in POINTS]
    model = TrackModel()
    model.begin(7, "drop", start, len(POINTS))
    assert not model.complete and model.describe().startswith("object 7: 0 of 2")
    for vertex, point in enumerate(points):
        left, right = truth(stereo, fish, start, *point)
        model.set_track(vertex, track_vertex(occluded, stereo, start, left, right, 0, 20))
    assert model.complete
    second = model.tracks[1]
    assert second.frames[-1] == hidden[0] - 1 and second.reason(+1) in ("correlation too low", "lost")
    stop = next(s for s in model.stops() if s.vertex == 1 and s.direction == 1)
    assert stop.frame == hidden[0] - 1 and stop.reason in model.describe()
    # the user goes past the occlusion and re-picks the vertex there: the track follows on from that frame
    frame = hidden[1] + 1
    picked = truth(stereo, fish, frame, *points[1])
    assert model.nearest_vertex(frame, tuple(picked[0])) == 1
    model.correct(1, track_vertex(occluded, stereo, frame, *picked, frame, 20))
    assert model.corrected[1] == {frame}
    track = model.tracks[1]
    assert not set(range(*hidden)) & set(track.frames.tolist())  # the occluded frames stay untracked
    assert track.frames[0] == model.tracks[0].frames[0] and track.frames[-1] > frame
    for vertex, point in enumerate(points):
        for f, left, right in zip(model.tracks[vertex].frames, model.tracks[vertex].left, model.tracks[vertex].right,
                                  strict=True):
            true_left, true_right = truth(stereo, fish, f, *point)
            assert np.linalg.norm(left - true_left) < 0.5 and np.linalg.norm(right - true_right) < 0.5
    # instants every 4 frames where both vertices are tracked, never on the object's own frame or in the gap
    common = set(model.tracked_frames().tolist())
    chosen = model.instant_frames(4)
    assert chosen and all(f in common and (f - start) % 4 == 0 and f != start for f in chosen)
    assert not set(chosen) & set(range(hidden[0], hidden[1] + 1))
    assert set(model.points_at(chosen[-1])) == {0, 1}
    assert set(model.points_at(hidden[0])) == {0}
    left_trail, right_trail = model.trail(0, start + 3, length=5)
    assert len(left_trail) == len(right_trail) == 6
    before_trail, _ = model.trail(0, 1, length=5)  # before the object's frame: the frames it came from
    assert len(before_trail) == 6 and np.allclose(before_trail[0], model.tracks[0].left[1])  # frames 1 to 6


def test_nothing_tracked_and_bad_requests_are_named():
    model = TrackModel()
    with pytest.raises(UsvipsError, match="nothing is tracked"):
        model.ordered_tracks()
    with pytest.raises(UsvipsError, match="no object is being tracked"):
        model.set_track(0, _track(None, 0, 0, 3))
    model.begin(3, "drop", 5, 2)
    with pytest.raises(UsvipsError, match="starts on frame 0, not on the object's frame 5"):
        model.set_track(0, _track(None, 0, 0, 3))
    with pytest.raises(UsvipsError, match="vertices 1 to 2, not 3"):
        model.set_track(2, _track(None, 5, 0, 9))
    with pytest.raises(UsvipsError, match="vertex 2 has no track to correct"):
        model.correct(1, _track(None, 7, 7, 9))
    model.set_track(0, _track(None, 5, 0, 9))
    with pytest.raises(UsvipsError, match=r"vertices \[2\] have no track yet"):
        model.ordered_tracks()
    with pytest.raises(UsvipsError, match="at least 1"):
        model.instant_frames(0)


def test_the_same_stop_of_several_vertices_is_said_once():
    model = TrackModel()
    model.begin(3, "drop", 5, 2)
    for vertex in range(2):
        model.set_track(vertex, _track(None, 5, 2, 9, seed=vertex))  # both lost before frame 2, ended at 9
    assert model.describe() == "object 3: 2 of 2 vertices tracked, frames 2–9; stopped: vertices 1, 2 before frame 2 " \
                               "(lost)"
    assert [(s.vertex, s.direction, s.frame) for s in model.stops()] == [(0, -1, 2), (1, -1, 2)]
