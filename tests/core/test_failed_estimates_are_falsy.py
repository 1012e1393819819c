"""Every estimator's result that can fail is falsy when it did (the pattern of detections, matches and
calibrations), with its reason kept: a caller writes ``if not result:`` and then says why."""

from __future__ import annotations

import dataclasses
from pathlib import Path

from usvips.core.calibration.report import ResidualRow
from usvips.core.synchronisation import SyncEstimate
from usvips.core.target_field import FieldPoint
from usvips.io.adjustment_report import read_adjustment_report

REPORT = Path(__file__).resolve().parents[1] / "io" / "data" / "adjustment_report_air_v1.json"


def test_a_sync_offset_at_the_edge_of_its_window_is_falsy():
    inside = SyncEstimate(12.3, 30.0, "flash", 0.9, window=(-40.0, 40.0))
    at_edge = dataclasses.replace(inside, offset_frames=40.0)
    beyond = dataclasses.replace(inside, beyond=120.0)
    unknown_window = dataclasses.replace(inside, window=None)
    assert inside and unknown_window and not at_edge and not beyond
    assert at_edge.at_edge and beyond.at_edge


def test_a_field_point_is_truthy_only_when_found():
    found = FieldPoint("7", (10.0, 20.0), (10.4, 19.8), 12.0, "found")
    doubtful = dataclasses.replace(found, status="doubtful", reason="two candidates")
    missing = dataclasses.replace(found, pixel=None, status="missing", reason="no target there")
    assert found and not doubtful and not missing and missing.reason


def test_a_report_of_an_adjustment_that_did_not_converge_is_falsy():
    report, _ = read_adjustment_report(REPORT)
    assert report and report.converged
    failed = dataclasses.replace(report, converged=False, reason="the damping grew beyond its limit")
    assert not failed and failed.reason
    row = report.residuals[0]
    assert isinstance(row, ResidualRow) and row.used and not row.set_aside
