"""Issue 32's acceptance for tracked and combined lengths: a person's clicks (0.5 px error) on a rendered,
swimming, bending fish, tracked through the video (T), stored as instants (Ctrl+T: add_tracked_instants)
and combined by the one figure function, over ≥ 50 fish: the truth lies inside 2σ of the combined length
in ≥ 90 % of them, and inside 2σ of each instant's length in ≥ 90 % of the instants (measured: 54 fish,
100 % and 97.8 % of 318 instants; NEES 0.55 combined, 0.81 per instant — the combined σ is conservative:
the bending's part is taken as random over the instants, which sample the tail beat evenly).

The calibration is a board's (σ0 = 0.06 px, of detected corners): the figures' pointing σ must be the
click's (the hand-click default, 0.5 px), not σ0 — with σ0 as the pointing the combined lengths were more
than 2σ off in 3 of 8 runs (issue 32). The σ must not be grossly conservative either (NEES ≥ 0.4)."""

import numpy as np
import pytest

from tests.app.test_tracked_instants_honesty import FPS, FRAMES, STEP, _fish, _render, _rig, _truth
from usvips.app.project_figures import evaluate, instant_measurements, measurement_input
from usvips.app.tracking import VideoTracker, add_tracked_instants
from usvips.app.video_project import add_video
from usvips.core.errors import InvalidParameterError
from usvips.core.measurements import measure_picks
from usvips.core.pointing import HAND_CLICK_SIGMA_PX
from usvips.core.stereo_calibration import StereoCalibration
from usvips.io.calibration_file import calibration_to_dict
from usvips.io.video_writer import encode_video
from usvips.store import Project
from usvips.store.project import Vertex

VIDEOS, LENGTHS = 10, 6
CLICK_PX = 0.5
BOARD_SIGMA0_PX = 0.06


@pytest.mark.slow  # ~1 min of CPU: 10 rendered videos, 60 lengths tracked
def test_tracked_and_combined_lengths_from_clicks_hold_their_sigma(tmp_path):
    assert HAND_CLICK_SIGMA_PX == CLICK_PX  # the clicks are made as the default says a person clicks
    rng = np.random.default_rng(3201)
    combined_z, instant_z = [], []
    for case in range(VIDEOS):
        stereo, fish = _rig(rng), _fish(rng, seed=100 + case)
        calibration = StereoCalibration.from_cameras(stereo.left, stereo.right, "water", BOARD_SIGMA0_PX)
        left, right = _render(stereo, fish)
        folder = tmp_path / str(case)
        folder.mkdir()
        encode_video(folder / "left.mkv", left, FPS, "ffv1")
        encode_video(folder / "right.mkv", right, FPS, "ffv1")
        start = int(rng.integers(6, FRAMES - 6))
        with Project.create(folder / "survey.usvips") as project:
            add_video(project, [folder / "left.mkv"], [folder / "right.mkv"], "drop")
            calibration_id = project.add_calibration("board", calibration_to_dict(calibration), ("drop",))
            tracker = VideoTracker.read(project, "drop")
            for _ in range(LENGTHS):
                for _attempt in range(10):  # another pair of points where the tracker refuses one, as a user would
                    s = np.array([rng.uniform(0.2, 0.3), rng.uniform(0.5, 0.6)]) * fish.length
                    v = rng.uniform(-0.4, 0.4, 2) * fish.half_depth(s)
                    points = np.array([fish.body_point(start / FPS, *sv) for sv in zip(s, v, strict=True)])
                    picks_left = stereo.left.project(points).pixels + rng.normal(0.0, CLICK_PX, (2, 2))
                    picks_right = stereo.right.project(points).pixels + rng.normal(0.0, CLICK_PX, (2, 2))
                    try:
                        tracks = tracker.track_many(start, list(zip(picks_left, picks_right, strict=True)), 0,
                                                    FRAMES - 1)
                        break
                    except InvalidParameterError:
                        continue
                else:
                    continue
                m = measure_picks("length", calibration, picks_left, picks_right, 0, "rig")
                vertices = [Vertex(*picks_left[i], *picks_right[i], tuple(m.points[i]),
                                   m.covariance[3 * i:3 * i + 3, 3 * i:3 * i + 3], calibration_id, "drop", "drop",
                                   start, start, start / FPS) for i in range(2)]
                object_id = project.add_object("length", vertices, "Pagrus auratus")
                reached = set.intersection(*(set(map(int, t.frames)) for t in tracks))
                frames = [f for f in range(start % STEP, FRAMES, STEP) if f in reached and f != start]
                if len(frames) < 2:
                    continue
                add_tracked_instants(project, object_id, tracks, frames, "drop")
                source = measurement_input(project, project.object(object_id))
                truth = _truth(fish, s, v)
                combined = evaluate(source).main
                combined_z.append((combined.value - truth) / combined.sigma)
                # each instant against the fish's own snout-fork distance at that instant's time
                for instant, measured in zip((source, *source.instants), instant_measurements(source), strict=True):
                    frame = project.object(int(instant.id)).vertices[0].frame_left
                    at = np.linalg.norm(fish.body_point(frame / FPS, s[1], v[1]) - fish.body_point(frame / FPS, s[0],
                                                                                                    v[0]))
                    instant_z.append((measured.main.value - at) / measured.main.sigma)
    combined_z, instant_z = np.array(combined_z), np.array(instant_z)
    inside, inside_instants = np.mean(np.abs(combined_z) <= 2), np.mean(np.abs(instant_z) <= 2)
    print(f"{len(combined_z)} fish: combined inside 2σ {inside:.1%} (NEES {np.mean(combined_z ** 2):.2f}); "
          f"{len(instant_z)} instants inside 2σ {inside_instants:.1%} (NEES {np.mean(instant_z ** 2):.2f})")
    assert len(combined_z) >= 50
    assert inside >= 0.90 and inside_instants >= 0.90
    assert np.mean(combined_z ** 2) >= 0.4 and np.mean(instant_z ** 2) >= 0.4
