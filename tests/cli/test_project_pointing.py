"""``usvips project pointing``: an estimate from an annotator's repeated picks printed, stored for use
(every figure then uses it), listed, and bad options refused in one line."""

import numpy as np

from usvips.app.pointing_settings import pointing_in_use
from usvips.cli import main
from usvips.store import Project
from usvips.store.project import Vertex


def _project(path):
    rng = np.random.default_rng(1)
    with Project.create(path) as project:
        project.add_pair("P")
        for _ in range(15):
            truth = rng.uniform(100, 1800, (2, 4))
            for _ in range(3):
                picks = truth + rng.normal(0, 0.7, truth.shape)
                project.add_object("length", [Vertex(*p, pair="P") for p in picks], creator="ana")
    return path


def test_estimate_store_and_list(tmp_path, capsys):
    path = _project(tmp_path / "p.usvips")
    assert main(["project", "pointing", str(path), "--from-repeats", "ana"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("pointing σ (hand click, ana): 0.") and "45 objects measured repeatedly by ana" in out
    with Project.open(path, read_only=True) as project:
        assert pointing_in_use(project) == {}  # printed, not stored
    assert main(["project", "pointing", str(path), "--from-repeats", "ana", "--use"]) == 0
    assert "as the one in use" in capsys.readouterr().out
    with Project.open(path, read_only=True) as project:
        assert 0.55 < pointing_in_use(project)[("ana", "hand click")].value_px < 0.85
    assert main(["project", "pointing", str(path)]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].split()[:3] == ["#", "annotator", "source"] and lines[1].split()[:3] == ["1", "ana", "hand"]
    assert "yes" in lines[1]


def test_bad_options_are_one_line(tmp_path, capsys):
    path = _project(tmp_path / "p.usvips")
    for args, option in ((["--use"], "--use"), (["--use-estimate", "3"], "--use-estimate"),
                         (["--from-repeats", "bo"], "bo has picked no point twice"),
                         (["--from-repeats", "ana", "--gate-px", "0"], "--gate-px")):
        assert main(["project", "pointing", str(path), *args]) == 2
        err = capsys.readouterr().err
        assert option in err and len(err.strip().splitlines()) == 1
