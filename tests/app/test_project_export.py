"""GeoJSON places objects on the Earth through the georeference of the OBJECT frame: an object measured
in the rig frame (on a pair that is not a calibrated station: camera-relative metres) is left out and
named, not written with a height as if its Z were up; the CSV keeps it."""

import csv
import json
import shutil

import numpy as np

from tests.gui.conftest import SAMPLES, isolated_targets, truth_pixels
from usvips.app.pair_geometry import pair_geometry
from usvips.app.project_export import export_project
from usvips.app.project_figures import store_measurements
from usvips.app.samples import open_or_create_from_manifest
from usvips.core.deployment import Georeference


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
