"""The window's Detect on a range of a video's frames, without a window: the proposals of each fish on the
frames are stored as one object with further instants (the cache holds the links at once, so the object
list shows each fish once); the model chosen becomes the project's default, a new session takes it, and a
default whose file is gone is named."""

import pytest

from tests.app.detection_scenes import make_video_project, scene, write_switching_model
from usvips.app.detection_model import project_model_path
from usvips.core.errors import InputFileError
from usvips.gui.detect_model import DetectSession
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
