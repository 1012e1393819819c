"""An object's instants as the window lists them (Qt-free), on a project with a rendered swimming fish:
tracked instants each with its figure, weight and residual, the combined figure as the one figure path
gives it, and a planted outlying instant named."""

import shutil

import numpy as np
import pytest

from tests.core.test_tracking import truth
from tests.gui.swimming_project import OFFSET, POINTS, START, make_survey_project
from usvips.app.calibrations import read_calibration
from usvips.app.object_instants import add_instant
from usvips.app.project_figures import evaluate, measurement_input
from usvips.app.tracking import add_tracked_instants, track_in_video
from usvips.core.measurements import measure_picks
from usvips.gui.instants_model import object_instants, whole_object
from usvips.store import Project
from usvips.store.project import Vertex


@pytest.fixture(scope="module")
def survey(tmp_path_factory):
    folder = tmp_path_factory.mktemp("instants")
    path, object_id, fish, stereo = make_survey_project(folder)
    with Project.open(path) as project:
        stored = project.object(object_id)
        tracks = [track_in_video(project, "drop", START, (v.xl, v.yl), (v.xr, v.yr), 0, 30) for v in stored.vertices]
        add_tracked_instants(project, object_id, tracks, [2, 10, 18], "drop")
    return path, object_id, fish, stereo


def _copy(path, name):
    target = path.with_name(name)
    shutil.copy(path, target)
    return target


def test_each_tracked_instant_is_listed_with_its_weight_and_the_combined_figure(survey):
    path, object_id, fish, stereo = survey
    with Project.open(_copy(path, "listed.usvips")) as project:
        listed = object_instants(project, object_id)
        assert [r.frame for r in listed.rows] == [START, 2, 10, 18]
        assert listed.rows[0].object_id == object_id and [r.video for r in listed.rows] == ["drop"] * 4
        assert listed.rows[2].time_s == pytest.approx(10 / 25.0) and listed.rows[2].where == "drop frame 10, 0.400 s"
        assert sum(r.weight for r in listed.rows) == pytest.approx(1.0) and all(r.weight > 0 for r in listed.rows)
        combined = evaluate(measurement_input(project, project.object(object_id)))
        assert listed.combined.value == combined.figures[0].value and listed.combined.sigma == combined.figures[0].sigma
        assert listed.combined.count == 4 and not any(r.outlier for r in listed.rows)
        for row in listed.rows:  # each instant's own length lies within its sigma's reach of the truth
            ends = [fish.body_point(row.frame / 25.0, f * fish.length) for f in POINTS]
            assert abs(row.figure.value - np.linalg.norm(ends[1] - ends[0])) < 4 * row.figure.sigma
        text = listed.summary()
        assert f"object {object_id}: length" in text and "over 4 instants" in text and "p = " in text
        assert listed.tracked and "kept whole in σ" in text  # the pick's error, carried by the tracker
        # asked about one of its instants, the list is the object's
        assert whole_object(project, listed.rows[3].object_id) == object_id
        assert object_instants(project, listed.rows[3].object_id).object_id == object_id


def test_a_planted_outlying_instant_is_flagged_and_named(survey):
    path, object_id, fish, stereo = survey
    with Project.open(_copy(path, "planted.usvips")) as project:
        stored = project.object(object_id)
        calibration_id = stored.vertices[0].calibration_id
        frame = 14
        picks = [truth(stereo, fish, frame, f * fish.length) for f in (POINTS[0], 0.75)]  # a far longer "length"
        calibration = read_calibration(project, calibration_id)
        m = measure_picks("length", calibration, np.array([p[0] for p in picks]), np.array([p[1] for p in picks]),
                          0, "rig")
        vertices = [Vertex(*p[0], *p[1], tuple(xyz), m.covariance[3 * i:3 * i + 3, 3 * i:3 * i + 3], calibration_id,
                           "drop", "drop", frame, frame + OFFSET, frame / 25.0)
                    for i, (p, xyz) in enumerate(zip(picks, m.points, strict=True))]
        planted = project.add_object("length", vertices)
        add_instant(project, object_id, planted)
        listed = object_instants(project, object_id)
        flagged = [r.object_id for r in listed.rows if r.outlier]
        assert flagged == [planted]
        assert f"outlying: object {planted}" in listed.summary()
        assert "disagree" in listed.summary()


def test_an_object_on_one_instant_says_so(survey):
    path, object_id, fish, stereo = survey
    with Project.open(_copy(path, "single.usvips")) as project:
        for instant in project.instants(object_id):
            project.remove_instant(instant)
        listed = object_instants(project, object_id)
        assert len(listed.rows) == 1 and listed.combined is None and listed.rows[0].weight == 1.0
        assert "on one instant" in listed.summary()


def test_instants_picked_by_hand_are_not_said_to_carry_one_pick(survey):
    path, object_id, fish, stereo = survey
    with Project.open(_copy(path, "by_hand.usvips")) as project:
        for instant in project.instants(object_id):
            project.remove_instant(instant)
        calibration_id = project.object(object_id).vertices[0].calibration_id
        calibration = read_calibration(project, calibration_id)
        for frame in (10, 14):
            picks = [truth(stereo, fish, frame, f * fish.length) for f in POINTS]
            m = measure_picks("length", calibration, np.array([p[0] for p in picks]),
                              np.array([p[1] for p in picks]), 0, "rig")
            vertices = [Vertex(*p[0], *p[1], tuple(xyz), m.covariance[3 * i:3 * i + 3, 3 * i:3 * i + 3],
                               calibration_id, "drop", "drop", frame, frame + OFFSET, frame / 25.0)
                        for i, (p, xyz) in enumerate(zip(picks, m.points, strict=True))]
            add_instant(project, object_id, project.add_object("length", vertices))
        listed = object_instants(project, object_id)
        assert listed.combined.count == 3 and not listed.tracked
        assert "over 3 instants" in listed.summary() and "tracked" not in listed.summary()
