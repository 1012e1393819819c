"""Tracking picks through a project's stereo video (encoded from a rendered swimming fish) and measuring
the tracked object on several instants."""

import numpy as np
import pytest

from tests.core.test_tracking import truth, video
from usvips.app.project_figures import evaluate, measurement_input
from usvips.app.tracking import add_tracked_instants, propose_on_frame, track_in_video
from usvips.app.video_project import add_video
from usvips.core.errors import UsvipsError
from usvips.core.measurements import measure_picks
from usvips.core.stereo_calibration import StereoCalibration
from usvips.core.synth.swimming import SwimmingFish
from usvips.io.calibration_file import calibration_to_dict
from usvips.io.video_writer import encode_video
from usvips.store import Project
from usvips.store.project import Vertex

FRAMES, OFFSET = 24, 2
POINTS = (0.3, 0.45)  # the measured body points, as fractions of the fork length from the snout


@pytest.fixture(scope="module")
def survey(tmp_path_factory):
    return _survey(tmp_path_factory.mktemp("tracking"))


def _survey(folder, times_s=None):
    """The stereo video of a swimming fish in a project, with a length measured on left frame 6; both
    cameras' frames at ``times_s`` (s, one per frame: a variable frame rate) or at 25 fps."""
    fish = SwimmingFish(start=(0.25, 0.0, -1.0), length=0.36, speed=0.15, bend=0.3, seed=7)
    stereo, frames = video(fish)
    # the right camera started OFFSET frames earlier: right frame i + OFFSET shows left frame i (the store's
    # convention), so the right video's last partner is left frame FRAMES - 1 - OFFSET
    left = [np.repeat(frames(i)[0][:, :, None], 3, axis=2) for i in range(FRAMES)]
    right = [np.repeat(frames(max(i - OFFSET, 0))[1][:, :, None], 3, axis=2) for i in range(FRAMES)]
    encode_video(folder / "left.mkv", left, 25.0, "ffv1", times_s=times_s)
    encode_video(folder / "right.mkv", right, 25.0, "ffv1", times_s=times_s)
    calibration = StereoCalibration.from_cameras(stereo.left, stereo.right, "water", 0.3)
    path = folder / "survey.usvips"
    with Project.create(path) as project:
        add_video(project, [folder / "left.mkv"], [folder / "right.mkv"], "drop")
        project.set_video_offset("drop", OFFSET)
        calibration_id = project.add_calibration("cal", calibration_to_dict(calibration), ("drop",))
        start = 6
        picks = [truth(stereo, fish, start, f * fish.length) for f in POINTS]
        m = measure_picks("length", calibration, np.array([p[0] for p in picks]), np.array([p[1] for p in picks]),
                          0, "rig")
        vertices = [Vertex(*p[0], *p[1], tuple(xyz), m.covariance[3 * i:3 * i + 3, 3 * i:3 * i + 3], calibration_id,
                           "drop", "drop", start, start + OFFSET,
                           start / 25.0 if times_s is None else times_s[start] - times_s[0])
                    for i, (p, xyz) in enumerate(zip(picks, m.points, strict=True))]
        object_id = project.add_object("length", vertices, "Pagrus auratus")
    return path, object_id, fish, stereo, start


def test_tracked_vertices_become_instants_of_the_object_with_the_combined_length(survey):
    path, object_id, fish, stereo, start = survey
    with Project.open(path) as project:
        stored = project.object(object_id)
        seen = []
        tracks = [track_in_video(project, "drop", start, (v.xl, v.yl), (v.xr, v.yr), 0, 100,
                                 progress=lambda done, total: seen.append(total)) for v in stored.vertices]
        for k, track in enumerate(tracks):
            assert track.frames[0] == 0 and track.reason(-1) == "reached the end"
            # the right video ends OFFSET frames after the left frame that it partners: the track says so
            assert track.frames[-1] == FRAMES - 1 - OFFSET and "no right partner" in track.reason(+1)
            for frame, left, right in zip(track.frames, track.left, track.right, strict=True):
                true_left, true_right = truth(stereo, fish, frame, POINTS[k] * fish.length)
                assert np.linalg.norm(left - true_left) < 0.5 and np.linalg.norm(right - true_right) < 0.5
        assert seen[0] == FRAMES - 1  # the frames asked for, clipped to the video
        ids = add_tracked_instants(project, object_id, tracks, [2, 10, 18], "drop")
        assert project.instants(object_id) == ids
        assert project.instant_sources(object_id) == dict.fromkeys(ids, start)  # stored as tracked from there
        instant = project.object(ids[1])
        assert [(v.video, v.frame_left, v.frame_right) for v in instant.vertices] == [("drop", 10, 12)] * 2
        combined = evaluate(measurement_input(project, project.object(object_id)))
        assert combined.instant_count == 4
        distances = [np.linalg.norm(fish.body_point(f / 25.0, POINTS[1] * fish.length)
                                    - fish.body_point(f / 25.0, POINTS[0] * fish.length)) for f in (start, 2, 10, 18)]
        assert abs(combined.main.value - np.mean(distances)) < 3 * combined.main.sigma + 1e-4
        refused = r"frame 22: the track of vertex 1 does not reach it \(it stopped: [^(]*no right partner"
        with pytest.raises(UsvipsError, match=refused):
            add_tracked_instants(project, object_id, tracks, [4, 22], "drop")
        assert project.instants(object_id) == ids  # nothing stored
        with pytest.raises(UsvipsError, match=f"object {object_id} is itself measured on frame {start}"):
            add_tracked_instants(project, object_id, tracks, [start], "drop")


def test_a_cancel_stops_tracking_and_a_video_without_calibration_is_refused(survey):
    path, object_id, fish, stereo, start = survey
    with Project.open(path) as project:
        v = project.object(object_id).vertices[0]
        track = track_in_video(project, "drop", start, (v.xl, v.yl), (v.xr, v.yr), 0, 20, cancel=lambda: True)
        assert list(track.frames) == [start] and "cancelled" in (track.reason(-1), track.reason(+1))
        project.add_pair("other")
        with pytest.raises(UsvipsError, match="no active calibration"):
            track_in_video(project, "other", start, (v.xl, v.yl), (v.xr, v.yr), 0, 20)


def _readers() -> list[str]:
    """The frame source's decoder threads alive (they read ahead of the tracker)."""
    import threading

    return [t.name for t in threading.enumerate() if t.name.startswith(("usvips-left-grey", "usvips-right-grey"))]


def test_the_decoders_reading_ahead_are_stopped_and_joined_on_cancel_and_on_error(survey):
    """A cancel and an error in the middle of a track both leave no decoder thread behind: the frame
    source's threads read ahead while the tracker works (seen during the track), and are stopped and
    joined before the call returns or raises."""
    path, object_id, fish, stereo, start = survey
    with Project.open(path) as project:
        v = project.object(object_id).vertices[0]
        seen, calls = [], [0]

        def cancel() -> bool:
            calls[0] += 1
            return calls[0] > 6

        def progress(done: int, total: int) -> None:
            seen.extend(_readers())

        track = track_in_video(project, "drop", start, (v.xl, v.yl), (v.xr, v.yr), 0, FRAMES - 1 - OFFSET,
                               cancel=cancel, progress=progress)
        assert "cancelled" in (track.reason(-1), track.reason(+1)) and 1 < len(track.frames) < 8
        assert seen and not _readers()

        def failing(done: int, total: int) -> None:
            seen.extend(_readers())
            if done == 3:
                raise RuntimeError("the worker failed")

        seen.clear()
        with pytest.raises(RuntimeError, match="the worker failed"):
            track_in_video(project, "drop", start, (v.xl, v.yl), (v.xr, v.yr), 0, FRAMES - 1 - OFFSET,
                           progress=failing)
        assert seen and not _readers()


def test_an_objects_vertices_are_proposed_on_another_frame_by_tracking_them_there(survey):
    path, object_id, fish, stereo, start = survey
    with Project.open(path) as project:
        proposals = propose_on_frame(project, object_id, 14)
        for k, proposal in enumerate(proposals):
            true_left, true_right = truth(stereo, fish, 14, POINTS[k] * fish.length)
            assert np.linalg.norm(np.subtract(proposal.left, true_left)) < 0.5
            assert np.linalg.norm(np.subtract(proposal.right, true_right)) < 0.5
        beyond = propose_on_frame(project, object_id, FRAMES - 1)  # past the right video's last partner
        assert all(p.left is None and "no right partner" in p.reason for p in beyond)
        still = project.add_object("point", [Vertex(1.0, 2.0, 3.0, 4.0, pair="drop")])
        with pytest.raises(UsvipsError, match="not measured on a video"):
            propose_on_frame(project, still, 3)


def test_tracked_instants_store_the_time_the_window_gives_their_frame_on_a_variable_frame_rate_video(tmp_path):
    """On a VFR video a frame's presentation time is not frame / fps: each tracked instant stores the time
    the window shows (and stores) for a vertex picked on that frame, from the tracks or, for tracks made
    without the times, from the video's left stream."""
    import dataclasses

    from usvips.app.video_project import frame_pair
    from usvips.gui.video_model import FrameSource

    rng = np.random.default_rng(12)
    times = np.concatenate([[0.0], np.cumsum(rng.uniform(0.02, 0.07, FRAMES - 1))])  # irregular, around 25 fps
    path, object_id, fish, stereo, start = _survey(tmp_path, times)
    frames = [2, 9, 15]
    with Project.open(path) as project:
        assert project.video("drop").fps > 0
        stored = project.object(object_id)
        tracks = [track_in_video(project, "drop", start, (v.xl, v.yl), (v.xr, v.yr), 0, 100) for v in stored.vertices]
        source = FrameSource(project, "drop")
        try:
            window = {f: source.pictures(f)[3] for f in frames}  # the time shown with the frame, as a pick stores it
        finally:
            source.left.close()
            source.right.close()
        np.testing.assert_allclose([window[f] for f in frames], times[frames] - times[0], atol=1.5e-3)
        nominal = np.array(frames) / project.video("drop").fps
        assert np.max(np.abs(nominal - [window[f] for f in frames])) > 0.01  # the old frame / fps was wrong here
        ids = add_tracked_instants(project, object_id, tracks, frames, "drop")
        for frame, instant in zip(frames, ids, strict=True):
            assert {v.time_s for v in project.object(instant).vertices} == {window[frame]}
            assert frame_pair(project, "drop", frame)[3] == window[frame]
        # tracks that do not hold the times (made elsewhere): read from the left stream, the same times
        bare = [dataclasses.replace(t, times_s=None) for t in tracks]
        other = project.add_object("length", stored.vertices, "Pagrus auratus")
        ids_bare = add_tracked_instants(project, other, bare, frames, "drop")
        for frame, instant in zip(frames, ids_bare, strict=True):
            assert {v.time_s for v in project.object(instant).vertices} == {window[frame]}
