"""Direct linear transformation (11 parameters) and its decomposition into starting values.

The DLT maps object points (X, Y, Z) to pixels by a 3 × 4 projective matrix; it needs at least six
well-spread, non-coplanar control points and ignores distortion and refraction, so it serves as the
starting value of every calibration (thesis 3.5.1, Table 3.3). The decomposition returns f, xp, yp, sy
and the exterior orientation in USVIPS's conventions (``interior.py``, ``rotation.py``).

``robust_dlt`` tries random minimal subsets and keeps the one whose median reprojection error is least
(least median of squares), so that one gross error in the control or the pixels does not spoil the start.
Its trials are solved as one stack (:func:`_least_median_trials`: batched SVDs, all reprojections in one
product); the loop over trials stays as the reference path (:func:`usvips.core.batch_mode.reference`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from usvips.core.batch_mode import using_reference
from usvips.core.camera import Exterior
from usvips.core.errors import DegenerateGeometryError
from usvips.core.rotation import angles_from_matrix

#: Flip from OpenCV's camera frame (x right, y down, z forward) to ours (x right, y up, z backward).
FLIP = np.diag([1.0, -1.0, -1.0])


@dataclass(frozen=True)
class DltResult:
    """The 3 × 4 projection (pixels), its decomposition and its reprojection residuals (pixels)."""

    matrix: np.ndarray
    f: float
    xp: float
    yp: float
    sy: float
    skew: float
    exterior: Exterior
    residuals: np.ndarray
    inliers: np.ndarray

    @property
    def rms_px(self) -> float:
        return float(np.sqrt(np.mean(np.sum(self.residuals[self.inliers] ** 2, axis=1))))


def check_spread(points: np.ndarray, minimum: int = 6, what: str = "control points") -> None:
    """Raise :class:`DegenerateGeometryError` if there are too few points or they are (nearly) coplanar."""
    points = np.asarray(points, dtype=np.float64)
    if len(points) < minimum:
        raise DegenerateGeometryError(f"the DLT needs at least {minimum} {what}, got {len(points)}")
    centred = points - points.mean(axis=0)
    singular = np.linalg.svd(centred, compute_uv=False)
    if singular[0] == 0 or singular[2] / singular[0] < 1e-3:
        raise DegenerateGeometryError(
            f"the {len(points)} {what} are (nearly) coplanar (thickness/extent = "
            f"{singular[2] / max(singular[0], 1e-300):.1e}); the DLT needs 3-D spread: add points off the plane")


def _normalisation(values: np.ndarray) -> np.ndarray:
    centre = values.mean(axis=0)
    spread = np.sqrt(np.mean(np.sum((values - centre) ** 2, axis=1)))
    dim = values.shape[1]
    scale = np.sqrt(dim) / max(spread, 1e-300)
    transform = np.eye(dim + 1)
    transform[:dim, :dim] *= scale
    transform[:dim, dim] = -scale * centre
    return transform


def _solve_matrix(points: np.ndarray, pixels: np.ndarray) -> np.ndarray:
    t_obj = _normalisation(points)
    t_img = _normalisation(pixels)
    x = (t_obj @ np.column_stack([points, np.ones(len(points))]).T).T
    u = (t_img @ np.column_stack([pixels, np.ones(len(pixels))]).T).T
    rows = np.zeros((2 * len(x), 12))  # per point: [X, 0, −u X] and [0, X, −v X]
    rows[0::2, :4], rows[0::2, 8:] = x, -u[:, :1] * x
    rows[1::2, 4:8], rows[1::2, 8:] = x, -u[:, 1:2] * x
    _, _, vt = np.linalg.svd(rows, full_matrices=False)  # only V is needed: no 2n × 2n U
    normalised = vt[-1].reshape(3, 4)
    return np.linalg.inv(t_img) @ normalised @ t_obj


def reproject(matrix: np.ndarray, points: np.ndarray) -> np.ndarray:
    homogeneous = np.column_stack([points, np.ones(len(points))]) @ matrix.T
    with np.errstate(divide="ignore", invalid="ignore"):  # a point in the camera's plane: inf/nan, an outlier
        return homogeneous[:, :2] / homogeneous[:, 2:3]


def decompose(matrix: np.ndarray, points: np.ndarray, pixels: np.ndarray,
              inliers: np.ndarray | None = None) -> DltResult:
    """Split a projection matrix into interior (f, xp, yp, sy) and exterior orientation."""
    matrix = np.asarray(matrix, dtype=np.float64)
    # orient so that the control lies in front of the camera (positive depth in OpenCV's frame)
    depth = np.column_stack([points, np.ones(len(points))]) @ matrix[2]
    if np.median(depth) < 0:
        matrix = -matrix
    left = matrix[:, :3]
    if abs(np.linalg.det(left)) < 1e-300:
        raise DegenerateGeometryError("the DLT solution is singular: the control does not fix the camera")
    centre = -np.linalg.solve(left, matrix[:, 3])
    from scipy.linalg import rq  # deferred: scipy.linalg is slow to import (the window's start-up)

    k, r = rq(left)
    signs = np.diag(np.sign(np.diag(k)))
    k, r = k @ signs, signs @ r
    if np.linalg.det(r) < 0:  # a reflection: the overall sign of P was wrong
        r = -r
        k = -k
    k = k / k[2, 2]
    rotation = FLIP @ r
    omega, phi, kappa = angles_from_matrix(rotation)
    residuals = pixels - reproject(matrix, points)
    fx, fy = float(k[0, 0]), float(k[1, 1])
    return DltResult(matrix / np.linalg.norm(matrix), fx, float(k[0, 2]), float(k[1, 2]), fx / fy, float(k[0, 1]),
                     Exterior(*centre, omega, phi, kappa), residuals,
                     np.ones(len(points), bool) if inliers is None else inliers)


def dlt(points: np.ndarray, pixels: np.ndarray) -> DltResult:
    """Least-squares DLT from control points (N, 3) metres and their pixels (N, 2); N >= 6, non-coplanar."""
    points = np.asarray(points, dtype=np.float64)
    pixels = np.asarray(pixels, dtype=np.float64)
    check_spread(points)
    return decompose(_solve_matrix(points, pixels), points, pixels)


def _fit_sigma(points: np.ndarray, pixels: np.ndarray) -> tuple[np.ndarray, float]:
    matrix = _solve_matrix(points, pixels)
    errors = pixels - reproject(matrix, points)
    dof = 2 * len(points) - 11
    return matrix, float(np.sqrt(np.sum(errors**2) / dof)) if dof > 0 else 0.0


def _least_median_loop(points: np.ndarray, pixels: np.ndarray, subsets: np.ndarray, h: int
                       ) -> tuple[np.ndarray | None, float]:
    """The least-median-of-squares trial (projection matrix, its h-th smallest error in pixels) over the
    6-point ``subsets`` (trials, 6), one trial at a time (the reference path); (None, inf) if none is usable."""
    matrix, best_statistic = None, np.inf
    for subset in subsets:
        try:
            check_spread(points[subset])
            candidate = _solve_matrix(points[subset], pixels[subset])
            errors = np.linalg.norm(pixels - reproject(candidate, points), axis=1)
        except (DegenerateGeometryError, np.linalg.LinAlgError):
            continue
        if not np.all(np.isfinite(errors)):
            continue
        statistic = float(np.sort(errors)[h - 1])
        if statistic < best_statistic:
            matrix, best_statistic = candidate, statistic
    return matrix, best_statistic


def _batch_normalisation(values: np.ndarray) -> np.ndarray:
    """:func:`_normalisation` of each stacked point set (trials, k, dim) → (trials, dim + 1, dim + 1)."""
    trials, _, dim = values.shape
    centre = values.mean(axis=1)
    spread = np.sqrt(np.mean(np.sum((values - centre[:, None, :]) ** 2, axis=2), axis=1))
    scale = np.sqrt(dim) / np.maximum(spread, 1e-300)
    transform = np.zeros((trials, dim + 1, dim + 1))
    transform[:, np.arange(dim), np.arange(dim)] = scale[:, None]
    transform[:, :dim, dim] = -scale[:, None] * centre
    transform[:, dim, dim] = 1.0
    return transform


def _least_median_trials(points: np.ndarray, pixels: np.ndarray, subsets: np.ndarray, h: int
                         ) -> tuple[np.ndarray | None, float]:
    """:func:`_least_median_loop` with every trial at once: the spread check, the normalised DLT of each
    subset (a stack of 12 × 12 SVDs), the reprojection of all points by every candidate in one product and
    the h-th smallest error by partition; the first trial with the least statistic wins, as in the loop.
    Raises ``LinAlgError`` when an SVD of the stack does not converge."""
    chosen, seen = points[subsets], pixels[subsets]  # (trials, 6, 3), (trials, 6, 2)
    singular = np.linalg.svd(chosen - chosen.mean(axis=1, keepdims=True), compute_uv=False)
    spread = (singular[:, 0] != 0) & ~(singular[:, 2] / np.where(singular[:, 0] != 0, singular[:, 0], 1.0) < 1e-3)
    t_obj, t_img = _batch_normalisation(chosen), _batch_normalisation(seen)
    x = np.concatenate([chosen, np.ones(chosen.shape[:2] + (1,))], axis=2) @ t_obj.transpose(0, 2, 1)
    u = np.concatenate([seen, np.ones(seen.shape[:2] + (1,))], axis=2) @ t_img.transpose(0, 2, 1)
    rows = np.zeros((len(subsets), 12, 12))  # per point: [X, 0, −u X] and [0, X, −v X]
    rows[:, 0::2, :4], rows[:, 0::2, 8:] = x, -u[:, :, :1] * x
    rows[:, 1::2, 4:8], rows[:, 1::2, 8:] = x, -u[:, :, 1:2] * x
    normalised = np.linalg.svd(rows)[2][:, -1].reshape(-1, 3, 4)
    candidates = np.linalg.inv(t_img) @ normalised @ t_obj
    homogeneous = np.concatenate([points, np.ones((len(points), 1))], axis=1) @ candidates.transpose(0, 2, 1)
    with np.errstate(divide="ignore", invalid="ignore"):  # a point in the camera's plane: an outlier
        errors = np.linalg.norm(pixels - homogeneous[:, :, :2] / homogeneous[:, :, 2:3], axis=2)
    usable = spread & np.all(np.isfinite(errors), axis=1)
    if not usable.any():
        return None, np.inf
    statistic = np.partition(np.where(usable[:, None], errors, np.inf), h - 1, axis=1)[:, h - 1]
    best = int(np.argmin(np.where(usable, statistic, np.inf)))
    return candidates[best], float(statistic[best])


def robust_dlt(points: np.ndarray, pixels: np.ndarray, trials: int = 300, seed: int = 0,
               threshold_px: float = 3.0) -> DltResult:
    """DLT that one or two gross errors cannot spoil.

    Up to 12 points: every subset that leaves out none, one or two points (keeping at least 7, so that
    each fit has redundancy) is fitted, and a point is left out only if that lowers the fit's standard
    deviation more than twofold (least trimmed squares). More points: least median of squares over random
    6-point subsets, judged by the h-th smallest error, h = (n + 7) // 2. Points whose error under the
    chosen solution exceeds max(threshold_px, 3 × its scale) are left out of the final fit
    (``inliers``).
    """
    from itertools import combinations

    points = np.asarray(points, dtype=np.float64)
    pixels = np.asarray(pixels, dtype=np.float64)
    check_spread(points)
    n = len(points)
    if n <= 7:
        return dlt(points, pixels)
    if n <= 12:
        everything = np.arange(n)
        _, best_sigma = _fit_sigma(points, pixels)
        best_keep = everything
        for leave in (1, 2):
            if n - leave < 7:
                break
            level_best, level_keep = np.inf, None
            for dropped in combinations(range(n), leave):
                keep = np.setdiff1d(everything, dropped)
                try:
                    check_spread(points[keep])
                    _, sigma = _fit_sigma(points[keep], pixels[keep])
                except (DegenerateGeometryError, np.linalg.LinAlgError):
                    continue
                if sigma < level_best:
                    level_best, level_keep = sigma, keep
            if level_keep is None or not level_best * 2.0 < best_sigma:
                break
            best_sigma, best_keep = level_best, level_keep
        matrix, _ = _fit_sigma(points[best_keep], pixels[best_keep])
        scale = best_sigma
    else:
        rng = np.random.default_rng(seed)
        h = (n + 7) // 2
        subsets = np.array([rng.choice(n, 6, replace=False) for _ in range(trials)]).reshape(trials, 6)
        try:
            if using_reference():
                raise np.linalg.LinAlgError("the reference path")
            matrix, best_statistic = _least_median_trials(points, pixels, subsets, h)
        except np.linalg.LinAlgError:  # an SVD of the stack did not converge: the trials one by one
            matrix, best_statistic = _least_median_loop(points, pixels, subsets, h)
        if matrix is None:
            return dlt(points, pixels)
        scale = 1.4826 * best_statistic
    errors = np.linalg.norm(pixels - reproject(matrix, points), axis=1)
    inliers = errors <= max(threshold_px, 3.0 * scale)
    try:
        if inliers.sum() < 7:
            raise DegenerateGeometryError("too few inliers")
        check_spread(points[inliers])
    except DegenerateGeometryError:
        return dlt(points, pixels)
    matrix = _solve_matrix(points[inliers], pixels[inliers])
    return decompose(matrix, points, pixels, inliers)


#: Rows of the image over which :func:`skew_effect` states the effect of a dropped skew (top, middle, bottom).
SKEW_BANDS = ("top", "middle", "bottom")


@dataclass(frozen=True)
class DltCamera:
    """A camera read from 11 DLT coefficients: the pinhole ``interior`` (f, xp, yp, sy; no distortion — the
    11-parameter DLT has none) and ``exterior`` in the DLT's object frame, and the ``skew`` (pixels) of its
    camera matrix, which USVIPS's interior does not hold (:func:`skew_effect` states what dropping it does)."""

    f: float
    xp: float
    yp: float
    sy: float
    skew: float
    exterior: Exterior

    @property
    def fy(self) -> float:
        """The focal length in y pixels (f / sy)."""
        return self.f / self.sy


def matrix_from_coefficients(coefficients: np.ndarray) -> np.ndarray:
    """The 3 × 4 projection of 11 DLT coefficients L1…L11 (L12 = 1): u = (L1 X + L2 Y + L3 Z + L4) / (L9 X +
    L10 Y + L11 Z + 1), v = (L5 X + L6 Y + L7 Z + L8) / (the same)."""
    values = np.asarray(coefficients, dtype=np.float64).ravel()
    if values.size != 11 or not np.all(np.isfinite(values)):
        raise DegenerateGeometryError(f"a DLT camera has 11 finite coefficients, got {values.size}")
    return np.append(values, 1.0).reshape(3, 4)


def camera_from_matrix(matrix: np.ndarray, what: str = "the camera") -> DltCamera:
    """Decompose a 3 × 4 projection (pixels: x right, y down) into USVIPS's interior, exterior and the skew.

    The sign of the matrix is chosen for a proper rotation with positive focal lengths. The object frame's
    origin must then lie in front of the camera (DLT frames put it among the points calibrated): behind it
    means a mirrored projection (an image whose y axis points up read as pointing down), refused by name, as
    is a singular one."""
    matrix = np.asarray(matrix, dtype=np.float64)
    left = matrix[:, :3]
    determinant = float(np.linalg.det(left))
    if not np.isfinite(determinant) or abs(determinant) < 1e-300 * max(np.abs(left).max(), 1.0):
        raise DegenerateGeometryError(f"{what}: the DLT coefficients are singular (no camera centre)")
    if determinant < 0:
        matrix, left = -matrix, -left
    if matrix[2, 3] <= 0:
        raise DegenerateGeometryError(f"{what}: the DLT coefficients put the object frame's origin behind the "
                                      "camera, a mirrored image (is the image's y axis up, the origin at the bottom "
                                      "left?)")
    centre = -np.linalg.solve(left, matrix[:, 3])
    from scipy.linalg import rq  # deferred: scipy.linalg is slow to import

    k, r = rq(left)
    signs = np.diag(np.sign(np.diag(k)))
    k, r = k @ signs, signs @ r
    k = k / k[2, 2]
    omega, phi, kappa = angles_from_matrix(FLIP @ r)
    fx, fy = float(k[0, 0]), float(k[1, 1])
    return DltCamera(fx, float(k[0, 2]), float(k[1, 2]), fx / fy, float(k[0, 1]), Exterior(*centre, omega, phi, kappa))


def skew_effect(camera: DltCamera, height: float | None = None) -> dict[str, float]:
    """What dropping ``camera``'s skew does to a pixel, per band of image rows (:data:`SKEW_BANDS`): the
    largest |Δx| in pixels in each third of the image's height (``height`` pixels, default 2 × yp). With the
    skew s the DLT puts a point at x = xp + f·x̄ + s·ȳ (ȳ = (y − yp) / fy, the normalised image y, down),
    the camera without it at s·ȳ less: the shift is along x, grows linearly with the distance from the
    principal point's row, and is the same along a row."""
    rows = float(height) if height else 2.0 * camera.yp
    edges = np.linspace(-0.5, rows - 0.5, len(SKEW_BANDS) + 1)
    out = {}
    for name, top, bottom in zip(SKEW_BANDS, edges[:-1], edges[1:], strict=True):
        farthest = max(abs(top - camera.yp), abs(bottom - camera.yp))
        out[name] = abs(camera.skew) * farthest / camera.fy
    return out
