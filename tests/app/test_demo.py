"""The demo service: its steps, in order, on a synthetic sample with known truth."""

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

from tests.core.calibration_scenes import FLAT, control_frame, observe, rig_at
from usvips.app.demo import CheckSummary, DemoStart, PhaseSummary, SkippedCheck, phase_summary, run_demo
from usvips.core.adjustment import Suspect
from usvips.core.errors import UsvipsError
from usvips.io.adjustment_report import read_adjustment_report
from usvips.io.tables import write_control, write_observations

REPORTS = Path(__file__).resolve().parents[1] / "io" / "data"


def _sample(folder, check_pairs):
    control = control_frame()
    write_control(folder / "control.csv", control)
    write_observations(folder / "air.csv", observe(rig_at(0), control.xyz, control.ids, "a", seed=3).observations)
    water = observe(rig_at(0, FLAT), control.xyz, control.ids, "w", seed=4).observations
    write_observations(folder / "water.csv", water.take(range(0, len(water), 2)))
    write_observations(folder / "check.csv", water.take(range(1, len(water), 2)))
    manifest = {"format": "usvips-sample", "version": 1, "name": "synthetic", "description": "flat ports",
                "control": "control.csv", "housing": "flat-port",
                "pairs": [{"label": "a", "medium": "air"}, {"label": "w", "medium": "water"},
                          {"label": "x", "medium": "water"}],
                "observations": [{"file": "air.csv", "role": "calibration-air", "pairs": ["a"]},
                                 {"file": "water.csv", "role": "calibration-water", "pairs": ["w"]},
                                 {"file": "check.csv", "role": "check", "pairs": check_pairs}]}
    (folder / "project.json").write_text(json.dumps(manifest))
    return control


def test_the_demo_yields_start_both_phases_and_the_check_points_against_control(tmp_path):
    control = _sample(tmp_path, ["w"])
    steps = list(run_demo(tmp_path))
    assert [type(s) for s in steps] == [DemoStart, PhaseSummary, PhaseSummary, CheckSummary]
    assert steps[0] == DemoStart("synthetic", "flat ports")
    assert steps[1].title.startswith("phase 1 (in air") and steps[2].title.startswith("phase 2 (flat-port")
    for phase in steps[1:3]:
        assert 0.5 < phase.sigma0_px / 0.3 < 2 and phase.redundancy > 0  # the scenes' pointing noise: 0.3 px
    check = steps[3]
    assert 0 < len(check.ids) <= check.count and check.errors.shape == check.sigmas.shape == (len(check.ids), 3)
    np.testing.assert_allclose(check.rms, np.sqrt(np.mean(check.errors**2, axis=0)))
    # the errors are those of the control points named, and they are of the size their sigmas say
    assert set(check.ids) <= set(control.ids)
    z = check.errors / check.sigmas
    assert 0.2 < np.mean(z**2) < 5


def test_a_check_file_of_an_uncalibrated_pair_is_skipped_by_name(tmp_path):
    _sample(tmp_path, ["x"])
    steps = list(run_demo(tmp_path))
    assert steps[-1] == SkippedCheck("check.csv", ("x",))


def test_a_project_without_in_air_observations_is_refused_by_its_manifest(tmp_path):
    _sample(tmp_path, ["w"])
    manifest = json.loads((tmp_path / "project.json").read_text())
    manifest["observations"] = manifest["observations"][1:]
    (tmp_path / "project.json").write_text(json.dumps(manifest))
    with pytest.raises(UsvipsError, match="project.json: the project has no in-air calibration observations"):
        next(run_demo(tmp_path))


def test_a_suspect_is_named_once_per_image_with_the_y_verdict_first():
    report = read_adjustment_report(REPORTS / "adjustment_report_air_v1.json")[0]
    report = dataclasses.replace(report, suspects=(
        Suspect("4", "l", "x", "air1", 5.0, 0.5, 0.4, ""), Suspect("4", "l", "y", "air1", -6.0, 0.6, 0.4, ""),
        Suspect("9", "r", "x", "air1", None, None, None, "not visible")))
    summary = phase_summary(report, "phase 1")
    assert [(t.id, t.side, t.w, t.reason) for t in summary.excluded] == [("4", "left", -6.0, ""),
                                                                          ("9", "right", None, "not visible")]
