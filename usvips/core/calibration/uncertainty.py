"""Intersection with the calibration's own uncertainty propagated into every point.

The pixel part of a point's covariance comes from the pointing precision (``intersection.py``). A
calibration estimated from few control points is itself uncertain, and that error is common to every
point measured with it: its part is J Σ Jᵀ, with Σ the calibration's a-posteriori covariance of its free
parameters and J = ∂point/∂parameter by differences (re-intersecting with each parameter stepped).
"""

from __future__ import annotations

import numpy as np

from usvips.core.calibration.model import _STEPS, stereo_cameras, symbol
from usvips.core.errors import InvalidParameterError
from usvips.core.intersection import Intersection, intersect
from usvips.core.stereo_calibration import StereoCalibration


def _station_label(calibration: StereoCalibration, station: int | str) -> str:
    return calibration.stations[calibration.station_index(station)]


def intersect_with_calibration(calibration: StereoCalibration, left: np.ndarray, right: np.ndarray,
                               station: int | str = 0, frame: str = "object",
                               include_calibration: bool = True) -> Intersection:
    """Intersect conjugate pixels (N, 2) with a calibrated rig; covariance = pointing + calibration.

    The pointing precision is the calibration's a-posteriori sigma0 (pixels). Where the calibration has
    no parameter covariance (e.g. imported from OpenCV), only the pointing part is given.
    """
    if frame not in ("object", "rig"):
        raise InvalidParameterError("frame", f"must be 'object' or 'rig', got {frame!r}")
    rig = calibration.rig(station, frame=frame)
    result = intersect(rig.cameras, [left, right], calibration.sigma0_px)
    if not include_calibration or calibration.covariance is None or not result.ok.any():
        return result
    names, sigma = calibration.covariance
    values = {name: p.value for name, p in calibration.parameters.items()}
    if not all(name in values for name in names):
        return result
    kind = calibration.left.housing.kind
    label = _station_label(calibration, station)
    size = (calibration.left.width, calibration.left.height)
    derivatives = np.zeros((len(names),) + result.points.shape)
    ok = result.ok
    for j, name in enumerate(names):
        step = _STEPS.get(symbol(name), 1e-6)
        moved = dict(values)
        moved[name] += step
        try:
            cameras = stereo_cameras(kind, moved, calibration.stations, label, size, frame)
        except Exception:  # noqa: BLE001 - a step outside the valid region: leave this column at zero
            continue
        again = intersect(cameras, [left, right], calibration.sigma0_px)
        usable = ok & again.ok
        derivatives[j, usable] = (again.points[usable] - result.points[usable]) / step
    calibration_part = np.einsum("jni,jk,knl->nil", derivatives, sigma, derivatives)
    covariance = result.covariance + np.where(ok[:, None, None], calibration_part, 0.0)
    return Intersection(result.points, covariance, result.residuals_m, result.residuals_px, result.status)
