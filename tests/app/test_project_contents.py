"""A project's contents summarised, and files imported all or nothing."""

import numpy as np
import pytest

from usvips.app.project_contents import plan_import, store_import, summarise
from usvips.core.errors import InputFileError, UsvipsError
from usvips.core.observations import ControlPoints, StereoObservations
from usvips.io.tables import write_control, write_observations
from usvips.store import Project, ProjectError


def test_the_summary_counts_everything_and_lists_a_video_once(tmp_path):
    (tmp_path / "l.mp4").write_bytes(b"left")
    (tmp_path / "r.mp4").write_bytes(b"right")
    with Project.create(tmp_path / "p.usvips") as project:
        project.add_pair("air1", medium="air")
        project.add_pair("w1")
        calibration = project.add_calibration("c", {"phase": "water"}, ("w1",))
        project.add_video("dive", [(tmp_path / "l.mp4", 10, 25.0)], [(tmp_path / "r.mp4", 10, 25.0)], 25.0, 10,
                          (64, 48))
        project.set_video_offset("dive", -2)
        project.set_control(ControlPoints(("1", "2"), np.zeros((2, 3))))
        summary = summarise(project)
    assert (summary.pair_count, summary.control_count, summary.object_count) == (3, 2, 0)
    assert [(p.label, p.medium, p.calibration_id) for p in summary.pairs] == [("air1", "air", None),
                                                                               ("w1", "water", calibration)]
    assert [(v.label, v.frame_count, v.fps, v.offset_frames) for v in summary.videos] == [("dive", 10, 25.0, -2)]


@pytest.mark.parametrize("seed", range(4))
def test_the_summary_counts_an_object_over_several_instants_once_and_every_review(tmp_path, seed):
    from usvips.app.project_contents import ReviewCounts, objects_text, reviews_text
    from usvips.store.records import Vertex

    rng = np.random.default_rng(seed)
    with Project.create(tmp_path / "p.usvips") as project:
        ids = [project.add_object("point", [Vertex(*map(float, rng.uniform(0, 99, 4)))])
               for _ in range(int(rng.integers(3, 12)))]
        first = ids[0]
        instants = [i for i in ids[1:] if rng.random() < 0.5]
        for instant in instants:
            project.add_instant(first, instant)
        states = [str(rng.choice(["unreviewed", "accepted", "flagged"])) for _ in ids]
        for object_id, state in zip(ids, states, strict=True):
            project.set_review(object_id, state, "why" if state == "flagged" else "")
        summary = summarise(project)
    assert (summary.object_count, summary.instant_count) == (len(ids) - len(instants), len(instants))
    assert summary.reviews == ReviewCounts(states.count("unreviewed"), states.count("accepted"),
                                           states.count("flagged"))
    assert summary.reviews.total == len(ids)
    assert reviews_text(ReviewCounts(5, 2, 1)) == "2 accepted, 1 flagged, 5 unreviewed"
    assert [objects_text(*n) for n in ((1, 0), (5, 0), (5, 1), (2, 3))] == [
        "1 object", "5 objects", "5 objects (1 further instant)", "2 objects (3 further instants)"]


def test_an_import_is_checked_before_anything_is_stored_and_stored_all_or_nothing(tmp_path):
    rng = np.random.default_rng(1)
    write_control(tmp_path / "c.csv", ControlPoints(("1", "2", "3"), rng.normal(size=(3, 3))))
    observations = StereoObservations(("1", "2"), rng.uniform(0, 99, (2, 2)), rng.uniform(0, 99, (2, 2)),
                                      ("a", "b"))
    write_observations(tmp_path / "o.csv", observations)
    with pytest.raises(UsvipsError, match="nothing to import"):
        plan_import()
    with pytest.raises(UsvipsError, match="observations need the image pair they belong to"):
        plan_import(observations=tmp_path / "o.csv")
    with pytest.raises(InputFileError, match="o.csv: holds observations of 2 pairs"):
        plan_import(observations=tmp_path / "o.csv", pair="z")
    plan = plan_import(tmp_path / "c.csv", tmp_path / "o.csv", "a")
    assert plan.observations.ids == ("1",)
    with Project.create(tmp_path / "p.usvips") as project:
        store_import(project, plan)
        assert len(project.control()) == 3 and project.control_observations("calibration-water", "a").ids == ("1",)
        moved = ControlPoints(("9",), np.ones((1, 3)))
        with pytest.raises(ProjectError):  # the same observation again: the new control must not stay either
            store_import(project, plan.__class__(moved, plan.observations, "a"))
        assert project.control().ids == ("1", "2", "3")


def test_an_import_says_what_it_replaced_added_and_left_without_control(tmp_path):
    """Control points replace the stored ones (said, with how many were there); observations are added to
    the pair's (a point observed again is named); points observed but no longer control points are named."""
    rng = np.random.default_rng(2)
    write_control(tmp_path / "c3.csv", ControlPoints(("1", "2", "3"), rng.normal(size=(3, 3))))
    write_control(tmp_path / "c1.csv", ControlPoints(("1",), rng.normal(size=(1, 3))))
    write_observations(tmp_path / "o.csv", StereoObservations(("1", "2", "3"), rng.uniform(0, 99, (3, 2)),
                                                              rng.uniform(0, 99, (3, 2)), ("a", "a", "a")))
    write_observations(tmp_path / "more.csv", StereoObservations(("3", "4"), rng.uniform(0, 99, (2, 2)),
                                                                 rng.uniform(0, 99, (2, 2)), ("a", "a")))
    with Project.create(tmp_path / "p.usvips") as project:
        assert store_import(project, plan_import(tmp_path / "c3.csv", tmp_path / "o.csv", "a")) == [
            "3 control points", "3 calibration-water observations of pair 'a'"]
        with pytest.raises(ProjectError, match="pair 'a', role 'calibration-water': point.s. 3 already have "
                                               "observations stored; nothing was imported"):
            store_import(project, plan_import(observations=tmp_path / "more.csv", pair="a"))
        said = store_import(project, plan_import(tmp_path / "c1.csv"))
        assert said == ["1 control point (replacing the 3 stored)", "observed points that are no longer control "
                        "points: 2, 3 (their observations stay, unused until they are given again)"]
        assert project.control().ids == ("1",) and len(project.control_observations("calibration-water", "a")) == 3


def test_observations_of_one_pair_are_not_filed_under_another_pair_given(tmp_path):
    rng = np.random.default_rng(3)
    write_observations(tmp_path / "o.csv", StereoObservations(("1", "2"), rng.uniform(0, 99, (2, 2)),
                                                              rng.uniform(0, 99, (2, 2)), ("water1", "water1")))
    with pytest.raises(InputFileError, match="its pair column says 'water1', but the image pair given is 'watr1'"):
        plan_import(observations=tmp_path / "o.csv", pair="watr1")
    assert plan_import(observations=tmp_path / "o.csv", pair="water1").pair == "water1"
    write_observations(tmp_path / "bare.csv", StereoObservations(("1",), rng.uniform(0, 99, (1, 2)),
                                                                 rng.uniform(0, 99, (1, 2))), with_pair=False)
    assert plan_import(observations=tmp_path / "bare.csv", pair="any").pair == "any"  # no pair column
