"""Quality control of a survey: objects made to break each rule are listed with the rule, the value,
the limit and where they were measured; objects that pass are not; a species without a maximum is a note."""

import numpy as np
import pytest

from usvips.app.object_instants import add_instant
from usvips.app.project_figures import evaluate, measurement_input
from usvips.app.quality import FAIL, NOTE, Checked, Place, check, check_project, report_rows, species_maxima
from usvips.bench import scaling
from usvips.core.measurements import QualityRules, measure
from usvips.core.observation_record import ObservationRecord, Species
from usvips.io.calibration_file import calibration_to_dict, load_calibration
from usvips.store import Project
from usvips.store.project import StoredObject, Vertex

SPECIES = [Species("Sparidae", "Pagrus", "auratus", "37353001", max_length_m=0.25),
           Species("Labridae", "Achoerodus", "gouldii", "37384040")]


def build_survey(path):
    """A project measured with the sample's calibration: one object per rule to break, one that passes.
    Returns the project path and the object ids by name."""
    calibration = load_calibration(scaling.CALIBRATION)
    rig = calibration.rig(0, "rig")
    rng = np.random.default_rng(3)
    ids = {}
    with Project.create(path) as project:
        project.add_pair("dive")
        calibration_id = project.add_calibration("cal", calibration_to_dict(calibration), ("dive",))
        project.set_species_list(SPECIES)

        def add(name, ends, species=None, shift=0.0, noise=0.2):
            left, right = rig.left.project(np.array(ends)), rig.right.project(np.array(ends))
            assert left.ok.all() and right.ok.all(), name
            picks = np.hstack([left.pixels, right.pixels]) + rng.normal(0, noise, (len(ends), 4))
            picks[:, 3] += shift  # the right pick moved off the epipolar curve: rays that do not meet
            kind = "length" if len(ends) == 2 else "point"
            ids[name] = project.add_object(kind, [Vertex(*map(float, p), calibration_id=calibration_id, pair="dive")
                                                  for p in picks])
            if species is not None:
                project.set_record(ids[name], ObservationRecord.of(species))

        add("good", [[0.05, 0.0, -2.4], [0.25, 0.0, -2.38]], SPECIES[0])          # 0.20 m < 0.25 m
        add("too long", [[0.0, 0.0, -2.4], [0.32, 0.0, -2.4]], SPECIES[0])        # 0.32 m > 0.25 m
        add("no maximum", [[0.05, 0.05, -2.4], [0.30, 0.05, -2.4]], SPECIES[1])
        add("unknown", [[0.05, -0.05, -2.4], [0.30, -0.05, -2.4]], Species("Mullidae", "Parupeneus", "spp"))
        add("rms", [[0.05, 0.1, -2.4], [0.25, 0.1, -2.4]], shift=25.0)
        add("range", [[0.5, 0.0, -9.0], [1.0, 0.0, -9.0]])
        add("precision", [[0.1, 0.0, -6.0], [0.11, 0.0, -6.0]], noise=0.5)
        ids["no figures"] = project.add_object("point", [Vertex(1.0, 2.0, 3.0, 4.0, pair="dive")])
        # an object on two instants: checked once, on its combined length
        add("instant 1", [[0.05, 0.12, -2.4], [0.25, 0.12, -2.4]])
        add("instant 2", [[0.06, 0.10, -2.4], [0.26, 0.10, -2.4]])
        add_instant(project, ids["instant 1"], ids["instant 2"])
    return ids


def test_each_rule_broken_is_listed_once_with_its_value_limit_and_place(tmp_path):
    ids = build_survey(tmp_path / "survey.usvips")
    with Project.open(tmp_path / "survey.usvips", read_only=True) as project:
        report = check_project(project)
    assert report.checked == len(ids) - 1  # the second instant is part of the first
    by_object = {}
    for issue in report.issues:
        by_object.setdefault(int(issue.object_id), []).append(issue)
    named = {name: [(i.rule, i.status) for i in by_object.get(object_id, [])] for name, object_id in ids.items()}
    assert named["good"] == [] and named["instant 1"] == [] and named["instant 2"] == []
    assert named["too long"] == [("species_max", FAIL)]
    assert named["no maximum"] == [("no_maximum", NOTE)]
    assert named["unknown"] == [("unknown_species", NOTE)]
    assert ("ray_rms", FAIL) in named["rms"]
    assert ("range", FAIL) in named["range"]
    assert named["precision"] == [("precision", FAIL)]
    assert named["no figures"] == [("no_figures", FAIL)]
    too_long = by_object[ids["too long"]][0]
    assert too_long.value == pytest.approx(0.32, abs=0.01) and too_long.limit == 0.25 and too_long.unit == "m"
    assert too_long.species == "Pagrus auratus" and too_long.place == Place("pair dive", "dive")
    rms = next(i for i in by_object[ids["rms"]] if i.rule == "ray_rms")
    assert rms.value > 0.02 and rms.limit == 0.02
    far = next(i for i in by_object[ids["range"]] if i.rule == "range")
    assert far.value == pytest.approx(np.linalg.norm([1.0, 0.0, -9.0]), rel=0.02) and far.limit == 8.0
    precise = by_object[ids["precision"]][0]
    assert precise.value > 0.1 and precise.limit == 0.1 and precise.unit == "1"
    assert report.failing_objects == 5
    rows = report_rows(report)
    row = next(r for r in rows if r[0] == str(ids["too long"]))
    assert row[3:8] == ["length > species maximum", "fail", row[5], "250", "mm"] and float(row[5]) > 300


def test_the_limits_are_the_rules_given():
    rng = np.random.default_rng(1)
    points = np.array([[0.0, 0.0, -2.0], [0.4, 0.0, -2.0]])
    measurement = measure("length", points + rng.normal(0, 1e-4, (2, 3)), np.eye(6) * 1e-6, ray_rms_m=0.004,
                          range_m=2.0)
    item = Checked("7", "length", measurement, None, Place("video 'dive', frame 1200", "dive", "dive", 1200))
    assert check([item]).issues == ()
    strict = check([item], QualityRules(max_ray_rms_m=0.003, max_relative_precision=0.001, max_range_m=1.5))
    assert [i.rule for i in strict.issues] == ["ray_rms", "precision", "range"]
    assert all(i.place.video == "dive" and i.place.frame == 1200 for i in strict.issues)
    # without the species list the species rule is not checked; a record without a species neither
    record = ObservationRecord.of(SPECIES[0])
    long_fish = Checked("8", "length", measurement, record, item.place)
    assert check([long_fish]).issues == ()
    assert [i.rule for i in check([long_fish], species=species_maxima(SPECIES)).issues] == ["species_max"]
    anonymous = Checked("9", "length", measurement, ObservationRecord(), item.place)
    assert check([anonymous], species=species_maxima(SPECIES)).issues == ()


def test_a_video_vertex_is_placed_by_its_video_and_left_frame():
    stored = StoredObject(3, "point", "", "", "", "", "", (Vertex(1, 2, 3, 4, pair="dive", video="dive",
                                                                  frame_left=812, frame_right=815, time_s=32.5),))
    assert Place.of(stored) == Place("video 'dive', frame 812", "dive", "dive", 812)


def test_the_590_mm_fish_of_a_wrong_accepted_match_is_listed_by_the_weak_match_and_geometry_rules(tmp_path):
    """Issue 32's case: a 360 mm fish side on 3 m away; the fork's conjugate proposed on the wrong peak of its
    epipolar curve (a weak match: ambiguous), accepted with Enter. The length comes out near 590 mm and every
    precision rule passes — the weak-match rule (a fact stored with the vertex, whatever the notes say) and
    the geometry rule (the length leans far out of the image plane) list it; the good fish beside it is not."""
    from usvips.app.quality import object_facts
    from usvips.core.pointing import WeakMatch

    calibration = load_calibration(scaling.CALIBRATION)
    rig = calibration.rig(0, "rig")
    snout, fork = np.array([-0.18, 0.0, -3.0]), np.array([0.18, 0.0, -3.0])
    # the wrong conjugate: a point on the fork's LEFT ray (same left pixel) 590 mm from the snout
    ray = rig.left.rays(rig.left.project(fork[None]).pixels)
    origin, direction = ray.origins[0], ray.directions[0]
    along = np.linspace(0.5, 8.0, 20001)
    candidates = origin + along[:, None] * direction
    wrong = candidates[np.argmin(np.abs(np.linalg.norm(candidates - snout, axis=1) - 0.59))]
    shift = float(np.linalg.norm(rig.right.project(wrong[None]).pixels[0] - rig.right.project(fork[None]).pixels[0]))
    assert 15 < shift < 60, shift  # tens of pixels along the curve, as in the issue
    path = tmp_path / "survey.usvips"
    with Project.create(path) as project:
        project.add_pair("dive")
        calibration_id = project.add_calibration("cal", calibration_to_dict(calibration), ("dive",))

        def vertex(point, right_point=None, **pointing):
            left = rig.left.project(point[None]).pixels[0]
            right = rig.right.project((point if right_point is None else right_point)[None]).pixels[0]
            return Vertex(*map(float, (*left, *right)), calibration_id=calibration_id, pair="dive", **pointing)

        weak = WeakMatch(0.46, "a second peak scores 0.97 of the best: ambiguous")
        bad = project.add_object("length", [vertex(snout), vertex(fork, wrong, source="auto-match", weak=weak)],
                                 "Pagrus auratus", "weak: ambiguous")
        good = project.add_object("length", [vertex(snout + [0, 0.3, 0]), vertex(fork + [0, 0.3, 0])], "Pagrus auratus")
        project.update_object(bad, notes="looks fine to me")  # a colleague's notes edit erases nothing
    with Project.open(path, read_only=True) as project:
        report = check_project(project)
        stored = project.object(bad)
        m = evaluate(measurement_input(project, stored))
        facts = object_facts(stored, m)
    assert abs(m.main.value - 0.59) < 0.01 and not m.failures  # 590 mm, and every precision rule passes
    listed = {(i.object_id, i.rule) for i in report.issues}
    assert {(str(bad), "weak_match"), (str(bad), "geometry")} <= listed
    assert not any(object_id == str(good) for object_id, _ in listed)
    geometry = next(i for i in report.issues if i.rule == "geometry")
    assert geometry.status == FAIL and geometry.value > geometry.limit == 45.0
    assert len(facts) == 2 and "weak match accepted" in facts[0] and "0.46" in facts[0]


def test_a_damaged_calibration_stops_the_check_and_the_export_rather_than_change_their_figures(tmp_path):
    """Figures of objects whose calibration cannot be read would come from the vertices' stored values
    and differ from the calibration's, silently: the check and the export name the calibration instead."""
    import sqlite3

    from usvips.app.project_export import export_project
    from usvips.core.errors import UsvipsError

    build_survey(tmp_path / "survey.usvips")
    connection = sqlite3.connect(tmp_path / "survey.usvips")
    with connection:
        connection.execute("UPDATE calibrations SET json = '{not json'")
    connection.close()
    with Project.open(tmp_path / "survey.usvips", read_only=True) as project:
        with pytest.raises(UsvipsError, match="calibration 1 is damaged"):
            check_project(project)
        with pytest.raises(UsvipsError, match="calibration 1 is damaged"):
            export_project(project, tmp_path / "objects.csv")
    assert not (tmp_path / "objects.csv").exists()
