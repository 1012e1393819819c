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

import numpy as np

from usvips.core import validation
from usvips.core.camera import Camera
from usvips.core.errors import DegenerateGeometryError, InvalidParameterError
from usvips.core.rays import RayStatus, describe_status

#: Pixel step (pixels) of the forward differences that give each ray's sensitivity to its pixel.
SENSITIVITY_STEP_PX = 1e-3


@dataclass(frozen=True)
class Intersection:
    """Intersected points and their quality.

    points (N, 3) metres; covariance (N, 3, 3) m² for the given pixel sigma; residuals_m (N, k) the
    perpendicular distance of the point from each ray (metres); residuals_px (N, k) the same expressed
    as an image-measurement error (pixels, first order); status (N,) :class:`RayStatus` (PARALLEL_RAYS,
    FAILED_RAY, BEHIND_CAMERA when the point lies behind a ray's origin). Rows that are not OK hold
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
        bad = np.flatnonzero(~self.ok)
        if bad.size:
            first = int(bad[0])
            raise DegenerateGeometryError(
                f"point {first}: {RayStatus(int(self.status[first])).reason} ({describe_status(self.status)})")
        return self


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
    k = len(cameras)
    sigma = np.broadcast_to(np.asarray(sigma_px, dtype=np.float64).reshape(
        (1, k) if np.ndim(sigma_px) == 1 else np.shape(sigma_px)), (n, k))
    if not np.all(np.isfinite(sigma)) or np.any(sigma <= 0):
        raise InvalidParameterError("sigma_px", "must be finite and > 0")

    origins = np.empty((n, k, 3))
    directions = np.empty((n, k, 3))
    d_origin = np.empty((n, k, 3, 2))
    d_direction = np.empty((n, k, 3, 2))
    status = np.zeros(n, dtype=np.uint8)
    h = SENSITIVITY_STEP_PX
    for j, (camera, pix) in enumerate(zip(cameras, arrays, strict=True)):
        stacked = np.concatenate([pix, pix + [h, 0.0], pix + [0.0, h]])
        bundle = camera.rays(stacked)
        o0, ox, oy = np.split(bundle.origins, 3)
        d0, dx, dy = np.split(bundle.directions, 3)
        failed = np.any(np.stack(np.split(bundle.status, 3)) != RayStatus.OK, axis=0)
        status[failed & (status == RayStatus.OK)] = RayStatus.FAILED_RAY
        origins[:, j], directions[:, j] = o0, d0
        d_origin[:, j, :, 0], d_origin[:, j, :, 1] = (ox - o0) / h, (oy - o0) / h
        d_direction[:, j, :, 0], d_direction[:, j, :, 1] = (dx - d0) / h, (dy - d0) / h

    # pass 1: midpoint, to know how far along each ray the point lies
    points, _, good = intersect_rays(origins, directions)
    # pass 2: weight each ray by the inverse covariance of its perpendicular miss at that depth
    for _ in range(2):
        along = np.einsum("nkj,nkj->nk", points[:, None, :] - origins, directions)
        projector = np.eye(3) - directions[..., :, None] * directions[..., None, :]
        moved = d_origin + along[..., None, None] * d_direction                 # (n, k, 3, 2)
        b = np.einsum("nkij,nkjl->nkil", projector, moved)                       # perpendicular motion
        gram = np.einsum("nkil,nkim->nklm", b, b)                                 # (n, k, 2, 2)
        det = gram[..., 0, 0] * gram[..., 1, 1] - gram[..., 0, 1] * gram[..., 1, 0]
        det = np.where(np.abs(det) > 0, det, 1e-300)
        inv = np.empty_like(gram)
        inv[..., 0, 0], inv[..., 1, 1] = gram[..., 1, 1] / det, gram[..., 0, 0] / det
        inv[..., 0, 1] = inv[..., 1, 0] = -gram[..., 0, 1] / det
        inv2 = np.einsum("nkab,nkbc->nkac", inv, inv)
        weights = np.einsum("nkia,nkab,nkjb->nkij", b, inv2, b) / (sigma ** 2)[..., None, None]
        points, covariance, good = intersect_rays(origins, directions, weights)

    miss = points[:, None, :] - origins
    along = np.einsum("nkj,nkj->nk", miss, directions)
    perpendicular = miss - along[..., None] * directions
    residuals_m = np.linalg.norm(perpendicular, axis=2)
    residuals_px = np.sqrt(np.clip(np.einsum("nki,nkij,nkj->nk", perpendicular, weights, perpendicular),
                                   0.0, None)) * sigma
    status[~good & (status == RayStatus.OK)] = RayStatus.PARALLEL_RAYS
    status[np.any(along <= 0.0, axis=1) & (status == RayStatus.OK)] = RayStatus.BEHIND_CAMERA
    bad = status != RayStatus.OK
    if np.any(bad):
        points[bad] = 0.0
        covariance[bad] = 0.0
        residuals_m[bad] = 0.0
        residuals_px[bad] = 0.0
    return Intersection(points, covariance, residuals_m, residuals_px, status)
