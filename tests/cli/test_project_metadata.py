"""`usvips project set-metadata` and `set-georeference`: stored, merged with what was stored, shown by
`project info`, written to CheckEM's _Metadata.csv by `project export`; bad values are one line, exit 2,
nothing stored."""

import csv

from usvips.cli import main
from usvips.store import Project


def _run(capsys, *argv):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def test_metadata_and_georeference_from_the_command_line(tmp_path, capsys):
    path = tmp_path / "p.usvips"
    assert _run(capsys, "project", "new", path)[0] == 0
    code, _, err = _run(capsys, "project", "set-metadata", path, "--site", "North")
    assert code == 2 and err.count("\n") == 1 and "--opcode is needed" in err
    assert _run(capsys, "project", "set-metadata", path, "--opcode", "BRUV-01", "--date", "2024-03-01", "--time",
                "6:30", "--latitude", "-32.05", "--longitude", "115.2", "--depth", "12.5")[0] == 0
    assert _run(capsys, "project", "set-metadata", path, "--site", "North", "--successful-length", "no")[0] == 0
    for bad, message in ((["--latitude", "95"], "latitude: must be between -90 and 90"),
                         (["--date", "1/3/2024"], "date: must be a date YYYY-MM-DD"),
                         (["--video", "T1", "--opcode", "X"], "no video pair 'T1'")):
        code, _, err = _run(capsys, "project", "set-metadata", path, *bad)
        assert code == 2 and err.count("\n") == 1 and message in err, err
    for bad, message in ((["--latitude", "-32", "--longitude", "181"], "longitude: must be between -180 and 180"),
                         (["--latitude", "-32", "--longitude", "115", "--depth", "-4"], "depth: must be between 0"),
                         (["--latitude", "-32"], "needs --latitude and --longitude")):
        code, _, err = _run(capsys, "project", "set-georeference", path, *bad)
        assert code == 2 and err.count("\n") == 1 and message in err, err
    assert _run(capsys, "project", "set-georeference", path, "--latitude", "-32.05", "--longitude", "115.2",
                "--depth", "12", "--heading", "-90")[0] == 0
    with Project.open(path, read_only=True) as project:
        deployment = project.deployment()
        assert (deployment.opcode, deployment.site, deployment.latitude, deployment.successful_length) == (
            "BRUV-01", "North", -32.05, False)
        assert project.georeference().heading_deg == 270.0
    code, out, _ = _run(capsys, "project", "info", path)
    assert "deployment BRUV-01: date 2024-03-01" in out and "+X heading 270°" in out
    assert _run(capsys, "project", "export", path, tmp_path / "s.em.txt")[0] == 0
    (row,) = csv.DictReader((tmp_path / "s_Metadata.csv").open(encoding="utf-8"))
    assert (row["OpCode"], row["Date"], row["Time"], row["Depth"], row["Site"], row["Successful.length"]) == (
        "BRUV-01", "20240301", "06:30:00", "12.5", "North", "No")
    assert _run(capsys, "project", "set-metadata", path, "--clear")[0] == 0
    assert _run(capsys, "project", "set-georeference", path, "--clear")[0] == 0
    with Project.open(path, read_only=True) as project:
        assert project.deployment() is None and project.georeference() is None
