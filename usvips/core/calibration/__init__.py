"""Calibration: DLT start, phase 1 (in air), phase 2 (underwater, ray tracing), joint multi-pair."""

from usvips.core.calibration.phases import (
    CalibrationOptions,
    CalibrationResult,
    calibrate_air,
    calibrate_water,
)

__all__ = ["CalibrationOptions", "CalibrationResult", "calibrate_air", "calibrate_water"]
