"""A camera: interior orientation ∘ housing ∘ exterior orientation.

``Camera.rays(pixels)`` traces observed pixels into object-space rays (thesis 2.2.4: eq. 2.14 to 2.27);
``Camera.project(points)`` back-projects object points to pixels through the housing by an iterative
solve. Both are vectorised over N rows, float64, metres and pixels.

Exterior orientation (X0, Y0, Z0, omega, phi, kappa): the perspective centre in object space (metres)
and the omega-phi-kappa angles (radians) of M, the object → image rotation (``rotation.py``).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from usvips.core import kernels, validation
from usvips.core.errors import DegenerateGeometryError, UsvipsError
from usvips.core.housing import AirHousing, GeneralHousing, Housing
from usvips.core.interior import Interior
from usvips.core.rays import RayBundle, RayStatus, require_all_ok
from usvips.core.rotation import rotation_matrix
from usvips.core.surfaces import Plane

EXTERIOR_PARAMETERS = ("X0", "Y0", "Z0", "omega", "phi", "kappa")

#: Back-projection stops when the pixel update is below this (pixels).
PROJECTION_TOLERANCE_PX = 1e-9


@dataclass(frozen=True)
class Exterior:
    """Perspective centre (X0, Y0, Z0) in metres and omega, phi, kappa in radians."""

    X0: float
    Y0: float
    Z0: float
    omega: float = 0.0
    phi: float = 0.0
    kappa: float = 0.0

    def __post_init__(self) -> None:
        for name in EXTERIOR_PARAMETERS:
            object.__setattr__(self, name, validation.finite(name, getattr(self, name)))

    @cached_property
    def rotation(self) -> np.ndarray:
        """M, object → image rotation (3, 3)."""
        return rotation_matrix(self.omega, self.phi, self.kappa)

    @property
    def position(self) -> np.ndarray:
        return np.array([self.X0, self.Y0, self.Z0])

    def to_camera(self, points: np.ndarray) -> np.ndarray:
        """Object points (N, 3) → camera frame: M · (P − X0)."""
        return _rotate(points - self.position, self.rotation.T)

    def to_object(self, points: np.ndarray) -> np.ndarray:
        """Camera-frame points (N, 3) → object space: X0 + Mᵀ · p."""
        out = _rotate(points, self.rotation)
        out += self.position
        return out

    def with_values(self, **changes: float) -> Exterior:
        values = {name: getattr(self, name) for name in EXTERIOR_PARAMETERS}
        values.update(changes)
        return Exterior(**values)


#: rows up to which :func:`_rotate` forms the nine products in one broadcast (a single pick, a tracked
#: point: the column loop's eighteen small ufunc calls cost ~40 µs for one row, the broadcast ~6 µs)
_FEW_ROWS = 64


def _rotate(vectors: np.ndarray, matrix: np.ndarray) -> np.ndarray:
    """vectors (N, 3) @ matrix (3, 3) as nine column products: a BLAS call for three columns costs more
    (and spins its threads) than the arithmetic. Few rows: the same products summed in the same order
    (x·m0 + y·m1, then + z·m2, so the same bits) in two ufunc calls."""
    if len(vectors) <= _FEW_ROWS:
        return (vectors[:, :, None] * matrix[None]).sum(axis=1)
    out = np.empty(vectors.shape)
    x, y, z = vectors[:, 0], vectors[:, 1], vectors[:, 2]
    for c in range(3):
        np.multiply(x, matrix[0, c], out=out[:, c])
        out[:, c] += y * matrix[1, c]
        out[:, c] += z * matrix[2, c]
    return out


@dataclass(frozen=True)
class Projection:
    """Back-projected pixels (N, 2) and a :class:`RayStatus` per point.

    Rows whose status is not OK hold the finite last iterate (or the pinhole guess) and must not be used.
    """

    pixels: np.ndarray
    status: np.ndarray

    @property
    def ok(self) -> np.ndarray:
        return self.status == RayStatus.OK

    def require_ok(self, what: str = "point") -> Projection:
        """Return self, or raise :class:`DegenerateGeometryError` naming the first point not visible."""
        require_all_ok(self.status, what)
        return self


@dataclass(frozen=True)
class Camera:
    """Interior + exterior orientation + housing; ``width``/``height`` (pixels) bound the frame if given."""

    interior: Interior
    exterior: Exterior
    housing: Housing = field(default_factory=AirHousing)
    width: int | None = None
    height: int | None = None

    # ---------------------------------------------------------------- pixel -> object-space ray
    def camera_rays(self, pixels: np.ndarray) -> RayBundle:
        """Trace pixels (N, 2) through the lens and housing; the result is in the camera frame."""
        pixels = validation.finite_array("pixels", pixels, 2)
        uv = self.interior.pixels_to_normalised(pixels)
        directions = np.column_stack([uv, -np.ones(len(uv))])
        return self.housing.trace(np.zeros_like(directions), directions)

    def rays_with_derivatives(self, pixels: np.ndarray) -> tuple[RayBundle, np.ndarray, np.ndarray]:
        """Object-space rays of pixels (N, 2) and how they move with the pixel.

        Returns the bundle and the derivatives of the origins and unit directions with respect to the
        pixel coordinates, each (N, 3, 2): column 0 per pixel of x, column 1 per pixel of y (metres per
        pixel and 1 per pixel). Exact (forward-mode through distortion and every refraction).
        """
        pixels = validation.finite_array("pixels", pixels, 2)
        if kernels.wanted(len(pixels), self.housing.surfaces):
            n = len(pixels)
            origins, directions = np.empty((n, 3)), np.empty((n, 3))
            d_origins, d_directions = np.empty((n, 3, 2)), np.empty((n, 3, 2))
            status, failed = np.empty(n, dtype=np.uint8), np.empty(n, dtype=np.int16)
            if kernels.trace_into(self, pixels, origins, directions, d_origins, d_directions, status, failed):
                return RayBundle(origins, directions, status, failed), d_origins, d_directions
        return self._rays_with_derivatives_reference(pixels)

    def _rays_with_derivatives_reference(self, pixels: np.ndarray) -> tuple[RayBundle, np.ndarray, np.ndarray]:
        """The numpy path of :meth:`rays_with_derivatives` (the reference the compiled kernel matches)."""
        return self.rays_with_derivatives_at_ideal(self.interior.pixels_to_normalised(pixels))

    def rays_with_derivatives_at_ideal(self, uv: np.ndarray) -> tuple[RayBundle, np.ndarray, np.ndarray]:
        """:meth:`rays_with_derivatives` of the pixels whose ideal normalised coordinates are ``uv`` (N, 2),
        without undistorting them: also where a pixel lies beyond the fold of the lens distortion (two ideal
        directions give it, and :meth:`Interior.undistort` refuses it), as a projection can compute one
        (:meth:`ideal_of_points` gives its ``uv``). The derivatives per pixel use the distortion's local
        inverse there (its Jacobian's determinant is not zero)."""
        interior = self.interior
        uv = np.asarray(uv, dtype=np.float64)
        jac = interior.distortion_jacobian(uv) if interior.has_distortion else None
        directions = np.column_stack([uv, -np.ones(len(uv))])
        tangents = []
        for column, scale in ((0, 1.0 / interior.f), (1, -interior.sy / interior.f)):
            d_uv = np.zeros_like(uv)
            d_uv[:, column] = scale
            if jac is not None:  # d(uv)/d(uv_d) = J⁻¹
                det = jac[:, 0, 0] * jac[:, 1, 1] - jac[:, 0, 1] * jac[:, 1, 0]
                du = (jac[:, 1, 1] * d_uv[:, 0] - jac[:, 0, 1] * d_uv[:, 1]) / det
                dv = (-jac[:, 1, 0] * d_uv[:, 0] + jac[:, 0, 0] * d_uv[:, 1]) / det
                d_uv = np.column_stack([du, dv])
            d_direction = np.column_stack([d_uv, np.zeros(len(uv))])
            tangents.append((np.zeros_like(directions), d_direction))
        bundle, carried = self.housing.trace_with_tangents(np.zeros_like(directions), directions, tuple(tangents))
        m = self.exterior.rotation
        d_origins = np.stack([_rotate(do, m) for do, _ in carried], axis=2)
        d_directions = np.stack([_rotate(dd, m) for _, dd in carried], axis=2)
        world = RayBundle(self.exterior.to_object(bundle.origins), _rotate(bundle.directions, m),
                          bundle.status, bundle.failed_surface)
        return world, d_origins, d_directions

    def rays(self, pixels: np.ndarray) -> RayBundle:
        """Object-space rays (N) of observed pixels (N, 2): origin on the outer cover surface, unit
        direction in the water, with a status per ray (see :class:`RayBundle`)."""
        bundle = self.camera_rays(pixels)
        return RayBundle(self.exterior.to_object(bundle.origins), _rotate(bundle.directions, self.exterior.rotation),
                         bundle.status, bundle.failed_surface)

    # ---------------------------------------------------------------- object point -> pixel
    def project(self, points: np.ndarray, start_pixels: np.ndarray | None = None) -> Projection:
        """Back-project object points (N, 3) to observed pixels through the housing.

        Converges to far below 1e-6 px wherever the point is visible; ``start_pixels`` (N, 2), e.g. the
        answer for slightly different parameters, speeds up a non-axial housing's solve. Status per point:
        BEHIND_CAMERA (not in front of the housing), MISSED_SURFACE / TOTAL_INTERNAL_REFLECTION (no ray of
        the camera reaches it), NOT_CONVERGED, OUTSIDE_FRAME (when the frame size is known; also a point
        whose direction lies beyond the fold of the lens distortion, which folds its pixel back).
        """
        uv, status = self.ideal_of_points(points, start_pixels)
        pixels = self.interior.normalised_to_pixels(uv)
        if self.width is not None and self.height is not None:
            outside = (
                (pixels[:, 0] < -0.5) | (pixels[:, 0] > self.width - 0.5)
                | (pixels[:, 1] < -0.5) | (pixels[:, 1] > self.height - 0.5)
            )
            # a direction beyond the distortion's fold folds back to a pixel that may lie in the frame,
            # but the lens forms no such image: the point is outside what the camera sees
            outside |= self.interior.folded(uv)
            status[(status == RayStatus.OK) & outside] = RayStatus.OUTSIDE_FRAME
        return Projection(pixels, status)

    def ideal_of_points(self, points: np.ndarray, start_pixels: np.ndarray | None = None
                        ) -> tuple[np.ndarray, np.ndarray]:
        """The ideal normalised coordinates (N, 2) of the rays that reach object points (N, 3), and their
        :class:`RayStatus` codes: :meth:`project` before the lens (no frame, no fold check; ``start_pixels``
        as there)."""
        points = validation.finite_array("points", points, 3)
        local = self.exterior.to_camera(points)
        start = None
        # (a flat port's 1-D solve is cheaper from its own start than undistorting a warm one)
        if start_pixels is not None and len(start_pixels) == len(points) and not self.housing.is_planar_stack:
            start_pixels = np.asarray(start_pixels, dtype=np.float64)
            rows = np.all(np.isfinite(start_pixels), axis=1)
            if rows.any():
                start = np.full((len(points), 2), np.nan)
                try:
                    start[rows] = self.interior.pixels_to_normalised(start_pixels[rows])
                except UsvipsError:  # a start the distortion cannot invert: use the default start
                    start = None
        return _back_project(self.housing, local, start)

    def project_point(self, point) -> np.ndarray:
        """Pixel (2,) of one object point (X, Y, Z) in metres; raises :class:`DegenerateGeometryError`
        saying why when the point is not visible (behind the camera, unreachable, outside the frame)."""
        projection = self.project(validation.finite_vector("point", point, 3)[None, :])
        status = RayStatus(int(projection.status[0]))
        if status != RayStatus.OK:
            raise DegenerateGeometryError(f"point {tuple(float(v) for v in point)}: {status.reason}")
        return projection.pixels[0]

    def with_exterior(self, exterior: Exterior) -> Camera:
        return Camera(self.interior, exterior, self.housing, self.width, self.height)


# ---------------------------------------------------------------------------------------------------
# back-projection solvers (camera frame)
# ---------------------------------------------------------------------------------------------------

def _back_project(housing: Housing, local: np.ndarray,
                  start: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Ideal normalised coordinates (N, 2) of the rays that reach camera-frame points, and a status."""
    n = local.shape[0]
    status = np.zeros(n, dtype=np.uint8)
    in_front = local[:, 2] < 0.0
    safe_z = np.where(in_front, local[:, 2], -1.0)
    uv = -local[:, :2] / safe_z[:, None]  # pinhole direction: the answer in air, the start otherwise
    status[~in_front] = RayStatus.BEHIND_CAMERA
    if not housing.is_refractive and not housing.surfaces:
        return uv, status
    live = np.flatnonzero(in_front)
    if live.size == 0:
        return uv, status
    if housing.is_planar_stack:
        solved, sub_status = _back_project_planar(housing, local[live])
    elif housing.axis is not None and start is None:
        solved, sub_status = _back_project_axial(housing, local[live])
    else:
        warm = start[live] if start is not None else None
        if kernels.wanted(live.size, housing.surfaces):
            solved, sub_status = kernels.back_project_general(housing, local[live], uv[live], warm,
                                                              _outer_plane_start(housing))
        else:
            solved, sub_status = _back_project_general(housing, local[live], uv[live], warm)
    uv[live] = solved
    status[live] = sub_status
    return uv, status


def _final_segment_check(housing: Housing, uv: np.ndarray, points: np.ndarray,
                         status: np.ndarray) -> np.ndarray:
    """Mark points that the solved ray reaches only backwards (inside the housing) or not at all."""
    directions = np.column_stack([uv, -np.ones(len(uv))])
    bundle = housing.trace(np.zeros_like(directions), directions)
    out = status.copy()
    failed = (bundle.status != RayStatus.OK) & (out == RayStatus.OK)
    out[failed] = bundle.status[failed]
    along = np.einsum("ij,ij->i", points - bundle.origins, bundle.directions)
    out[(out == RayStatus.OK) & (along <= 0.0)] = RayStatus.BEHIND_CAMERA
    return out


def _back_project_planar(housing: Housing, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Parallel planes about an axis through the perspective centre: a 1-D Newton solve in the plane of
    refraction with the closed-form radial offset (n_i sin θ_i is the same in every medium)."""
    planes = housing.surfaces
    axis = housing.axis
    indices = np.asarray(housing.indices)
    # distances along the axis from the centre to each plane (plane: n·p + h = 0, n = ±axis)
    distances = np.array([-p.offset * float(p.normal @ axis) for p in planes])
    if np.any(distances <= 0.0) or np.any(np.diff(distances) <= 0.0):
        # planes behind the camera or out of order: let the general solver say what happens
        return _back_project_general(housing, points, -points[:, :2] / points[:, 2:3])
    if kernels.wanted(len(points), planes):  # the compiled per-point solve (core/kernels.py)
        return kernels.back_project_planar(points, axis, distances, indices)
    thickness = np.diff(np.concatenate([[0.0], distances]))  # air gap, then each glass layer
    depth = points @ axis
    radial_vec = points - depth[:, None] * axis
    radial = np.linalg.norm(radial_vec, axis=1)
    status = np.zeros(len(points), dtype=np.uint8)
    beyond = depth > distances[-1]
    status[~beyond] = RayStatus.BEHIND_CAMERA
    water = np.where(beyond, depth - distances[-1], 1.0)
    # unknown: q = n1·sin θ1 (the invariant); layer i has sin θ = q / n_i
    layers_n = indices[:-1]  # media before each plane: n1, n2, ...
    n_water = indices[-1]
    q_max = min(indices.min(), n_water) * (1.0 - 1e-15)
    # start from a pinhole-like guess in water
    q = np.minimum(n_water * np.sin(np.arctan2(radial, depth)), 0.999 * q_max)
    for _ in range(60):
        # radial offset at the point's depth as a function of q, and its derivative
        total = -radial
        slope = np.zeros_like(q)
        for width, n_layer in zip([*thickness, water], [*layers_n, n_water], strict=True):
            s = q / n_layer
            inv_c = 1.0 / np.sqrt(1.0 - s * s)
            tan = s * inv_c
            total = total + width * tan
            slope = slope + (width / n_layer) * inv_c * inv_c * inv_c
        step = total / slope
        new_q = np.clip(q - step, 0.0, q_max)
        new_q = np.where(new_q >= q_max, 0.5 * (q + q_max), new_q)
        change = float(np.max(np.abs(new_q - q)))
        q = new_q
        if change < 1e-14:
            break
    unconverged = np.abs(step) * slope > 1e-9 * np.maximum(1.0, radial)
    status[unconverged & (status == RayStatus.OK)] = RayStatus.NOT_CONVERGED
    sin1 = q / indices[0]
    cos1 = np.sqrt(1.0 - sin1 * sin1)
    safe_radial = np.where(radial > 0, radial, 1.0)
    e_r = np.where((radial > 0)[:, None], radial_vec / safe_radial[:, None], 0.0)
    direction = cos1[:, None] * axis + sin1[:, None] * e_r
    status[(direction[:, 2] >= 0.0) & (status == RayStatus.OK)] = RayStatus.BEHIND_CAMERA
    dz = np.where(direction[:, 2] < 0, direction[:, 2], -1.0)
    uv = -direction[:, :2] / dz[:, None]
    # q stays below every index, so no layer reflects totally, and every plane lies ahead along the
    # axis: the solved ray reaches the point without a further trace
    return uv, status


def _in_plane_miss(housing: Housing, axis: np.ndarray, e_r: np.ndarray, points: np.ndarray,
                   theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Signed perpendicular distance (metres) of each point from the ray traced at angle θ (radians) from
    the axis in the plane of refraction (spanned by the axis and e_r), and the trace's status.

    The perpendicular distance is well conditioned for every θ in [0, π], also where the ray runs square
    to the axis (a dome port decentred across its axis looks sideways along it)."""
    directions = np.cos(theta)[:, None] * axis + np.sin(theta)[:, None] * e_r
    bundle = housing.trace(np.zeros_like(directions), directions)
    w = points - bundle.origins
    # 2-D cross product in the plane: (w · axis)(d · e_r) − (w · e_r)(d · axis)
    miss = (w @ axis) * np.einsum("ij,ij->i", bundle.directions, e_r) - \
        np.einsum("ij,ij->i", w, e_r) * (bundle.directions @ axis)
    return miss, bundle.status


def _back_project_axial(housing: Housing, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rotationally symmetric housing: secant iteration on the ray's angle θ from the axis (radians, the
    full range 0 to π), in the plane that holds the axis and the point.

    The axis points out of the camera but need not be its optical axis: a dome port decentred sideways
    has its axis across the view, and points on the far side lie more than 90° from it."""
    axis = housing.axis
    depth = points @ axis
    radial_vec = points - depth[:, None] * axis
    radial = np.linalg.norm(radial_vec, axis=1)
    safe_radial = np.where(radial > 0, radial, 1.0)
    e_r = np.where((radial > 0)[:, None], radial_vec / safe_radial[:, None],
                   np.array([1.0, 0.0, 0.0]) - axis[0] * axis)
    e_r /= np.linalg.norm(e_r, axis=1, keepdims=True)
    largest = np.pi - 1e-9
    theta0 = np.arctan2(radial, depth)
    f0, status0 = _in_plane_miss(housing, axis, e_r, points, theta0)
    for _ in range(40):  # a start whose ray fails (reflects totally, misses): move it towards the axis
        failed = status0 != RayStatus.OK
        if not failed.any():
            break
        theta0 = np.where(failed, 0.5 * theta0, theta0)
        f0, status0 = _in_plane_miss(housing, axis, e_r, points, theta0)
    theta1 = np.clip(theta0 * 0.98 + 1e-9, 0.0, largest)
    f1, status1 = _in_plane_miss(housing, axis, e_r, points, theta1)
    # a secant step whose ray fails is halved until it does not; ``refused`` keeps why the latest failed
    damping = np.where(status1 == RayStatus.OK, 1.0, 0.5)
    refused = status1.astype(np.uint8)
    theta1 = np.where(status1 == RayStatus.OK, theta1, theta0)
    f1 = np.where(status1 == RayStatus.OK, f1, f0)
    for _ in range(80):
        denominator = f1 - f0
        usable = np.abs(denominator) > 1e-300
        safe = np.where(usable, denominator, 1e-300)
        step = np.where(usable, -f1 * (theta1 - theta0) / safe, 0.0)
        theta2 = np.clip(theta1 + damping * step, 0.0, largest)
        f2, status2 = _in_plane_miss(housing, axis, e_r, points, theta2)
        good = status2 == RayStatus.OK
        if good.all():  # the usual case: every ray got through
            moved = np.abs(theta2 - theta1)
            theta0, f0, theta1, f1 = theta1, f1, theta2, f2
            damping[:] = 1.0
            if np.all(moved < 1e-15):
                break
            continue
        moved = np.where(good, np.abs(theta2 - theta1), 0.0)
        theta0, f0 = np.where(good, theta1, theta0), np.where(good, f1, f0)
        theta1, f1 = np.where(good, theta2, theta1), np.where(good, f2, f1)
        damping = np.where(good, 1.0, 0.5 * damping)
        refused = np.where(good, refused, status2).astype(np.uint8)
        if np.all((moved < 1e-15) & (good | (damping < 1e-12))):
            break
    status1 = np.where(status0 == RayStatus.OK, RayStatus.OK, status0)
    status = status1.astype(np.uint8)
    direction = np.cos(theta1)[:, None] * axis + np.sin(theta1)[:, None] * e_r
    dz = np.where(direction[:, 2] < 0, direction[:, 2], -1.0)
    status[(direction[:, 2] >= 0.0) & (status == RayStatus.OK)] = RayStatus.BEHIND_CAMERA
    uv = -direction[:, :2] / dz[:, None]
    scale = np.maximum(1.0, np.linalg.norm(points, axis=1))
    missed = (np.abs(f1) > 1e-9 * scale) & (status == RayStatus.OK)
    # not reached: the ray that would reach the point fails (lies beyond the critical angle, say) where the
    # last step was refused, else the solve did not converge
    status[missed] = np.where(refused[missed] != RayStatus.OK, refused[missed], RayStatus.NOT_CONVERGED)
    return uv, _final_segment_check(housing, uv, points, status)


def _back_project_general(housing: Housing, points: np.ndarray, start: np.ndarray,
                          warm: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Any housing: Gauss–Newton on the normalised image coordinates (u, v) so that the traced ray
    passes through the point, with the exact Jacobian carried through the trace (forward mode).

    The start is the flat-port solution of the outer plane alone where the housing ends in a plane
    (it absorbs most of the bending), else the pinhole direction. A step that leads to a ray that fails
    (misses a surface, reflects totally) is halved until it does not."""
    uv = _proxy_start(housing, points, start)
    if warm is not None:
        usable = np.all(np.isfinite(warm), axis=1)
        uv[usable] = warm[usable]
    n = len(points)
    status = np.zeros(n, dtype=np.uint8)
    last_good = np.full((n, 2), np.nan)
    last_step = np.zeros((n, 2))
    halvings = np.zeros(n, dtype=np.int16)
    active = np.arange(n)
    for _ in range(80):
        if active.size == 0:
            break
        m = active.size
        zero = np.zeros((m, 3))
        unit_u, unit_v = zero.copy(), zero.copy()
        unit_u[:, 0] = 1.0
        unit_v[:, 1] = 1.0
        current = uv[active]
        directions = np.column_stack([current, -np.ones(m)])
        bundle, carried = housing.trace_with_tangents(zero, directions, ((zero, unit_u), (zero, unit_v)))
        traced = bundle.status == RayStatus.OK
        # rays that failed: back off half-way towards the last good iterate, or give up
        failed = np.flatnonzero(~traced)
        if failed.size:
            idx = active[failed]
            can_retry = np.isfinite(last_good[idx, 0]) & (halvings[idx] < 40)
            first = np.isnan(last_good[idx, 0]) & (halvings[idx] == 0)
            retry = idx[can_retry]
            last_step[retry] *= 0.5
            uv[retry] = last_good[retry] + last_step[retry]
            halvings[retry] += 1
            restart = idx[first]            # a failing start: fall back to the pinhole direction once
            uv[restart] = start[restart]
            halvings[restart] = 1
            give_up = idx[~can_retry & ~first]
            status[give_up] = bundle.status[failed][~can_retry & ~first]
        p = points[active]
        w = p - bundle.origins
        along = _dot3(w, bundle.directions)
        miss = w - along[:, None] * bundle.directions
        columns = []
        for d_origin, d_direction in carried:
            d_along = -_dot3(d_origin, bundle.directions) + _dot3(w, d_direction)
            columns.append(-d_origin - d_along[:, None] * bundle.directions - along[:, None] * d_direction)
        ju, jv = columns
        a11, a12, a22 = _dot3(ju, ju), _dot3(ju, jv), _dot3(jv, jv)
        b1, b2 = _dot3(ju, miss), _dot3(jv, miss)
        det = a11 * a22 - a12 * a12
        ok_det = det > 1e-300
        safe = np.where(ok_det, det, 1.0)
        du = np.where(ok_det, -(a22 * b1 - a12 * b2) / safe, 0.0)
        dv = np.where(ok_det, -(a11 * b2 - a12 * b1) / safe, 0.0)
        good = np.flatnonzero(traced & ok_det)
        idx = active[good]
        last_good[idx] = uv[idx]
        last_step[idx, 0], last_step[idx, 1] = du[good], dv[good]
        halvings[idx] = 0
        uv[idx, 0] += du[good]
        uv[idx, 1] += dv[good]
        singular = active[traced & ~ok_det]
        status[singular] = RayStatus.NOT_CONVERGED
        # quadratic convergence: once a step is below 1e-10 (1e-7 px at f = 1000 px) the next would be
        # below 1e-18, so the iterate just updated is final
        converged = np.zeros(m, dtype=bool)
        converged[good] = np.maximum(np.abs(du[good]), np.abs(dv[good])) < 1e-10
        behind = converged & (along <= 0.0)
        status[active[behind]] = RayStatus.BEHIND_CAMERA
        active = active[~converged & (status[active] == RayStatus.OK)]
    status[active] = RayStatus.NOT_CONVERGED
    return uv, status


def _dot3(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return a[:, 0] * b[:, 0] + a[:, 1] * b[:, 1] + a[:, 2] * b[:, 2]


def _outer_plane_start(housing: Housing) -> Plane | None:
    """The outer plane whose exact air-to-water solve starts the non-axial back-projection, or None for
    the pinhole start.

    A stack of planes bends a ray, far from the camera, as air straight to water would: the outer plane
    alone is then a close start. A housing with a sphere (a dome cover) is built to keep rays near the
    pinhole direction, and the plane alone overshoots: for the bench's non-axial dome cover the pinhole
    start is 0.02 from the solution (normalised units, median) and the plane's 0.18 (0.05 with the
    glass's index). Only a plane in front of the camera qualifies."""
    surfaces = housing.surfaces
    if not surfaces or not all(isinstance(s, Plane) for s in surfaces):
        return None
    outer = surfaces[-1]
    proxy = GeneralHousing((outer,), (housing.indices[0], housing.indices[-1]))
    if not proxy.is_planar_stack or (proxy.surfaces[0].offset * (proxy.surfaces[0].normal @ proxy.axis)) >= 0:
        return None
    return outer


def _proxy_start(housing: Housing, points: np.ndarray, start: np.ndarray) -> np.ndarray:
    """A starting (u, v): the exact solution through the outer plane alone (air straight to water) where
    :func:`_outer_plane_start` says so, else the pinhole direction ``start``."""
    outer = _outer_plane_start(housing)
    if outer is None:
        return start.copy()
    proxy = GeneralHousing((outer,), (housing.indices[0], housing.indices[-1]))
    uv, status = _back_project_planar(proxy, points)
    return np.where((status == RayStatus.OK)[:, None], uv, start)
