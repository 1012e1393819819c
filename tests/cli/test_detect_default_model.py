"""The project's default detection model: ``usvips detect ... --model M --remember`` keeps M in the project
(the store's key/value drafts, no schema change), a later ``usvips detect`` without ``--model`` and ``usvips
batch detect`` use it, and a default whose file is gone is one line naming it (exit 2, nothing stored)."""

import pytest

from tests.app.detection_scenes import make_project, scene, write_switching_model
from usvips.app.detection_model import PROJECT_MODEL_KEY, model_path_for, project_model_path, remember_model
from usvips.cli import main
from usvips.core.errors import InputFileError
from usvips.store import Project


@pytest.fixture
def survey(tmp_path):
    truth = scene(seed=5)
    folder = tmp_path / "models"
    folder.mkdir()
    return make_project(tmp_path), write_switching_model(folder, truth, sigma=1.0, name="reef"), truth


def test_remember_keeps_the_model_in_the_project_and_detect_then_uses_it(survey, capsys):
    project, model, _ = survey
    with Project.open(project) as opened:
        assert project_model_path(opened) is None
    assert main(["detect", str(project), "--pair", "dive", "--model", str(model), "--remember"]) == 0
    out = capsys.readouterr().out
    assert f"default detection model is now {model.resolve()}" in out
    with Project.open(project) as opened:
        assert project_model_path(opened) == model.resolve()
        assert opened.draft(PROJECT_MODEL_KEY) == str(model.resolve())
        for stored in opened.objects():
            opened.delete_object(stored.id)
    assert main(["detect", str(project), "--pair", "dive"]) == 0  # no --model: the project's default
    out = capsys.readouterr().out
    assert "model reef sha256:" in out and "3 stored as unreviewed proposals" in out


def test_a_default_model_that_is_gone_is_one_line_naming_it_and_nothing_is_stored(survey, capsys):
    project, model, _ = survey
    with Project.open(project) as opened:
        remember_model(opened, model)
    model.unlink()
    assert main(["detect", str(project), "--pair", "dive"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and str(model.resolve()) in err[0] and "no longer there" in err[0]
    with Project.open(project) as opened:
        assert opened.objects() == []
        with pytest.raises(InputFileError, match="default detection model"):
            model_path_for(opened)
        assert model_path_for(opened, "given.toml").name == "given.toml"  # a model given wins


def test_a_bad_model_is_not_remembered(survey, tmp_path):
    project, model, _ = survey
    model.write_text(model.read_text().replace('["snout", "fork"]', '["snout", "fork", "eye"]'))
    with Project.open(project) as opened:
        with pytest.raises(InputFileError, match="does not match"):
            remember_model(opened, model)
        assert project_model_path(opened) is None


@pytest.mark.parametrize("argv,words", [
    (["--pair", "dive", "--remember"], "--remember"),  # nothing to remember without --model
    (["--pair", "dive", "--model", "MODEL", "--max-speed", "1"], "--max-speed"),
    (["--video", "drop", "--model", "MODEL", "--max-speed", "0"], "--max-speed"),
    (["--video", "drop", "--model", "MODEL", "--max-speed", "fast"], "--max-speed"),
])
def test_bad_options_are_one_line(survey, capsys, argv, words):
    project, model, _ = survey
    assert main(["detect", str(project), *(str(model) if a == "MODEL" else a for a in argv)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert words in err[-1] and "Traceback" not in "".join(err)


def test_batch_detect_uses_each_projects_default_model(survey, capsys):
    project, model, _ = survey
    with Project.open(project) as opened:
        remember_model(opened, model)
    assert main(["batch", "detect", "--jobs", "1", str(project)]) == 0
    assert "3 proposals stored" in capsys.readouterr().out
