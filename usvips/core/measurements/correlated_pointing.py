"""The pointing covariance of vertices whose left and right pointing errors are CORRELATED.

A vertex's pointing is normally two independent errors, one per image, each of its own sigma (px, one image
coordinate, x and y alike): :mod:`usvips.core.pointing`. A pair whose right point was found by matching the
left one along its epipolar curve (a model's keypoints refined in the right image,
:mod:`usvips.core.detection.refine`) is not that: the right point follows the left one, so the right error is
the left error carried over plus the match's own error. Its pixel errors then have the covariance, per image
coordinate,

    [[σ_L²,         ρ σ_L σ_R],
     [ρ σ_L σ_R,    σ_R²     ]]

with ρ the correlation of the left and right errors (for the right error = the left error + an independent
match error of σ_m: σ_R² = σ_L² + σ_m² and ρ = σ_L / σ_R). The disparity's error is then σ_m alone, not
√(σ_L² + σ_R²): depth, and with it a length, is far better known than two independent errors would say.

The point's covariance is J Σ Jᵀ, J (3, 4) the derivatives of the intersected point by the four pixel
coordinates (left x, y, right x, y), taken by central differences of the intersection itself (the same
weighted least-squares point as the figure path's, through the housing) — first order, like the rest of the
pointing part. With ρ = 0 it is the intersection's own (Σ W)⁻¹ (the tests check it), and vertices of ρ = 0
are never recomputed. Metres and pixels.
"""

from __future__ import annotations

import numpy as np

from usvips.core.errors import InvalidParameterError
from usvips.core.stereo_calibration import StereoCalibration

#: the central difference's step (px): small against any pointing sigma, large against rounding
STEP_PX = 0.05


def correlations(pointing_correlation: float | np.ndarray | None, count: int) -> np.ndarray | None:
    """(count,) correlations of a scalar, a (count,) array or None (None: every vertex independent); each
    must lie in [0, 1) — a pixel's right error follows its left one, or not. A wrong shape or value is an
    :class:`InvalidParameterError` on ``pointing_correlation``."""
    if pointing_correlation is None:
        return None
    rho = np.asarray(pointing_correlation, dtype=np.float64)
    rho = np.full(count, float(rho)) if rho.ndim == 0 else rho.reshape(-1)
    if rho.shape != (count,):
        raise InvalidParameterError("pointing_correlation", f"expected a scalar or ({count},) for {count} vertices, "
                                                            f"got shape {np.shape(pointing_correlation)}")
    if not np.all(np.isfinite(rho)) or np.any(rho < 0) or np.any(rho >= 1):
        raise InvalidParameterError("pointing_correlation", "every correlation of a vertex's left and right pointing "
                                                            "must lie in [0, 1)")
    return rho if np.any(rho > 0) else None


def correlated_covariances(calibration: StereoCalibration, left: np.ndarray, right: np.ndarray,
                           sigma_px: np.ndarray, correlation: np.ndarray, station: int | str = 0,
                           frame: str = "object") -> np.ndarray:
    """(N, 3, 3) pointing covariances (m²) of the intersected picks ``left``/``right`` (N, 2) px with
    pointing sigmas ``sigma_px`` (N, 2) [left, right] px and left–right correlations ``correlation`` (N,)
    (see the module docstring). A vertex whose rays fail for a pixel a step away (at the edge of what the
    housing sees) gets NaN: the caller keeps its independent covariance, the larger one."""
    from usvips.core.calibration.uncertainty import intersect_with_calibration  # not needed to import this

    left = np.asarray(left, dtype=np.float64).reshape(-1, 2)
    right = np.asarray(right, dtype=np.float64).reshape(-1, 2)
    sigma = np.asarray(sigma_px, dtype=np.float64).reshape(-1, 2)
    rho = np.asarray(correlation, dtype=np.float64).reshape(-1)
    n = len(left)
    steps = np.zeros((8, n, 4))
    for c in range(4):
        steps[2 * c, :, c], steps[2 * c + 1, :, c] = STEP_PX, -STEP_PX
    moved = np.concatenate([left, right], axis=1)[None] + steps
    result = intersect_with_calibration(calibration, moved[..., :2].reshape(-1, 2), moved[..., 2:].reshape(-1, 2),
                                        station, frame, include_calibration=False,
                                        pointing_sigma_px=np.tile(sigma, (8, 1)))
    points = result.points.reshape(8, n, 3)
    usable = result.ok.reshape(8, n).all(axis=0)
    jacobian = (points[0::2] - points[1::2]).transpose(1, 2, 0) / (2 * STEP_PX)  # (n, 3, 4)
    cross = rho * sigma[:, 0] * sigma[:, 1]
    pixels = np.zeros((n, 4, 4))
    for c in range(2):
        pixels[:, c, c] = sigma[:, 0] ** 2
        pixels[:, 2 + c, 2 + c] = sigma[:, 1] ** 2
        pixels[:, c, 2 + c] = pixels[:, 2 + c, c] = cross
    covariance = np.einsum("nij,njk,nlk->nil", jacobian, pixels, jacobian)
    covariance[~usable] = np.nan
    return covariance


def kept_where_failed(correlated: np.ndarray, independent: np.ndarray) -> np.ndarray:
    """``correlated`` (M, 3, 3) with the vertices it could not give (NaN) taken from ``independent``."""
    return np.where(np.isnan(correlated).any(axis=(1, 2))[:, None, None], independent, correlated)


def with_correlation(calibration: StereoCalibration, left: np.ndarray, right: np.ndarray, sigma_px: np.ndarray,
                     correlation: np.ndarray | None, pointing: np.ndarray, station: int | str = 0,
                     frame: str = "object") -> np.ndarray:
    """The block-diagonal pointing part (3N, 3N) m² of N vertices with the blocks of the correlated ones
    (``correlation`` > 0) replaced by :func:`correlated_covariances`; ``pointing`` itself (not copied) when
    none is correlated."""
    if correlation is None or not np.any(correlation > 0):
        return pointing
    chosen = np.flatnonzero(correlation > 0)
    blocks = correlated_covariances(calibration, np.asarray(left).reshape(-1, 2)[chosen],
                                    np.asarray(right).reshape(-1, 2)[chosen], np.asarray(sigma_px)[chosen],
                                    correlation[chosen], station, frame)
    out = np.array(pointing, dtype=np.float64, copy=True)
    own = np.array([out[3 * i:3 * i + 3, 3 * i:3 * i + 3] for i in chosen])
    for block, i in zip(kept_where_failed(blocks, own), chosen, strict=True):
        out[3 * i:3 * i + 3, 3 * i:3 * i + 3] = block
    return out
