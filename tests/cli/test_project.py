import json
from pathlib import Path

import numpy as np
import pytest

from usvips.cli import main
from usvips.store import Project
from usvips.store.project import Vertex

SAMPLE = Path(__file__).resolve().parents[2] / "sample_projects" / "tank_1995"


def test_project_from_the_sample_and_export(tmp_path, capsys):
    out = tmp_path / "tank.usvips"
    assert main(["project", "new", str(out), "--from", str(SAMPLE)]) == 0
    assert main(["project", "info", str(out)]) == 0
    text = capsys.readouterr().out
    assert "3 image pairs, 0 videos, 24 control points, 0 objects" in text
    with Project.open(out) as project:
        assert len(project.control_observations("check", "water2")) == 9
        cov = np.diag([1e-6, 1e-6, 4e-6])
        project.add_object("line", [Vertex(1, 2, 3, 4, (0, 0, -2.0), cov), Vertex(5, 6, 7, 8, (0.3, 0.4, -2.0), cov)],
                           attribute="cod")
    assert main(["project", "export", str(out), str(tmp_path / "objects.geojson")]) == 2
    assert "no georeference" in capsys.readouterr().err and not (tmp_path / "objects.geojson").exists()
    assert main(["project", "set-georeference", str(out), "--latitude", "-32", "--longitude", "115"]) == 0
    assert main(["project", "export", str(out), str(tmp_path / "objects.geojson")]) == 0
    feature = json.loads((tmp_path / "objects.geojson").read_text())["features"][0]
    assert feature["properties"]["length"] == 0.5


def test_project_errors_are_one_line(tmp_path, capsys):
    assert main(["project", "info", str(SAMPLE / "README.md")]) == 2
    assert "not a USVIPS project" in capsys.readouterr().err
    out = tmp_path / "p.usvips"
    assert main(["project", "new", str(out)]) == 0
    assert main(["project", "new", str(out)]) == 2
    assert "already exists" in capsys.readouterr().err
    assert main(["project", "import", str(out), "--obs", str(SAMPLE / "air_pair1_table3_2.csv")]) == 2
    assert "observations need the image pair they belong to (set it with --pair)" in capsys.readouterr().err
    bad = tmp_path / "bad"
    bad.mkdir()
    (bad / "project.json").write_text('{"format": "usvips-sample", "version": 1, "name": "x", "control": "no.csv"}')
    assert main(["project", "new", str(tmp_path / "q.usvips"), "--from", str(bad)]) == 2
    assert not (tmp_path / "q.usvips").exists()


def test_export_for_checkem_fills_opcode_rms_range_and_image_names(tmp_path):
    """A fish measured in the rendered sample, exported as EventMeasure-style tables: the columns CheckEM
    filters on (RMS, range, precision) are filled, so its default filters keep the row."""
    import json
    import shutil

    from usvips.app.samples import open_or_create_from_manifest
    from usvips.gui.workspace import Workspace, load_pair_images

    sample = tmp_path / "rov"
    shutil.copytree(Path(__file__).resolve().parents[2] / "sample_projects" / "rov_flatport", sample,
                    ignore=shutil.ignore_patterns("project.usvips*"))
    project = open_or_create_from_manifest(sample)
    truth = json.loads((sample / "truth.json").read_text())
    cameras = next(p for p in truth["pairs"] if p["label"] == "measure1")["cameras"]
    ws = Workspace()
    ws.open_project(project)
    ws.set_pair("measure1", *load_pair_images(project, "measure1"))
    ws.pick_tool.set_tool("line")
    for point in ("snout", "fork"):
        ws.pick_tool.pick("left", cameras["left"]["objects"]["fish1"][point])
        ws.pick_tool.pick("right", cameras["right"]["objects"]["fish1"][point])
    ws.pick_tool.finish_object("Sparidae Pagrus auratus")
    ws.close_project()
    assert main(["project", "export", str(sample / "project.usvips"), str(tmp_path / "survey.em.txt"),
                 "--opcode", "DEP01"]) == 0
    header, row = [line.split("\t") for line in (tmp_path / "survey_Lengths.txt").read_text().splitlines()]
    values = dict(zip(header, row, strict=True))
    assert values["OpCode"] == "DEP01" and values["FilenameLeft"] == "measure1_left.png"
    assert float(values["Length"]) == pytest.approx(truth["objects"][0]["length"] * 1000, abs=3 * float(
        values["Precision"]))
    assert 0 < float(values["RMS"]) < 20 and 1000 < float(values["Range"]) < 10_000
    assert float(values["Precision"]) / float(values["Length"]) < 0.10


def _snapshot(path: Path) -> dict:
    with Project.open(path, read_only=True) as project:
        return {"pairs": project.pairs(), "control": project.control().ids,
                "calibrations": [c.id for c in project.calibrations()],
                "obs": {p.label: project.control_observations("calibration-water", p.label).ids
                        for p in project.pairs()}}


def test_a_failed_import_changes_nothing(tmp_path, capsys):
    """Control that reads, then observations whose pair cannot take them: neither is stored."""
    out = tmp_path / "tank.usvips"
    assert main(["project", "new", str(out), "--from", str(SAMPLE)]) == 0
    before = _snapshot(out)
    bad_obs = tmp_path / "bad.csv"
    bad_obs.write_text("id,xl,yl,xr,yr\n1,1,2,3,4\n2,1,2,3\n")
    assert main(["project", "import", str(out), "--control", str(SAMPLE / "control_table3_2.csv"),
                 "--obs", str(bad_obs), "--pair", "new-pair"]) == 2
    assert "bad.csv, line 3" in capsys.readouterr().err
    good_obs = tmp_path / "good.csv"
    good_obs.write_text("id,xl,yl,xr,yr\n1,1,2,3,4\n")
    assert main(["project", "import", str(out), "--obs", str(good_obs), "--pair", "fresh"]) == 0
    capsys.readouterr()
    with_fresh = _snapshot(out)
    # the same observation again: the stored one collides, after the control was replaced in the transaction
    assert main(["project", "import", str(out), "--control", str(SAMPLE / "control_table3_2.csv"),
                 "--obs", str(good_obs), "--pair", "fresh"]) == 2
    err = capsys.readouterr().err
    assert "point(s) 1 already have observations stored" in err and err.count("\n") == 1
    assert _snapshot(out) == with_fresh and before["control"] == with_fresh["control"]


def test_info_and_export_never_change_an_older_project(tmp_path, capsys):
    old = tmp_path / "old.usvips"
    old.write_bytes((Path(__file__).resolve().parents[1] / "store" / "data" / "project_v1.usvips").read_bytes())
    before = old.read_bytes()
    assert main(["project", "info", str(old)]) == 0
    assert "schema 1" in capsys.readouterr().out
    assert main(["project", "export", str(old), str(tmp_path / "objects.csv")]) == 0
    assert old.read_bytes() == before and not list(tmp_path.glob("*.bak"))
    assert main(["project", "import", str(old), "--control", str(SAMPLE / "control_table3_2.csv")]) == 0
    assert (tmp_path / "old.usvips.schema1.bak").read_bytes()[:16] == before[:16]


def test_output_paths_that_cannot_be_written_are_one_line(tmp_path, capsys):
    out = tmp_path / "p.usvips"
    assert main(["project", "new", str(out), "--from", str(SAMPLE)]) == 0
    capsys.readouterr()
    (tmp_path / "folder.csv").mkdir()
    for target, message in ((tmp_path / "folder.csv", "is a folder"), (tmp_path / ("x" * 300 + ".csv"), "too long"),
                            (tmp_path / "missing" / "o.csv", "does not exist")):
        assert main(["project", "export", str(out), str(target)]) == 2
        err = capsys.readouterr().err
        assert message in err and err.count("\n") == 1, err


def test_new_on_a_dangling_symlink_in_a_sample_folder_is_refused(tmp_path, capsys):
    import shutil

    from usvips.app.samples import open_or_create_from_manifest
    from usvips.store import ProjectError

    sample = tmp_path / "tank"
    shutil.copytree(SAMPLE, sample, ignore=shutil.ignore_patterns("project.usvips*"))
    (sample / "project.usvips").symlink_to(tmp_path / "target.usvips")
    with pytest.raises(ProjectError, match="symbolic link"):
        open_or_create_from_manifest(sample)
    assert not (tmp_path / "target.usvips").exists()


def test_a_species_list_and_records_reach_the_checkem_tables(tmp_path):
    """A species list imported into a project, a record typed for a stored fish: `project export` writes
    the record's family, genus, species, code, number, stage and activity into the Lengths table."""
    import shutil

    from usvips.app.samples import open_or_create_from_manifest
    from usvips.core.observation_record import ObservationRecord
    from usvips.io.species_list import read_species_list
    from usvips.store.project import Vertex

    sample = tmp_path / "rov"
    shutil.copytree(Path(__file__).resolve().parents[2] / "sample_projects" / "rov_flatport", sample,
                    ignore=shutil.ignore_patterns("project.usvips*"))
    (tmp_path / "species.csv").write_text("family,genus,species,code\nSparidae,Chrysophrys,auratus,37353001\n"
                                          "Labridae,Notolabrus,tetricus,37384045\n")
    project = open_or_create_from_manifest(sample)
    species = read_species_list(tmp_path / "species.csv")
    project.set_species_list(species)
    measured = [Vertex(100.0, 200.0, 80.0, 200.0, (0.0, 0.0, -2.0), np.eye(3) * 1e-6),
                Vertex(300.0, 200.0, 280.0, 200.0, (0.3, 0.0, -2.0), np.eye(3) * 1e-6)]
    fish = project.add_object("length", measured, attribute="snapper")
    snapper = next(s for s in project.species_list() if s.genus == "Chrysophrys")
    project.set_record(fish, ObservationRecord(snapper.family, snapper.genus, snapper.species, snapper.code, 2,
                                               "J", "passing"))
    project.close()
    assert main(["project", "export", str(sample / "project.usvips"), str(tmp_path / "s.em.txt")]) == 0
    header, row = [line.split("\t") for line in (tmp_path / "s_Lengths.txt").read_text().splitlines()]
    values = dict(zip(header, row, strict=True))
    assert [values[k] for k in ("Family", "Genus", "Species", "Code", "Number", "Stage", "Activity")] == [
        "Sparidae", "Chrysophrys", "auratus", "37353001", "2", "J", "passing"]


def test_a_calibration_made_active_for_pairs_given_in_several_options_is_active_for_all(tmp_path, capsys):
    """`--active-for A --active-for B C` makes it active for A, B and C (a second option used to replace the
    first silently)."""
    rov = SAMPLE.parent / "rov_flatport"
    project = tmp_path / "p.usvips"
    assert main(["project", "new", str(project), "--from", str(rov)]) == 0
    with Project.open(project) as p:
        labels = [pair.label for pair in p.pairs()][:3]
    assert main(["project", "import", str(project), "--calibration", str(rov / "calibration_air.json"),
                 "--active-for", labels[0], "--active-for", *labels[1:]]) == 0
    with Project.open(project) as p:
        active = {p.active_calibration(label) for label in labels}
    assert len(active) == 1 and None not in active
