"""The adjustment report file (JSON) of ``usvips calibrate --report``: a
:class:`~usvips.core.calibration.report.CalibrationReport` written and read here, and only here.

The format is the one every version has written: ``sigma0_px``, ``rms_px``, ``parameters`` (name →
``{"value", "sigma", "status"}``), ``correlations_over_0_95`` (``{"a", "b", "r"}``), ``residuals`` (one
object per image point; a set-aside one flagged ``"set_aside": true``), ``suspects``, ``control_blunders``,
``global_test``, ``notes`` …, and optionally ``validation`` (held-out views,
:meth:`usvips.core.calibration.validation.Validation.as_dict`). Reading accepts the files of earlier
versions, which lack the fields added since (``rms_px_kept``, ``set_aside``, ``on_bound``,
``model_doubt``, ``control_blunders``, ``estimation``, ``weak_directions``): they read as empty.
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from usvips.core.adjustment import Suspect
from usvips.core.calibration.control_blunders import ControlBlunder
from usvips.core.calibration.report import BoundHit, CalibrationReport, Correlation, ResidualRow
from usvips.core.errors import InputFileError
from usvips.core.stereo_calibration import ParameterEstimate
from usvips.io.atomic import write_text_atomic


def report_to_dict(report: CalibrationReport, validation: Mapping | None = None) -> dict:
    """The report as its file's JSON object (``validation``: the held-out views' record, if any)."""
    data = {
        "phase": report.phase, "housing": report.housing, "stations": list(report.stations),
        "converged": report.converged, "reason": report.reason, "iterations": report.iterations,
        "on_bound": [{"parameter": b.parameter, "bound": b.bound, "value": b.value} for b in report.on_bound],
        "model_doubt": report.model_doubt,
        "sigma0_px": report.sigma0_px, "rms_px": report.rms_px, "rms_px_kept": report.rms_px,
        "rms_px_all": report.rms_px_all, "set_aside": report.set_aside, "redundancy": report.redundancy,
        "parameters": {name: {"value": p.value, "sigma": p.sigma, "status": p.status}
                       for name, p in report.parameters.items()},
        "correlations_over_0_95": [{"a": c.a, "b": c.b, "r": c.r} for c in report.correlations],
        "condition_number": report.condition_number,
        "weak_directions": [[{"parameter": n, "weight": w} for n, w in d] for d in report.weak_directions],
        "control_blunders": [b.as_dict() for b in report.control_blunders],
        "suspects": [{"id": s.point, "side": s.side, "coordinate": s.coordinate, "station": s.group, "w": s.w,
                      "residual_px": s.residual, "mdb_px": s.mdb, "reason": s.reason} for s in report.suspects],
        "global_test": dict(report.global_test), "residuals": [_residual_to_dict(r) for r in report.residuals],
        "notes": list(report.notes), "estimation": dict(report.estimation),
    }
    if report.sigma0_px_estimated is not None:
        data["sigma0_px_estimated"] = report.sigma0_px_estimated
    if report.variance_scale is not None:
        data["variance_scale"] = dict(report.variance_scale)
    if validation is not None:
        data["validation"] = dict(validation)
    return data


def _residual_to_dict(row: ResidualRow) -> dict:
    out = {"id": row.id, "side": row.side, "station": row.station, "vx": row.vx, "vy": row.vy, "wx": row.wx,
           "wy": row.wy, "redundancy_x": row.redundancy_x, "redundancy_y": row.redundancy_y, "used": row.used}
    if not row.used:
        out["set_aside"] = True
        if row.note:
            out["note"] = row.note
    return out


def report_from_dict(data: Mapping, where: str = "adjustment report") -> CalibrationReport:
    """A report file's JSON object as a :class:`CalibrationReport`; a missing or malformed required field is
    an :class:`InputFileError` naming ``where`` and the field."""
    try:
        return _report_from_dict(data)
    except (KeyError, TypeError, ValueError, AttributeError) as error:
        raise InputFileError(where, f"not an adjustment report: {type(error).__name__} {error}") from None


def _optional(value) -> float | None:
    return None if value is None else float(value)


def _report_from_dict(data: Mapping) -> CalibrationReport:
    residuals = tuple(ResidualRow(str(r["id"]), str(r["side"]), str(r["station"]), _optional(r["vx"]),
                                  _optional(r["vy"]), float(r["wx"]), float(r["wy"]), float(r["redundancy_x"]),
                                  float(r["redundancy_y"]), bool(r["used"]), str(r.get("note", "")))
                      for r in data["residuals"])
    suspects = tuple(Suspect(str(s["id"]), str(s["side"]), str(s["coordinate"]), str(s["station"]),
                             _optional(s.get("w")), _optional(s.get("residual_px")), _optional(s.get("mdb_px")),
                             str(s.get("reason", "w-test"))) for s in data.get("suspects", ()))
    blunders = tuple(ControlBlunder(str(b["id"]), np.asarray(b["control"], float), np.asarray(b["fitted"], float),
                                    np.asarray(b["sigma"], float), tuple(b["axes"]), tuple(b["freed"]),
                                    float(b["chi2"]), str(b["message"])) for b in data.get("control_blunders", ()))
    rms_all = data.get("rms_px_all")
    return CalibrationReport(
        phase=str(data["phase"]), housing=str(data["housing"]), stations=tuple(str(s) for s in data["stations"]),
        converged=bool(data["converged"]), reason=str(data.get("reason", "")),
        iterations=int(data.get("iterations", 0)), sigma0_px=float(data["sigma0_px"]),
        rms_px=float(data["rms_px"]), rms_px_all=_optional(rms_all),
        set_aside=int(data.get("set_aside", sum(1 for r in residuals if not r.used) * 2)),
        redundancy=int(data["redundancy"]),
        parameters={str(name): ParameterEstimate(float(p["value"]), _optional(p.get("sigma")),
                                                 str(p.get("status", "free")))
                    for name, p in data["parameters"].items()},
        correlations=tuple(Correlation(str(c["a"]), str(c["b"]), float(c["r"]))
                           for c in data.get("correlations_over_0_95", ())),
        condition_number=float(data.get("condition_number", float("nan"))),
        weak_directions=tuple(tuple((str(e["parameter"]), float(e["weight"])) for e in d)
                              for d in data.get("weak_directions", ())),
        control_blunders=blunders, suspects=suspects,
        on_bound=tuple(BoundHit(str(b["parameter"]), str(b["bound"]), float(b["value"]))
                       for b in data.get("on_bound", ())),
        model_doubt=data.get("model_doubt"), global_test=dict(data.get("global_test") or {}),
        estimation=dict(data.get("estimation") or {"estimator": "least squares"}), residuals=residuals,
        notes=tuple(str(n) for n in data.get("notes", ())),
        sigma0_px_estimated=_optional(data.get("sigma0_px_estimated")),
        variance_scale=data.get("variance_scale"))


def report_text(report: CalibrationReport, validation: Mapping | None = None) -> str:
    """The report file's text (JSON, indented; no NaN: a figure that is not a number is refused here)."""
    return json.dumps(report_to_dict(report, validation), indent=2, allow_nan=False) + "\n"


def write_adjustment_report(path: str | Path, report: CalibrationReport, validation: Mapping | None = None) -> None:
    """Write the report file at ``path`` (atomically)."""
    write_text_atomic(path, report_text(report, validation))


def read_adjustment_report(path: str | Path) -> tuple[CalibrationReport, dict | None]:
    """(report, validation record or None) of a report file written by any version of USVIPS."""
    try:
        data = json.loads(Path(path).read_text(encoding="utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as error:
        raise InputFileError(str(path), f"not a JSON adjustment report ({error})") from None
    if not isinstance(data, dict):
        raise InputFileError(str(path), "not an adjustment report (a JSON object is expected)")
    validation = data.get("validation")
    return report_from_dict(data, str(path)), dict(validation) if isinstance(validation, dict) else None
