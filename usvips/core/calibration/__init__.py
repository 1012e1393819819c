"""Calibration: DLT start, phase 1 (in air), phase 2 (underwater, ray tracing), joint multi-pair.

The names below are loaded from :mod:`usvips.core.calibration.phases` when first used (PEP 562), not when
the package is: measuring needs only :mod:`~usvips.core.calibration.uncertainty`, and the phases' import
chain (the adjustment, DLT, blunder tests) would cost the window's start-up a tenth of a second.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from usvips.core.calibration.phases import (
        CalibrationOptions,
        CalibrationResult,
        calibrate_air,
        calibrate_water,
    )

__all__ = ["CalibrationOptions", "CalibrationResult", "calibrate_air", "calibrate_water"]


def __getattr__(name: str) -> object:
    if name in __all__:
        from usvips.core.calibration import phases

        return getattr(phases, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
