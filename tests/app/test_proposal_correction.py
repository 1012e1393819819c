"""A reviewer's correction of a proposal (usvips.app.proposal_correction.corrected_vertices, GUI-free): the
moved point is a hand click, the others keep the model's σ, and the stored 3-D points are those the object's
figure, recomputed from its picks, gives — the left–right correlation of an unmoved refined right point kept,
that of the moved vertex dropped."""

from dataclasses import replace

import numpy as np
import pytest

from tests.app.detection_scenes import make_project
from tests.app.test_unmeasured_proposals import refused_scene, stereo_model
from usvips.app.detection_service import (
    pair_pointing,
    plan_detection,
    run_detection,
    store_proposals,
    with_model_sigma,
)
from usvips.app.pair_geometry import pair_geometry
from usvips.app.project_figures import measure_stored
from usvips.app.proposal_correction import corrected_vertices
from usvips.core.errors import UsvipsError
from usvips.core.measurements import measure_picks
from usvips.core.pointing import HAND_CLICK_SIGMA_PX, RIGHT_FOLLOWS_LEFT
from usvips.store import Project


@pytest.fixture
def stored_refined(tmp_path):
    """A proposal stored without a length whose two right keypoints were refined (they follow the left), given
    the sigma it would have been measured with (usvips.app.detection_service.with_model_sigma)."""
    truth, true_fork = refused_scene()
    path = make_project(tmp_path)
    model = stereo_model(truth)
    project = Project.open(path)
    run = run_detection(plan_detection(project, pair="dive"), model, refine=False)
    i = next(i for i, p in enumerate(run.proposals) if p.measurement is None)
    sigmas, _ = pair_pointing(model, run.proposals[i].pair, [True, True], (1280, 960))
    run.proposals[i] = replace(run.proposals[i], pointing=tuple(map(tuple, sigmas.tolist())),
                               right_follows=(True, True))
    store_proposals(project, run)
    stored = project.object(run.proposals[i].object_id)
    project.update_object(stored.id, vertices=with_model_sigma(stored.vertices, run.proposals[i], model))
    yield project, project.object(stored.id), truth, true_fork
    project.close()


def test_moving_a_refined_vertexs_left_point_makes_it_independent_and_keeps_the_other_correlated(stored_refined):
    project, stored, truth, _ = stored_refined
    geometry = pair_geometry(project, "dive")
    snout = stored.vertices[0]
    assert all(RIGHT_FOLLOWS_LEFT in v.source for v in stored.vertices) and stored.vertices[0].xyz is None
    vertices = corrected_vertices(stored, 0, "left", (snout.xl + 0.7, snout.yl - 0.4), geometry, "ben")
    assert vertices[0].source == "hand click (snout, by ben)" and RIGHT_FOLLOWS_LEFT in vertices[1].source
    assert vertices[0].pointing_px == (HAND_CLICK_SIGMA_PX, snout.pointing_px[1])
    project.update_object(stored.id, vertices=vertices)
    figure = measure_stored(project, project.object(stored.id))
    assert np.allclose(figure.points, [v.xyz for v in vertices], atol=1e-12)
    for i, v in enumerate(vertices):  # the stored covariance is the recomputed figure's, correlation and all
        assert np.allclose(v.covariance, figure.covariance[3 * i:3 * i + 3, 3 * i:3 * i + 3], rtol=1e-9, atol=0)
    sigmas = np.array([v.pointing_px for v in vertices])
    left = np.array([(v.xl, v.yl) for v in vertices])
    right = np.array([(v.xr, v.yr) for v in vertices])
    independent = measure_picks("length", geometry.calibration, left, right, geometry.station, geometry.frame,
                                pointing_sigma_px=sigmas)
    correlated = measure_picks("length", geometry.calibration, left, right, geometry.station, geometry.frame,
                               pointing_sigma_px=sigmas,
                               pointing_correlation=np.array([0.0, sigmas[1, 0] / sigmas[1, 1]]))
    assert figure.main.sigma == pytest.approx(correlated.main.sigma, rel=1e-9)
    assert abs(correlated.main.sigma - independent.main.sigma) > 1e-3 * independent.main.sigma


def test_both_sides_moved_make_the_vertex_a_whole_hand_click(stored_refined):
    project, stored, truth, true_fork = stored_refined
    geometry = pair_geometry(project, "dive")
    once = replace(stored, vertices=corrected_vertices(stored, 1, "right", tuple(true_fork), geometry, "ben"))
    twice = corrected_vertices(once, 1, "left", tuple(truth.left[0][1]), geometry, "ben")
    assert twice[1].pointing_px == (HAND_CLICK_SIGMA_PX, HAND_CLICK_SIGMA_PX)
    assert twice[1].source == "hand click (fork, by ben)" and twice[0].source == stored.vertices[0].source


def test_a_correction_without_a_sigma_or_geometry_leaves_the_points_out_and_bad_requests_are_named(stored_refined):
    project, stored, _, _ = stored_refined
    geometry = pair_geometry(project, "dive")
    bare = replace(stored, vertices=[replace(v, pointing_px=None) for v in stored.vertices])
    assert all(v.xyz is None for v in corrected_vertices(bare, 0, "right", (10.0, 10.0), geometry, "ben"))
    assert all(v.xyz is None for v in corrected_vertices(stored, 0, "right", (10.0, 10.0), None, "ben"))
    with pytest.raises(UsvipsError, match="left or right image, not 'top'"):
        corrected_vertices(stored, 0, "top", (10.0, 10.0), geometry, "ben")
    with pytest.raises(UsvipsError, match="vertices 1 to 2, not 3"):
        corrected_vertices(stored, 2, "left", (10.0, 10.0), geometry, "ben")


def test_a_first_correction_whose_rays_do_not_meet_yet_is_stored_without_points_not_refused(stored_refined):
    """The first keypoint a reviewer moves may leave the other side's wrong one with rays that do not meet in
    front of the cameras (a negative disparity): the move is kept, without 3-D points, until the rest is
    corrected."""
    project, stored, _, _ = stored_refined
    geometry = pair_geometry(project, "dive")
    fork = stored.vertices[1]
    vertices = corrected_vertices(stored, 1, "left", (fork.xr - 150.0, fork.yr), geometry, "ben")
    assert (vertices[1].xl, vertices[1].source) == (fork.xr - 150.0, "hand click (fork, by ben)")
    assert all(v.xyz is None and v.covariance is None and v.calibration_id is None for v in vertices)


def test_a_moved_keypoint_takes_the_reviewers_hand_click_estimate_in_use(stored_refined):
    """A dragged keypoint is the reviewer's click: its σ is the project's hand-click estimate in use for them
    (their own, else anyone's), as their other clicks take — not the 0.5 px default while an estimate is in
    use — and the stored 3-D points are measured with it."""
    from usvips.app.pointing_settings import add_estimate
    from usvips.app.proposal_correction import hand_click_sigma
    from usvips.core.pointing_estimates import from_pointing_test

    project, stored, truth, _ = stored_refined
    geometry = pair_geometry(project, "dive")
    assert hand_click_sigma(project, "ben") == HAND_CLICK_SIGMA_PX
    rng = np.random.default_rng(3)
    clicks = rng.uniform(0, 900, (40, 2))
    bens = from_pointing_test(clicks + rng.normal(0, 1.6, clicks.shape), clicks)
    anyones = from_pointing_test(clicks + rng.normal(0, 0.9, clicks.shape), clicks)
    add_estimate(project, bens, "ben")
    add_estimate(project, anyones, "")
    assert hand_click_sigma(project, "ben") == pytest.approx(bens.sigma_px)
    assert hand_click_sigma(project, "ana") == pytest.approx(anyones.sigma_px)
    assert abs(bens.sigma_px - HAND_CLICK_SIGMA_PX) > 0.5
    fork = stored.vertices[1]
    moved = corrected_vertices(stored, 1, "right", (fork.xr + 0.8, fork.yr), geometry, "ben",
                               hand_click_sigma(project, "ben"))
    assert moved[1].pointing_px == (fork.pointing_px[0], pytest.approx(bens.sigma_px))
    default = corrected_vertices(stored, 1, "right", (fork.xr + 0.8, fork.yr), geometry, "ben")
    assert default[1].pointing_px == (fork.pointing_px[0], HAND_CLICK_SIGMA_PX)
    # a larger click σ widens the stored point's covariance
    assert np.trace(moved[1].covariance) > np.trace(default[1].covariance)
    with pytest.raises(UsvipsError, match="click_sigma_px"):
        corrected_vertices(stored, 1, "right", (fork.xr, fork.yr), geometry, "ben", 0.0)
