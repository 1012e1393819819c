"""The adjustment report file (``usvips calibrate --report``): a typed report written and read in one
place; the files earlier versions wrote still load, field for field."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

from tests.core.calibration.test_blunder_search_scales import NOISE, _field
from usvips.core.calibration import CalibrationOptions, calibrate_air
from usvips.core.calibration.report import CalibrationReport
from usvips.core.errors import InputFileError
from usvips.core.observations import StereoObservations
from usvips.io.adjustment_report import (
    read_adjustment_report,
    report_from_dict,
    report_to_dict,
    write_adjustment_report,
)

DATA = Path(__file__).resolve().parent / "data"
#: reports written by ``usvips calibrate --report`` before the report was typed (the sample rov_flatport)
OLD_FILES = ("adjustment_report_air_v1.json", "adjustment_report_water_v1.json")
#: fields the first report files did not have
ADDED_SINCE = ("rms_px_kept", "set_aside", "on_bound", "model_doubt", "control_blunders", "estimation",
               "weak_directions")


@pytest.mark.parametrize("name", OLD_FILES)
def test_a_report_written_before_reads_and_writes_back_field_for_field(name, tmp_path):
    data = json.loads((DATA / name).read_text())
    report, validation = read_adjustment_report(DATA / name)
    assert isinstance(report, CalibrationReport) and validation is None
    assert report.sigma0_px == data["sigma0_px"] and report.stations == tuple(data["stations"])
    assert report.parameters["f_l"].sigma == data["parameters"]["f_l"]["sigma"]
    assert [row.vx for row in report.residuals] == [row["vx"] for row in data["residuals"]]
    assert report_to_dict(report) == data
    write_adjustment_report(tmp_path / "again.json", report)
    assert json.loads((tmp_path / "again.json").read_text()) == data


def test_a_report_of_the_first_format_reads_with_the_later_fields_empty():
    data = json.loads((DATA / OLD_FILES[1]).read_text())
    for key in ADDED_SINCE:
        del data[key]
    report = report_from_dict(data)
    assert report.control_blunders == () and report.on_bound == () and report.weak_directions == ()
    assert report.model_doubt is None and report.set_aside == 0 and report.estimation["estimator"] == "least squares"
    assert report.rms_px == data["rms_px"] and len(report.residuals) == len(data["residuals"])


def test_set_aside_rows_suspects_and_a_validation_survive_the_file(tmp_path):
    control, observations, rng = _field(801, stations=4)
    row = int(rng.integers(len(observations)))
    left = observations.left.copy()
    left[row] += rng.choice([-1, 1], 2) * rng.uniform(6, 12, 2)  # a blunder (px) the adjustment sets aside
    planted = StereoObservations(observations.ids, left, observations.right, observations.pairs)
    report = calibrate_air(control, planted, CalibrationOptions(sigma_px=NOISE)).report
    assert report.set_aside_residuals() and report.suspects
    validation = {"held_out": {"views": ["3"], "rms_px": 0.4}}
    write_adjustment_report(tmp_path / "report.json", report, validation)
    again, read_validation = read_adjustment_report(tmp_path / "report.json")
    assert read_validation == validation
    assert again.residuals == report.residuals and again.suspects == report.suspects
    assert again.parameters == report.parameters and again.notes == report.notes
    assert [b.point for b in again.control_blunders] == [b.point for b in report.control_blunders]
    for a, b in zip(again.control_blunders, report.control_blunders, strict=True):
        assert np.array_equal(a.offset, b.offset) and a.message == b.message
    plain = dataclasses.replace(report, control_blunders=())
    assert dataclasses.replace(again, control_blunders=()) == plain


@pytest.mark.parametrize("damage", ["not json", "[1, 2]", '{"phase": "air"}'])
def test_a_file_that_is_not_a_report_is_one_error_naming_it(tmp_path, damage):
    path = tmp_path / "report.json"
    path.write_text(damage)
    with pytest.raises(InputFileError, match="report.json: not a"):
        read_adjustment_report(path)
