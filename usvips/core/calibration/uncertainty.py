"""Intersection with the calibration's own uncertainty propagated into every point.

The pixel part of a point's covariance comes from the pointing precision (``intersection.py``). A
calibration estimated from few control points is itself uncertain, and that error is common to every
point measured with it: its part is J Σ Jᵀ, with Σ the calibration's a-posteriori covariance of its free
parameters and J = ∂point/∂parameter by differences (re-intersecting with each parameter stepped).
"""

from __future__ import annotations

import numpy as np

from usvips.core.calibration.model import _STEPS, stereo_cameras, symbol
from usvips.core.errors import InvalidParameterError, UsvipsError
from usvips.core.intersection import Intersection, intersect_traced, retrace, trace
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
    result, derivatives, sigma = _intersect_and_derivatives(calibration, left, right, station, frame,
                                                            include_calibration)
    if derivatives is None:
        return result
    calibration_part = np.einsum("jni,jk,knl->nil", derivatives, sigma, derivatives, optimize=True)
    covariance = result.covariance + np.where(result.ok[:, None, None], calibration_part, 0.0)
    return Intersection(result.points, covariance, result.residuals_m, result.residuals_px, result.status)


def joint_covariance(calibration: StereoCalibration, left: np.ndarray, right: np.ndarray,
                     station: int | str = 0, frame: str = "object") -> tuple[Intersection, np.ndarray]:
    """The intersection and the full (3N, 3N) covariance of all its points: the pointing part per point,
    and the calibration's part between every pair of points (a common calibration error correlates
    them; a length between two points partly cancels it)."""
    result, derivatives, sigma = _intersect_and_derivatives(calibration, left, right, station, frame, True)
    n = len(result.points)
    full = np.zeros((3 * n, 3 * n))
    for i in range(n):
        full[3 * i:3 * i + 3, 3 * i:3 * i + 3] = result.covariance[i]
    if derivatives is not None:
        flat = derivatives.reshape(len(derivatives), 3 * n)
        full += flat.T @ sigma @ flat
    return result, full


def _intersect_and_derivatives(calibration, left, right, station, frame, include_calibration):
    if frame not in ("object", "rig"):
        raise InvalidParameterError("frame", f"must be 'object' or 'rig', got {frame!r}")
    rig = calibration.rig(station, frame=frame)
    traced = [trace(camera, pixels, f"pixels of camera {i}")
              for i, (camera, pixels) in enumerate(zip(rig.cameras, (left, right), strict=True))]
    result = intersect_traced(traced, calibration.sigma0_px)
    if not include_calibration or calibration.covariance is None or not result.ok.any():
        return result, None, None
    names, sigma = calibration.covariance
    values = {name: p.value for name, p in calibration.parameters.items()}
    if not all(name in values for name in names):
        return result, None, None
    kind = calibration.left.housing.kind
    label = _station_label(calibration, station)
    size = (calibration.left.width, calibration.left.height)
    derivatives = np.zeros((len(names),) + result.points.shape)
    ok = result.ok
    for j, name in enumerate(names):
        if "@" in name and symbol(name) in ("X", "Y", "Z"):
            continue  # a control (or demoted tie) point's coordinate moves no camera: its column is zero
        step = _STEPS.get(symbol(name), 1e-6)
        moved = dict(values)
        moved[name] += step
        try:
            cameras = stereo_cameras(kind, moved, calibration.stations, label, size, frame)
        except UsvipsError:  # a step outside the valid region: leave this column at zero
            continue
        # (a camera the step did not change keeps its traced rays)
        again = intersect_traced([retrace(one, camera) for one, camera in zip(traced, cameras, strict=True)],
                                 calibration.sigma0_px)
        usable = ok & again.ok
        derivatives[j, usable] = (again.points[usable] - result.points[usable]) / step
    return result, derivatives, np.asarray(sigma)
