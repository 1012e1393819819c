"""A run's proposals stored a slice at a time (usvips/app/detection_service.py, storing_proposals: the window
stores a step a turn of its event loop, issue 35's "no freeze over 0.1 s"): no step stores more than its
slice of proposals or links more than its slice of instants, and once done the project and the run are
exactly as storing them in one go leaves them."""

import shutil
from dataclasses import astuple, replace

import numpy as np
import pytest

from tests.app.test_detection_tracks import _model
from tests.app.test_detection_tracks import video as video  # noqa: F401 (the fixture)
from usvips.app import detection_tracks
from usvips.app.detection_service import plan_detection, run_detection, store_proposals, storing_proposals
from usvips.core.errors import InvalidParameterError
from usvips.store import Project


def _run(project, truth):
    velocity = np.array([[0.3, 0.0, 0.0], [0.0, 0.2, 0.0], [-0.4, 0.1, 0.05]])  # m/s: three fish over 6 frames
    return run_detection(plan_detection(project, video="drop"), _model(truth.fish, velocity), refine=False)


def _stored(project):
    """Everything stored of the objects (but the times they were made) and the instant links."""
    def plain(vertex):
        return tuple(np.asarray(x).tolist() if isinstance(x, np.ndarray) else x for x in astuple(vertex))

    return ([(o.id, o.kind, o.attribute, o.notes, o.creator, [plain(v) for v in o.vertices])
             for o in project.objects()], project.instant_links(), project.instant_sources())


def _outcome(run):
    return [(p.frame, p.object_id, p.duplicate_of, p.instant_of) for p in run.proposals], run.joined


def test_storing_a_step_at_a_time_stores_at_most_a_slice_a_step_and_ends_as_storing_at_once(video, tmp_path,
                                                                                             monkeypatch):
    path, truth = video
    other = tmp_path / "other.usvips"
    shutil.copy(path, other)
    with Project.open(path) as project:
        run = _run(project, truth)
        at_once = store_proposals(project, replace(run, proposals=list(run.proposals)))
        expected = _stored(project)
    linked = []
    add_instant = detection_tracks.add_instant
    monkeypatch.setattr(detection_tracks, "add_instant", lambda *a, **k: linked.append(a[2]) or add_instant(*a, **k))
    with Project.open(other) as project:
        added = []
        add_objects = project.add_objects
        monkeypatch.setattr(project, "add_objects", lambda rows: added.append(len(rows)) or add_objects(rows))
        steps = []
        for step in storing_proposals(project, run, per_step=4):
            steps.append((step, sum(added), len(linked)))  # what each step stored and linked
        assert _stored(project) == expected
    assert len(run.proposals) == 18 and run.joined is not None and run.joined.instants == 15
    assert _outcome(run) == _outcome(at_once)
    assert len({p.instant_of for p in run.proposals}) == 4  # three fish, and None
    assert max(added) <= 4 and sum(added) == 18
    made = np.diff([(0, 0)] + [(objects, links) for _, objects, links in steps], axis=0)
    assert made.max() <= 4 and not np.any((made[:, 0] > 0) & (made[:, 1] > 0))  # one kind of work a step
    said = [(len(step.added), len(step.links)) for step, *_ in steps]  # each step says what it did
    assert said == [tuple(m) for m in made]
    assert sorted(i for step, *_ in steps for i in step.added) == sorted(p.object_id for p in run.proposals)
    assert {link for step, *_ in steps for link in step.links} == {
        (p.object_id, p.instant_of) for p in run.proposals if p.instant_of is not None}
    assert len(steps) == 5 + 4  # 18 proposals in slices of 4, then 15 instants in slices of 4


def test_a_step_slice_is_a_whole_number_of_proposals(video):
    path, truth = video
    with Project.open(path) as project, pytest.raises(InvalidParameterError, match="per_step"):
        next(storing_proposals(project, _run(project, truth), per_step=0))
