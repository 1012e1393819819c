"""A proposal WITHOUT a length (its pair refused) carries the pointing sigma the model's [stereo_sigma] gives
its keypoints by the fish's size; given it, a reviewer's correction of the wrong keypoint measures it
(usvips.app.proposal_correction.corrected_vertices, the window's drag). It is not stored
(STORE_UNMEASURED_SIGMA off): such corrected lengths' σ was conservative (docs/detection.md)."""

from dataclasses import replace

import numpy as np
import pytest

from tests.app.detection_scenes import calibration, fake_model, make_project, scene
from tests.core.calibration_scenes import HEIGHT, WIDTH
from usvips.app.detection_service import (
    KEYPOINTS,
    detect_in_project,
    pair_pointing,
    plan_detection,
    run_detection,
    with_model_sigma,
)
from usvips.app.pair_geometry import pair_geometry
from usvips.app.project_figures import UNMEASURED, measure_stored
from usvips.app.proposal_correction import corrected_vertices
from usvips.core.detection.keypoint_sigma import SizeSigma, StereoSigma
from usvips.core.errors import UsvipsError
from usvips.core.measurements import measure_picks
from usvips.core.pointing import HAND_CLICK_SIGMA_PX, RIGHT_FOLLOWS_LEFT
from usvips.store import Project


def stereo_model(truth, sigma_table: float | None = None):
    """The fake model with a [stereo_sigma] table (the right keypoints the model's own get the ``unmatched``
    sigma), or with one measured sigma per keypoint (``sigma_table``) and no [stereo_sigma]."""
    model = fake_model(truth, sigma=sigma_table)
    if sigma_table is not None:
        return model
    stereo = StereoSigma({n: SizeSigma(1.0, 0.01) for n in KEYPOINTS}, {n: SizeSigma(0.3, 0.0) for n in KEYPOINTS},
                         "test clips", {n: SizeSigma(1.5, 0.012) for n in KEYPOINTS})
    return replace(model, description=replace(model.description, validated_keypoint_sigma=(0.9, 1.3),
                                               validation_source="test validation", stereo_sigma=stereo))


def refused_scene():
    """The test scene with fish 0's right fork moved along its left fork's epipolar curve to twice the depth:
    on the curve (paired), but the fish's right length 145 px against 266 px in the left image — refused
    (the right keypoints are the model's own, the length ratio beyond 1.5). Returns the scene and the true
    right fork."""
    truth = scene(seed=3)
    rig = calibration().rig(0, "rig")
    bundle = rig.left.rays(truth.left[0][1][None])
    depth = np.linalg.norm(truth.fish[0][1] - bundle.origins[0])
    moved = rig.right.project((bundle.origins[0] + 2 * depth * bundle.directions[0])[None]).pixels[0]
    true_fork = truth.right[0][1].copy()
    truth.right[0][1] = moved
    return truth, true_fork


@pytest.fixture
def refused(tmp_path):
    truth, true_fork = refused_scene()
    return make_project(tmp_path), truth, true_fork


def _proposal_without_a_length(project, model):
    """``usvips detect``'s run on pair "dive": its proposal stored without a length, and that object as stored."""
    run = detect_in_project(project, model, pair="dive", refine=False)
    proposal = next(p for p in run.proposals if p.measurement is None)
    return proposal, project.object(proposal.object_id)


def test_a_proposal_without_a_length_is_stored_with_the_stereo_sigma_by_the_fishs_size(refused):
    path, truth, _ = refused
    model = stereo_model(truth)
    with Project.open(path) as project:
        run = detect_in_project(project, model, pair="dive", refine=False)
        lacking = [p for p in run.proposals if p.measurement is None]
        assert len(lacking) == 1 and "differ by more than 1.5" in lacking[0].problem
        proposal = lacking[0]
        sigmas, rho = pair_pointing(model, proposal.pair, [False, False], (WIDTH, HEIGHT))
        assert np.allclose(proposal.pointing, sigmas) and proposal.right_follows == (False, False)
        assert np.all(rho == 0) and np.all(sigmas[:, 1] > sigmas[:, 0])  # the right keypoints the model's own
        stored = project.object(proposal.object_id)
        assert all(v.pointing_px is None and v.xyz is None for v in stored.vertices)  # not stored: see below
        given = with_model_sigma(stored.vertices, proposal, model)
        assert [v.pointing_px for v in given] == [tuple(s) for s in sigmas.tolist()]
        assert all(v.pointing_origin == "estimated" and v.xyz is None and v.calibration_id is None
                   and RIGHT_FOLLOWS_LEFT not in v.source for v in given)
        with pytest.raises(UsvipsError, match="without 3-D coordinates"):
            measure_stored(project, stored)
        assert "re-pick every point" in UNMEASURED  # the object list's reason


def test_with_the_switch_on_a_proposal_without_a_length_is_stored_with_that_sigma(refused, monkeypatch):
    """STORE_UNMEASURED_SIGMA (off: the corrected lengths' σ was conservative, docs/detection.md) stores it."""
    import usvips.app.detection_service as service

    monkeypatch.setattr(service, "STORE_UNMEASURED_SIGMA", True)
    path, truth, _ = refused
    model = stereo_model(truth)
    with Project.open(path) as project:
        proposal, stored = _proposal_without_a_length(project, model)
        assert [v.pointing_px for v in stored.vertices] == list(proposal.pointing)
        assert all(v.pointing_origin == "estimated" and v.xyz is None for v in stored.vertices)


def test_a_refined_right_keypoint_of_a_proposal_without_a_length_is_stored_as_following_the_left(refused):
    """What the pair knew (which right keypoints were refined) goes into the sources: a refined one follows
    the left (its sigma √(σ_L² + σ_m²), correlated), one kept as the model's is independent."""
    from usvips.app.detection_service import store_proposals

    path, truth, _ = refused
    model = stereo_model(truth)
    with Project.open(path) as project:
        run = run_detection(plan_detection(project, pair="dive"), model, refine=False)
        i = next(i for i, p in enumerate(run.proposals) if p.measurement is None)
        sigmas, _ = pair_pointing(model, run.proposals[i].pair, [True, False], (WIDTH, HEIGHT))
        run.proposals[i] = replace(run.proposals[i], pointing=tuple(map(tuple, sigmas.tolist())),
                                   right_follows=(True, False))
        store_proposals(project, run)
        stored = project.object(run.proposals[i].object_id)
        given = with_model_sigma(stored.vertices, run.proposals[i], model)
        assert [RIGHT_FOLLOWS_LEFT in v.source for v in given] == [True, False]
        snout = given[0].pointing_px
        assert snout[1] == pytest.approx(np.hypot(snout[0], 0.3))


def test_a_model_with_one_measured_sigma_stores_it_for_a_proposal_without_a_length_as_before(refused):
    path, truth, _ = refused
    with Project.open(path) as project:
        run = detect_in_project(project, stereo_model(truth, sigma_table=1.2), pair="dive", refine=False)
        lacking = [p for p in run.proposals if p.measurement is None]
        assert len(lacking) == 1 and lacking[0].pointing == ()
        stored = project.object(lacking[0].object_id)
        assert [v.pointing_px for v in stored.vertices] == [(1.2, 1.2)] * 2


def test_correcting_the_wrong_keypoint_of_a_proposal_given_its_sigma_measures_it(refused):
    """As stored (no sigma) a correction does not measure it. Given the sigma it would have been measured with
    (what the corrections' Monte Carlo does, and STORE_UNMEASURED_SIGMA would store), the reviewer who drags
    the wrong right fork to the true one gets it measured: its figure (recomputed from the picks) the stored
    points', with the click's sigma on the moved point and the model's elsewhere; its length near the truth."""
    path, truth, true_fork = refused
    model = stereo_model(truth)
    with Project.open(path) as project:
        proposal, stored = _proposal_without_a_length(project, model)
        geometry = pair_geometry(project, "dive")
        assert all(v.xyz is None for v in corrected_vertices(stored, 1, "right", tuple(true_fork), geometry, "ana"))
        stored = replace(stored, vertices=with_model_sigma(stored.vertices, proposal, model))
        vertices = corrected_vertices(stored, 1, "right", tuple(true_fork), geometry, "ana")
        assert vertices[1].source == "hand click (fork, by ana)"
        assert vertices[1].pointing_px == (proposal.pointing[1][0], HAND_CLICK_SIGMA_PX)
        assert vertices[0].pointing_px == proposal.pointing[0] and vertices[0].source == stored.vertices[0].source
        assert all(v.xyz is not None and v.calibration_id == geometry.calibration_id for v in vertices)
        project.update_object(stored.id, vertices=vertices)
        figure = measure_stored(project, project.object(stored.id))
        expected = measure_picks("length", geometry.calibration, truth.left[0], np.array([truth.right[0][0],
                                 true_fork]), geometry.station, geometry.frame,
                                 pointing_sigma_px=np.array([proposal.pointing[0],
                                                             (proposal.pointing[1][0], HAND_CLICK_SIGMA_PX)]))
        assert figure.main.sigma == pytest.approx(expected.main.sigma, rel=1e-9)
        assert figure.main.value == pytest.approx(truth.lengths[0], abs=1e-6)
        assert np.allclose(figure.points, [v.xyz for v in vertices])
