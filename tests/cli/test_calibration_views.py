"""``usvips video calibration-views``: the chosen views of a rendered calibration video written as an
observations CSV that reads back, the coverage printed, and bad target files as one line, exit 2."""

import json

import pytest

from tests.app.test_calibration_video import _film
from tests.core.board_views import SectorChessboard
from usvips.app import calibration_video
from usvips.cli import main
from usvips.io.tables import read_observations


def test_views_written_as_observations(tmp_path, monkeypatch, capsys):
    path, _, _, _ = _film(tmp_path, 5, 1)
    target = tmp_path / "board.json"
    target.write_text(json.dumps({"kind": "test-board"}))
    read = []
    monkeypatch.setattr(calibration_video, "read_target", lambda p: read.append(p) or SectorChessboard())
    out = tmp_path / "views.csv"
    code = main(["video", "calibration-views", str(path), "--pair", "cal", "--target", str(target), "--every", "2",
                 "--max-views", "6", "--out", str(out), "--quiet"])
    printed = capsys.readouterr()
    assert code == 0, printed.err
    assert read == [str(target)]
    observations = read_observations(out)
    assert len(observations.pair_labels) == 6
    assert all(label.startswith("cal-") for label in observations.pair_labels)
    assert len(observations) == 6 * 54
    assert f"wrote {out}: 6 views, {6 * 54} observations" in printed.out
    assert "6 views" in printed.out.splitlines()[1]
    assert printed.err == ""


@pytest.mark.parametrize("content,problem", [
    (None, "no such file"), ("{", "not valid JSON"), ('{"kind": "chessboard"}', "not a USVIPS target file"),
    ('{"format": "usvips-target", "version": 1, "kind": "no-such-kind"}', "unknown target kind 'no-such-kind'")])
def test_a_bad_target_file_is_one_line(tmp_path, capsys, content, problem):
    target = tmp_path / "target.json"
    if content is not None:
        target.write_text(content)
    code = main(["video", "calibration-views", str(tmp_path / "p.usvips"), "--pair", "cal", "--target", str(target),
                 "--out", str(tmp_path / "v.csv")])
    err = capsys.readouterr().err
    assert code == 2
    assert len(err.strip().splitlines()) == 1 and str(target) in err and problem in err
    assert not (tmp_path / "v.csv").exists()


def test_out_onto_the_project_s_own_video_is_refused_and_the_video_kept(tmp_path, monkeypatch, capsys):
    path, _, _, _ = _film(tmp_path, 5, 1)
    target = tmp_path / "board.json"
    target.write_text(json.dumps({"kind": "test-board"}))
    monkeypatch.setattr(calibration_video, "read_target", lambda p: SectorChessboard())
    from usvips.store.opening import open_project

    with open_project(str(path), read_only=True) as project:
        left = project.media_path(project.video("cal").left[0].path)
    before = left.read_bytes()
    code = main(["video", "calibration-views", str(path), "--pair", "cal", "--target", str(target), "--out",
                 str(left), "--quiet"])
    err = capsys.readouterr().err
    assert code == 2 and len(err.strip().splitlines()) == 1 and "input of this command" in err
    assert left.read_bytes() == before


@pytest.mark.parametrize("option,value", [("--max-views", "0"), ("--max-blur", "-1"), ("--every", "0")])
def test_a_bad_value_is_named_as_the_option_typed(tmp_path, monkeypatch, capsys, option, value):
    path, _, _, _ = _film(tmp_path, 5, 1)
    target = tmp_path / "board.json"
    target.write_text(json.dumps({"kind": "test-board"}))
    monkeypatch.setattr(calibration_video, "read_target", lambda p: SectorChessboard())
    code = main(["video", "calibration-views", str(path), "--pair", "cal", "--target", str(target), "--out",
                 str(tmp_path / "v.csv"), option, value, "--quiet"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and f": error: {option}: must be" in err[0], err
    assert "_" not in err[0].split("error:")[1].split(":")[0]
