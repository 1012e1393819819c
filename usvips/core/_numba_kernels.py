"""The per-point numba code behind :mod:`usvips.core.kernels` (imported only through it; needs numba):
the flat port's back-projection, the outer plane's start of the others, and the batch undistortion.
The trace, the intersection and the non-axial back-projection are block kernels (``_numba_blocks``),
which use :func:`_distort` and :func:`_proxy_start` from here.

One point at a time, in scalars: no temporaries over whole arrays. Each kernel's loop is a ``_range``
function over rows lo..hi, so that blocks of rows could be handed to threads; they run on one thread
(numba's ``parallel=True`` ran slower here on two cores shared by other jobs). Status codes are those of
:class:`usvips.core.rays.RayStatus`. Compiled code is cached next to this file (``cache=True``), so a
run pays the compilation once per installation, then only for loading it. The entry points release the
GIL (``nogil``), so a worker thread running one does not freeze the window.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

OK, MISSED_SURFACE, TOTAL_INTERNAL_REFLECTION, BEHIND_CAMERA = 0, 1, 2, 3
NOT_CONVERGED, PARALLEL_RAYS, FAILED_RAY = 4, 6, 7

#: LLVM fast-math flags that keep IEEE semantics for NaN and infinity (the status logic tests them):
#: fused multiply-add, reciprocal multiplication, no signed zeros.
_FAST = {"contract", "arcp", "nsz"}


@njit(cache=True, error_model="numpy", fastmath=_FAST)
def _distort(u, v, k1, k2, k3, p1, p2):
    """Observed normalised (u_d, v_d) of ideal (u, v) and the Jacobian entries (Interior's model)."""
    r2 = u * u + v * v
    radial = k1 * r2 + (k2 + k3 * r2) * r2 * r2
    ud = u + u * radial + p1 * (r2 + 2 * u * u) + 2 * p2 * u * v
    vd = v + v * radial + p2 * (r2 + 2 * v * v) + 2 * p1 * u * v
    dradial = 2 * k1 + (4 * k2 + 6 * k3 * r2) * r2
    cross = u * v * dradial
    j00 = 1 + radial + u * u * dradial + 6 * p1 * u + 2 * p2 * v
    j01 = cross + 2 * p1 * v + 2 * p2 * u
    j10 = cross + 2 * p2 * u + 2 * p1 * v
    j11 = 1 + radial + v * v * dradial + 6 * p2 * v + 2 * p1 * u
    return ud, vd, j00, j01, j10, j11


@njit(cache=True, error_model="numpy", fastmath=_FAST)
def _undistort_newton(u, v, tu, tv, k1, k2, k3, p1, p2, tolerance):
    """Newton's method from (u, v) for the ideal normalised coordinates whose distortion is (tu, tv); at
    most 60 steps, until both components of a step are below ``tolerance``."""
    for _ in range(60):
        ud, vd, j00, j01, j10, j11 = _distort(u, v, k1, k2, k3, p1, p2)
        ru, rv = ud - tu, vd - tv
        det = j00 * j11 - j01 * j10
        if not abs(det) > 1e-12:
            det = 1e-12
        step_u = (j11 * ru - j01 * rv) / det
        step_v = (j00 * rv - j10 * ru) / det
        u -= step_u
        v -= step_v
        if abs(step_u) < tolerance and abs(step_v) < tolerance:
            break
    return u, v


@njit(cache=True, error_model="numpy", fastmath=_FAST)
def _proxy_start(px, py, pz, indices, proxy):
    """The exact (u, v) of the ray through the outer plane alone (air straight to water), by the 1-D
    Newton solve of ``camera._back_project_planar``; (nan, nan) where it has none."""
    ax, ay, az, distance = proxy[0], proxy[1], proxy[2], proxy[3]
    n_in, n_out = indices[0], indices[indices.shape[0] - 1]
    depth = px * ax + py * ay + pz * az
    if not distance > 0.0 or not depth > distance:
        return math.nan, math.nan
    rx, ry, rz = px - depth * ax, py - depth * ay, pz - depth * az
    radial = math.sqrt(rx * rx + ry * ry + rz * rz)
    water = depth - distance
    q_max = min(n_in, n_out) * (1.0 - 1e-15)
    q = min(n_out * math.sin(math.atan2(radial, depth)), 0.999 * q_max)
    step, slope = 0.0, 1.0
    for _ in range(60):
        s_in, s_out = q / n_in, q / n_out
        c_in, c_out = 1.0 / math.sqrt(1.0 - s_in * s_in), 1.0 / math.sqrt(1.0 - s_out * s_out)
        total = -radial + distance * s_in * c_in + water * s_out * c_out
        slope = (distance / n_in) * c_in * c_in * c_in + (water / n_out) * c_out * c_out * c_out
        step = total / slope
        new_q = min(max(q - step, 0.0), q_max)
        if new_q >= q_max:
            new_q = 0.5 * (q + q_max)
        change = abs(new_q - q)
        q = new_q
        if change < 1e-14:
            break
    if abs(step) * slope > 1e-9 * max(1.0, radial):
        return math.nan, math.nan
    sin1 = q / n_in
    cos1 = math.sqrt(1.0 - sin1 * sin1)
    ex, ey, ez = 0.0, 0.0, 0.0
    if radial > 0.0:
        ex, ey, ez = rx / radial, ry / radial, rz / radial
    dx, dy, dz = cos1 * ax + sin1 * ex, cos1 * ay + sin1 * ey, cos1 * az + sin1 * ez
    if dz >= 0.0:
        return math.nan, math.nan
    return -dx / dz, -dy / dz


@njit(cache=True, error_model="numpy", fastmath=_FAST, nogil=True)
def back_project_planar(points, axis, distances, indices):
    """``camera._back_project_planar`` per point: parallel planes at ``distances`` (m,) metres along
    ``axis`` from the perspective centre, media ``indices`` (m + 1,) (air, glass..., water). A 1-D Newton
    solve for the invariant q = n1·sin θ1 so that the refracted path reaches the point's radial offset;
    returns uv (N, 2) and a status."""
    n = points.shape[0]
    m = distances.shape[0]
    uv = np.empty((n, 2))
    status = np.zeros(n, dtype=np.uint8)
    widths = np.empty(m + 1)
    previous = 0.0
    for k in range(m):
        widths[k] = distances[k] - previous
        previous = distances[k]
    last = distances[m - 1]
    n_water = indices[m]
    lowest = n_water
    for k in range(m + 1):
        lowest = min(lowest, indices[k])
    q_max = lowest * (1.0 - 1e-15)
    ax, ay, az = axis[0], axis[1], axis[2]
    for i in range(n):
        px, py, pz = points[i, 0], points[i, 1], points[i, 2]
        depth = px * ax + py * ay + pz * az
        rx, ry, rz = px - depth * ax, py - depth * ay, pz - depth * az
        radial = math.sqrt(rx * rx + ry * ry + rz * rz)
        code = OK
        if depth > last:
            widths[m] = depth - last
        else:
            code = BEHIND_CAMERA
            widths[m] = 1.0
        q = min(n_water * math.sin(math.atan2(radial, depth)), 0.999 * q_max)
        step, slope = 0.0, 1.0
        for _ in range(60):
            total = -radial
            slope = 0.0
            for k in range(m + 1):
                layer = indices[k]
                s = q / layer
                inv_c = 1.0 / math.sqrt(1.0 - s * s)
                total += widths[k] * s * inv_c
                slope += (widths[k] / layer) * inv_c * inv_c * inv_c
            step = total / slope
            new_q = min(max(q - step, 0.0), q_max)
            if new_q >= q_max:
                new_q = 0.5 * (q + q_max)
            change = abs(new_q - q)
            q = new_q
            if change < 1e-14:
                break
        if code == OK and abs(step) * slope > 1e-9 * max(1.0, radial):
            code = NOT_CONVERGED
        sin1 = q / indices[0]
        cos1 = math.sqrt(1.0 - sin1 * sin1)
        ex, ey, ez = 0.0, 0.0, 0.0
        if radial > 0:
            ex, ey, ez = rx / radial, ry / radial, rz / radial
        dx, dy, dz = cos1 * ax + sin1 * ex, cos1 * ay + sin1 * ey, cos1 * az + sin1 * ez
        if dz >= 0.0:
            if code == OK:
                code = BEHIND_CAMERA
            dz = -1.0
        uv[i, 0] = -dx / dz
        uv[i, 1] = -dy / dz
        status[i] = code
    return uv, status


@njit(cache=True, error_model="numpy", fastmath=_FAST, nogil=True)
def undistort(target, k1, k2, k3, p1, p2, tolerance):
    """``Interior.undistort`` per point: observed normalised coordinates (N, 2) → ideal ones by Newton's
    method to ``tolerance``. Returns them and how many rows cannot be inverted (residual over 1e3 ×
    tolerance, a fold, or a point flipped through the centre: the caller lets the reference name them)."""
    n = target.shape[0]
    out = np.empty((n, 2))
    unusable = 0
    for i in range(n):
        tu, tv = target[i, 0], target[i, 1]
        u, v = _undistort_newton(tu, tv, tu, tv, k1, k2, k3, p1, p2, tolerance)
        ud, vd, j00, j01, j10, j11 = _distort(u, v, k1, k2, k3, p1, p2)
        residual = max(abs(ud - tu), abs(vd - tv))
        if not residual <= 1e3 * tolerance or j00 * j11 - j01 * j10 <= 0.0 or u * tu + v * tv < 0.0:
            unusable += 1
        out[i, 0], out[i, 1] = u, v
    return out, unusable
