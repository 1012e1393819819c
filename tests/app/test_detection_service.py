"""Detection in a project: proposals stored as unreviewed objects made by the model (its name and hash
recorded), lengths with the model's measured sigma or none without one, never over a person's object."""

from dataclasses import replace

import numpy as np
import pytest

from tests.app.detection_scenes import fake_model, make_project, scene, write_switching_model
from usvips.app.detection_model import load_model
from usvips.app.detection_service import detect_in_project, plan_detection, run_detection
from usvips.app.project_figures import measure_stored
from usvips.app.proposals import is_proposal
from usvips.core.errors import InputFileError, UsvipsError
from usvips.core.pointing import source_from_label
from usvips.store import Project
from usvips.store.project import Vertex


@pytest.fixture
def survey(tmp_path):
    return make_project(tmp_path), scene(seed=3)


def test_proposals_are_stored_unreviewed_with_the_model_as_their_source_and_measured_lengths(survey):
    path, truth = survey
    model = fake_model(truth, sigma=0.8)
    with Project.open(path) as project:
        run = detect_in_project(project, model, pair="dive", refine=False)
        assert len(run.proposals) == 3 and all(p.object_id is not None for p in run.proposals)
        for proposal in run.proposals:
            stored = project.object(proposal.object_id)
            assert is_proposal(stored) and stored.kind == "length" and stored.creator == "model fake-fish"
            assert project.review(stored.id).state == "unreviewed"
            assert "sha256:abababababab" in stored.notes
            for vertex, point in zip(stored.vertices, ("snout", "fork"), strict=True):
                assert vertex.source == f"keypoint ({point}, model fake-fish sha256:abababababab)"
                assert source_from_label(vertex.source).kind == "keypoint"
                assert vertex.pointing_px == (0.8, 0.8) and vertex.pointing_origin == "estimated"
            fish = int(np.argmin(np.linalg.norm(truth.left[:, 0] - proposal.pair.left.keypoint("snout").pixel, axis=1)))
            main = proposal.measurement.main
            assert abs(main.value - truth.lengths[fish]) < 1e-3  # noise-free keypoints: the true length
            assert main.sigma > 0 and proposal.measurement.pointing_origin == "estimated"
            assert any("measured on test scenes" in mark for mark in proposal.measurement.marks)
        assert "3 stored as unreviewed proposals" in run.summary()[0]
        assert "measured (test scenes)" in run.summary()[1]


def test_a_stored_proposals_figure_is_its_measured_length_with_the_validated_sigma_in_image_pixels(survey):
    """A model whose σ is its held-out validation's (model input pixels, no [keypoint_sigma] table): the
    stored vertices carry the σ scaled to the frame's pixels that the length was measured with, so the object's
    figure recomputed from its picks (the object list, exports) is the proposal's, σ and all. (Before, the
    vertices got no σ and the object's figure took the keypoint source's assumed 2 px: not what was measured.)"""
    path, truth = survey
    model = fake_model(truth, sigma=None)
    model = replace(model, description=replace(model.description, validated_keypoint_sigma=(0.9, 1.3),
                                               validation_source="test validation"))
    with Project.open(path) as project:
        run = detect_in_project(project, model, pair="dive", refine=False)
        assert run.proposals and all(p.measurement is not None for p in run.proposals)
        for proposal in run.proposals:
            stored = project.object(proposal.object_id)
            used = np.asarray(proposal.measurement.pointing_sigma_px)
            assert used[0, 0] > 0.9 and used[1, 0] > 1.3  # scaled up from the input's pixels to the image's
            assert [v.pointing_px for v in stored.vertices] == [tuple(row) for row in used]
            figure = measure_stored(project, stored).main
            assert figure.value == pytest.approx(proposal.measurement.main.value, rel=1e-9)
            assert figure.sigma == pytest.approx(proposal.measurement.main.sigma, rel=1e-6)


def test_a_proposal_never_repeats_a_persons_object_nor_an_earlier_proposal(survey):
    path, truth = survey
    model = fake_model(truth)
    with Project.open(path) as project:
        # a person measured fish 1 (clicked slightly off the model's keypoints)
        (sl, fl), (sr, fr) = truth.left[1], truth.right[1]
        person = project.add_object("length", [Vertex(*(sl + 3), *(sr + 3), pair="dive"),
                                               Vertex(*(fl - 4), *(fr - 4), pair="dive")], "Pagrus auratus")
        before = project.object(person)
        run = detect_in_project(project, model, pair="dive", refine=False)
        assert sorted(p.duplicate_of for p in run.proposals if p.duplicate_of) == [person]
        assert sum(p.object_id is not None for p in run.proposals) == 2
        assert project.object(person) == before           # the person's object is untouched
        again = detect_in_project(project, model, pair="dive", refine=False)
        assert all(p.object_id is None and p.duplicate_of is not None for p in again.proposals)
        assert len(project.objects()) == 3
        assert "0 stored" in again.summary()[0] and "3 not stored" in again.summary()[0]


def test_without_a_measured_sigma_proposals_have_no_length_and_the_run_says_why(survey):
    path, truth = survey
    with Project.open(path) as project:
        run = detect_in_project(project, fake_model(truth, sigma=None), pair="dive", refine=False)
        assert run.proposals and all(p.measurement is None for p in run.proposals)
        for proposal in run.proposals:
            stored = project.object(proposal.object_id)
            assert all(v.xyz is None and v.pointing_px is None for v in stored.vertices)
            assert "no length" in proposal.line()
        assert "no measured pointing sigma for snout, fork" in run.summary()[1]
        assert "never assumed" in run.summary()[1]


def test_a_run_reports_progress_and_stops_at_a_cancel(survey):
    path, truth = survey
    with Project.open(path) as project:
        plan = plan_detection(project, pair="dive")
    seen = []
    run = run_detection(plan, fake_model(truth), progress=lambda done, total: seen.append((done, total)))
    assert seen == [(1, 1)] and run.frames_done == 1 and not run.cancelled
    stopped = run_detection(plan, fake_model(truth), cancel=lambda: True)
    assert stopped.cancelled and stopped.frames_done == 0 and not stopped.proposals


def test_what_the_project_lacks_is_named(tmp_path, survey):
    path, truth = survey
    with Project.open(path) as project:
        project.add_pair("bare")
        with pytest.raises(UsvipsError, match="no image pair 'nowhere'"):
            plan_detection(project, pair="nowhere")
        with pytest.raises(UsvipsError, match="no video 'drop'"):
            plan_detection(project, video="drop")
        with pytest.raises(UsvipsError, match="no image files"):
            plan_detection(project, pair="bare")


def test_an_onnx_model_runs_from_its_description_and_a_mismatched_description_is_refused(tmp_path, survey):
    path, truth = survey
    description = write_switching_model(tmp_path, truth, sigma=1.2)
    model = load_model(description)
    assert model.name == "fish" and len(model.sha256) == 64
    with Project.open(path) as project:
        run = detect_in_project(project, model, pair="dive")
    assert len(run.proposals) == 3 and all(p.measurement is not None for p in run.proposals)
    assert all(p.refined == 0 for p in run.proposals)  # flat images: nothing to match, the model's points kept
    text = description.read_text().replace('keypoints = ["snout", "fork"]', 'keypoints = ["snout", "fork", "eye"]')
    text = text.replace("px = {snout = 1.2, fork = 1.2}", "px = {snout = 1.2}")
    description.write_text(text)
    with pytest.raises(InputFileError, match="does not match its model's output"):
        load_model(description)


def test_on_a_video_every_kth_frame_of_a_range_is_detected_with_progress_and_a_stop_keeps_the_frames_done(survey):
    from tests.app.detection_scenes import add_video, calibration
    from usvips.io.calibration_file import calibration_to_dict

    path, truth = survey
    with Project.open(path) as project:
        add_video(path.parent, project, "drop", frames=6)
        project.add_calibration("cal", calibration_to_dict(calibration()), ("drop",))
        with pytest.raises(UsvipsError, match="frames 2:9"):
            plan_detection(project, video="drop", frames=(2, 9))
        seen = []
        run = detect_in_project(project, fake_model(truth), video="drop", every=2, frames=(1, 5), refine=False,
                                progress=lambda done, total: seen.append((done, total)))
        assert seen == [(1, 3), (2, 3), (3, 3)]
        assert sorted({p.frame for p in run.proposals}) == [1, 3, 5] and len(run.proposals) == 9
        stored = project.object(run.proposals[0].object_id)
        assert all(v.video == "drop" and v.frame_left == v.frame_right == run.proposals[0].frame for v in
                   stored.vertices)
        assert stored.vertices[0].time_s == pytest.approx(run.proposals[0].frame / 25.0)
        plan = plan_detection(project, video="drop")
    done = []
    stopped = run_detection(plan, fake_model(truth), cancel=lambda: len(done) >= 2,
                            progress=lambda d, t: done.append(d))
    assert stopped.cancelled and stopped.frames_done == 2 and {p.frame for p in stopped.proposals} == {0, 1}


def test_a_proposal_measured_with_the_stereo_sigma_by_size_keeps_its_sigma_when_stored(survey):
    """A model with a [stereo_sigma] table: each pair's keypoints get their sigma by the fish's size, and a
    right keypoint refined along the left one's curve follows it (correlated). The stored vertices say so
    (their source: 'right matched to left'), so the object's figure recomputed from its picks is the
    proposal's, σ and all; taken as independent, the σ would be far larger. (The test scenes are flat, so
    their keypoints cannot be refined: the pairs are measured here as refined ones are.)"""
    from usvips.app.detection_service import pair_pointing, store_proposals
    from usvips.core.detection.keypoint_sigma import SizeSigma, StereoSigma
    from usvips.core.detection.stereo import measure_pairs
    from usvips.core.pointing import RIGHT_FOLLOWS_LEFT

    path, truth = survey
    model = fake_model(truth, sigma=None)
    stereo = StereoSigma({n: SizeSigma(1.0, 0.01) for n in ("snout", "fork")},
                         {n: SizeSigma(0.3, 0.0) for n in ("snout", "fork")}, "test clips")
    model = replace(model, description=replace(model.description, validated_keypoint_sigma=(0.9, 1.3),
                                               validation_source="test validation", stereo_sigma=stereo))
    with Project.open(path) as project:
        plan = plan_detection(project, pair="dive")
        run = run_detection(plan, model, refine=False)
        assert run.proposals and "by the fish's size" in run.summary()[1]
        assert all(p.measurement.pointing_correlation is None for p in run.proposals)  # none refined
        follows = [[True, True], [True, False]] + [[False, True]] * (len(run.proposals) - 2)
        calibration = plan.geometry.calibration
        for i, (proposal, refined) in enumerate(zip(run.proposals, follows, strict=True)):
            own = pair_pointing(model, proposal.pair, refined, (640, 480))
            again = measure_pairs([proposal.pair], calibration, 1.0, station=plan.geometry.station,
                                  frame=plan.geometry.frame, measured_basis="test clips", pair_pointing=[own])[0]
            run.proposals[i] = replace(proposal, measurement=again)
        store_proposals(project, run)
        for proposal, refined in zip(run.proposals, follows, strict=True):
            stored = project.object(proposal.object_id)
            assert [RIGHT_FOLLOWS_LEFT in v.source for v in stored.vertices] == refined
            figure = measure_stored(project, stored).main
            assert figure.sigma == pytest.approx(proposal.measurement.main.sigma, rel=1e-6)
            independent = measure_pairs([proposal.pair], calibration, 1.0, station=plan.geometry.station,
                                        frame=plan.geometry.frame, pair_pointing=[(
                                            proposal.measurement.pointing_sigma_px, np.zeros(2))])[0].main
            assert independent.sigma > (1.2 if all(refined) else 1.0) * figure.sigma


def test_an_accepted_proposal_whose_right_keypoints_follow_the_left_counts_in_the_reviews_sigma(survey):
    """A proposal stored with 'right matched to left' sources is still the model's for the reviews' sigma and
    the training set's corrections."""
    from usvips.app.detection_review import review_corrections
    from usvips.app.detection_service import store_proposals
    from usvips.app.training_set import reviewed_samples
    from usvips.core.detection.stereo import measure_pairs

    path, truth = survey
    model = fake_model(truth, sigma=1.0)
    with Project.open(path) as project:
        plan = plan_detection(project, pair="dive")
        run = run_detection(plan, model, refine=False)
        for i, proposal in enumerate(run.proposals):
            again = measure_pairs([proposal.pair], plan.geometry.calibration, 1.0, station=plan.geometry.station,
                                  frame=plan.geometry.frame, measured_basis="test",
                                  pair_pointing=[(np.array([[1.0, 1.1]] * 2), np.array([1 / 1.1, 0.0]))])[0]
            run.proposals[i] = replace(proposal, measurement=again)
        store_proposals(project, run)
        for proposal in run.proposals:
            project.set_review(proposal.object_id, "accepted")
        proposed, reviewed = review_corrections(project, model)
        assert len(proposed) == len(run.proposals) and np.array_equal(proposed, reviewed)
        samples, _ = reviewed_samples(project)  # the training set's corrections name the model's tag alone
        assert {s.model for _, pair in samples for s in pair} == {"fake-fish sha256:abababababab"}


def test_refinements_move_limit_grows_with_the_fish_and_honest_errors_pass_it_in_99_percent_of_cases():
    """The shipped model's [stereo_sigma]: the move refinement may make (shift_limits) grows with the fish's
    size, and the moves that keypoint errors of exactly the measured σ make — the left error carried over,
    plus the match's, minus the model's right keypoint's own (as the left's) — pass it in about 99 % of
    cases (a 2-D move beyond 3σ: a Rayleigh tail of 1.1 %)."""
    from usvips.app.detection_model import bundled_model_path
    from usvips.app.detection_service import KEYPOINTS, shift_limits
    from usvips.core.detection import Detection, Keypoint
    from usvips.core.detection.stereo import StereoPair

    model = load_model(bundled_model_path())
    stereo, scale = model.stereo_sigma(KEYPOINTS), model.input_scale((640, 480))
    sizes = np.array([25.0, 60.0, 120.0, 250.0])
    pairs = []
    for size in sizes:
        detection = Detection((0, 0, size, 10), "fish", 0.9, (Keypoint("snout", 100.0, 100.0, 0.9),
                                                            Keypoint("fork", 100.0 + size, 100.0, 0.9)))
        pairs.append(StereoPair(detection, detection, 0, 0, 0.0))
    limits = shift_limits(model, pairs, (640, 480), model.keypoint_sigma(KEYPOINTS, (640, 480)))
    rng = np.random.default_rng(35)
    for name in KEYPOINTS:
        limit = np.array([table[name] for table in limits])
        assert np.all(np.diff(limit) > 0)
        for size, most in zip(sizes, limit, strict=True):
            left = float(stereo.left[name](size * scale)) / scale
            match = float(stereo.match[name](size))
            move = (rng.normal(0, left, (20000, 2)) + rng.normal(0, match, (20000, 2))
                    - rng.normal(0, left, (20000, 2)))
            beyond = np.mean(np.linalg.norm(move, axis=1) > most)
            assert 0.006 <= beyond <= 0.017, (name, size, beyond)


def _pair(left_ends, right_ends, refined):
    """A refined pair with snout and fork at ``left_ends``/``right_ends`` (px) and each right keypoint matched
    to the left one or not (``refined``)."""
    from usvips.core.detection import Detection, Keypoint
    from usvips.core.detection.refine import KeypointRefinement, RefinedPair
    from usvips.core.detection.stereo import StereoPair

    def detection(ends):
        points = tuple(Keypoint(name, float(x), float(y), 0.9) for name, (x, y) in zip(("snout", "fork"), ends,
                                                                                          strict=True))
        xs, ys = [p.x for p in points], [p.y for p in points]
        return Detection((min(xs) - 5, min(ys) - 5, max(xs) + 5, max(ys) + 5), "fish", 0.9, points)

    steps = tuple(KeypointRefinement(name, tuple(end), tuple(end), 0.9 if done else 0.2,
                                     "" if done else "no match scored above the floor")
                  for name, end, done in zip(("snout", "fork"), right_ends, refined, strict=True))
    return RefinedPair(StereoPair(detection(left_ends), detection(right_ends), 0, 0, 0.5), steps)


@pytest.mark.parametrize("right_fork, refined, refused", [
    ((260.0, 100.0), (True, False), True),    # 160 px against 100 px with the fork the model's own: refused
    ((140.0, 100.0), (False, True), True),    # 40 px against 100 px
    ((140.0, 100.0), (True, True), False),    # both matched to the left ones: the left's points, not checked
    ((140.0, 100.0), (False, False), True),
    ((240.0, 100.0), (True, False), False),   # 140 / 100 = 1.4: within 1.5
])
def test_a_pair_whose_lengths_differ_in_the_two_images_with_an_unmatched_keypoint_gets_no_length(
        right_fork, refined, refused):
    from usvips.app.detection_service import _disagreement

    why = _disagreement(_pair([(100.0, 100.0), (200.0, 100.0)], [(100.0, 100.0), right_fork], refined))
    assert bool(why) == refused
    if refused:
        assert "differ by more than 1.5" in why and "one image's keypoints are not the fish's" in why
