"""Compiled kernels (numba) of the hot paths: the refractive trace with pixel derivatives, the weighted
intersection with covariance, and the back-projection through a housing.

Two kinds, both in ``_numba_kernels``. Block kernels (every stage one loop over a block of 256 rows,
which the compiler runs several rows at a time in SIMD registers) for the trace, the intersection (from
pixels: :func:`intersect_pixels`; from traced rays: :func:`intersect_rays`) and the non-axial
back-projection. Per-point kernels (a point at a time in scalars) for the flat port's back-projection
and the batch undistortion. A point at a time, the CPU waits on each ray's chain of dependent divisions,
square roots and Newton steps; blocks of independent rows hide that latency (the intersection became
about 4 × faster, see the README's speed section).

Two small per-point kernels add the pose and housing columns' pixel motions of the calibration's share of
a point's covariance (:func:`add_pose_shifts`, :func:`add_housing_shift`; the numpy of
``core/calibration/point_derivatives.pixel_motions`` is their reference): one pass over the points instead
of a dozen whole-array temporaries per column.

Each kernel does exactly what the vectorised numpy code does over whole arrays
(``Interior.undistort``, ``Housing.trace_with_tangents``, ``intersection.intersect``,
``camera._back_project_general``, ``camera._back_project_planar``); that numpy code stays the reference
the tests compare against (1e-9 m, covariances to 1e-9 relative, 1e-6 px, identical statuses, over
random cameras and housings). Conventions as there: camera frame with the camera looking along −z,
normalised coordinates (u, v) with the ray (u, v, −1), metres, pixels.

Only planes and spheres compile (every parametric housing); a housing with an implicit surface, or a
machine without numba, takes the numpy path. :func:`mode` chooses: ``"auto"`` (compiled for batches of
at least :data:`MIN_ROWS` rows, where it pays for loading the compiled code), ``"always"`` or
``"never"``. The mode is a context variable, not process state: a ``with mode(...)`` block sets it for
the thread (or asyncio task) that runs the block only, so two worker threads cannot switch each other's
mode, and a new thread starts in ``"auto"``. numba is imported only when a kernel first runs, so a window
that never intersects a batch does not pay for it.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from contextvars import ContextVar

import numpy as np

from usvips.core.surfaces import MIN_ADVANCE, Plane, Sphere

#: Batches smaller than this use the numpy path in ``"auto"`` mode (rows).
MIN_ROWS = 512

_MODES = ("auto", "always", "never")
#: The current mode of this thread / task (see :func:`mode`).
_mode: ContextVar[str] = ContextVar("usvips_kernel_mode", default="auto")
_compiled: dict[str, object] = {}

PLANE, SPHERE = 0, 1


@contextmanager
def mode(name: str) -> Iterator[None]:
    """Within the block, use the compiled kernels ``"always"``, ``"never"`` or ``"auto"`` (in this thread
    or task only; other threads keep their own mode)."""
    if name not in _MODES:
        raise ValueError(f"kernel mode must be one of {_MODES}, got {name!r}")
    token = _mode.set(name)
    try:
        yield
    finally:
        _mode.reset(token)


def current_mode() -> str:
    """The kernel mode in force in this thread or task (``"auto"`` unless within :func:`mode`)."""
    return _mode.get()


def surface_table(surfaces) -> tuple[np.ndarray, np.ndarray] | None:
    """(kinds (m,), geometry (m, 4)) of a stack of planes (normal, offset) and spheres (centre, radius),
    or None when a surface is of another kind."""
    kinds = np.empty(len(surfaces), dtype=np.int64)
    geometry = np.empty((len(surfaces), 4))
    for i, surface in enumerate(surfaces):
        if isinstance(surface, Plane):
            kinds[i] = PLANE
            geometry[i, :3], geometry[i, 3] = surface.normal, surface.offset
        elif isinstance(surface, Sphere):
            kinds[i] = SPHERE
            geometry[i, :3], geometry[i, 3] = surface.center, surface.radius
        else:
            return None
    return kinds, geometry


def wanted(rows: int, surfaces=()) -> bool:
    """Whether to run a compiled kernel on ``rows`` rows (traced through ``surfaces``; see :func:`mode`)."""
    current = _mode.get()
    if current == "never" or (current == "auto" and rows < MIN_ROWS):
        return False
    if surface_table(surfaces) is None:
        return False
    return _load() is not None


def _load():
    """The compiled functions (a dict), or None when numba is not installed."""
    if "kernels" not in _compiled:
        try:
            from usvips.core import _numba_kernels
        except ImportError:  # numba missing: the numpy path serves
            _compiled["kernels"] = None
        else:
            _compiled["kernels"] = _numba_kernels
    return _compiled["kernels"]


def trace_into(camera, pixels: np.ndarray, origins: np.ndarray, directions: np.ndarray,
               d_origins: np.ndarray, d_directions: np.ndarray, status: np.ndarray, failed: np.ndarray) -> bool:
    """Compiled :meth:`Camera.rays_with_derivatives` of pixels (N, 2), written into the given arrays:
    object-space origins and unit directions (N, 3), their derivatives per pixel x and y (N, 3, 2),
    :class:`RayStatus` codes (N,) uint8 and failed surfaces (N,) int16. Returns False when the lens
    distortion cannot be inverted at some pixel (the reference path then names it)."""
    rows, surfaces, counts = camera_table((camera,))
    unusable = _load().trace_pixels(np.ascontiguousarray(pixels, dtype=np.float64), rows[0], surfaces[0],
                                           counts[0], MIN_ADVANCE, origins, directions, d_origins, d_directions,
                                           status, failed)
    return unusable == 0


def trace_ideal(camera, ideal: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Compiled object-space rays of ideal normalised coordinates (N, 2) of ``camera`` (the camera-frame
    rays (u, v, −1) through its housing, no lens, no derivatives): origins, unit directions (N, 3), status
    codes (N,) uint8 and failed surfaces (N,) int16."""
    rows, surfaces, counts = camera_table((camera,))
    n = len(ideal)
    origins, directions = np.empty((n, 3)), np.empty((n, 3))
    status, failed = np.empty(n, dtype=np.uint8), np.empty(n, dtype=np.int16)
    _load().trace_ideal(np.ascontiguousarray(ideal, dtype=np.float64), rows[0], surfaces[0], counts[0],
                        MIN_ADVANCE, origins, directions, status, failed)
    return origins, directions, status, failed


def trace_ideal_in_housing(housing, ideal: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Compiled ``Housing.trace`` of the camera-frame rays (u, v, −1) of ideal normalised coordinates
    (N, 2), in the camera frame (:func:`trace_ideal` with the identity pose)."""
    rows = _surface_rows(housing)
    table = np.array(rows, dtype=np.float64) if rows else np.zeros((1, 7))
    pose = np.zeros(21)
    pose[9:18] = np.eye(3).ravel()
    n = len(ideal)
    origins, directions = np.empty((n, 3)), np.empty((n, 3))
    status, failed = np.empty(n, dtype=np.uint8), np.empty(n, dtype=np.int16)
    _load().trace_ideal(np.ascontiguousarray(ideal, dtype=np.float64), pose, table, len(rows), MIN_ADVANCE,
                        origins, directions, status, failed)
    return origins, directions, status, failed


def intersect_rays(origins, directions, d_origins, d_directions, ray_ok, weights):
    """Compiled two-pass weighted intersection of k rays per point (see ``intersection.intersect``):
    tuples over the k cameras of origins, directions (N, 3), their derivatives per pixel (N, 3, 2) and
    whether each ray is valid (N,); ``weights`` (1 or N, k) 1/σ² (1/px²). Returns points, covariance,
    residuals in metres and pixels, and a status per point."""
    def contiguous(arrays, dtype=np.float64):
        return tuple(np.ascontiguousarray(a, dtype=dtype) for a in arrays)
    return _load().intersect_rays(contiguous(origins), contiguous(directions), contiguous(d_origins),
                                         contiguous(d_directions), contiguous(ray_ok, np.bool_),
                                         np.ascontiguousarray(weights, dtype=np.float64))


def _surface_rows(housing) -> list[list[float]]:
    """A housing's planes and spheres as rows for the block kernels (see :func:`camera_table`)."""
    indices = housing.indices
    rows = []
    for q, surface in enumerate(housing.surfaces):
        ratio = indices[q] / indices[q + 1]
        if isinstance(surface, Plane):
            rows.append([PLANE, *surface.normal.tolist(), surface.offset, ratio, 0.0])
        else:
            rows.append([SPHERE, *surface.center.tolist(), surface.radius, ratio, 1.0 / surface.radius])
    return rows


def camera_table(cameras) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Cameras as rows for the block kernels: (cameras (k, 21): f, xp, yp, sy, k1, k2, p1, p2, k3, the
    rotation M row by row, X0, Y0, Z0; surfaces (k, m, 7): kind (0 plane, 1 sphere), normal or centre (3),
    offset or radius (metres), n_in / n_out, 1 / radius (spheres); counts (k,): surfaces per camera)."""
    rows = []
    tables = []
    for camera in cameras:
        interior, exterior = camera.interior, camera.exterior
        rows.append([interior.f, interior.xp, interior.yp, interior.sy, interior.k1, interior.k2, interior.p1,
                     interior.p2, interior.k3, *exterior.rotation.ravel().tolist(), *exterior.position.tolist()])
        tables.append(_surface_rows(camera.housing))
    surfaces = np.zeros((len(tables), max([len(t) for t in tables] + [1]), 7))
    for j, table in enumerate(tables):
        if table:
            surfaces[j, :len(table)] = table
    return np.array(rows, dtype=np.float64), surfaces, np.array([len(t) for t in tables], dtype=np.int64)


def intersect_pixels(cameras, pixels, weights: np.ndarray) -> tuple | None:
    """Compiled, fused ``intersection.intersect``: pixels of the k cameras (k arrays (N, 2)) straight to
    points, covariance, residuals (metres, pixels) and a status per point, with no per-ray arrays in
    between; ``weights`` (1 or N, k) are 1/σ² (1/px²). None when the distortion cannot be inverted at
    some pixel (the reference path then names it)."""
    rows, surfaces, counts = camera_table(cameras)
    *result, unusable = _load().intersect_pixels(
        tuple(np.ascontiguousarray(p, dtype=np.float64) for p in pixels), rows, surfaces, counts,
        np.ascontiguousarray(weights, dtype=np.float64), MIN_ADVANCE)
    return None if unusable else tuple(result)


def back_project_general(housing, points: np.ndarray, start: np.ndarray, warm: np.ndarray | None,
                         outer: Plane | None):
    """Compiled ``camera._back_project_general``: (uv (N, 2), status (N,)) of camera-frame points (N, 3);
    ``start`` the pinhole (u, v), ``warm`` given starts (rows of NaN: none), ``outer`` the plane whose
    air-to-water solve starts the others (None: the pinhole start)."""
    proxy = np.zeros(4)
    if outer is not None:
        axis = -outer.normal if outer.normal[2] > 0 else outer.normal
        proxy[:3], proxy[3] = axis, -outer.offset * float(outer.normal @ axis)
    if warm is None:
        warm = np.full((len(points), 2), np.nan)
    rows = _surface_rows(housing)
    table = np.array(rows, dtype=np.float64) if rows else np.zeros((1, 7))
    return _load().back_project(np.ascontiguousarray(points, dtype=np.float64),
                                       np.ascontiguousarray(start, dtype=np.float64),
                                       np.ascontiguousarray(warm, dtype=np.float64), table, len(rows),
                                       np.asarray(housing.indices, dtype=np.float64), proxy, MIN_ADVANCE)


def back_project_planar(points: np.ndarray, axis: np.ndarray, distances: np.ndarray, indices) -> tuple:
    """Compiled ``camera._back_project_planar``: (uv (N, 2), status (N,)) of camera-frame points (N, 3)
    behind parallel planes at ``distances`` (metres, increasing, > 0) along the unit ``axis``, media
    ``indices`` (air, glass..., water)."""
    return _load().back_project_planar(np.ascontiguousarray(points, dtype=np.float64),
                                       np.ascontiguousarray(axis, dtype=np.float64),
                                       np.ascontiguousarray(distances, dtype=np.float64),
                                       np.asarray(indices, dtype=np.float64))


def undistort(interior, target: np.ndarray, tolerance: float) -> np.ndarray | None:
    """Compiled ``Interior.undistort`` of observed normalised coordinates (N, 2); None when the distortion
    cannot be inverted at some row (the reference path then names it)."""
    out, unusable = _load().undistort(np.ascontiguousarray(target, dtype=np.float64), float(interior.k1),
                                      float(interior.k2), float(interior.k3), float(interior.p1),
                                      float(interior.p2), float(tolerance))
    return None if unusable else out


def available() -> bool:
    """True when numba is installed and the compiled kernels can run."""
    return _load() is not None


__all__ = ["MIN_ROWS", "available", "back_project_general", "back_project_planar", "camera_table", "current_mode",
           "intersect_pixels", "intersect_rays", "mode", "surface_table", "trace_ideal", "trace_ideal_in_housing",
           "trace_into", "undistort", "wanted"]


def add_pose_shifts(rows: np.ndarray, origins: np.ndarray, directions: np.ndarray, along: np.ndarray,
                    centre: np.ndarray, turns: np.ndarray, shifts: np.ndarray, columns, out: np.ndarray) -> None:
    """Compiled pose part of ``point_derivatives.pixel_motions``: adds A ((Q − C_b) T_e + c_e) to column
    ``columns[e]`` of ``out`` (N, 2, m), A = ``rows`` (N, 2, 3), Q = origins + along · directions (N, 3),
    C_b = ``centre``, ``turns`` (E, 3, 3), ``shifts`` (E, 3)."""
    f64 = np.float64
    _load().add_pose_shifts(np.ascontiguousarray(rows, f64), np.ascontiguousarray(origins, f64),
                            np.ascontiguousarray(directions, f64), np.ascontiguousarray(along, f64),
                            np.ascontiguousarray(centre, f64), np.ascontiguousarray(turns, f64),
                            np.ascontiguousarray(shifts, f64), np.asarray(columns, dtype=np.int64), out)


def add_housing_shift(rows: np.ndarray, along: np.ndarray, minus, plus, span: float, column: int,
                      out: np.ndarray) -> None:
    """Compiled housing part of ``point_derivatives.pixel_motions``: adds A m / span to column ``column`` of
    ``out`` (N, 2, m), m the motion of the rays ``minus`` → ``plus`` (RayBundle) at the depths ``along``;
    zero where either ray failed."""
    f64 = np.float64
    _load().add_housing_shift(np.ascontiguousarray(rows, f64), np.ascontiguousarray(along, f64),
                              np.ascontiguousarray(minus.origins, f64), np.ascontiguousarray(minus.directions, f64),
                              np.ascontiguousarray(minus.status), np.ascontiguousarray(plus.origins, f64),
                              np.ascontiguousarray(plus.directions, f64), np.ascontiguousarray(plus.status),
                              float(span), int(column), out)
