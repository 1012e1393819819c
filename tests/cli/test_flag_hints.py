"""The command line says how to fix an error about a setting in its own terms: the option that sets it.
The same errors through the app layer name no flag (and carry the setting in ``parameter``; the scan of
every message: tests/test_error_words.py)."""

from __future__ import annotations

from pathlib import Path

import pytest

from usvips.app.batch import run as run_tasks
from usvips.app.project_contents import plan_import
from usvips.app.video_project import plan_image_pairs
from usvips.cli import main
from usvips.core.calibration.validation import holdout_views
from usvips.core.errors import UsvipsError
from usvips.io.atomic import guard_output

ROV = Path(__file__).resolve().parents[2] / "sample_projects" / "rov_flatport"


def _error_line(capsys, argv: list[str]) -> str:
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "Traceback" not in err
    return err


@pytest.fixture
def images(tmp_path: Path) -> tuple[Path, Path]:
    left, right = tmp_path / "L", tmp_path / "R"
    for folder in (left, right):
        folder.mkdir()
        (folder / "a.png").write_bytes(b"")
    return left, right


def test_an_invalid_time_between_partners_names_max_dt(capsys, images, tmp_path):
    left, right = images
    err = _error_line(capsys, ["project", "add-pairs", str(tmp_path / "p.usvips"), "--left", str(left),
                               "--right", str(right), "--max-dt", "0", "--dry-run"])
    assert "must be > 0 seconds" in err and "(set it with --max-dt)" in err
    with pytest.raises(UsvipsError) as raised:
        plan_image_pairs([left], [right], max_dt=0.0)
    assert raised.value.parameter == "max_dt" and "--" not in str(raised.value)
    assert "the time between partners' capture" in str(raised.value)


def test_a_missing_folder_names_the_side_s_option(capsys, images, tmp_path):
    left, _ = images
    err = _error_line(capsys, ["project", "add-pairs", str(tmp_path / "p.usvips"), "--left", str(left),
                               "--right", str(tmp_path / "nowhere"), "--dry-run"])
    assert "the right camera's files: no such file or folder" in err and "(set it with --right)" in err
    with pytest.raises(UsvipsError) as raised:
        plan_image_pairs([left], [tmp_path / "nowhere"])
    assert raised.value.parameter == "right" and "--" not in str(raised.value)


def test_observations_without_their_pair_name_pair(capsys, tmp_path):
    observations = ROV / "observations_water.csv"
    err = _error_line(capsys, ["project", "import", str(tmp_path / "p.usvips"), "--obs", str(observations)])
    assert "observations need the image pair they belong to (set it with --pair)" in err
    with pytest.raises(UsvipsError) as raised:
        plan_import(observations=ROV / "observations_water.csv")
    assert raised.value.parameter == "pair" and "--" not in str(raised.value)


def test_nothing_to_import_names_the_options(capsys, tmp_path):
    err = _error_line(capsys, ["project", "import", str(tmp_path / "p.usvips")])
    assert "--control, --obs or --calibration" in err
    with pytest.raises(UsvipsError, match="give control points, observations or a calibration") as raised:
        plan_import()
    assert "--" not in str(raised.value)


def test_an_output_onto_an_input_names_out_and_force(tmp_path):
    source = tmp_path / "scene.json"
    source.write_text("{}")
    with pytest.raises(UsvipsError) as raised:
        guard_output(source, [source])
    error = raised.value
    assert error.parameter == "out" and error.replace_parameter == "force" and "--" not in str(error)
    assert "the output is an input of this command" in str(error)


def test_the_share_held_out_and_the_jobs_are_said_in_words():
    with pytest.raises(UsvipsError) as raised:
        holdout_views(["a", "b", "c"], 1.5)
    assert raised.value.parameter == "holdout" and str(raised.value).startswith("the share of views held out:")
    with pytest.raises(UsvipsError) as raised:
        run_tasks([], jobs=0)
    assert raised.value.parameter == "jobs" and "--" not in str(raised.value)


def test_an_export_onto_a_calibration_names_force_though_its_output_is_no_option(capsys, tmp_path):
    """``project export PROJECT OUT``: OUT is a positional argument, so no option to name; --force is."""
    project = tmp_path / "p.usvips"
    assert main(["project", "new", str(project)]) == 0
    victim = tmp_path / "objects.csv"
    victim.write_text((ROV / "calibration.json").read_text())  # a calibration saved under that name
    err = _error_line(capsys, ["project", "export", str(project), str(victim)])
    assert "the output is a USVIPS calibration" in err and err.endswith(".bak) (--force replaces it)")
