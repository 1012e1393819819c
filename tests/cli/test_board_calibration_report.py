"""``usvips calibration report`` on a calibration from board views: its views are found again from the
target and the images it names, so the PDF holds the views and their coverage, the residuals per view and
the validation (held-out views, known distances by range, OpenCV beside ours) — and never says the data
were not found or that the calibration "records no data files (e.g. imported from OpenCV)"."""

from __future__ import annotations

import dataclasses
import re

import numpy as np
import pytest

from tests.app.board_images import air_scene
from usvips.app.board_report import target_report_data
from usvips.cli import main
from usvips.io.calibration_file import load_calibration
from usvips.io.calibration_report import ReportData, _summary_lines, write_calibration_report


def _pages(path) -> int:
    return len(re.findall(rb"/Type\s*/Page\b", path.read_bytes()))


@pytest.fixture(scope="module")
def calibrated(tmp_path_factory):
    folder = tmp_path_factory.mktemp("board_report")
    board, rig, pairs, _ = air_scene(folder, 6, seed=4)
    target = folder / "board.json"
    assert main(["target", "describe", "chessboard", "--cols", "9", "--rows", "6", "--square", "30",
                 "--out", str(target)]) == 0
    out = folder / "cal.json"
    images = [str(p) for pair in pairs for p in pair]
    assert main(["calibrate", "air", "--target", str(target), "--images", *images, "--holdout", "0.3",
                 "--image-size", "480x360", "--out", str(out)]) == 0
    return folder, out, pairs


def test_the_report_finds_the_views_again_and_shows_the_validation(calibrated, capsys):
    folder, out, pairs = calibrated
    calibration = load_calibration(out)
    validation = calibration.statistics["validation"]  # the calibration carries its validation
    assert len(validation["held_out"]["views"]) == 2 and validation["opencv"]["f_l"] > 0
    data = target_report_data(calibration, out)
    assert data.control is not None and len(data.control.ids) == 54
    assert set(data.observations.pairs) == {p[0].stem for p in pairs}  # the fitted and the held-out views
    assert [role for role, _, _ in data.files].count("image") == 12
    capsys.readouterr()
    assert main(["calibration", "report", str(out), "--out", str(folder / "report.pdf")]) == 0
    printed = capsys.readouterr()
    assert "not found" not in printed.out + printed.err
    pages = _pages(folder / "report.pdf")
    # without the views found again and the validation: the views page, the validation page, the residual
    # pages (4 fitted views, 2 a page) and the histograms go (and the files read, listed on the summary)
    bare = dataclasses.replace(calibration, statistics={k: v for k, v in calibration.statistics.items()
                                                         if k != "validation"})
    assert write_calibration_report(bare, folder / "bare.pdf", out, data=ReportData(None, None, [])) <= pages - 5


def test_a_missing_image_is_named_and_the_report_still_written(calibrated, tmp_path, capsys):
    folder, out, pairs = calibrated
    lonely = tmp_path / "cal.json"  # the calibration without its images beside it
    lonely.write_bytes(out.read_bytes())
    (tmp_path / "board.json").write_bytes((folder / "board.json").read_bytes())
    assert main(["calibration", "report", str(lonely), "--out", str(tmp_path / "r.pdf")]) == 0
    assert _pages(tmp_path / "r.pdf") >= 4
    data = target_report_data(load_calibration(lonely), lonely)
    assert data.observations is None
    assert any(role == "image" and ("not found" in why or "not read" in why) for role, _, why in data.files)


def test_a_video_calibration_does_not_read_as_imported():
    from usvips.core.camera import Camera, Exterior
    from usvips.core.interior import Interior
    from usvips.core.stereo_calibration import StereoCalibration

    camera = Camera(Interior(800.0, 320.0, 240.0), Exterior(0, 0, 0))
    calibration = StereoCalibration.from_cameras(camera, Camera(Interior(800.0, 320.0, 240.0),
                                                                Exterior(0.1, 0, 0)), "air", 0.3,
                                                 source={"target": "board.json", "video": "cal"})
    lines = "\n".join(_summary_lines(calibration, ReportData(None, None, []), None))
    assert "imported from OpenCV" not in lines and "source video: cal" in lines
    imported = dataclasses.replace(calibration, source={})
    assert "imported from OpenCV" in "\n".join(_summary_lines(imported, ReportData(None, None, []), None))
    assert np.isfinite(calibration.sigma0_px)
