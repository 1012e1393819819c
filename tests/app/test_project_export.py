"""GeoJSON places objects on the Earth through the georeference of the OBJECT frame: an object measured
in the rig frame (on a pair that is not a calibrated station: camera-relative metres) is left out and
named, not written with a height as if its Z were up; the CSV keeps it. An object measured on several
instants is exported once by every format, with its combined figures and its number of instants."""

import csv
import json
import shutil

import numpy as np
import pytest

from tests.gui.conftest import SAMPLES, isolated_targets, truth_pixels
from usvips.app.object_instants import add_instant
from usvips.app.pair_geometry import pair_geometry
from usvips.app.project_export import export_project
from usvips.app.project_figures import evaluate, measurement_input, store_measurements
from usvips.app.samples import open_or_create_from_manifest
from usvips.core.deployment import Georeference
from usvips.io.georeference import object_to_geographic


def test_geojson_holds_the_object_frame_objects_and_names_the_rig_frame_ones(tmp_path):
    directory = tmp_path / "tank_system1"
    shutil.copytree(SAMPLES / "tank_system1", directory, ignore=shutil.ignore_patterns("project.usvips*"))
    project = open_or_create_from_manifest(directory)
    try:
        assert pair_geometry(project, "water1").frame == "object" and pair_geometry(project, "measure1").frame == "rig"
        left, right = truth_pixels(directory, "water1", "targets")
        targets = isolated_targets(left, right)[:2]
        points = [(f"p{k}", "point", np.array([[*left[t], *right[t]]], float), "") for k, t in enumerate(targets)]
        station_ids = store_measurements(project, "water1", points)[1]
        left, right = truth_pixels(directory, "measure1", "objects")
        fish = [("f", "length", np.array([[*left["fish1"][p], *right["fish1"][p]] for p in ("snout", "fork")],
                                         float), "fish")]
        (rig_id,) = store_measurements(project, "measure1", fish)[1]
        project.set_georeference(Georeference(-32.0, 115.0, 12.0, 30.0))
        skipped: list[str] = []
        assert export_project(project, tmp_path / "out.geojson", skipped=skipped) == len(station_ids)
        features = json.loads((tmp_path / "out.geojson").read_text())["features"]
        assert sorted(int(f["id"]) for f in features) == sorted(station_ids)
        assert skipped == [f"object {rig_id}: measured in the rig frame of pair 'measure1' (not a calibrated station), "
                           "so it has no place on the Earth and no height; it is in the CSV exports"]
        assert export_project(project, tmp_path / "out.csv") == len(station_ids) + 1  # the CSV keeps it
        with open(tmp_path / "out.csv", newline="") as stream:
            assert {row["pair"] for row in csv.DictReader(stream)} == {"water1", "measure1"}
    finally:
        project.close()


def test_an_object_on_several_instants_is_exported_once_everywhere_with_its_combined_figure(tmp_path):
    """A length measured three times and a point twice on a calibrated station (pixel noise each time):
    every export holds each object once (never its instants as further fish), with the combined figure,
    its sigma and the number of instants; a combined point is placed at its combined X, Y, Z."""
    directory = tmp_path / "tank_system1"
    shutil.copytree(SAMPLES / "tank_system1", directory, ignore=shutil.ignore_patterns("project.usvips*"))
    project = open_or_create_from_manifest(directory)
    rng = np.random.default_rng(25)
    try:
        left, right = truth_pixels(directory, "water1", "targets")
        a, b, c = isolated_targets(left, right)[:3]

        def picks(*targets):
            return np.array([[*left[t], *right[t]] for t in targets], float) + rng.normal(0, 0.3, (len(targets), 4))

        lengths = store_measurements(project, "water1", [(f"l{k}", "length", picks(a, b), "fish") for k in range(3)])[1]
        points = store_measurements(project, "water1", [(f"p{k}", "point", picks(c), "") for k in range(2)])[1]
        (single,) = store_measurements(project, "water1", [("s", "point", picks(a), "")])[1]
        for whole, further in ((lengths[0], lengths[1:]), (points[0], points[1:])):
            for instant in further:
                add_instant(project, whole, instant)
        combined = {i: evaluate(measurement_input(project, project.object(i))) for i in (lengths[0], points[0], single)}
        assert combined[lengths[0]].instant_count == 3 and combined[points[0]].instant_count == 2
        firsts = {i: evaluate(measurement_input(project, project.object(i), with_instants=False)) for i in combined}
        assert combined[lengths[0]].main.value != firsts[lengths[0]].main.value  # not the first instant's
        georeference = Georeference(-32.0, 115.0, 12.0, 30.0)
        project.set_georeference(georeference)
        wanted = sorted(combined)
        # objects CSV: one row per object, its combined figures and its number of instants
        assert export_project(project, tmp_path / "out.csv") == 3
        with open(tmp_path / "out.csv", newline="") as stream:
            rows = {int(r["id"]): r for r in csv.DictReader(stream)}
        assert sorted(rows) == wanted
        assert [rows[i]["instants"] for i in wanted] == [str(combined[i].instant_count) for i in wanted]
        assert float(rows[lengths[0]]["length"]) == combined[lengths[0]].main.value
        assert float(rows[lengths[0]]["s_length"]) == combined[lengths[0]].main.sigma
        assert float(rows[points[0]]["sZ"]) == combined[points[0]].main.sigma
        # GeoJSON: one feature per object, the same figures and count; the point at its combined place
        assert export_project(project, tmp_path / "out.geojson") == 3
        features = {int(f["id"]): f for f in json.loads((tmp_path / "out.geojson").read_text())["features"]}
        assert sorted(features) == wanted
        for i in wanted:
            properties = features[i]["properties"]
            assert properties["instants"] == combined[i].instant_count
            for figure in combined[i].figures:
                assert properties[figure.name] == figure.value
        assert features[lengths[0]]["properties"]["s_length"] == combined[lengths[0]].main.sigma
        place = np.array([f.value for f in combined[points[0]].figures])  # X, Y, Z combined
        assert not np.allclose(place, firsts[points[0]].points[0], rtol=0, atol=1e-9)
        assert np.allclose(features[points[0]]["geometry"]["coordinates"], object_to_geographic(georeference,
                                                                                                place[None])[0],
                           rtol=0, atol=1e-9)
        # CheckEM (EventMeasure-style tables): one length with its precision, the instants in its comment;
        # one 3-D point per point object, the combined one at its combined place and sigmas
        assert export_project(project, tmp_path / "survey.em.txt") == 3
        table = list(csv.DictReader((tmp_path / "survey_Lengths.txt").open(), delimiter="\t"))
        assert len(table) == 1 and table[0]["Comment"] == "mean of 3 instants"
        assert float(table[0]["Length"]) == pytest.approx(combined[lengths[0]].main.value * 1000, rel=1e-12)
        assert float(table[0]["Precision"]) == pytest.approx(combined[lengths[0]].main.sigma * 1000, rel=1e-12)
        table = list(csv.DictReader((tmp_path / "survey_3DPoints.txt").open(), delimiter="\t"))
        assert len(table) == 2 and [r["Comment"] for r in table] == ["mean of 2 instants", ""]
        sigmas = [f.sigma for f in combined[points[0]].figures]
        for axis, value, sigma in zip("XYZ", place, sigmas, strict=True):
            assert float(table[0][axis]) == pytest.approx(value * 1000, rel=1e-12)
            assert float(table[0][f"s{axis}"]) == pytest.approx(sigma * 1000, rel=1e-12)
    finally:
        project.close()
