"""Media know their medium (issue 33, item 4): a stereo video added with ``--medium air`` is stored as air (an
in-air calibration video is not water); ``project info`` lists every calibration and what it is active for,
the videos' media; phase 2 is stored as phase 2."""

from __future__ import annotations

from tests.cli.test_video import _run, _stereo
from usvips.app.calibrations import store_calibration
from usvips.app.project_contents import summarise
from usvips.core.camera import Camera, Exterior
from usvips.core.interior import Interior
from usvips.core.stereo_calibration import StereoCalibration
from usvips.store import Project
from usvips.store.opening import open_project


def _calibration(phase: str) -> StereoCalibration:
    left = Camera(Interior(f=150.0, xp=80.0, yp=60.0), Exterior(0, 0, 0))
    right = Camera(Interior(f=150.0, xp=80.0, yp=60.0), Exterior(0.1, 0, 0))
    return StereoCalibration.from_cameras(left, right, phase, 0.5)


def test_a_video_keeps_its_medium_and_info_lists_calibrations_and_what_they_are_active_for(tmp_path, capsys):
    project = tmp_path / "p.usvips"
    assert _run(capsys, "project", "new", project)[0] == 0
    left, right = _stereo(tmp_path / "air", 0, frames=10)
    assert _run(capsys, "project", "add-video", project, "--left", *left, "--right", *right, "--label", "cal",
                "--medium", "air")[0] == 0
    left, right = _stereo(tmp_path / "water", 0, frames=10)
    assert _run(capsys, "project", "add-video", project, "--left", *left, "--right", *right, "--label", "dive")[0] == 0
    with Project.open(project) as stored:
        media = {p.label: p.medium for p in stored.pairs()}
        assert media == {"cal": "air", "dive": "water"}
    sample = Project.open(project)
    store_calibration(sample, "in air", _calibration("air"), ["cal"])
    store_calibration(sample, "unused", _calibration("water"))
    sample.close()
    code, out, err = _run(capsys, "project", "info", project)
    assert code == 0, err
    assert "calibration 1 'in air' (phase 1, air" in out and "active for cal" in out
    assert "calibration 2 'unused' (phase 2, water" in out and "active for none" in out
    assert "video cal: 10 frames" in out and "; air" in out
    with open_project(project, read_only=True) as opened:
        summary = summarise(opened)
    assert [c.active_for for c in summary.calibrations] == [("cal",), ()]


def test_a_bad_medium_is_refused_by_argparse_in_one_line(tmp_path, capsys):
    project = tmp_path / "p.usvips"
    assert _run(capsys, "project", "new", project)[0] == 0
    code, _, err = _run(capsys, "project", "add-video", project, "--left", "a.mp4", "--right", "b.mp4",
                        "--medium", "oil")
    assert code == 2 and len(err.strip().splitlines()) == 1 and "--medium" in err
