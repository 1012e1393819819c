"""A video run's proposals joined into fish (usvips/app/detection_tracks.py through store_proposals): the
proposals of one fish on successive frames become one object with further instants (picked, not tracked),
the survey counts it once and its length combines its instants; a person's object, a duplicate, a proposal
without a length are never joined; fish that cross near each other are kept apart."""

from dataclasses import replace

import numpy as np
import pytest

from tests.app.detection_scenes import (
    BRIGHT,
    DARK,
    add_video,
    calibration,
    description,
    detections,
    make_project,
    scene,
)
from usvips.app.detection_model import DetectionModel
from usvips.app.detection_service import detect_in_project
from usvips.app.object_instants import survey_objects
from usvips.app.project_figures import evaluate, instant_measurements, instant_pointing, measurement_input
from usvips.core.errors import InvalidParameterError
from usvips.core.measurements.instants import combine_measurements
from usvips.io.calibration_file import calibration_to_dict
from usvips.store import Project
from usvips.store.project import Vertex

FPS = 25.0


class MovingDetector:
    """Gives, on the n-th stereo frame detected on (left, then right), each fish moved by its velocity
    (m/s) for n / 25 s, imaged through the scene's rig: dark images are left, bright ones right."""

    def __init__(self, fish: np.ndarray, velocity: np.ndarray, every: int = 1) -> None:
        self.fish, self.velocity, self.every, self.calls = fish, velocity, every, 0
        self.rig = calibration().rig(0, "rig")

    def detect(self, image):
        frame = self.calls // 2 * self.every
        self.calls += 1
        bodies = self.fish + self.velocity[:, None, :] * frame / FPS
        camera = self.rig.left if float(np.mean(image)) < (DARK + BRIGHT) / 2 else self.rig.right
        return detections(np.array([camera.project(b).pixels for b in bodies]))


def _model(fish, velocity, every=1, sigma=0.8):
    return DetectionModel("moving-fish", "cd" * 32, description(sigma), lambda: MovingDetector(fish, velocity, every))


@pytest.fixture
def video(tmp_path):
    path = make_project(tmp_path)
    with Project.open(path) as project:
        add_video(tmp_path, project, "drop", frames=6)
        project.add_calibration("cal", calibration_to_dict(calibration()), ("drop",))
    return path, scene(seed=3)


def test_each_fish_seen_on_several_frames_is_one_object_with_its_frames_as_instants(video):
    path, truth = video
    velocity = np.array([[0.3, 0.0, 0.0], [0.0, 0.2, 0.0], [-0.4, 0.1, 0.05]])  # m/s, within 1.5 m/s
    with Project.open(path) as project:
        run = detect_in_project(project, _model(truth.fish, velocity), video="drop", refine=False)
        assert len(run.proposals) == 18 and run.joined is not None
        assert len(run.joined.fish) == 3 and run.joined.instants == 15 and run.joined.ambiguous == 0
        fish = survey_objects(project)
        assert len(fish) == 3  # the survey counts each fish once
        for stored in fish:
            instants = project.instants(stored.id)
            assert len(instants) == 5 and stored.vertices[0].frame_left == 0
            assert [project.object(i).vertices[0].frame_left for i in instants] == [1, 2, 3, 4, 5]
            # each instant was detected on its own frame: picked, not tracked
            assert set(project.instant_sources(stored.id).values()) == {None}
            combined = evaluate(measurement_input(project, stored))
            assert combined.instant_count == 6
            nearest = int(np.argmin(np.linalg.norm(truth.fish[:, 0] - stored.vertices[0].xyz, axis=1)))
            assert abs(combined.main.value - truth.lengths[nearest]) < 3 * combined.main.sigma
        lines = [p.line() for p in run.proposals]
        assert sum("instant of object" in line for line in lines) == 15
        assert "3 fish seen on several frames joined into objects with 15 further instant(s)" in run.summary()[1]


def test_a_fish_faster_than_the_stated_speed_is_not_joined(video):
    path, truth = video
    velocity = np.array([[3.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]])  # the first fish darts at 3 m/s
    with Project.open(path) as project:
        run = detect_in_project(project, _model(truth.fish[:1], velocity[:1]), video="drop", frames=(0, 2),
                                refine=False)
        assert run.joined.fish == () and len(survey_objects(project)) == 3
    with Project.open(path) as project:
        run = detect_in_project(project, _model(truth.fish[:1], velocity[:1]), video="drop", frames=(3, 5),
                                refine=False, max_speed_m_s=4.0)
        assert len(run.joined.fish) == 1 and run.joined.instants == 2


def test_a_persons_object_and_proposals_without_a_length_are_never_joined(video):
    path, truth = video
    still = np.zeros((3, 3))
    rig = calibration().rig(0, "rig")
    with Project.open(path) as project:
        # a person measured fish 0 on frame 2: the model's proposal there is its duplicate, not stored
        left, right = rig.left.project(truth.fish[0]).pixels, rig.right.project(truth.fish[0]).pixels
        person = project.add_object("length", [Vertex(*left[i], *right[i], pair="drop", video="drop", frame_left=2,
                                                      frame_right=2, time_s=0.08) for i in range(2)], "Pagrus auratus")
        before = project.object(person)
        run = detect_in_project(project, _model(truth.fish, still), video="drop", frames=(0, 4), refine=False)
        assert [p.frame for p in run.proposals if p.duplicate_of == person] == [2]
        assert project.object(person) == before and project.instants(person) == []
        assert person not in project.instant_links()
        # fish 0's proposals on frames 0, 1, 3, 4 are joined over the frame where the person's object stands
        assert run.joined.instants == 3 + 4 + 4
        frames = sorted([project.object(w).vertices[0].frame_left]
                        + [project.object(i).vertices[0].frame_left for i in rest] for w, rest in run.joined.fish)
        assert frames == [[0, 1, 2, 3, 4], [0, 1, 2, 3, 4], [0, 1, 3, 4]]
    with Project.open(path) as project:
        run = detect_in_project(project, _model(truth.fish, still, sigma=None), video="drop", frames=(5, 5),
                                refine=False)
        assert run.joined.fish == () and "3 proposal(s) without a length not joined" in run.summary()[1]


def test_a_bad_speed_is_refused_before_anything_is_stored(video):
    path, truth = video
    with Project.open(path) as project:
        with pytest.raises(InvalidParameterError, match="max_speed"):
            detect_in_project(project, _model(truth.fish, np.zeros((3, 3))), video="drop", refine=False,
                              max_speed_m_s=0.0)
        assert project.objects() == []


def test_batch_detect_joins_each_video_fish_into_one_object(video):
    from tests.app.detection_scenes import write_switching_model
    from usvips.app.detection_batch import detect_project_task

    path, truth = video
    model = write_switching_model(path.parent, truth, sigma=1.0)  # the same keypoints on every frame: still fish
    summary = detect_project_task(str(path), str(model))
    assert summary["instants"] == 3 * 5 and summary["proposals"] == 3 + 3 * 6
    with Project.open(path) as project:
        assert len(survey_objects(project)) == 3 + 3  # the pair's three fish, and the video's three once each


def test_a_fish_joined_over_frames_keeps_its_models_error_as_one_error(video):
    """A model's error on one fish repeats on the frames that see it (on rendered survey clips the combined
    lengths of fish joined over 4 frames erred by 1.7 times their sigma, NEES 3.0, when the instants counted
    as independent: docs/detection.md, "Acceptance"), so combining a still fish's identical proposals does
    not shrink the keypoints' share of its sigma by √6 — it stays the single proposal's."""
    path, truth = video
    with Project.open(path) as project:
        run = detect_in_project(project, _model(truth.fish[:1], np.zeros((1, 3))), video="drop", refine=False)
        assert len(run.joined.fish) == 1 and run.joined.instants == 5
        whole = project.object(run.joined.fish[0][0])
        single = evaluate(measurement_input(project, whole, with_instants=False)).main
        combined = evaluate(measurement_input(project, whole)).main
        assert combined.value == pytest.approx(single.value, abs=1e-9)
        assert combined.sigma >= single.sigma * 0.999


def test_a_joined_fish_keeps_whole_the_share_of_its_pointing_error_the_models_frame_correlation_says(tmp_path):
    """A model with a measured frame correlation states it in its proposals' sources; the fish joined over
    frames is combined with it: its σ lies between the independent instants' and the whole error's (what a
    model without one gets), and equals the one combination computed from the instants directly."""
    truth = scene(seed=3)
    velocity = np.array([[0.3, 0.0, 0.0], [0.0, 0.2, 0.0], [-0.4, 0.1, 0.05]])
    plain = _model(truth.fish, velocity)
    correlated = DetectionModel("moving-fish", "cd" * 32, replace(plain.description, frame_correlation=0.4),
                                lambda: MovingDetector(truth.fish, velocity))
    sigmas = {}
    for name, model in (("whole", plain), ("correlated", correlated)):
        folder = tmp_path / name
        folder.mkdir()
        path = make_project(folder)
        with Project.open(path) as project:
            add_video(folder, project, "drop", frames=6)
            project.add_calibration("cal", calibration_to_dict(calibration()), ("drop",))
            detect_in_project(project, model, video="drop", refine=False)
            fish = survey_objects(project)
            assert len(fish) == 3
            sources = {v.source for f in fish for i in (f.id, *project.instants(f.id))
                       for v in project.object(i).vertices}
            assert all(("frame correlation 0.400" in s) == (name == "correlated") for s in sources), sources
            source = measurement_input(project, fish[0])
            sigmas[name] = evaluate(source).main.sigma
            measured, pointing = instant_measurements(source), instant_pointing(source)
            independent = combine_measurements(measured, pointing).main.sigma
            if name == "correlated":
                assert sigmas[name] == pytest.approx(
                    combine_measurements(measured, pointing, shared_fraction=0.4).main.sigma, rel=1e-12)
    assert independent < sigmas["correlated"] < sigmas["whole"]


def test_a_reviewers_correction_of_one_instant_makes_only_that_instant_a_persons(tmp_path):
    """A reviewer moves the snout of one instant of a fish joined over frames: that point is now a person's
    click, independent of the model's other frames. The fish is still combined with the model's frame
    correlation — per instant, ρ for the model's instants and ρ × ½ for the corrected one (one of its two
    points is still the model's) — not as wholly independent instants (which it was before: too sure)."""
    truth = scene(seed=3)
    velocity = np.array([[0.3, 0.0, 0.0], [0.0, 0.2, 0.0], [-0.4, 0.1, 0.05]])
    plain = _model(truth.fish, velocity)
    model = DetectionModel("moving-fish", "cd" * 32, replace(plain.description, frame_correlation=0.4),
                           lambda: MovingDetector(truth.fish, velocity))
    path = make_project(tmp_path)
    with Project.open(path) as project:
        add_video(tmp_path, project, "drop", frames=6)
        project.add_calibration("cal", calibration_to_dict(calibration()), ("drop",))
        detect_in_project(project, model, video="drop", refine=False)
        fish = survey_objects(project)[0]
        instants = project.instants(fish.id)
        assert len(instants) >= 3
        corrected = project.object(instants[1])
        snout = replace(corrected.vertices[0], xl=corrected.vertices[0].xl + 0.6, source="hand click",
                        pointing_px=None, pointing_origin="default")
        project.update_object(corrected.id, vertices=[snout, *corrected.vertices[1:]])
        source = measurement_input(project, project.object(fish.id))
        assert [i.model_share for i in (source, *source.instants)] == [1.0, 1.0, 0.5] + [1.0] * (len(instants) - 2)
        sigma = evaluate(source).main.sigma
        measured, pointing = instant_measurements(source), instant_pointing(source)
        shares = [0.4, 0.4, 0.2] + [0.4] * (len(instants) - 2)
        assert sigma == pytest.approx(combine_measurements(measured, pointing, shared_fraction=shares).main.sigma,
                                      rel=1e-12)
        assert combine_measurements(measured, pointing).main.sigma < sigma
