"""Issue 25's promise, end to end: over many random rendered stereo videos of a swimming, bending fish
(random rigs, housings, poses), a length picked with pixel noise on one frame, tracked through the video
(:mod:`usvips.app.tracking`), stored as instants (:func:`add_tracked_instants`) and combined by the one
figure function the window and the exports use (:mod:`usvips.app.project_figures`) has a mean squared
normalised error near 1 against the true length, and a smaller error than one instant's."""

import numpy as np

from tests.core.scenes import HOUSINGS
from tests.core.test_tracking import floor_seen
from usvips.app.project_figures import evaluate, instant_measurements, measurement_input
from usvips.app.tracking import VideoTracker, add_tracked_instants
from usvips.app.video_project import add_video
from usvips.core.camera import Camera, Exterior
from usvips.core.errors import InvalidParameterError
from usvips.core.interior import Interior
from usvips.core.measurements import measure_picks
from usvips.core.rig import RelativeOrientation, StereoRig
from usvips.core.stereo_calibration import StereoCalibration
from usvips.core.synth.swimming import SwimmingFish
from usvips.io.calibration_file import calibration_to_dict
from usvips.io.video_writer import encode_video
from usvips.store import Project
from usvips.store.project import Vertex

W, H, FRAMES, FPS = 320, 240, 24, 25.0
VIDEOS, LENGTHS = 10, 6  # random videos, and lengths picked (each with its own pick noise) on each
STEP = 4  # frames between the stored instants


def _rig(rng) -> StereoRig:
    interior = Interior(rng.uniform(280, 340), W / 2 + rng.uniform(-6, 6), H / 2 + rng.uniform(-6, 6), 1.0,
                        k1=rng.uniform(-0.08, 0.02))
    housing = HOUSINGS[str(rng.choice(["flat-port", "dome-cover"]))]
    left = Camera(interior, Exterior(0.0, 0.0, 0.0, 0.0, 0.0, 0.0), housing, W, H)
    return StereoRig.from_relative(left, left, RelativeOrientation(rng.uniform(0.25, 0.35), rng.uniform(-0.01, 0.01),
                                                                   rng.uniform(-0.01, 0.01), rng.uniform(-0.02, 0.02),
                                                                   rng.uniform(-0.09, -0.04), rng.uniform(-0.02, 0.02)))


def _fish(rng, seed: int) -> SwimmingFish:
    # it swims across both views along x at about a metre, slowly enough to stay in view for FRAMES frames
    return SwimmingFish(start=(rng.uniform(0.24, 0.34), rng.uniform(-0.05, 0.05), -rng.uniform(0.9, 1.15)),
                        heading=(1.0, rng.uniform(-0.1, 0.1), rng.uniform(-0.15, 0.15)),
                        length=rng.uniform(0.3, 0.4), speed=rng.uniform(0.03, 0.12), bend=rng.uniform(0.2, 0.6),
                        beat_hz=rng.uniform(1.0, 2.5), phase=rng.uniform(0, 2 * np.pi), seed=seed)


def _render(stereo: StereoRig, fish: SwimmingFish) -> list[list[np.ndarray]]:
    """Each camera's FRAMES frames (grey as RGB): the fish before a textured floor 3 m away."""
    videos = []
    for camera in (stereo.left, stereo.right):
        bundle, floor = floor_seen(camera)
        frames = []
        for i in range(FRAMES):
            t, grey = fish.at(i / FPS).hit(bundle.origins, bundle.directions)
            image = np.clip(np.rint(np.where(np.isfinite(t), grey, floor)), 0, 255).astype(np.uint8).reshape(H, W)
            frames.append(np.repeat(image[:, :, None], 3, axis=2))
        videos.append(frames)
    return videos


def _truth(fish: SwimmingFish, s: np.ndarray, v: np.ndarray) -> float:
    """What the combination estimates: the distance between the two body points averaged over a tail beat."""
    times = np.linspace(0.0, 1.0 / fish.beat_hz, 60, endpoint=False)
    return float(np.mean([np.linalg.norm(fish.body_point(t, s[1], v[1]) - fish.body_point(t, s[0], v[0]))
                          for t in times]))


def test_a_tracked_length_combined_over_its_instants_is_honest_and_better_than_one_instant(tmp_path):
    rng = np.random.default_rng(2511)
    normalised, combined_errors, single_errors, counts = [], [], [], []
    refused = 0
    for case in range(VIDEOS):
        stereo, fish = _rig(rng), _fish(rng, seed=case)
        sigma_px = rng.uniform(0.2, 0.5)  # the picks' noise, stored as their pointing sigma (and the sigma0)
        calibration = StereoCalibration.from_cameras(stereo.left, stereo.right, "water", sigma_px)
        left, right = _render(stereo, fish)
        folder = tmp_path / str(case)
        folder.mkdir()
        encode_video(folder / "left.mkv", left, FPS, "ffv1")
        encode_video(folder / "right.mkv", right, FPS, "ffv1")
        start = int(rng.integers(6, FRAMES - 6))
        with Project.create(folder / "survey.usvips") as project:
            add_video(project, [folder / "left.mkv"], [folder / "right.mkv"], "drop")
            calibration_id = project.add_calibration("cal", calibration_to_dict(calibration), ("drop",))
            tracker = VideoTracker.read(project, "drop")
            for _ in range(LENGTHS):
                for _attempt in range(10):  # as a user would, another pair of points where the tracker refuses one
                    # a length of a fifth to two fifths of the fish between two points of its deep body (a
                    # much shorter one, a few sigmas of depth long, has a sigma that its noisy direction inflates)
                    s = np.array([rng.uniform(0.2, 0.3), rng.uniform(0.5, 0.6)]) * fish.length
                    v = rng.uniform(-0.4, 0.4, 2) * fish.half_depth(s)  # on the deep body, off the midline
                    points = np.array([fish.body_point(start / FPS, *sv) for sv in zip(s, v, strict=True)])
                    picks_left = stereo.left.project(points).pixels + rng.normal(0.0, sigma_px, (2, 2))
                    picks_right = stereo.right.project(points).pixels + rng.normal(0.0, sigma_px, (2, 2))
                    try:
                        tracks = tracker.track_many(start, list(zip(picks_left, picks_right, strict=True)), 0,
                                                    FRAMES - 1)
                        break
                    except InvalidParameterError:  # featureless or an edge: the tracker says so, nothing stored
                        refused += 1
                else:
                    continue
                m = measure_picks("length", calibration, picks_left, picks_right, 0, "rig", pointing_sigma_px=sigma_px)
                vertices = [Vertex(*picks_left[i], *picks_right[i], tuple(m.points[i]),
                                   m.covariance[3 * i:3 * i + 3, 3 * i:3 * i + 3], calibration_id, "drop", "drop",
                                   start, start, start / FPS, pointing_px=(sigma_px, sigma_px), pointing_origin="given")
                            for i in range(2)]
                object_id = project.add_object("length", vertices, "Pagrus auratus")
                reached = set.intersection(*(set(map(int, t.frames)) for t in tracks))
                frames = [f for f in range(start % STEP, FRAMES, STEP) if f in reached and f != start]
                if len(frames) < 2:
                    continue
                add_tracked_instants(project, object_id, tracks, frames, "drop")
                source = measurement_input(project, project.object(object_id))
                combined = evaluate(source).main
                truth = _truth(fish, s, v)
                normalised.append(((combined.value - truth) / combined.sigma) ** 2)
                combined_errors.append(combined.value - truth)
                single_errors.extend(m.main.value - truth for m in instant_measurements(source))
                counts.append(len(frames) + 1)
    msne = float(np.mean(normalised))
    rms_combined = float(np.sqrt(np.mean(np.square(combined_errors))))
    rms_single = float(np.sqrt(np.mean(np.square(single_errors))))
    print(f"{len(normalised)} lengths, {np.mean(counts):.1f} instants each: MSNE {msne:.3f}, RMS error combined "
          f"{rms_combined * 1000:.2f} mm, one instant {rms_single * 1000:.2f} mm; {refused} picks refused")
    assert len(normalised) >= 0.8 * VIDEOS * LENGTHS  # the lengths tracked far enough to make instants
    assert 0.7 <= msne <= 1.5, msne
    assert rms_combined < rms_single
