"""``usvips project check``: the survey's quality report printed, as JSON, and exported."""

import csv
import json

from tests.app.test_quality import build_survey
from usvips.cli import main


def test_the_report_is_printed_as_a_table_and_as_json_and_written_as_checkem_does(tmp_path, capsys):
    path = tmp_path / "survey.usvips"
    ids = build_survey(path)
    assert main(["project", "check", str(path)]) == 0
    out = capsys.readouterr().out
    lines = out.splitlines()
    assert lines[0].split() == ["ObjectId", "Genus", "species", "Rule", "Status", "Value", "Limit", "Unit", "Where"]
    assert any(line.startswith(str(ids["too long"])) and "length > species maximum" in line and "pair dive" in line
               for line in lines)
    assert lines[-1] == "9 objects checked: 5 break a rule (2 notes)"
    assert main(["project", "check", str(path), "--json", "--out", str(tmp_path / "qa.txt")]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["checked"] == 9 and report["failing_objects"] == 5
    too_long = next(i for i in report["issues"] if i["object_id"] == str(ids["too long"]))
    assert too_long["rule"] == "species_max" and too_long["limit"] == 0.25 and too_long["pair"] == "dive"
    rows = list(csv.DictReader((tmp_path / "qa.txt").open(), delimiter="\t"))
    assert len(rows) == len(report["issues"])
    assert {r["Rule"] for r in rows} >= {"ray RMS", "range", "precision/length", "no maximum"}
    assert main(["project", "check", str(path), "--out", str(tmp_path / "qa.csv")]) == 0
    assert list(csv.DictReader((tmp_path / "qa.csv").open())) == rows


def test_a_bad_limit_or_project_is_one_line_and_writes_nothing(tmp_path, capsys):
    path = tmp_path / "survey.usvips"
    build_survey(path)
    assert main(["project", "check", str(path), "--max-range-m", "-1", "--out", str(tmp_path / "qa.txt")]) == 2
    err = capsys.readouterr().err
    assert "--max-range-m" in err and len(err.strip().splitlines()) == 1 and not (tmp_path / "qa.txt").exists()
    assert main(["project", "check", str(tmp_path / "missing.usvips")]) == 2
    assert "missing.usvips" in capsys.readouterr().err


def test_fail_on_gives_a_pipeline_a_failing_exit_status(tmp_path, capsys):
    path = tmp_path / "survey.usvips"
    build_survey(path)
    assert main(["project", "check", str(path)]) == 0
    assert main(["project", "check", str(path), "--fail-on", "error"]) == 1
    assert main(["project", "check", str(path), "--fail-on", "warning", "--json"]) == 1
    assert main(["project", "check", str(path), "--fail-on", "fatal"]) == 2
    assert "--fail-on" in capsys.readouterr().err


def test_fail_on_passes_a_clean_survey(tmp_path):
    from usvips.store import Project

    path = tmp_path / "empty.usvips"
    Project.create(path).close()
    assert main(["project", "check", str(path), "--fail-on", "warning"]) == 0
