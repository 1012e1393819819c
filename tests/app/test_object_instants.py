"""An object measured on several instants in a project: linked with the domain's checks, its figures
combined through the one figure path, exported once with the number of instants."""

import csv

import numpy as np
import pytest

from usvips.app.object_instants import add_instant, has_tracked_instants, is_tracked, survey_objects
from usvips.app.project_export import export_project
from usvips.app.project_figures import (
    _pointing_only,
    evaluate,
    instant_measurements,
    measure_stored,
    measurement_input,
)
from usvips.bench import scaling
from usvips.core.errors import UsvipsError
from usvips.core.measurements.instants import combine_figure
from usvips.io.calibration_file import calibration_to_dict, load_calibration
from usvips.store import Project
from usvips.store.project import Vertex


@pytest.fixture
def calibration():
    return load_calibration(scaling.CALIBRATION)  # the sample's, with its parameters' covariance


def _picks(rig, ends, rng, noise=0.3):
    left, right = rig.left.project(ends), rig.right.project(ends)
    assert left.ok.all() and right.ok.all()
    return np.hstack([left.pixels, right.pixels]) + rng.normal(0, noise, (len(ends), 4))


def _store_instants(project, calibration, calibration_id, lengths, rng, pair="dive"):
    """One length object per instant (the fish at another place each time); returns their ids."""
    rig = calibration.rig(0, "rig")
    ids = []
    for k, length in enumerate(lengths):
        snout = np.array([0.05 + 0.02 * k, 0.02 * k, -2.4])  # the rig frame: cameras look along -Z
        ends = np.array([snout, snout + [length, 0.0, 0.02]])
        picks = _picks(rig, ends, rng)
        ids.append(project.add_object("length", [Vertex(*map(float, p), calibration_id=calibration_id, pair=pair)
                                                 for p in picks], "Pagrus auratus"))
    return ids


def test_an_object_on_several_instants_shows_the_combined_length_everywhere(tmp_path, calibration):
    rng = np.random.default_rng(4)
    with Project.create(tmp_path / "p.usvips") as project:
        project.add_pair("dive")
        calibration_id = project.add_calibration("cal", calibration_to_dict(calibration), ("dive",))
        ids = _store_instants(project, calibration, calibration_id, [0.30] * 5, rng)  # a rigid object
        single = _store_instants(project, calibration, calibration_id, [0.25], rng)
        for other in ids[1:]:
            add_instant(project, ids[0], other)
        assert [o.id for o in survey_objects(project)] == [ids[0], single[0]]
        source = measurement_input(project, project.object(ids[0]))
        combined = evaluate(source)
        instants = instant_measurements(source)
        assert combined.instant_count == 5 and len(instants) == 5
        assert measure_stored(project, project.object(single[0])).instant_count == 1
        length = combined.combined[0]
        assert length.labels[0] == f"pair dive (object {ids[0]})"
        # the combination of the instants' own lengths, with the calibration's common part kept whole
        values = [m.main.value for m in instants]
        assert min(values) < combined.main.value < max(values)
        assert combined.main.sigma < min(m.main.sigma for m in instants)
        instant_sources = (source, *source.instants)
        pointing = [_pointing_only(i, m).main.sigma for i, m in zip(instant_sources, instants, strict=True)]
        common = np.mean([m.main.sigma ** 2 - p ** 2 for m, p in zip(instants, pointing, strict=True)])
        assert common > 0 and combined.main.sigma ** 2 >= common
        assert combined.main.sigma > combine_figure(values, [m.main.sigma for m in instants]).sigma
        out = tmp_path / "survey.csv"
        assert export_project(project, out) == 2
        rows = list(csv.DictReader(out.open()))
        assert [r["id"] for r in rows] == [str(ids[0]), str(single[0])]
        assert [r["instants"] for r in rows] == ["5", "1"]
        assert float(rows[0]["length"]) == pytest.approx(combined.main.value, rel=1e-12)
        assert float(rows[0]["s_length"]) == pytest.approx(combined.main.sigma, rel=1e-12)
        export_project(project, tmp_path / "survey.em.txt")
        lengths = list(csv.DictReader((tmp_path / "survey_Lengths.txt").open(), delimiter="\t"))
        assert len(lengths) == 2 and lengths[0]["Comment"] == "mean of 5 instants"
        assert float(lengths[0]["Length"]) == pytest.approx(combined.main.value * 1000, rel=1e-9)
        assert float(lengths[0]["Precision"]) == pytest.approx(combined.main.sigma * 1000, rel=1e-9)


def test_instants_on_two_calibrations_are_refused_and_nothing_is_stored(tmp_path, calibration):
    rng = np.random.default_rng(5)
    with Project.create(tmp_path / "p.usvips") as project:
        project.add_pair("dive")
        first = project.add_calibration("cal", calibration_to_dict(calibration), ("dive",))
        second = project.add_calibration("recalibrated", calibration_to_dict(calibration))
        a = _store_instants(project, calibration, first, [0.3], rng)[0]
        b = _store_instants(project, calibration, second, [0.3], rng)[0]
        point = project.add_object("point", [Vertex(1.0, 2.0, 3.0, 4.0, calibration_id=first)])
        with pytest.raises(UsvipsError, match=f"object {a}.*calibration {first}.*object {b}.*calibration {second}"):
            add_instant(project, a, b)
        with pytest.raises(UsvipsError, match="one kind"):
            add_instant(project, a, point)
        assert project.instant_links() == {}
        # linked behind the service's back (an older program): the figures refuse it by name, the export
        # leaves the object out and says why
        project.add_instant(a, b)
        with pytest.raises(UsvipsError, match=f"object {a}:.*calibration {first}.*calibration {second}"):
            evaluate(measurement_input(project, project.object(a)))
        skipped = []
        assert export_project(project, tmp_path / "out.csv", skipped=skipped) == 0  # the point has no 3-D values
        assert f"object {a}: " in skipped[0] and "calibration" in skipped[0] and f"object {point}" in skipped[1]


@pytest.mark.parametrize("seed", range(3))
def test_whether_instants_were_tracked_is_stored_and_editing_their_notes_leaves_the_combined_sigma(
        tmp_path, calibration, seed):
    """Tracked instants keep their common pointing error whole in the combined sigma; whether an instant
    was tracked is the link's stored ``tracked_from`` (schema 10), so rewriting the notes — dropping
    "tracked from frame N", or writing it on hand-picked instants — changes no figure."""
    rng = np.random.default_rng(40 + seed)
    with Project.create(tmp_path / "p.usvips") as project:
        project.add_pair("dive")
        calibration_id = project.add_calibration("cal", calibration_to_dict(calibration), ("dive",))
        ids = _store_instants(project, calibration, calibration_id, [0.30] * int(rng.integers(3, 7)), rng)
        start = int(rng.integers(0, 500))
        for other in ids[1:]:
            add_instant(project, ids[0], other, tracked_from=start)
        assert is_tracked(project, ids[1]) and not is_tracked(project, ids[0])
        assert has_tracked_instants(project, ids[0])

        def sigma() -> float:
            return evaluate(measurement_input(project, project.object(ids[0]))).main.sigma

        tracked = sigma()
        for instant in ids:
            project.update_object(instant, notes=f"looked again {rng.random()}")
        assert sigma() == tracked
        for other in ids[1:]:  # the same instants linked as picked by hand …
            project.remove_instant(other)
            add_instant(project, ids[0], other)
        assert not has_tracked_instants(project, ids[0]) and not is_tracked(project, ids[1])
        by_hand = sigma()
        assert by_hand < tracked  # … average their pointing errors out
        for instant in ids:
            project.update_object(instant, notes=f"tracked from frame {start}")  # the old marker, now only text
        assert sigma() == by_hand
