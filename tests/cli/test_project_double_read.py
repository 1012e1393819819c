"""``usvips project double-read``: the report on the terminal and as CSV; bad input in one line."""

from __future__ import annotations

import csv

import numpy as np

from usvips.cli import main
from usvips.core.observation_record import ObservationRecord
from usvips.store.opening import create_project
from usvips.store.records import Vertex


def _run(capsys, *argv):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    return code, out, err


def _survey(path):
    """12 fish on pair p1 read by ann and bob; bob reads fish 4 five centimetres long and misses fish 7."""
    rng = np.random.default_rng(3)
    project = create_project(path)
    project.add_pair("p1")
    ids = {}
    for n in range(12):
        snout = np.array([rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(2, 4)])
        fork = snout + [0.3, 0.0, 0.0]
        for reader in ("ann", "bob"):
            if reader == "bob" and n == 7:
                continue
            end = fork + ([0.05, 0, 0] if reader == "bob" and n == 4 else 0)
            vertices = [Vertex(0, 0, 0, 0, tuple(map(float, p + rng.normal(0, 0.002, 3))), np.eye(3) * 4e-6, None, "p1")
                        for p in (snout, end)]
            (ids[reader, n],) = project.add_objects([("length", vertices, "", "", reader)])
            project.set_record(ids[reader, n], ObservationRecord(genus="Pagrus", species="auratus"))
    project.close()
    return ids


def test_the_report_prints_and_writes_every_row(tmp_path, capsys):
    project = tmp_path / "s.usvips"
    ids = _survey(project)
    out_csv = tmp_path / "report.csv"
    code, out, err = _run(capsys, "project", "double-read", project, "--readers", "ann", "bob", "--csv", out_csv)
    assert code == 0 and err == ""
    assert "matched: 11 pairs" in out and "unmatched: 1 of A, 0 of B" in out
    lines = out.splitlines()
    flagged = [line.split() for line in lines if line.startswith("disagreement")]
    assert [int(line[1]) for line in flagged if int(line[2]) == ids["bob", 4]] == [ids["ann", 4]]
    assert any(line.startswith("unmatched A") and f" {ids['ann', 7]} " in line for line in lines)
    text = out_csv.read_text().splitlines()
    assert text[0].startswith("# readers: A 'ann'")
    rows = list(csv.DictReader(line for line in text if not line.startswith("#")))
    assert len(rows) == 12 and {r["row"] for r in rows} <= {"disagreement", "agreement", "unmatched A"}
    four = next(r for r in rows if r["object_a"] == str(ids["ann", 4]))
    assert four["row"] == "disagreement" and abs(float(four["difference"]) + 0.05) < 0.01


def test_bad_input_is_one_line(tmp_path, capsys):
    project = tmp_path / "s.usvips"
    _survey(project)
    for argv, words in ((["--readers", "ann", "carol"], "annotator 'carol' measured no object"),
                        (["--readers", "ann", "bob", "--k", "-1"], "parameter --k"),
                        (["--readers", "ann", "bob", "--tolerance-s", "nan"], "parameter --tolerance-s"),
                        (["--readers", "ann", "bob", "--csv", project], "is the project this command works on"),
                        (["--readers", "ann", "bob", "--csv", tmp_path / "no" / "r.csv"], "does not exist")):
        code, out, err = _run(capsys, "project", "double-read", project, *argv)
        assert code == 2 and words in err and len(err.strip().splitlines()) == 1, err
    code, out, err = _run(capsys, "project", "double-read", tmp_path / "none.usvips", "--readers", "a", "b")
    assert code == 2 and "none.usvips" in err


def _video_survey(path):
    """ann and bob read one fish on video 'dive' (25 frames/s) four frames apart (0.16 s); bob also reads
    another fish 40 frames after ann's (1.6 s)."""
    project = create_project(path)
    (path.parent / "v0.mp4").write_bytes(b"video")
    chapters = [(path.parent / "v0.mp4", 1000, 40.0)]
    project.add_video("dive", chapters, chapters, 25.0, 1000, (64, 48))
    for reader, frame, x in (("ann", 250, 0.0), ("bob", 254, 0.0), ("ann", 500, 1.0), ("bob", 540, 1.0)):
        vertices = [Vertex(0, 0, 0, 0, (x + dx, 0.0, 3.0), np.eye(3) * 1e-6, None, None, "dive", frame, frame,
                           frame / 25.0) for dx in (0.0, 0.3)]
        project.add_objects([("length", vertices, "", "", reader)])
    project.close()


def test_the_time_tolerance_in_frames(tmp_path, capsys):
    project = tmp_path / "v.usvips"
    _video_survey(project)
    for option, value, matched in (("--tolerance-frames", 4, 1), ("--tolerance-frames", 3, 0),
                                   ("--tolerance-frames", 40, 2), ("--tolerance-s", 0.2, 1), ("--tolerance-s", 1.7, 2)):
        code, out, err = _run(capsys, "project", "double-read", project, "--readers", "ann", "bob", option, value)
        assert code == 0 and err == "", err
        unit = "frames" if option == "--tolerance-frames" else "s"
        assert f"tolerance {value:g} {unit}," in out and f"matched: {matched} pair" in out, out
    code, out, err = _run(capsys, "project", "double-read", project, "--readers", "ann", "bob")
    assert code == 0 and "tolerance 0.5 s," in out and "matched: 1 pair" in out  # the default: half a second
    for argv, words in ((["--tolerance-s", "0.5", "--tolerance-frames", "3"], "parameter --tolerance-frames: give "
                         "the time tolerance in seconds (--tolerance-s) or in frames (--tolerance-frames), not both"),
                        (["--tolerance-frames", "-2"], "parameter --tolerance-frames")):
        code, out, err = _run(capsys, "project", "double-read", project, "--readers", "ann", "bob", *argv)
        assert code == 2 and words in err and len(err.strip().splitlines()) == 1, err
