"""A video run reads its proposals' frame times itself (on the worker, in the window), so that storing them
— on the project's thread, the window's — does not open the video again: the times are those storing would
read, and the stored proposals carry them."""

import pytest

from tests.app.detection_scenes import make_video_project, scene, write_switching_model
from usvips.app import detection_service
from usvips.app.detection_model import load_model
from usvips.app.detection_service import plan_detection, run_detection, store_proposals
from usvips.store import Project


def test_a_video_run_carries_its_frame_times_and_storing_does_not_read_the_video(tmp_path, monkeypatch):
    truth = scene(seed=5)
    path = make_video_project(tmp_path)
    model = load_model(write_switching_model(tmp_path, truth, sigma=1.0))
    with Project.open(path) as project:
        plan = plan_detection(project, video="drop", frames=(0, 3))
        run = run_detection(plan, model)
        frames = sorted({p.frame for p in run.proposals})
        assert len(frames) == 4 and run.times == detection_service._times(plan, frames)
        times = [run.times[f] for f in frames]
        assert list(run.times) == frames and times == sorted(times) and len(set(times)) == 4

        def no_video(*_):
            raise AssertionError("storing opened the video")

        monkeypatch.setattr(detection_service, "_times", no_video)
        store_proposals(project, run)
        stored = {o.id: o for o in project.objects()}
        for proposal in run.proposals:
            vertex = stored[proposal.object_id].vertices[0]
            assert vertex.time_s == pytest.approx(run.times[proposal.frame])
