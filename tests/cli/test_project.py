import json
from pathlib import Path

import numpy as np

from usvips.cli import main
from usvips.store import Project
from usvips.store.project import Vertex

SAMPLE = Path(__file__).resolve().parents[2] / "sample_projects" / "tank_1995"


def test_project_from_the_sample_and_export(tmp_path, capsys):
    out = tmp_path / "tank.usvips"
    assert main(["project", "new", str(out), "--from", str(SAMPLE)]) == 0
    assert main(["project", "info", str(out)]) == 0
    text = capsys.readouterr().out
    assert "3 image pairs, 24 control points, 0 objects" in text
    with Project.open(out) as project:
        assert len(project.control_observations("check", "water2")) == 9
        cov = np.diag([1e-6, 1e-6, 4e-6])
        project.add_object("line", [Vertex(1, 2, 3, 4, (0, 0, -2.0), cov), Vertex(5, 6, 7, 8, (0.3, 0.4, -2.0), cov)],
                           attribute="cod")
    assert main(["project", "export", str(out), str(tmp_path / "objects.geojson")]) == 0
    feature = json.loads((tmp_path / "objects.geojson").read_text())["features"][0]
    assert feature["properties"]["length"]["value"] == 0.5


def test_project_errors_are_one_line(tmp_path, capsys):
    assert main(["project", "info", str(SAMPLE / "README.md")]) == 2
    assert "not a USVIPS project" in capsys.readouterr().err
    out = tmp_path / "p.usvips"
    assert main(["project", "new", str(out)]) == 0
    assert main(["project", "new", str(out)]) == 2
    assert "already exists" in capsys.readouterr().err
    assert main(["project", "import", str(out), "--obs", str(SAMPLE / "air_pair1_table3_2.csv")]) == 2
    assert "--obs needs --pair" in capsys.readouterr().err
    bad = tmp_path / "bad"
    bad.mkdir()
    (bad / "project.json").write_text('{"format": "usvips-sample", "version": 1, "name": "x", "control": "no.csv"}')
    assert main(["project", "new", str(tmp_path / "q.usvips"), "--from", str(bad)]) == 2
    assert not (tmp_path / "q.usvips").exists()
