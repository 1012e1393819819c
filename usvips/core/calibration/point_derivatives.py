"""How an intersected point moves with the calibration's parameters, for many points at once.

The point X of k traced rays is the weighted least-squares point of ``intersection.py``: it minimises
Σ_j |A_j (X − Q_j)|² / σ_j², A_j (2 × 3) the pixel Jacobian of ray j at the point's depth (how its pixel
measures a motion of the point square to the ray), Q_j on the ray. When a parameter moves ray j by m_j at
the point's depth (metres per parameter unit), the implicit-function theorem on that minimum gives

    ∂X/∂θ = C Σ_j A_jᵀ (A_j m_j) / σ_j²,        C = (Σ_j A_jᵀ A_j / σ_j²)⁻¹

(C the pointing covariance the intersection reports). It is the first-order derivative, as the pointing
covariance is the first-order covariance: the terms in the rays' residual misses are left out. They vanish
for consistent pixels; for noisy ones they are what the difference of two noisy intersections adds (on
nearly parallel rays a skew of the rays moves their closest approach along them: ~10 % of a column at
0.5 px of noise), a property of the realised noise, not of the calibration's error.

A_j m_j is the pixel motion equivalent to the ray's motion, and each kind of
parameter gives it in closed form from the rays traced once with their pixel derivatives:

* a camera's **pose** moves its rays rigidly: m = (Q − C_b) ∂(M_bᵀ M)/∂θ + ∂C/∂θ (object vectors are rows,
  v = v_camera · M; M the object → image rotation, C the perspective centre);
* an **interior** parameter (principal distance, principal point, y scale, distortion) changes which ideal
  normalised coordinate u the camera reads at a pixel, which is what the same camera reads at a shifted
  pixel: Δp = (∂x_d/∂p)⁻¹ (∂x_d/∂θ − ∂D/∂θ(u)), with x_d the distorted normalised coordinates of the pixel
  (affine in the pixel) and D the lens distortion (linear in its coefficients); then A m = Δp exactly;
* a **housing** parameter is differenced: the ideal rays of the pixels (the lens does not move) traced
  through the housing built at θ ± h (every housing kind alike; compiled, without derivatives, where the
  kernels trace the kind's surfaces).

The cameras' derivatives by each parameter (∂M/∂θ, ∂C/∂θ, ∂x_d/∂θ, ∂D/∂θ, the two housings) come from
the cameras the calibration's named values build at θ ± h (:class:`CameraMotion`): a pose or interior value
enters them linearly or smoothly, so their central differences are exact to O(h²), and they are built once
per calibration. Every per-point step is a vectorised array operation over all points; the pose and
housing columns' pixel motions are one compiled pass over the points for large batches
(:mod:`usvips.core.kernels`, numpy the reference).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from usvips.core import kernels
from usvips.core.camera import Camera
from usvips.core.interior import Interior
from usvips.core.intersection import TracedRays, pixel_jacobian
from usvips.core.rays import RayBundle


@dataclass(frozen=True)
class CameraMotion:
    """How one parameter moves one camera, per unit of the parameter (central differences of the cameras
    the values build at θ ± h, over ``span`` = 2h; h at a bound of the valid region). ``turn`` (3, 3) is
    M_bᵀ ∂M/∂θ and ``shift`` (3,) ∂C/∂θ (None: the pose does not move); ``interiors`` the two interiors
    (None: the interior does not move); ``housings`` the camera the rays were traced with, carrying each of
    the two housings (None: the housing does not move)."""

    turn: np.ndarray | None
    shift: np.ndarray | None
    interiors: tuple[Interior, Interior] | None
    housings: tuple[Camera, Camera] | None
    span: float

    @property
    def moves(self) -> bool:
        return self.turn is not None or self.interiors is not None or self.housings is not None


def camera_motion(base: Camera, minus: Camera, plus: Camera, span: float) -> CameraMotion:
    """How a parameter moves ``base`` (the camera the picks are traced with) from the cameras ``minus`` and
    ``plus`` it builds at θ ∓ h, ``span`` apart (parameter units)."""
    turn = shift = interiors = housings = None
    if minus.exterior != plus.exterior:
        turn = base.exterior.rotation.T @ (plus.exterior.rotation - minus.exterior.rotation) / span
        shift = (plus.exterior.position - minus.exterior.position) / span
    if minus.interior != plus.interior:
        interiors = (minus.interior, plus.interior)
    if not _equal(minus.housing, plus.housing):
        housings = (replace(base, housing=minus.housing), replace(base, housing=plus.housing))
    return CameraMotion(turn, shift, interiors, housings, span)


def _equal(one, other) -> bool:
    try:
        return one is other or bool(one == other)
    except (ValueError, TypeError):  # a housing holding arrays does not compare by value
        return False


def housing_rays(rays: TracedRays, motions: list[CameraMotion], ideal: np.ndarray
                 ) -> dict[int, tuple[RayBundle, RayBundle]]:
    """The rays of the ``ideal`` normalised coordinates (N, 2) of the pixels of ``rays`` through the camera
    with each moved housing of ``motions`` (by position in the list): (rays at θ − h, rays at θ + h)."""
    return {k: tuple(ideal_rays(camera, ideal) for camera in motion.housings)
            for k, motion in enumerate(motions) if motion.housings is not None}


def ideal_rays(camera: Camera, ideal: np.ndarray) -> RayBundle:
    """Object-space rays of ideal normalised coordinates (N, 2): the camera-frame rays (u, v, −1) through
    ``camera``'s housing (what :meth:`Camera.rays` gives for the pixels the lens maps there)."""
    if kernels.wanted(len(ideal), camera.housing.surfaces):
        return RayBundle(*kernels.trace_ideal(camera, ideal))
    directions = np.column_stack([ideal, -np.ones(len(ideal))])
    bundle = camera.housing.trace(np.zeros_like(directions), directions)
    exterior = camera.exterior
    return RayBundle(exterior.to_object(bundle.origins), bundle.directions @ exterior.rotation, bundle.status,
                     bundle.failed_surface)


def point_jacobian(traced: list[TracedRays], points: np.ndarray, covariance: np.ndarray, weights: np.ndarray,
                   motions: list[list[tuple[int, CameraMotion]]], count: int,
                   housings: list[dict[int, tuple[RayBundle, RayBundle]]] | None = None,
                   ideal: list[np.ndarray | None] | None = None) -> np.ndarray:
    """∂X/∂θ (N, 3, count) of N intersected ``points`` (metres per parameter unit) whose rays ``traced``
    (one TracedRays per camera) were intersected with pointing ``covariance`` (N, 3, 3) and ``weights``
    (N, k) 1/σ² (1/px²). ``motions[j]`` lists (column, motion) of the parameters that move camera j;
    ``housings[j]`` the rays of its moved housings (:func:`housing_rays` of the same rows; traced here when
    None), ``ideal[j]`` the ideal normalised coordinates of its pixels (or None: found here when needed).
    A column whose stepped housing loses a point's ray is zero in that point's row. Every row must
    be an intersected point (status OK)."""
    n = len(points)
    jacobian = np.zeros((n, 3, count))
    for j, rays in enumerate(traced):
        if not motions[j]:
            continue
        origins, directions = rays.rays.origins, rays.rays.directions
        along = np.einsum("ni,ni->n", points - origins, directions)
        a0, a1, _ = pixel_jacobian(directions, rays.d_origins, rays.d_directions, along)
        rows = np.stack([a0, a1], axis=1)  # A (N, 2, 3)
        columns = [c for c, _ in motions[j]]
        moving = [m for _, m in motions[j]]
        known = None if ideal is None else ideal[j]
        if housings is None:
            if known is None and any(m.housings is not None for m in moving):
                known = rays.camera.interior.pixels_to_normalised(rays.pixels)
            stepped = housing_rays(rays, moving, known)
        else:
            stepped = housings[j]
        shifts = pixel_motions(rays, rows, along, moving, stepped, known)
        # C Aᵀ / σ² (N, 3, 2): the point's motion per pixel of this camera
        gain = np.stack([np.einsum("nij,nj->ni", covariance, a0), np.einsum("nij,nj->ni", covariance, a1)], axis=2)
        gain *= weights[:, j, None, None]
        if columns == list(range(columns[0], columns[0] + len(columns))):  # a slice: no gather and scatter
            jacobian[:, :, columns[0]:columns[0] + len(columns)] += np.matmul(gain, shifts)
        else:
            jacobian[:, :, columns] += np.matmul(gain, shifts)
    return jacobian


def pixel_motions(rays: TracedRays, rows: np.ndarray, along: np.ndarray, motions: list[CameraMotion],
                  housings: dict[int, tuple[RayBundle, RayBundle]], ideal: np.ndarray | None = None) -> np.ndarray:
    """(N, 2, m): for each of ``motions`` the pixel motion A m equivalent to the motion of the rays at the
    points' depths ``along`` (metres), A = ``rows`` (N, 2, 3) the rays' pixel Jacobians (px per metre);
    ``housings`` the rays through the moved housings (:func:`housing_rays`); ``ideal`` the pixels' ideal
    normalised coordinates if known."""
    n = len(along)
    out = np.zeros((n, 2, len(motions)))
    posed = [k for k, m in enumerate(motions) if m.turn is not None]
    compiled = kernels.wanted(n)
    if posed and compiled:  # one pass over the points, no temporaries (the numpy below is the reference)
        kernels.add_pose_shifts(rows, rays.rays.origins, rays.rays.directions, along, rays.camera.exterior.position,
                                np.stack([motions[k].turn for k in posed]), np.stack([motions[k].shift for k in posed]),
                                posed, out)
    elif posed:  # rigid: A m = A ((Q − C_b) T + c) for every pose column at once, as one matrix product
        on_ray = rays.rays.origins + along[:, None] * rays.rays.directions
        on_ray -= rays.camera.exterior.position
        # per point the products A_ci (Q − C_b)_k and A_ci (2 × 12), times the constant (12 × E) of T, c
        constant = np.concatenate([np.stack([motions[k].turn for k in posed], axis=2).reshape(9, len(posed)),
                                   np.stack([motions[k].shift for k in posed], axis=1)])
        products = np.empty((n, 2, 4, 3))
        np.multiply(rows[:, :, None, :], on_ray[:, None, :, None], out=products[:, :, :3])
        products[:, :, 3] = rows
        out[:, :, posed] += (products.reshape(2 * n, 12) @ constant).reshape(n, 2, len(posed))
    read = [k for k, m in enumerate(motions) if m.interiors is not None]
    if read:
        _add_interior_shifts(out, rays.camera.interior, rays.pixels, [(k, motions[k]) for k in read], ideal)
    for k, (minus, plus) in housings.items():
        if compiled:
            kernels.add_housing_shift(rows, along, minus, plus, motions[k].span, k, out)
            continue
        moved = plus.directions - minus.directions
        moved *= along[:, None]
        moved += plus.origins
        moved -= minus.origins
        shift = np.einsum("nci,ni->nc", rows, moved)
        lost = (plus.status != 0) | (minus.status != 0)
        if lost.any():
            shift[lost] = 0.0
        out[:, :, k] += shift / motions[k].span
    return out


def _add_interior_shifts(out: np.ndarray, base: Interior, pixels: np.ndarray,
                         read: list[tuple[int, CameraMotion]], ideal: np.ndarray | None) -> None:
    """Add to ``out`` (N, 2, m) the pixel shifts Δp = (∂x_d/∂p)⁻¹ (∂x_d/∂θ − ∂D/∂θ(u)) of the interior
    motions ``read`` (column k, motion): what the camera reads at p with θ stepped it reads at p + Δp·h;
    ``ideal`` the pixels' ideal normalised coordinates u (found here when None and needed)."""
    for k, motion in read:
        minus, plus = motion.interiors
        change = np.zeros((len(pixels), 2))
        if any(getattr(minus, name) != getattr(plus, name) for name in ("f", "xp", "yp", "sy")):
            change += plus.pixels_to_image(pixels) / plus.f - minus.pixels_to_image(pixels) / minus.f
        if any(getattr(minus, name) != getattr(plus, name) for name in ("k1", "k2", "k3", "p1", "p2")):
            if ideal is None:
                ideal = base.pixels_to_normalised(pixels)
            change -= plus.distort(ideal) - minus.distort(ideal)
        out[:, 0, k] += change[:, 0] * (base.f / motion.span)
        out[:, 1, k] -= change[:, 1] * (base.f / (base.sy * motion.span))

