"""The window's Detect, without a window: the pair shown is planned, the worker's job reports its progress
and stops at a cancel, the proposals are stored unreviewed and the workspace's cache holds them at once
(they are drawn and queued for review as every object is)."""

import numpy as np
import pytest

from tests.app.detection_scenes import make_project, scene, write_switching_model
from usvips.core.errors import InputFileError, UsvipsError
from usvips.gui.detect_model import DetectSession
from usvips.gui.review_model import ReviewModel
from usvips.gui.workspace import Workspace
from usvips.store import Project


@pytest.fixture
def workspace(tmp_path):
    truth = scene(seed=11)
    path = make_project(tmp_path)
    model = write_switching_model(tmp_path, truth, sigma=1.0)
    ws = Workspace()
    project = Project.open(path)
    ws.open_project(project)
    yield ws, model
    project.close()


def test_detect_on_the_pair_shown_stores_unreviewed_proposals_the_views_see(workspace):
    ws, model = workspace
    session = DetectSession(ws)
    with pytest.raises(UsvipsError, match="show an image pair"):
        session.plan()
    ws.set_pair("dive", np.zeros((960, 1280), np.uint8), np.zeros((960, 1280), np.uint8))
    with pytest.raises(UsvipsError, match="choose a detection model"):
        session.job(session.plan())
    session.choose_model(str(model))
    fractions = []
    run = session.job(session.plan())(fractions.append, lambda: False)
    assert fractions == [1.0]
    added = []
    ws.objects_added.connect(added.append)
    lines = session.store(run)
    ids = [p.object_id for p in run.proposals]
    assert len(ids) == 3 and all(i in ws.cache for i in ids) and added == [tuple(ids)]
    assert lines[-2].startswith("dive: 1 of 1 pair(s) looked at") and "measured" in lines[-1]
    review = ReviewModel()
    review.load(ws.project)
    assert sorted(review.queue) == sorted(ids)   # review mode walks them: A accepts, F flags
    review.accept()
    assert ws.project.review(review.queue[0]).state == "accepted"


def test_a_stop_keeps_nothing_undone_and_a_bad_model_is_named(workspace, tmp_path):
    ws, model = workspace
    ws.set_pair("dive", np.zeros((960, 1280), np.uint8), np.zeros((960, 1280), np.uint8))
    session = DetectSession(ws)
    session.choose_model(str(model))
    run = session.job(session.plan())(lambda f: None, lambda: True)
    assert run.cancelled and run.frames_done == 0
    assert session.store(run)[-2].startswith("dive: 0 of 1 pair(s) looked at (cancelled)")
    with pytest.raises(InputFileError, match="nowhere.toml"):
        session.choose_model(str(tmp_path / "nowhere.toml"))


def test_the_unreviewed_proposals_keypoints_get_circles_of_95_percent_from_their_measured_sigma(workspace):
    from usvips.gui.proposal_marks import CIRCLE_SIGMAS, sigma_circles

    ws, model = workspace
    ws.set_pair("dive", np.zeros((960, 1280), np.uint8), np.zeros((960, 1280), np.uint8))
    session = DetectSession(ws)
    session.choose_model(str(model))
    assert sigma_circles(ws)["left"].shape == (0, 3)
    session.store(session.job(session.plan())(lambda f: None, lambda: False))
    circles = sigma_circles(ws)
    assert circles["left"].shape == circles["right"].shape == (6, 3)   # 3 fish, snout and fork
    np.testing.assert_allclose(circles["left"][:, 2], CIRCLE_SIGMAS * 1.0)
    assert abs(CIRCLE_SIGMAS - 2.4477) < 1e-4


def _detected_on_the_pair(workspace):
    """The workspace with the fake model's proposals on pair "dive" detected and stored, and the run."""
    ws, model = workspace
    ws.set_pair("dive", np.zeros((960, 1280), np.uint8), np.zeros((960, 1280), np.uint8))
    session = DetectSession(ws)
    session.choose_model(str(model))
    run = session.job(session.plan())(lambda f: None, lambda: False)
    session.store(run)
    return ws, run


def test_dragging_a_keypoint_corrects_it_as_one_undoable_edit_measured_again(workspace):
    from usvips.gui.proposal_marks import correct_keypoint, proposal_keypoints
    from usvips.store.annotator import annotating_as

    ws, run = _detected_on_the_pair(workspace)
    assert len(proposal_keypoints(ws)) == 12  # 3 fish × 2 keypoints × 2 images
    object_id = run.proposals[0].object_id
    ws.project.set_review(object_id, "accepted")
    ws.reload_objects()
    before = ws.stored_object(object_id)
    with annotating_as("ana"):
        correct_keypoint(ws, object_id, 1, "right", (before.vertices[1].xr + 1.5, before.vertices[1].yr - 0.5))
    after = ws.project.object(object_id)
    fork = after.vertices[1]
    assert (fork.xr, fork.yr) == (before.vertices[1].xr + 1.5, before.vertices[1].yr - 0.5)
    assert fork.source == "hand click (fork, by ana)" and fork.pointing_px == (1.0, 0.5)
    assert after.vertices[0].source == before.vertices[0].source                 # the snout is still the model's
    assert fork.xyz is not None and not np.allclose(fork.xyz, before.vertices[1].xyz)
    assert ws.project.review(object_id).state == "unreviewed"     # back to the reviewer
    assert object_id not in {o for o, *_ in proposal_keypoints(ws)}  # a corrected one is no longer the model's
    ws.undo.undo()
    undone = ws.project.object(object_id).vertices[1]
    assert (undone.xr, undone.yr, undone.source) == (before.vertices[1].xr, before.vertices[1].yr,
                                                     before.vertices[1].source)


def test_a_dragged_keypoint_takes_the_reviewers_hand_click_estimate_in_use(workspace):
    from usvips.app.pointing_settings import add_estimate
    from usvips.core.pointing_estimates import from_pointing_test
    from usvips.gui.proposal_marks import correct_keypoint
    from usvips.store.annotator import annotating_as

    ws, run = _detected_on_the_pair(workspace)
    rng = np.random.default_rng(5)
    clicks = rng.uniform(0, 900, (40, 2))
    estimate = from_pointing_test(clicks + rng.normal(0, 1.4, clicks.shape), clicks)
    add_estimate(ws.project, estimate, "ana")
    object_id = run.proposals[0].object_id
    before = ws.stored_object(object_id).vertices[0]
    with annotating_as("ana"):
        correct_keypoint(ws, object_id, 0, "left", (before.xl - 1.0, before.yl + 0.5))
    snout = ws.project.object(object_id).vertices[0]
    assert snout.source == "hand click (snout, by ana)"
    assert snout.pointing_px[0] == pytest.approx(estimate.sigma_px) and snout.pointing_px[1] == before.pointing_px[1]


def test_the_model_is_loaded_once_however_its_path_is_spelt_and_the_project_remembers_it(workspace):
    ws, model = workspace
    session = DetectSession(ws)
    first = session.choose_model(str(model), remember=True)
    # the project keeps the path resolved; the first Detect asks for it so: the model is not loaded again (a
    # load runs the network once, on the window's thread)
    assert session.project_model() is first
    assert session.choose_model(str(model.parent / "." / model.name)) is first
    other = model.parent / "elsewhere"
    other.mkdir()
    (other / model.name).write_bytes(model.read_bytes())
    for name in [p.name for p in model.parent.iterdir() if p.is_file() and p.suffix == ".onnx"]:
        (other / name).write_bytes((model.parent / name).read_bytes())
    assert session.choose_model(str(other / model.name)) is not first  # another file: loaded


def test_a_run_whose_project_was_closed_is_not_stored_and_says_so(workspace):
    ws, model = workspace
    session = DetectSession(ws)
    ws.set_pair("dive", np.zeros((960, 1280), np.uint8), np.zeros((960, 1280), np.uint8))
    session.choose_model(str(model))
    run = session.job(session.plan())(lambda f: None, lambda: False)
    ws.close_project()
    with pytest.raises(UsvipsError, match="the project was closed: the 3 proposal"):
        session.write(run)
