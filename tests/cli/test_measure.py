"""usvips measure: fish of known length, measured from noisy picks with a calibration from noisy data."""

import csv

import numpy as np
import pytest

from tests.core.calibration_scenes import FLAT, NOISE_PX, control_frame, observe, rig_at
from usvips.cli import main
from usvips.cli.measure import read_picks
from usvips.core.errors import InputFileError
from usvips.io.tables import write_control, write_observations


def test_fish_lengths_are_within_their_sigmas(tmp_path, capsys):
    control = control_frame()
    write_control(tmp_path / "c.csv", control)
    write_observations(tmp_path / "air.csv", observe(rig_at(0), control.xyz, control.ids, "1", seed=1).observations)
    write_observations(tmp_path / "w.csv", observe(rig_at(0, FLAT), control.xyz, control.ids, "1", seed=2).observations)
    assert main(["calibrate", "air", "--control", str(tmp_path / "c.csv"), "--obs", str(tmp_path / "air.csv"),
                 "--out", str(tmp_path / "air.json"), "--sigma-px", str(NOISE_PX)]) == 0
    assert main(["calibrate", "water", "--base", str(tmp_path / "air.json"), "--housing", "flat-port",
                 "--control", str(tmp_path / "c.csv"), "--obs", str(tmp_path / "w.csv"), "--out",
                 str(tmp_path / "w.json"), "--fix", "t=0.016", "n2=1.65", "--sigma-px", str(NOISE_PX)]) == 0
    rng = np.random.default_rng(7)
    rig = rig_at(0, FLAT)
    lengths, rows = {}, ["object,type,vertex,xl,yl,xr,yr,attribute"]
    for k in range(30):
        snout = np.array([rng.uniform(0.2, 1.0), rng.uniform(0.2, 1.2), rng.uniform(-0.6, -0.1)])
        direction = rng.normal(size=3)
        direction /= np.linalg.norm(direction)
        length = rng.uniform(0.2, 0.5)
        ends = np.array([snout, snout + length * direction])
        pl, pr = rig.left.project(ends), rig.right.project(ends)
        if not (pl.ok.all() and pr.ok.all()):
            continue
        lengths[f"fish{k}"] = length
        for v in range(2):
            xl, yl = pl.pixels[v] + rng.normal(0, NOISE_PX, 2)
            xr, yr = pr.pixels[v] + rng.normal(0, NOISE_PX, 2)
            rows.append(f"fish{k},line,{v},{xl},{yl},{xr},{yr},cod")
    (tmp_path / "picks.csv").write_text("\n".join(rows) + "\n")
    assert main(["measure", "--calibration", str(tmp_path / "w.json"), "--picks", str(tmp_path / "picks.csv"),
                 "--out", str(tmp_path / "fish.csv"), "--pointing-sigma", str(NOISE_PX)]) == 0
    assert f"pointing sigma {NOISE_PX:g} px (given)" in capsys.readouterr().out
    measured = list(csv.DictReader((tmp_path / "fish.csv").open()))
    assert len(measured) == len(lengths) > 20
    normalised = np.array([(float(m["value"]) - lengths[m["object"]]) / float(m["sigma"]) for m in measured])
    assert np.all(np.abs(normalised) < 3.5)
    assert 0.4 < np.mean(normalised**2) < 1.8


def test_bad_picks_are_one_line_errors(tmp_path, capsys):
    (tmp_path / "p.csv").write_text("object,type,vertex,xl,yl,xr,yr\nf,line,0,1,2,3,\n")
    (tmp_path / "cal.json").write_text("{}")
    assert main(["measure", "--calibration", str(tmp_path / "cal.json"), "--picks", str(tmp_path / "p.csv"),
                 "--out", str(tmp_path / "o.csv")]) == 2
    assert "not a USVIPS calibration file" in capsys.readouterr().err
    with pytest.raises(InputFileError, match="line 2: vertex and pixel columns must be numbers"):
        read_picks(tmp_path / "p.csv")
    (tmp_path / "q.csv").write_text("object,type,vertex,xl,yl,xr,yr\nf,hexagon,0,1,2,3,4\n")
    with pytest.raises(InputFileError, match="line 2: type 'hexagon'"):
        read_picks(tmp_path / "q.csv")
    (tmp_path / "big.csv").write_text("object,type,vertex,xl,yl,xr,yr\n\"" + "f" * 200_000 + "\",point,0,1,2,3,4\n")
    with pytest.raises(InputFileError, match="line 2: the line is 200018 characters long"):
        read_picks(tmp_path / "big.csv")
    (tmp_path / "nul.csv").write_bytes(b"object,type,vertex,xl,yl,xr,yr\nf,point,0\x00,1,2,3,4\n")
    with pytest.raises(InputFileError, match="line 2: binary data"):
        read_picks(tmp_path / "nul.csv")
    (tmp_path / "short.csv").write_text("object,type,vertex,xl,yl,xr,yr\nf,point,0,1\n")
    with pytest.raises(InputFileError, match="line 2: 4 fields but the header has 7"):
        read_picks(tmp_path / "short.csv")
    assert not (tmp_path / "o.csv").exists()


def _rov_project(tmp_path):
    import json
    import shutil
    from pathlib import Path

    from usvips.app.samples import open_or_create_from_manifest

    sample = tmp_path / "rov"
    shutil.copytree(Path(__file__).resolve().parents[2] / "sample_projects" / "rov_flatport", sample,
                    ignore=shutil.ignore_patterns("project.usvips*"))
    open_or_create_from_manifest(sample).close()
    truth = json.loads((sample / "truth.json").read_text())
    cameras = next(p for p in truth["pairs"] if p["label"] == "measure1")["cameras"]
    return sample / "project.usvips", cameras["left"]["objects"], cameras["right"]["objects"]


def test_one_figure_path_the_window_measure_and_every_export_agree(tmp_path, capsys):
    """The same objects, stored by ``usvips measure --project``: the window's figure, measure's CSV, the
    exported s_length / s_area / s_diameter and the EventMeasure Precision are one number (to 1e-9), and
    that number carries the correlation between the vertices (the per-vertex blocks give a larger sigma)."""
    from usvips.core.measurements import measure
    from usvips.core.measurements.breakdown import breakdown_text
    from usvips.gui.workspace import Workspace
    from usvips.store import Project

    project_path, left, right = _rov_project(tmp_path)
    ends = [(f, p) for f in ("fish1", "fish2") for p in ("snout", "fork")]
    objects = {"cod": ("line", ends[:2]), "bream": ("length", ends[2:]), "path": ("arc", ends[:3]),
               "patch": ("polygon", ends), "rim": ("circle", ends[1:]), "mark": ("point", ends[:1])}
    rows = ["object,type,vertex,xl,yl,xr,yr,attribute"]
    for name, (kind, vertices) in objects.items():
        for v, (fish, point) in enumerate(vertices):
            rows.append(f"{name},{kind},{v},{left[fish][point][0]},{left[fish][point][1]},{right[fish][point][0]},"
                        f"{right[fish][point][1]},{'=' + name if name == 'cod' else name}")
    (tmp_path / "picks.csv").write_text("\n".join(rows) + "\n")
    assert main(["measure", "--picks", str(tmp_path / "picks.csv"), "--project", str(project_path), "--pair",
                 "measure1", "--out", str(tmp_path / "measured.csv"), "--pointing-sigma", "0.7"]) == 0
    out = capsys.readouterr().out
    assert "stored 6 objects" in out and "pointing sigma 0.7 px (given)" in out
    measured = {r["object"]: r for r in csv.DictReader((tmp_path / "measured.csv").open())}
    assert measured["cod"]["type"] == "length" and measured["path"]["type"] == "arc"
    assert main(["project", "export", str(project_path), str(tmp_path / "objects.csv")]) == 0
    assert main(["project", "export", str(project_path), str(tmp_path / "survey.em.txt")]) == 0
    exported = {r["id"]: r for r in csv.DictReader((tmp_path / "objects.csv").open())}
    lengths = {r["Species"]: r for r in csv.DictReader((tmp_path / "survey_Lengths.txt").open(), dialect="excel-tab")}
    polygons = list(csv.DictReader((tmp_path / "survey_Polygons.txt").open(), dialect="excel-tab"))
    circles = list(csv.DictReader((tmp_path / "survey_Circles.txt").open(), dialect="excel-tab"))
    ws = Workspace()
    with Project.open(project_path) as project:
        ws.open_project(project)
        stored = {o.attribute: o for o in project.objects()}
        assert {o.kind for o in stored.values()} == {"length", "arc", "polygon", "circle", "point"}
        for attribute, obj in stored.items():
            name = attribute.lstrip("=")
            window = ws.figures([obj.id]).figures[0]
            row = exported[str(obj.id)]
            column = {"X": "sX", "Y": "sY", "Z": "sZ"}.get(window.name, f"s_{window.name}")
            assert row["covariance"] == "joint" and row["attribute"] == ("'" + attribute if name == "cod" else name)
            assert abs(float(measured[name]["sigma"]) - window.sigma) < 1e-9, name
            assert abs(float(row[column]) - window.sigma) < 1e-9, name
            assert abs(float(row[window.name]) - window.value) < 1e-9, name
            # the sigma's breakdown: one computation, the same numbers in the window, measure's CSV and the export
            shown = breakdown_text(ws.figures([obj.id]).measurement)
            for table in (measured[name], row):
                assert abs(float(table["sigma_pointing"]) - window.sigma_pointing) < 1e-9, name
                assert abs(float(table["sigma_calibration"]) - window.sigma_calibration) < 1e-9, name
                assert (table["pointing_sigma_px"], table["pointing_origin"]) == ("0.7", "given"), name
            assert window.sigma ** 2 == pytest.approx(window.sigma_pointing ** 2 + window.sigma_calibration ** 2)
            assert window.sigma_calibration > 0 and "pointing σ 0.7 px, given" in shown
            if obj.kind in ("length", "arc"):
                precision = float(lengths["'" + attribute if name == "cod" else name]["Precision"]) / 1000
                assert abs(precision - window.sigma) < 1e-9, name
            if obj.kind == "polygon":
                assert abs(float(polygons[0]["sArea"]) / 1e6 - window.sigma) < 1e-9
            if obj.kind == "circle":
                assert abs(float(circles[0]["sDiameter"]) / 1000 - window.sigma) < 1e-9
            if obj.kind == "length":  # the calibration's common part cancels in a length
                blocks = measure(obj.kind, np.array([v.xyz for v in obj.vertices]),
                                 np.array([v.covariance for v in obj.vertices]))
                assert blocks.main.sigma > 1.2 * window.sigma, (blocks.main.sigma, window.sigma)
        ws.close_project()


def test_measure_into_a_project_is_all_or_nothing_and_refuses_contradictions(tmp_path, capsys):
    from usvips.store import Project

    project_path, left, right = _rov_project(tmp_path)
    good = f"f,line,0,{left['fish1']['snout'][0]},{left['fish1']['snout'][1]},{right['fish1']['snout'][0]}," \
           f"{right['fish1']['snout'][1]}\nf,line,1,{left['fish1']['fork'][0]},{left['fish1']['fork'][1]}," \
           f"{right['fish1']['fork'][0]},{right['fish1']['fork'][1]}\n"
    bad = "g,circle,0,1,2,3,4\ng,circle,1,5,6,7,8\n"  # a circle of two vertices, after a good fish
    (tmp_path / "p.csv").write_text("object,type,vertex,xl,yl,xr,yr\n" + good + bad)
    arguments = ["measure", "--picks", str(tmp_path / "p.csv"), "--project", str(project_path)]
    assert main(arguments) == 2 and "--pair" in capsys.readouterr().err
    assert main(arguments + ["--pair", "measure1"]) == 2
    error = capsys.readouterr().err
    assert "object 'g'" in error and "at least 3 vertices" in error and len(error.strip().splitlines()) == 1
    assert main(arguments + ["--pair", "measure1", "--calibration", "x.json"]) == 2
    assert "leave out --calibration" in capsys.readouterr().err
    with Project.open(project_path) as project:
        assert project.objects() == []  # nothing half-stored
    (tmp_path / "p.csv").write_text("object,type,vertex,xl,yl,xr,yr\n" + good)
    assert main(arguments + ["--pair", "nowhere"]) == 2
    assert "no image pair 'nowhere'" in capsys.readouterr().err
    assert main(arguments + ["--pair", "measure1", "--annotator", "bad\tname"]) == 2
    error = capsys.readouterr().err
    assert "--annotator" in error and "control character" in error and len(error.strip().splitlines()) == 1
    assert main(arguments + ["--pair", "measure1", "--annotator", " K. Jones "]) == 0
    with Project.open(project_path) as project:
        assert [(o.kind, o.creator, o.vertices[0].pair) for o in project.objects()] == [("length", "K. Jones",
                                                                                         "measure1")]
        assert [(e.change, e.annotator) for e in project.history()] == [("add", "K. Jones")]
        assert {v[0] for v in project.provenance(project.objects()[0].id).vertices} == {"K. Jones"}


def test_project_export_names_the_objects_it_leaves_out(tmp_path, capsys):
    from usvips.store import Project
    from usvips.store.project import Vertex

    cov = np.eye(3) * 1e-6
    with Project.create(tmp_path / "p.usvips") as project:
        project.add_object("point", [Vertex(1, 2, 3, 4)], "no 3-D")
        project.add_object("length", [Vertex(1, 2, 3, 4, (0, 0, -2.0), cov), Vertex(5, 6, 7, 8, (0.3, 0.4, -2.0), cov)])
    assert main(["project", "export", str(tmp_path / "p.usvips"), str(tmp_path / "o.csv")]) == 0
    out = capsys.readouterr().out
    assert "skipped object 1: it has vertices without 3-D coordinates" in out and "exported 1 objects" in out
    (row,) = csv.DictReader((tmp_path / "o.csv").open())
    assert row["covariance"] == "per-vertex" and float(row["length"]) == pytest.approx(0.5)


@pytest.fixture(scope="module")
def video_survey(tmp_path_factory):
    from tests.app.test_tracking import _survey

    return _survey(tmp_path_factory.mktemp("video_measure"))


def test_measure_on_a_video_frame_stores_the_object_as_the_window_does(video_survey, tmp_path, capsys):
    """``usvips measure --project P --video LABEL --frame N``: the picks measured with the video's
    calibration, stored with the left frame, its synchronised right frame and the left frame's time."""
    import numpy as np

    from tests.app.test_tracking import OFFSET
    from tests.core.test_tracking import truth
    from usvips.store.opening import open_project

    path, object_id, fish, stereo, _ = video_survey
    frame = 9
    picks = [truth(stereo, fish, frame, f * fish.length) for f in (0.0, 1.0)]
    rows = "".join(f"fish,length,{k},{p[0][0]},{p[0][1]},{p[1][0]},{p[1][1]},Pagrus auratus\n"
                   for k, p in enumerate(picks))
    (tmp_path / "picks.csv").write_text("object,type,vertex,xl,yl,xr,yr,attribute\n" + rows)
    code = main(["measure", "--picks", str(tmp_path / "picks.csv"), "--project", str(path), "--video", "drop",
                 "--frame", str(frame), "--out", str(tmp_path / "m.csv")])
    out = capsys.readouterr().out
    assert code == 0 and "video drop, frame 9" in out
    assert out.startswith("stored 1 object in ") and "(video drop, frame 9): id " in out, out  # not "1 objects"
    with open_project(str(path), read_only=True) as project:
        stored = [o for o in project.objects() if o.id != object_id and o.vertices[0].frame_left == frame]
    assert len(stored) == 1
    vertex = stored[0].vertices[0]
    assert (vertex.video, vertex.frame_left, vertex.frame_right) == ("drop", frame, frame + OFFSET)
    assert abs(vertex.time_s - frame / 25.0) < 1e-6
    length = np.linalg.norm(np.subtract(stored[0].vertices[1].xyz, vertex.xyz))
    assert abs(length - fish.length) < 0.02 * fish.length


def test_measure_on_a_video_frame_refuses_bad_frames_in_one_line(video_survey, tmp_path, capsys):
    path = video_survey[0]
    (tmp_path / "picks.csv").write_text("object,type,vertex,xl,yl,xr,yr\nf,point,0,10,10,12,10\n")
    for frame, words in (("x", "a frame number"), ("999", "there is no frame 999")):
        assert main(["measure", "--picks", str(tmp_path / "picks.csv"), "--project", str(path), "--video", "drop",
                     "--frame", frame]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and words in err[0], err
    assert main(["measure", "--picks", str(tmp_path / "picks.csv"), "--project", str(path), "--video", "drop"]) == 2
    assert "--frame N" in capsys.readouterr().err
