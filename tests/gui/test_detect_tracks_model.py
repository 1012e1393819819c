"""The window's Detect on a range of a video's frames, without a window: the proposals of each fish on the
frames are stored as one object with further instants (the cache holds the links at once, so the object
list shows each fish once); the model chosen becomes the project's default, a new session takes it, and a
default whose file is gone is named."""

import numpy as np
import pytest

from tests.app.detection_scenes import make_video_project, scene, write_switching_model
from usvips.app.detection_model import project_model_path
from usvips.app.project_figures import evaluate, instant_measurements, instant_pointing, measurement_input
from usvips.core.errors import InputFileError
from usvips.core.measurements.instants import combine_measurements
from usvips.gui.detect_model import DetectSession
from usvips.gui.instants_model import object_instants
from usvips.gui.proposal_marks import correct_keypoint
from usvips.gui.workspace import Workspace
from usvips.store import Project


@pytest.fixture
def workspace(tmp_path):
    truth = scene(seed=11)
    path = make_video_project(tmp_path)
    model = write_switching_model(tmp_path, truth, sigma=1.0)
    ws = Workspace()
    project = Project.open(path)
    ws.open_project(project)
    yield ws, model
    project.close()


def test_a_range_of_frames_stores_each_fish_once_with_its_frames_as_instants(workspace):
    ws, model = workspace
    ws.video_frame = ("drop", 1)
    ws.pair = "drop"
    session = DetectSession(ws)
    session.choose_model(str(model))
    run = session.job(session.plan(frames=4))(lambda f: None, lambda: False)
    lines = session.store(run)
    assert any("3 fish seen on several frames joined into objects with 9 further instant(s)" in line
               for line in lines)
    links = ws.cache.instant_links()
    assert len(links) == 9 and len(set(links.values())) == 3  # held by the cache: the list shows 3 fish
    for whole in set(links.values()):
        assert sorted(ws.cache.instants_by_object()[whole]) == sorted(i for i, w in links.items() if w == whole)
        assert ws.stored_object(whole).vertices[0].frame_left == 1


def test_the_model_chosen_becomes_the_projects_default_and_a_gone_one_is_named(workspace):
    ws, model = workspace
    assert DetectSession(ws).project_model() is None
    DetectSession(ws).choose_model(str(model), remember=True)
    assert project_model_path(ws.project) == model.resolve()
    fresh = DetectSession(ws)
    assert fresh.project_model().name == model.stem and fresh.model_path == str(model.resolve())
    model.unlink()
    with pytest.raises(InputFileError, match="no longer there"):
        DetectSession(ws).project_model()


def test_a_reviewers_correction_in_the_window_keeps_the_fish_combined_by_the_models_frame_correlation(workspace):
    """The window's correction of one instant's snout makes that point a hand click: the fish's figure, from
    the store, combines that instant with half the model's frame correlation and the others with all of it —
    larger than as independent instants (what one correction gave before), below the uncorrected fish's."""
    ws, model = workspace
    model.write_text(model.read_text() + '\n[frame_correlation]\nlength = 0.4\nbasis = "test scenes"\n')
    blank = np.zeros((480, 640), np.uint8)
    ws.set_pair("drop", blank, blank, ("drop", 1, 1, 0.04))  # a correction is measured with the pair's geometry
    session = DetectSession(ws)
    session.choose_model(str(model))
    session.store(session.job(session.plan(frames=4))(lambda f: None, lambda: False))
    whole = sorted(set(ws.cache.instant_links().values()))[0]
    before = evaluate(measurement_input(ws.project, ws.project.object(whole))).main.sigma
    corrected = ws.project.instants(whole)[0]
    snout = ws.stored_object(corrected).vertices[0]
    correct_keypoint(ws, corrected, 0, "left", (snout.xl + 0.7, snout.yl - 0.4))
    assert ws.stored_object(corrected).vertices[0].source.startswith("hand click (snout")
    source = measurement_input(ws.project, ws.project.object(whole))
    assert [i.model_share for i in (source, *source.instants)] == [1.0, 0.5, 1.0, 1.0]
    after = evaluate(source).main.sigma
    measured, pointing = instant_measurements(source), instant_pointing(source)
    assert combine_measurements(measured, pointing).main.sigma < after < before
    listed = object_instants(ws.project, whole)  # the instants dialog: the weights the combination used
    used = combine_measurements(measured, pointing, shared_fraction=[0.4, 0.2, 0.4, 0.4]).combined
    np.testing.assert_allclose([r.weight for r in listed.rows], next(c for c in used if c.name == "length").weights)
    assert "a model pointed at 4 of the instants: up to 40% of their pointing error repeats" in listed.summary()
