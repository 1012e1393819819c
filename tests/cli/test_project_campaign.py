"""``usvips project set-campaign`` and ``usvips project export … --format globalarchive``: stored field by
field, every table written, and what is missing named in one line with nothing written."""

from __future__ import annotations

import numpy as np

from usvips.cli import main
from usvips.core.observation_record import ObservationRecord
from usvips.store.opening import create_project, open_project
from usvips.store.records import Vertex


def _run(capsys, *argv):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def _survey(path):
    project = create_project(path)
    project.add_pair("p1")
    vertices = [Vertex(0, 0, 0, 0, (0.0, 0.0, 3.0), np.eye(3) * 1e-6, None, "p1"),
                Vertex(0, 0, 0, 0, (0.3, 0.0, 3.0), np.eye(3) * 1e-6, None, "p1")]
    for number in (1, 2):
        (object_id,) = project.add_objects([("length", vertices, "", "", "")])
        project.set_record(object_id, ObservationRecord("Sparidae", "Pagrus", "auratus", number=number))
    project.close()


def test_the_campaign_is_set_field_by_field_and_the_archive_written(tmp_path, capsys):
    project = tmp_path / "s.usvips"
    _survey(project)
    out = tmp_path / "archive"
    out.mkdir()
    code, _, err = _run(capsys, "project", "export", project, out, "--format", "globalarchive")
    assert code == 2 and "has no campaign" in err and list(out.iterdir()) == []
    code, text, _ = _run(capsys, "project", "set-campaign", project, "--campaign-id", "2024-03_Reef_stereo-BRUVs",
                         "--method", "stereo-BRUVs")
    assert code == 0 and "still needs --project-name, --submitter" in text
    code, _, err = _run(capsys, "project", "export", project, out, "--format", "globalarchive")
    assert code == 2 and "the campaign's project, submitter are needed" in err and list(out.iterdir()) == []
    assert _run(capsys, "project", "set-campaign", project, "--project-name", "Reef", "--submitter", "Ana")[0] == 0
    with open_project(project, read_only=True) as stored:
        campaign = stored.campaign()
    assert (campaign.campaign_id, campaign.project, campaign.method, campaign.submitter) == (
        "2024-03_Reef_stereo-BRUVs", "Reef", "stereo-BRUVs", "Ana")  # earlier values kept
    code, _, err = _run(capsys, "project", "export", project, out, "--format", "globalarchive")
    assert code == 2 and "no deployment metadata" in err
    assert _run(capsys, "project", "set-metadata", project, "--opcode", "OP1", "--date", "2024-03-02", "--time",
                "09:10", "--latitude", "-28.7", "--longitude", "113.8", "--depth", "22")[0] == 0
    code, text, err = _run(capsys, "project", "export", project, out, "--format", "globalarchive")
    assert code == 0 and err == "" and "wrote 7" in text
    count = (out / "2024-03_Reef_stereo-BRUVs_Count.txt").read_text().splitlines()
    assert count[1].split("\t") == ["2024-03_Reef_stereo-BRUVs", "OP1", "Sparidae", "Pagrus", "auratus", "3"]
    assert _run(capsys, "project", "set-campaign", project, "--clear")[0] == 0
    with open_project(project, read_only=True) as stored:
        assert stored.campaign() is None


def test_bad_campaign_values_are_named_by_their_option(tmp_path, capsys):
    project = tmp_path / "s.usvips"
    _survey(project)
    for argv, words in ((["--campaign-id", "2024/03 reef"], "parameter --campaign-id"),
                        (["--start-date", "2024-03-09", "--end-date", "2024-03-01"], "parameter --end-date"),
                        (["--comment", "a\x1b[31m"], "--comment"),
                        (["--clear", "--method", "UVC"], "--clear removes the campaign")):
        code, _, err = _run(capsys, "project", "set-campaign", project, *argv)
        assert code == 2 and words in err and len(err.strip().splitlines()) == 1, err
    with open_project(project, read_only=True) as stored:
        assert stored.campaign() is None  # nothing stored by a refused command
    code, _, err = _run(capsys, "project", "export", project, tmp_path / "missing", "--format", "globalarchive")
    assert code == 2 and "has no campaign" in err
    code, _, err = _run(capsys, "project", "export", project, tmp_path / "o.csv", "--reader", "ann")
    assert code == 2 and "--reader goes with --format globalarchive" in err and not (tmp_path / "o.csv").exists()


def test_the_archive_folder_is_made_when_missing_and_not_left_behind_by_a_refused_export(tmp_path, capsys):
    project = tmp_path / "s.usvips"
    _survey(project)
    out = tmp_path / "archive"
    code, _, err = _run(capsys, "project", "export", project, out, "--format", "globalarchive")
    assert code == 2 and "has no campaign" in err and not out.exists()
    assert _run(capsys, "project", "set-campaign", project, "--campaign-id", "2024-03_Reef_stereo-BRUVs", "--method",
                "stereo-BRUVs", "--project-name", "Reef", "--submitter", "Ana")[0] == 0
    code, _, err = _run(capsys, "project", "export", project, out, "--format", "globalarchive")
    assert code == 2 and "no deployment metadata" in err and not out.exists()  # refused: no folder left
    assert _run(capsys, "project", "set-metadata", project, "--opcode", "OP1", "--date", "2024-03-02", "--time",
                "09:10", "--latitude", "-28.7", "--longitude", "113.8", "--depth", "22")[0] == 0
    code, _, err = _run(capsys, "project", "export", project, tmp_path / "no" / "archive", "--format", "globalarchive")
    assert code == 2 and "OUT" in err and "does not exist" in err and not (tmp_path / "no").exists()
    code, text, err = _run(capsys, "project", "export", project, out, "--format", "globalarchive")
    assert code == 0 and err == "" and "wrote 7" in text
    assert (out / "2024-03_Reef_stereo-BRUVs_Count.txt").is_file()


def test_batch_exports_the_archive_of_projects_of_one_name_in_their_own_folders(tmp_path, capsys):
    """``usvips batch export --format globalarchive`` over ``a/project.usvips`` and ``b/project.usvips``:
    a folder of tables each, named by its project's folder; a project the archive refuses fails alone."""
    for folder, campaign in (("a", "2024-03_Reef_stereo-BRUVs"), ("b", "")):
        (tmp_path / folder).mkdir()
        project = tmp_path / folder / "project.usvips"
        _survey(project)
        if campaign:
            assert _run(capsys, "project", "set-campaign", project, "--campaign-id", campaign, "--method",
                        "stereo-BRUVs", "--project-name", "Reef", "--submitter", "Ana")[0] == 0
            assert _run(capsys, "project", "set-metadata", project, "--opcode", "OP1", "--date", "2024-03-02",
                        "--time", "09:10", "--latitude", "-28.7", "--longitude", "113.8", "--depth", "22")[0] == 0
    code, text, err = _run(capsys, "batch", "export", tmp_path / "a" / "project.usvips",
                           tmp_path / "b" / "project.usvips", "--format", "globalarchive", "--out-dir",
                           tmp_path / "out", "--jobs", "1")
    assert code == 2 and "1 of 2 succeeded" in err and "7 tables" in text
    assert (tmp_path / "out" / "a_project" / "2024-03_Reef_stereo-BRUVs_Count.txt").is_file()
    assert "FAILED" in text and "has no campaign" in text and not (tmp_path / "out" / "b_project").exists()
