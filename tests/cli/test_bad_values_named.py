"""Values that were once accepted without a word, or refused with a message that blamed the wrong thing: each
is now one line on stderr, status 2, naming the file and line or the option, and nothing is written."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from tests.cli.test_bad_input import ROV, run

PICKS_HEADER = "object,type,vertex,xl,yl,xr,yr,attribute\n"
#: two vertices of the ROV sample's observations (a left and a right pixel each)
FIRST, SECOND = "455.9729,27.2609,227.7779,29.8239", "448.3771,244.2345,222.6491,246.0577"


def refused(args: list[str], *named: str) -> str:
    code, err = run(args)
    assert code == 2 and err.count("\n") == 1 and "Traceback" not in err, err
    for word in named:
        assert word in err, err
    return err


def measure(tmp_path: Path, picks: str, *extra: str) -> list[str]:
    path = tmp_path / "picks.csv"
    path.write_text(PICKS_HEADER + picks)
    return ["measure", "--calibration", str(ROV / "calibration.json"), "--picks", str(path),
            "--out", str(tmp_path / "out.csv"), *extra]


def test_two_attributes_for_one_object_name_both_lines(tmp_path):
    args = measure(tmp_path, f"f1,length,0,{FIRST},Bream\nf1,length,1,{SECOND},Snapper\n")
    refused(args, "picks.csv", "line 3", "'Bream' on line 2", "'Snapper' on line 3")
    assert not (tmp_path / "out.csv").exists()


def test_an_attribute_given_on_a_later_vertex_only_is_the_objects(tmp_path):
    args = measure(tmp_path, f"f1,length,0,{FIRST},\nf1,length,1,{SECOND},Bream\n")
    assert run(args)[0] == 0
    assert ",Bream," in (tmp_path / "out.csv").read_text()


def test_an_arc_with_a_vertex_given_twice_in_a_row_is_degenerate(tmp_path):
    args = measure(tmp_path, f"a,arc,0,{FIRST},\na,arc,1,{FIRST},\na,arc,2,{SECOND},\n")
    refused(args, "picks.csv", "object 'a'", "the arc's vertices 0 and 1 coincide")
    assert not (tmp_path / "out.csv").exists()


def test_a_line_of_one_vertex_is_named_as_the_type_written(tmp_path):
    refused(measure(tmp_path, f"f1,line,0,{FIRST},\n"), "line 2", "type 'line' with 1 vertex is read as arc",
            "an arc needs at least 2 vertices")


def test_pair_without_a_project_is_refused(tmp_path):
    refused(measure(tmp_path, f"f1,length,0,{FIRST},\nf1,length,1,{SECOND},\n", "--pair", "water1"), "--pair")
    assert not (tmp_path / "out.csv").exists()


@pytest.mark.parametrize("where", ["interior", "relative"])
def test_an_unknown_calibration_parameter_is_named_not_dropped(tmp_path, where):
    data = json.loads((ROV / "calibration.json").read_text())
    if where == "interior":
        data["cameras"]["left"]["interior"]["k4"] = 0.5
        named = "cameras.left.interior.k4"
    else:
        data["relative_orientation"]["bw"] = 0.1
        named = "relative_orientation.bw"
    calibration = tmp_path / "calibration.json"
    calibration.write_text(json.dumps(data))
    refused(["intersect", "--calibration", str(calibration), "--obs", str(ROV / "observations_water.csv"),
             "--out", str(tmp_path / "points.csv")], "calibration.json", named)
    assert not (tmp_path / "points.csv").exists()


@pytest.mark.parametrize("sigma", ["1e-300", "1e-4", "1e6"])
def test_an_implausible_pointing_sigma_is_named_not_blamed_on_the_rays(tmp_path, sigma):
    err = refused(["intersect", "--calibration", str(ROV / "calibration.json"), "--obs",
                   str(ROV / "observations_water.csv"), "--out", str(tmp_path / "p.csv"), f"--pointing-sigma={sigma}"],
                  "--pointing-sigma", "0.001 to 1000 pixels")
    assert "parallel" not in err


def test_a_species_code_given_to_two_taxa_is_refused_by_line(tmp_path):
    project = tmp_path / "survey.usvips"
    assert run(["project", "new", str(project)])[0] == 0
    species = tmp_path / "species.csv"
    species.write_text("family,genus,species,code,max_length_mm\nSparidae,Pagrus,auratus,SNA,1300\n"
                       "Labridae,Notolabrus,fucicola,SNA,500\n")
    refused(["species", "import", str(project), str(species)], "species.csv", "line 3", "'SNA'", "line 2")


def test_a_maximum_length_in_a_unit_not_read_is_refused(tmp_path):
    project = tmp_path / "survey.usvips"
    assert run(["project", "new", str(project)])[0] == 0
    species = tmp_path / "species.csv"
    species.write_text("family,genus,species,max_length_in\nSparidae,Pagrus,auratus,40\n")
    refused(["species", "import", str(project), str(species)], "species.csv", "'max_length_in'", "_mm, _cm or _m")


def test_a_negative_render_seed_is_named(tmp_path):
    target = tmp_path / "board.json"
    assert run(["target", "describe", "chessboard", "--cols", "9", "--rows", "6", "--square", "30",
                "--out", str(target)])[0] == 0
    refused(["render", "--target", str(target), "--views", "2", "--image-size", "320x240", "--supersample", "1",
             "--out", str(tmp_path / "views"), "--seed", "-1"], "--seed")
    assert not (tmp_path / "views").exists()


@pytest.mark.parametrize("option", ["--max-views", "--every"])
def test_a_count_of_zero_views_is_refused(tmp_path, option):
    refused(["calibrate", "air", "--control", str(ROV / "control.csv"), "--obs", str(ROV / "observations_air.csv"),
             "--out", str(tmp_path / "air.json"), option, "0"], option)
    assert not (tmp_path / "air.json").exists()


def test_observations_outside_the_given_image_size_are_refused_by_line(tmp_path):
    refused(["calibrate", "air", "--control", str(ROV / "control.csv"), "--obs", str(ROV / "observations_air.csv"),
             "--out", str(tmp_path / "air.json"), "--image-size", "64x48"],
            "observations_air.csv", "line 2", "outside the left image (64 × 48 px")
    assert not (tmp_path / "air.json").exists()


@pytest.mark.parametrize("option,value,named", [("--fix", "f_l=0", "f_l must be > 0"),
                                                ("--fix", "sy_r=-1", "sy_r must be > 0"),
                                                ("--prior", "f=0:10", "f (f_")])
def test_a_focal_length_fixed_or_believed_at_zero_is_named(tmp_path, option, value, named):
    refused(["calibrate", "air", "--control", str(ROV / "control.csv"), "--obs", str(ROV / "observations_air.csv"),
             "--out", str(tmp_path / "air.json"), option, value], named, option)
    assert not (tmp_path / "air.json").exists()


@pytest.mark.parametrize("option,value,named", [("--range", "1:1", "FROM must be less than TO"),
                                                ("--range", "2:1", "FROM must be less than TO"),
                                                ("--range", "0:3", "FROM must be > 0 m"),
                                                ("--across", "0:0", "FROM must be less than TO"),
                                                ("--across", "1:-1", "FROM must be less than TO"),
                                                ("--focal-px", "1e-9", "1 to 1e+06 pixels")])
def test_plan_spans_that_are_no_span_and_a_focal_length_of_no_camera_are_named(option, value, named):
    base = ["plan", "--json", "--focal-px", "1000", "--image-size", "1280x960", "--baseline", "0.3"]
    refused([*base, f"{option}={value}"], option, named)


def test_a_single_range_is_a_span_of_one():
    assert run(["plan", "--json", "--focal-px", "1000", "--image-size", "1280x960", "--baseline", "0.3",
                "--range", "2:2:1"])[0] == 0


def test_a_folder_given_for_a_file_is_said_to_be_a_folder(tmp_path):
    folder = tmp_path / "observations.csv"
    folder.mkdir()
    refused(["intersect", "--calibration", str(ROV / "calibration.json"), "--obs", str(folder),
             "--out", str(tmp_path / "p.csv")], "observations.csv", "is a folder, not a file")
    project = tmp_path / "survey.usvips"
    assert run(["project", "new", str(project)])[0] == 0
    refused(["species", "import", str(project), str(folder)], "is a folder, not a file")


def test_imported_observations_off_every_image_or_off_the_calibrations_are_refused_by_line(tmp_path):
    project = tmp_path / "survey.usvips"
    assert run(["project", "new", str(project)])[0] == 0
    before = project.read_bytes()
    left_of_all = tmp_path / "left_of_all.csv"
    left_of_all.write_text("id,xl,yl,xr,yr\n1,100,100,100,100\n2,-5000,100,100,100\n")
    refused(["project", "import", str(project), "--obs", str(left_of_all), "--pair", "measure1"],
            "left_of_all.csv", "line 3", "point '2'", "outside every image")
    beyond = tmp_path / "beyond.csv"
    beyond.write_text("id,xl,yl,xr,yr\n1,100,100,5000,100\n")
    refused(["project", "import", str(project), "--obs", str(beyond), "--pair", "measure1", "--calibration",
             str(ROV / "calibration.json"), "--active-for", "measure1"], "beyond.csv", "line 2",
            "outside the right image (640 × 480 px")
    assert project.read_bytes() == before


def test_a_scene_whose_cameras_are_in_one_place_is_named_by_its_file(tmp_path):
    scene = json.loads((ROV / "scene.json").read_text())
    scene["relative"].update(bx=0, by=0, bz=0)
    path = tmp_path / "scene.json"
    path.write_text(json.dumps(scene))
    refused(["render", str(path), "--out", str(tmp_path / "rendered")], "scene.json", "relative: bx, by and bz")
    assert not (tmp_path / "rendered").exists()


@pytest.mark.parametrize("rows", [1, 3000])  # one line read line by line; many read as a block
def test_python_digit_separators_are_no_number_in_a_table(tmp_path, rows):
    observations = tmp_path / "observations.csv"
    good = [f"{i},{100 + i % 400}.5,200.25,{90 + i % 400}.5,200.75" for i in range(rows)]
    good[-1] = f"{rows - 1},1_00.5,200.25,90.5,200.75"
    observations.write_text("id,xl,yl,xr,yr\n" + "\n".join(good) + "\n")
    refused(["intersect", "--calibration", str(ROV / "calibration.json"), "--obs", str(observations),
             "--out", str(tmp_path / "p.csv")], "observations.csv", f"line {rows + 1}", "'1_00.5' is not a number")
    picks = tmp_path / "picks.csv"
    picks.write_text(PICKS_HEADER + f"a,point,1_0,{FIRST},\n")
    refused(["measure", "--calibration", str(ROV / "calibration.json"), "--picks", str(picks), "--out",
             str(tmp_path / "m.csv")], "picks.csv", "line 2", "'1_0'")


@pytest.mark.parametrize("value", ["1e-300", "0.01", "200000"])
def test_a_maximum_length_of_no_organism_is_refused(tmp_path, value):
    project = tmp_path / "survey.usvips"
    assert run(["project", "new", str(project)])[0] == 0
    species = tmp_path / "species.csv"
    species.write_text(f"family,genus,species,max_length_mm\nSparidae,Pagrus,auratus,{value}\n")
    refused(["species", "import", str(project), str(species)], "species.csv", "line 2", "than any",
            "is the unit right?")


def test_json_and_toml_files_saved_with_a_byte_order_mark_are_read(tmp_path):
    calibration = tmp_path / "calibration.json"
    calibration.write_bytes(b"\xef\xbb\xbf" + (ROV / "calibration.json").read_bytes())
    code, err = run(["intersect", "--calibration", str(calibration), "--obs", str(ROV / "observations_water.csv"),
                     "--out", str(tmp_path / "p.csv")])
    assert code == 0, err
    scene = tmp_path / "scene.json"
    scene.write_bytes(b"\xef\xbb\xbf" + (ROV / "scene.json").read_bytes())
    from usvips.io.scene import read_scene
    assert read_scene(scene).seed == json.loads((ROV / "scene.json").read_text())["seed"]


def test_control_points_in_one_place_are_refused_by_line(tmp_path):
    control = tmp_path / "control.csv"
    control.write_text("id,X,Y,Z\na,0,0,0\nb,0.1,0,0\nc,0,0,0\n")
    refused(["calibrate", "air", "--control", str(control), "--obs", str(ROV / "observations_air.csv"),
             "--out", str(tmp_path / "air.json")], "control.csv", "line 4", "point 'c'", "point 'a' (line 2)")


@pytest.mark.parametrize("kind", ["calibration", "scene"])
def test_a_json_key_given_twice_is_named(tmp_path, kind):
    text = (ROV / f"{kind}.json").read_text()
    key = '"f":' if kind == "calibration" else '"seed":'
    path = tmp_path / f"{kind}.json"
    path.write_text(text.replace(key, f"{key} 1, {key}", 1))
    args = (["intersect", "--calibration", str(path), "--obs", str(ROV / "observations_water.csv"), "--out",
             str(tmp_path / "p.csv")] if kind == "calibration" else ["render", str(path), "--out", str(tmp_path / "r")])
    refused(args, f"{kind}.json", f"the key {key[:-1]!r}".replace('"', ""), "given twice")


def test_a_taxon_name_too_long_to_be_one_is_refused_by_line(tmp_path):
    project = tmp_path / "survey.usvips"
    assert run(["project", "new", str(project)])[0] == 0
    species = tmp_path / "species.csv"
    species.write_text("family,genus,species\nSparidae,Pagrus,auratus\nSparidae,Pagrus," + "a" * 1_000 + "\n")
    refused(["species", "import", str(project), str(species)], "species.csv", "line 3", "1,000 characters")
    species.write_text("family,genus,species\nSparidae,Pagrus,auratus\nSparidae,Pagrus," + "a" * 100_000 + "\n")
    refused(["species", "import", str(project), str(species)], "species.csv", "line 3", "characters long")


@pytest.fixture
def video_survey(tmp_path):
    """A new project holding the ROV sample's stereo video as pair 'V'."""
    project = tmp_path / "survey.usvips"
    assert run(["project", "new", str(project)])[0] == 0
    code, err = run(["project", "add-video", str(project), "--left", str(ROV / "video_left.mp4"),
                     "--right", str(ROV / "video_right.mp4"), "--label", "V"])
    assert code == 0, err
    return project


def test_a_period_name_given_twice_is_named_not_left_to_the_store(video_survey):
    assert run(["video", "period", str(video_survey), "--pair", "V", "--add", "p1", "0", "5"])[0] == 0
    err = refused(["video", "period", str(video_survey), "--pair", "V", "--add", "p1", "2", "8"],
                  "--add NAME", "already has a period 'p1'")
    assert "UNIQUE" not in err


def test_an_empty_frame_folder_is_refused(video_survey, tmp_path):
    refused(["video", "export-frame", str(video_survey), "--pair", "V", "--frame", "5", "--out", ""], "--out")
    assert not (tmp_path / "left.png").exists()


@pytest.mark.parametrize("opcode", ["", "a\nb"])
def test_an_empty_or_two_line_opcode_is_refused(video_survey, tmp_path, opcode):
    refused(["project", "export", str(video_survey), str(tmp_path / "z.em.txt"), "--opcode", opcode], "--opcode")
    assert not list(tmp_path.glob("z*"))


def test_an_empty_campaign_value_is_refused_not_stored_over_the_one_before(video_survey):
    assert run(["project", "set-campaign", str(video_survey), "--campaign-id", "2024-01_Test_stereo-BRUVs"])[0] == 0
    refused(["project", "set-campaign", str(video_survey), "--campaign-id", ""], "--campaign-id", "--clear")
    from usvips.store.opening import open_project
    with open_project(video_survey, read_only=True) as project:
        assert project.campaign().campaign_id == "2024-01_Test_stereo-BRUVs"


@pytest.mark.parametrize("option", [["--replicas", "5"], ["--seed", "3"], ["--pointing-sigma", "0.5"]])
def test_monte_carlo_options_without_sigma_are_refused(video_survey, option):
    refused(["project", "check", str(video_survey), *option], option[0], "--sigma")


def test_an_output_folder_that_is_a_file_is_named(tmp_path):
    observations = tmp_path / "obs.csv"
    observations.write_bytes((ROV / "observations_water.csv").read_bytes())
    before = observations.read_bytes()
    refused(["batch", "intersect", str(observations), "--calibration", str(ROV / "calibration.json"),
             "--out-dir", str(observations)], "--out-dir", "is a file, not a folder")
    assert observations.read_bytes() == before


def test_a_folder_given_for_a_project_is_said_to_be_a_folder(tmp_path):
    folder = tmp_path / "survey.usvips"
    folder.mkdir()
    refused(["video", "sync", str(folder), "--pair", "V"], "survey.usvips", "is a folder, not a project file")
    refused(["project", "check", str(folder)], "is a folder, not a project file")
