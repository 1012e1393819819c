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
        for round_ in range(12):
            truth = scene(seed=100 + round_, count=3)
            noisy = scene(seed=100 + round_, count=3)
            noisy.left = truth.left + rng.normal(0, model_sigma, truth.left.shape)
            run = detect_in_project(project, fake_model(noisy), pair="dive", refine=False)
            for proposal in run.proposals:
                if proposal.object_id is None:
                    continue
                stored = project.object(proposal.object_id)
                fish = int(np.argmin(np.linalg.norm(noisy.left[:, 0] - (stored.vertices[0].xl, stored.vertices[0].yl),
                                                    axis=1)))
                clicked = truth.left[fish] + rng.normal(0, reviewer_sigma, (2, 2))
                vertices = [Vertex(float(x), float(y), v.xr, v.yr, pair="dive") for (x, y), v in
                            zip(clicked, stored.vertices, strict=True)]
                project.update_object(stored.id, vertices=vertices)
                project.set_review(stored.id, "accepted")
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
