"""Least-squares intersection of two or more rays per point, with covariance (thesis 2.4).

The thesis intersects by least squares on eq. 2.34, whose weights depend on each ray's direction
cosines. We minimise instead the image-space error that a pixel-measurement noise actually causes:
each ray's perpendicular miss of the point is weighted by the inverse of its covariance, which follows
from how the traced ray moves when its pixel moves (origin and direction both move behind a housing).
To first order this is the maximum-likelihood point for isotropic pixel noise of ``sigma_px``, and
its covariance is (Σ W_i)⁻¹. With equal weights it reduces to the classic midpoint solution.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from statistics import NormalDist

import numpy as np

from usvips.core import kernels, validation
from usvips.core.camera import Camera
from usvips.core.errors import DegenerateGeometryError, InvalidParameterError
from usvips.core.rays import RayBundle, RayStatus, require_all_ok

#: the chance that a point whose picks are right (pixel errors normal with the stated pointing sigma) is
#: still said to miss by :func:`misfit_limit`: one point in ten thousand
MISFIT_SIGNIFICANCE = 1e-4


@dataclass(frozen=True)
class Intersection:
    """Intersected points and their quality.

    points (N, 3) metres; covariance (N, 3, 3) m² for the given pixel sigma; residuals_m (N, k) the
    perpendicular distance of the point from each ray (metres); residuals_px (N, k) the same expressed
    as an image-measurement error (pixels, first order); status (N,) :class:`RayStatus` (PARALLEL_RAYS,
    FAILED_RAY, DIVERGING_RAYS when the point lies behind a ray's origin). Rows that are not OK hold
    finite placeholders and must not be used.
    """

    points: np.ndarray
    covariance: np.ndarray
    residuals_m: np.ndarray
    residuals_px: np.ndarray
    status: np.ndarray

    @property
    def ok(self) -> np.ndarray:
        return self.status == RayStatus.OK

    @property
    def sigmas(self) -> np.ndarray:
        """Standard deviations sX, sY, sZ (N, 3), metres."""
        return np.sqrt(np.clip(np.einsum("nii->ni", self.covariance), 0.0, None))

    def require_ok(self) -> Intersection:
        require_all_ok(self.status, "point")
        return self

    @classmethod
    def gathered(cls, parts: list[tuple[np.ndarray, Intersection]], count: int) -> Intersection:
        """One intersection of ``count`` rows put together from ``parts``: (the rows' indices, the
        intersection of those rows), e.g. rows intersected at different stations; every row in one part."""
        arrays = {}
        for name in ("points", "covariance", "residuals_m", "residuals_px", "status"):
            template = getattr(parts[0][1], name)
            gathered = np.zeros((count, *template.shape[1:]), dtype=template.dtype)
            for rows, part in parts:
                gathered[rows] = getattr(part, name)
            arrays[name] = gathered
        return cls(**arrays)


def ray_misfit(residuals_px: np.ndarray, sigma_px: float | np.ndarray) -> np.ndarray:
    """Each point's misfit (N,): the sum over its rays of (residual / pointing sigma)², the residuals
    (N, k) in pixels as :class:`Intersection` gives them and ``sigma_px`` the picks' pointing sigma (px, one
    image coordinate; a scalar or (N,)). When the pixel errors are normal with that sigma it follows a
    chi-square distribution with 2k − 3 degrees of freedom (1 for a stereo pair: only the miss across the
    epipolar curve is seen); the calibration's own error is not in it, so a poor calibration shows here
    too."""
    residuals = np.asarray(residuals_px, dtype=np.float64)
    sigma = np.asarray(sigma_px, dtype=np.float64).reshape(-1)
    if not np.all(np.isfinite(sigma)) or np.any(sigma <= 0):
        raise InvalidParameterError("sigma_px", "a pointing sigma must be finite and > 0", label="pointing sigma")
    return np.sum(residuals ** 2, axis=1) / sigma ** 2


def misfit_limit(rays: int, significance: float = MISFIT_SIGNIFICANCE) -> float:
    """The misfit (:func:`ray_misfit`) beyond which a point of ``rays`` rays misses more than its pointing
    sigma explains: the chi-square quantile with 2·rays − 3 degrees of freedom exceeded by chance with
    probability ``significance``."""
    if rays < 2:
        raise InvalidParameterError("rays", f"a point needs at least 2 rays, got {rays}", label="rays")
    if rays == 2:  # a squared standard normal: no SciPy import in every worker of `usvips intersect`
        return NormalDist().inv_cdf(1.0 - significance / 2.0) ** 2
    from scipy.special import chdtri  # the chi-square's upper quantile

    return float(chdtri(2 * rays - 3, significance))


def _solve3(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Solve N symmetric 3×3 systems by the adjugate; returns x, inverse and a well-conditioned mask."""
    c00 = a[:, 1, 1] * a[:, 2, 2] - a[:, 1, 2] * a[:, 2, 1]
    c01 = a[:, 1, 2] * a[:, 2, 0] - a[:, 1, 0] * a[:, 2, 2]
    c02 = a[:, 1, 0] * a[:, 2, 1] - a[:, 1, 1] * a[:, 2, 0]
    c11 = a[:, 0, 0] * a[:, 2, 2] - a[:, 0, 2] * a[:, 2, 0]
    c12 = a[:, 0, 1] * a[:, 2, 0] - a[:, 0, 0] * a[:, 2, 1]
    c22 = a[:, 0, 0] * a[:, 1, 1] - a[:, 0, 1] * a[:, 1, 0]
    c10 = a[:, 0, 2] * a[:, 2, 1] - a[:, 0, 1] * a[:, 2, 2]
    c20 = a[:, 0, 1] * a[:, 1, 2] - a[:, 0, 2] * a[:, 1, 1]
    c21 = a[:, 0, 2] * a[:, 1, 0] - a[:, 0, 0] * a[:, 1, 2]
    det = a[:, 0, 0] * c00 + a[:, 0, 1] * c01 + a[:, 0, 2] * c02
    scale = np.einsum("nij,nij->n", a, a)
    good = np.abs(det) > 1e-12 * np.maximum(scale, 1e-300) ** 1.5
    safe = np.where(good, det, 1.0)
    inverse = np.empty_like(a)
    inverse[:, 0, 0], inverse[:, 0, 1], inverse[:, 0, 2] = c00, c10, c20
    inverse[:, 1, 0], inverse[:, 1, 1], inverse[:, 1, 2] = c01, c11, c21
    inverse[:, 2, 0], inverse[:, 2, 1], inverse[:, 2, 2] = c02, c12, c22
    inverse /= safe[:, None, None]
    inverse[~good] = 0.0
    x = np.einsum("nij,nj->ni", inverse, b)
    return x, inverse, good


def intersect_rays(origins: np.ndarray, directions: np.ndarray,
                   weights: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Least-squares point of k rays per point: origins, directions (N, k, 3) (directions unit).

    ``weights`` (N, k, 3, 3) are symmetric weight matrices of each ray's perpendicular miss (default:
    the projectors I − d dᵀ, i.e. the unweighted midpoint). Returns points (N, 3), the normal matrices'
    inverses (N, 3, 3) and a mask of well-conditioned (non-parallel) solutions.
    """
    if weights is None:
        weights = np.eye(3) - directions[..., :, None] * directions[..., None, :]
    normal = weights.sum(axis=1)
    rhs = np.einsum("nkij,nkj->ni", weights, origins)
    return _solve3(normal, rhs)


def _symmetric(xx, xy, xz, yy, yz, zz) -> np.ndarray:
    out = np.empty(xx.shape + (3, 3))
    out[..., 0, 0], out[..., 0, 1], out[..., 0, 2] = xx, xy, xz
    out[..., 1, 0], out[..., 1, 1], out[..., 1, 2] = xy, yy, yz
    out[..., 2, 0], out[..., 2, 1], out[..., 2, 2] = xz, yz, zz
    return out


def pixel_jacobian(direction: np.ndarray, d_origin: np.ndarray, d_direction: np.ndarray,
                    along: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Rows a0, a1 (N, 3) of ∂pixel/∂X for points ``along`` metres down each ray, and a validity mask.

    A pixel step moves the ray at that depth by B = (I − d dᵀ)(∂o/∂p + s ∂d/∂p) (3 × 2); the point's
    pixel then moves by A = (BᵀB)⁻¹Bᵀ per metre of the point's motion.
    """
    moved0 = d_origin[:, :, 0] + along[:, None] * d_direction[:, :, 0]
    moved1 = d_origin[:, :, 1] + along[:, None] * d_direction[:, :, 1]
    b0 = moved0 - _dot(direction, moved0)[:, None] * direction
    b1 = moved1 - _dot(direction, moved1)[:, None] * direction
    g00, g01, g11 = _dot(b0, b0), _dot(b0, b1), _dot(b1, b1)
    det = g00 * g11 - g01 * g01
    valid = det > 1e-30 * np.maximum(g00 * g11, 1e-300)
    det = np.where(valid, det, 1.0)
    a0 = (g11[:, None] * b0 - g01[:, None] * b1) / det[:, None]
    a1 = (g00[:, None] * b1 - g01[:, None] * b0) / det[:, None]
    return a0, a1, valid


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return a[:, 0] * b[:, 0] + a[:, 1] * b[:, 1] + a[:, 2] * b[:, 2]


@dataclass(frozen=True)
class TracedRays:
    """The object-space rays of N pixels of one camera, and how they move with the pixel.

    ``rays`` is the :class:`RayBundle` (metres, unit directions, a status per ray); ``d_origins`` and
    ``d_directions`` (N, 3, 2) their derivatives per pixel x (column 0) and y (column 1), metres per
    pixel and 1 per pixel. Tracing is most of an intersection's cost: a camera that did not change
    keeps its traced rays (e.g. while differentiating by the other camera's parameters).
    """

    camera: Camera
    pixels: np.ndarray
    rays: RayBundle
    d_origins: np.ndarray
    d_directions: np.ndarray


def trace(camera: Camera, pixels: np.ndarray, what: str = "pixels") -> TracedRays:
    """Trace observed pixels (N, 2) of ``camera`` for :func:`intersect_traced` (``what`` names them)."""
    pixels = validation.finite_array(what, pixels, 2)
    bundle, d_origins, d_directions = camera.rays_with_derivatives(pixels)
    return TracedRays(camera, pixels, bundle, d_origins, d_directions)


def retrace(traced: TracedRays, camera: Camera) -> TracedRays:
    """``traced`` itself when ``camera`` equals the camera it was traced with, else its pixels traced
    anew through ``camera``."""
    try:
        same = camera is traced.camera or bool(camera == traced.camera)
    except (ValueError, TypeError):  # a housing holding arrays does not compare by value
        same = False
    return traced if same else trace(camera, traced.pixels)


def intersect(cameras: Sequence[Camera], pixels: Sequence[np.ndarray], sigma_px: float | np.ndarray = 0.5
              ) -> Intersection:
    """Intersect conjugate pixels of two or more cameras (thesis 2.4) with covariance.

    cameras: k cameras; pixels: k arrays (N, 2) of observed pixel coordinates, row i of each the same
    object point; sigma_px: the standard deviation of one pixel coordinate (pixels), a scalar or one
    value per camera (k,) or per observation (N, k). Returns an :class:`Intersection` in metres.
    """
    if len(cameras) < 2 or len(cameras) != len(pixels):
        raise DegenerateGeometryError(
            f"intersection needs the pixels of at least two cameras, got {len(cameras)} cameras and "
            f"{len(pixels)} pixel sets")
    arrays = [validation.finite_array(f"pixels of camera {i}", p, 2) for i, p in enumerate(pixels)]
    n = arrays[0].shape[0]
    if any(a.shape[0] != n for a in arrays):
        raise InvalidParameterError("pixels", "every camera needs the same number of rows")
    sigma = _sigma(sigma_px, len(cameras), n)  # bad sigmas are named before any tracing
    if all(kernels.wanted(n, camera.housing.surfaces) for camera in cameras):
        # compiled, block by block: pixels to points and covariance with no per-ray arrays in between
        fused = kernels.intersect_pixels(cameras, arrays, _weights(sigma))
        if fused is not None:
            return Intersection(*fused)
    return intersect_traced([trace(camera, pix) for camera, pix in zip(cameras, arrays, strict=True)], sigma_px)


def _sigma(sigma_px: float | np.ndarray, k: int, n: int) -> np.ndarray:
    try:
        sigma = np.broadcast_to(np.asarray(sigma_px, dtype=np.float64).reshape(
            (1, k) if np.ndim(sigma_px) == 1 else np.shape(sigma_px)), (n, k))
    except ValueError:
        raise InvalidParameterError("sigma_px", f"must be a scalar, ({k},) or ({n}, {k})") from None
    if not np.all(np.isfinite(sigma)) or np.any(sigma <= 0):
        raise InvalidParameterError("sigma_px", "must be finite and > 0")
    return sigma


def _weights(sigma: np.ndarray) -> np.ndarray:
    """1/σ² (1/px²) of the (N, k) sigmas: one row when every point has the same (a broadcast scalar or
    (k,)), so that a batch of 10⁶ points does not write and read an (N, k) array of equal weights."""
    return 1.0 / (sigma[:1] if sigma.strides[0] == 0 else sigma) ** 2


def intersect_traced(traced: Sequence[TracedRays], sigma_px: float | np.ndarray = 0.5) -> Intersection:
    """:func:`intersect` of rays already traced by :func:`trace` (k cameras, N rows each)."""
    if len(traced) < 2:
        raise DegenerateGeometryError(f"intersection needs the rays of at least two cameras, got {len(traced)}")
    n = len(traced[0].rays)
    if any(len(t.rays) != n for t in traced):
        raise InvalidParameterError("pixels", "every camera needs the same number of rows")
    sigma = _sigma(sigma_px, len(traced), n)
    if kernels.wanted(n):
        return Intersection(*kernels.intersect_rays(
            tuple(t.rays.origins for t in traced), tuple(t.rays.directions for t in traced),
            tuple(t.d_origins for t in traced), tuple(t.d_directions for t in traced),
            tuple(t.rays.ok for t in traced), _weights(sigma)))
    return _intersect_reference(traced, sigma)


def _intersect_reference(traced: Sequence[TracedRays], sigma: np.ndarray) -> Intersection:
    """The numpy path of :func:`intersect_traced` (the reference the compiled kernel is tested against)."""
    k, n = len(traced), len(traced[0].rays)
    status = np.zeros(n, dtype=np.uint8)
    rays = []
    for one in traced:
        bundle = one.rays
        status[(bundle.status != RayStatus.OK) & (status == RayStatus.OK)] = RayStatus.FAILED_RAY
        rays.append((bundle.origins, bundle.directions, one.d_origins, one.d_directions))

    # pass 1: the midpoint (equal weights), to know how far along each ray the point lies
    zero = np.zeros(n)
    acc = [zero.copy() for _ in range(6)]
    rhs = np.zeros((n, 3))
    for origin, direction, _, _ in rays:
        dx, dy, dz = direction[:, 0], direction[:, 1], direction[:, 2]
        parts = (1 - dx * dx, -dx * dy, -dx * dz, 1 - dy * dy, -dy * dz, 1 - dz * dz)
        for a, part in zip(acc, parts, strict=True):
            a += part
        rhs += origin - _dot(direction, origin)[:, None] * direction
    points, covariance, good = _solve3(_symmetric(*acc), rhs)
    # pass 2: weight each ray by how its pixel measures the point (the pixel Jacobian at the midpoint's
    # depth; the depth error of the midpoint changes these weights only to second order)
    for _ in range(1):
        acc = [zero.copy() for _ in range(6)]
        rhs = np.zeros((n, 3))
        jacobians = []
        for j, (origin, direction, d_origin, d_direction) in enumerate(rays):
            along = _dot(points - origin, direction)
            a0, a1, valid = pixel_jacobian(direction, d_origin, d_direction, along)
            good &= valid
            weight = 1.0 / sigma[:, j] ** 2
            parts = (a0[:, 0] * a0[:, 0] + a1[:, 0] * a1[:, 0], a0[:, 0] * a0[:, 1] + a1[:, 0] * a1[:, 1],
                     a0[:, 0] * a0[:, 2] + a1[:, 0] * a1[:, 2], a0[:, 1] * a0[:, 1] + a1[:, 1] * a1[:, 1],
                     a0[:, 1] * a0[:, 2] + a1[:, 1] * a1[:, 2], a0[:, 2] * a0[:, 2] + a1[:, 2] * a1[:, 2])
            for a, part in zip(acc, parts, strict=True):
                a += weight * part
            rhs += weight[:, None] * (_dot(a0, origin)[:, None] * a0 + _dot(a1, origin)[:, None] * a1)
            jacobians.append((a0, a1))
        points, covariance, solved = _solve3(_symmetric(*acc), rhs)
        good &= solved

    residuals_m = np.empty((n, k))
    residuals_px = np.empty((n, k))
    behind = np.zeros(n, dtype=bool)
    for j, ((origin, direction, _, _), (a0, a1)) in enumerate(zip(rays, jacobians, strict=True)):
        miss = points - origin
        along = _dot(miss, direction)
        behind |= along <= 0.0
        perpendicular = miss - along[:, None] * direction
        residuals_m[:, j] = np.sqrt(_dot(perpendicular, perpendicular))
        residuals_px[:, j] = np.hypot(_dot(a0, perpendicular), _dot(a1, perpendicular))
    status[~good & (status == RayStatus.OK)] = RayStatus.PARALLEL_RAYS
    status[behind & (status == RayStatus.OK)] = RayStatus.DIVERGING_RAYS
    bad = status != RayStatus.OK
    if np.any(bad):
        points[bad] = 0.0
        covariance[bad] = 0.0
        residuals_m[bad] = 0.0
        residuals_px[bad] = 0.0
    return Intersection(points, covariance, residuals_m, residuals_px, status)
