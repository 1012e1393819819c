"""The keypoint sigma of a model measured from reviewers' corrections of its accepted proposals in a
project: proposals stored by the service, reviewers re-picking each (left) keypoint onto the true point
with their own pointing noise, then accepting; the measured sigma recovers the model's."""

import numpy as np

from tests.app.detection_scenes import fake_model, make_project, scene
from usvips.app.detection_review import description_table, review_corrections, sigma_from_reviews
from usvips.app.detection_service import detect_in_project
from usvips.store import Project
from usvips.store.project import Vertex


def test_reviewers_corrections_measure_the_models_keypoint_sigma(tmp_path):
    rng = np.random.default_rng(35)
    model_sigma, reviewer_sigma = 2.0, 0.5
    path = make_project(tmp_path)
    with Project.open(path) as project:
        _reviewed_rounds(project, fake_model, rng, 12, 100, model_sigma, reviewer_sigma, right_noisy=False)
        model = fake_model(scene(seed=0))
        proposed, reviewed = review_corrections(project, model)
        assert len(proposed) == len(project.reviews("accepted")) >= 20
        measured = sigma_from_reviews(project, model, reviewer_sigma_px=reviewer_sigma)
    for name in ("snout", "fork"):
        s = measured[name].sigma
        assert abs(s.value_px - model_sigma) < 3 * s.uncertainty_px, (name, s)
        assert s.origin == "estimated" and "corrections" in measured[name].basis
    table = description_table(measured, "reviews of survey 2026")
    assert table.startswith("[keypoint_sigma]") and '"snout" = ' in table


def test_the_reviews_of_a_model_with_a_frame_correlation_are_all_found(tmp_path):
    """A measured proposal of a model that states a frame correlation stores it in its vertices' source
    (``, frame correlation ρ``): its accepted proposals are the model's all the same."""
    from dataclasses import replace

    from tests.app.detection_scenes import FakeDetector, description
    from usvips.app.detection_model import DetectionModel

    def correlated(truth):
        return DetectionModel("fake-fish", "ab" * 32, replace(description(1.0), frame_correlation=0.3),
                              lambda: FakeDetector(truth))

    rng = np.random.default_rng(36)
    path = make_project(tmp_path)
    with Project.open(path) as project:
        ids = _reviewed_rounds(project, correlated, rng, 6, 200, 2.0, right_noisy=False)
        model = correlated(scene(seed=0))
        first = project.history(ids[0][0])[0].new["vertices"][0]["source"]
        assert "frame correlation" in first  # stored measured, with the correlation
        proposed, reviewed = review_corrections(project, model)
        assert len(proposed) == len(project.reviews("accepted")) == len(ids) >= 10


def _reviewed_rounds(project, model_of, rng, rounds, seed, model_sigma, reviewer_sigma=0.5, right_noisy=True):
    """``rounds`` detections on the pair, the model's keypoints off the truth by ``model_sigma`` px in the
    left image (and the right one, ``right_noisy``); each proposal's left keypoints re-picked onto the truth
    (reviewer noise) and accepted. Returns each proposal's stored object id and its fish's true length."""
    out = []
    for round_ in range(rounds):
        truth = scene(seed=seed + round_, count=3)
        noisy = scene(seed=seed + round_, count=3)
        noisy.left = truth.left + rng.normal(0, model_sigma, truth.left.shape)
        if right_noisy:
            noisy.right = truth.right + rng.normal(0, model_sigma, truth.right.shape)
        run = detect_in_project(project, model_of(noisy), pair="dive", refine=False)
        for proposal in run.proposals:
            if proposal.object_id is None:
                continue
            stored = project.object(proposal.object_id)
            fish = int(np.argmin(np.linalg.norm(noisy.left[:, 0] - (stored.vertices[0].xl, stored.vertices[0].yl),
                                                axis=1)))
            out.append((stored.id, float(truth.lengths[fish])))
            if reviewer_sigma is None:
                continue
            clicked = truth.left[fish] + rng.normal(0, reviewer_sigma, (2, 2))
            project.update_object(stored.id, vertices=[Vertex(float(x), float(y), v.xr, v.yr, pair="dive")
                                                       for (x, y), v in zip(clicked, stored.vertices, strict=True)])
            project.set_review(stored.id, "accepted")
    return out


def test_the_sigma_measured_from_reviews_gives_the_next_proposals_lengths_an_honest_sigma(tmp_path):
    """The loop a team runs: reviews measure the model's σ (``usvips detect --review-sigma``), its
    ``[keypoint_sigma]`` table goes into the description file, and the model's next proposals are measured
    with it: their vertices carry it, their lengths say they rest on the reviewers' corrections, and over
    them the lengths' NEES lies within what an honest σ gives for their count (the model's noise is 2 px in
    each image; with the 0.5 px its first description claimed, the NEES would be 16 times as large)."""
    from dataclasses import replace

    from usvips.app.project_figures import measure_stored
    from usvips.io.model_description import read_model_description

    rng = np.random.default_rng(351)
    first, second = tmp_path / "first", tmp_path / "second"
    first.mkdir()
    second.mkdir()
    with Project.open(make_project(first)) as project:
        _reviewed_rounds(project, lambda noisy: fake_model(noisy, sigma=0.5), rng, 12, 300, 2.0)
        measured = sigma_from_reviews(project, fake_model(scene(seed=0), sigma=0.5))
    description = tmp_path / "fish.toml"
    description.write_text('[model]\nfile = "fish.onnx"\nfamily = "yolo-pose"\ninput_width = 320\n'
                           'input_height = 320\n\n[output]\nclasses = ["fish"]\nkeypoints = ["snout", "fork"]\n\n'
                           + description_table(measured, "reviews of the first survey"))
    reviewed = read_model_description(description)
    with Project.open(make_project(second)) as project:
        def model_of(noisy):
            return replace(fake_model(noisy), description=reviewed)

        lengths = _reviewed_rounds(project, model_of, rng, 14, 600, 2.0, reviewer_sigma=None)
        z = []
        for object_id, true_length in lengths:
            stored = project.object(object_id)
            for vertex, name in zip(stored.vertices, ("snout", "fork"), strict=True):
                assert vertex.pointing_px == (reviewed.measured_sigma(name),) * 2
            assert "keypoint pointing sigma measured on reviews of the first survey" in stored.notes
            figure = measure_stored(project, stored)
            z.append((figure.main.value - true_length) / figure.main.sigma)
    n = len(z)
    assert n >= 30
    assert abs(np.mean(np.square(z)) - 1) <= 3 * np.sqrt(2 / n)
