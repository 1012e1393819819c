"""``usvips detect`` and ``usvips batch detect``: one line per stored proposal and a summary; bad input (a
missing or invalid model, a description that does not match its model, a video the project lacks) is one
line, exit 2, nothing stored; batch detect runs on a local Dask cluster and names the project that fails."""

import shutil

import pytest

from tests.app.detection_scenes import make_project, scene, write_switching_model
from usvips.cli import main
from usvips.store import Project


@pytest.fixture
def survey(tmp_path):
    truth = scene(seed=5)
    return make_project(tmp_path), write_switching_model(tmp_path, truth, sigma=1.0), truth


def test_detect_stores_proposals_and_prints_a_line_each_and_a_summary(survey, capsys):
    project, model, truth = survey
    assert main(["detect", str(project), "--pair", "dive", "--model", str(model), "--annotator", "ana"]) == 0
    out = capsys.readouterr().out.splitlines()
    assert sum(line.startswith("dive: object ") for line in out) == 3
    assert any("3 stored as unreviewed proposals" in line for line in out)
    assert any("keypoint pointing sigma measured (test scenes)" in line for line in out)
    with Project.open(project) as opened:
        assert len(opened.objects()) == 3
        assert {opened.review(o.id).state for o in opened.objects()} == {"unreviewed"}
    assert main(["detect", str(project), "--pair", "dive", "--model", str(model)]) == 0  # again: nothing new
    assert "3 not stored (duplicates" in capsys.readouterr().out


@pytest.mark.parametrize("spoil,words", [
    ("missing model", "no such file"),
    ("mismatch", "does not match its model's output"),
    ("no onnx", "model.file: no such file"),
    ("video", "no video 'drop'"),
    ("pair frames", "--frames"),
    ("frames", "0 <= A <= B"),
])
def test_bad_input_is_one_line_exit_2_and_stores_nothing(survey, capsys, spoil, words):
    project, model, truth = survey
    argv = ["detect", str(project), "--pair", "dive", "--model", str(model)]
    if spoil == "missing model":
        argv[-1] = str(model.with_name("nowhere.toml"))
    elif spoil == "mismatch":
        model.write_text(model.read_text().replace('["snout", "fork"]', '["snout", "fork", "eye"]'))
    elif spoil == "no onnx":
        model.with_suffix(".onnx").unlink()
    elif spoil == "video":
        argv[2:4] = ["--video", "drop"]
    elif spoil == "pair frames":
        argv += ["--frames", "0:3"]
    else:
        argv[2:4] = ["--video", "drop", "--frames", "5:2"]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and words in err[0] and "Traceback" not in err[0]
    with Project.open(project) as opened:
        assert opened.objects() == []


def test_batch_detect_runs_on_a_local_dask_cluster_and_names_the_project_that_fails(survey, tmp_path, capsys):
    project, model, truth = survey
    other = tmp_path / "second"
    other.mkdir()
    shutil.copy(project, other / "survey.usvips")
    for name in ("left.png", "right.png"):
        shutil.copy(tmp_path / name, other / name)
    missing = tmp_path / "nowhere.usvips"
    code = main(["batch", "detect", "--model", str(model), "--scheduler", "local:1", str(project),
                 str(other / "survey.usvips"), str(missing)])
    captured = capsys.readouterr()
    assert code == 2
    assert captured.out.count("3 proposals stored, 0 duplicates not stored, 1 pairs or videos") == 2
    assert "FAILED" in captured.out and "nowhere.usvips" in captured.out
    assert "batch detect: 2 of 3 succeeded, 1 failed" in captured.err
    for path in (project, other / "survey.usvips"):
        with Project.open(path) as opened:
            assert len(opened.objects()) == 3


def test_review_sigma_needs_enough_accepted_proposals_and_says_so(survey, capsys):
    project, model, truth = survey
    assert main(["detect", str(project), "--pair", "dive", "--model", str(model)]) == 0
    capsys.readouterr()
    assert main(["detect", str(project), "--review-sigma", "--model", str(model)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "0 points with a reference, at least 10" in err[0]
