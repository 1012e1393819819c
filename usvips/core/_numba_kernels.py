"""The per-point numba code behind :mod:`usvips.core.kernels` (imported only through it; needs numba):
the back-projections and the batch undistortion; the trace and the intersection are block kernels
(``_numba_blocks``), which use :func:`_distort` from here.

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
def _trace_state(s, kinds, geometry, indices, min_advance, tangents):
    """Trace the ray held in ``s`` (origin 0:3, unit direction 3:6, then per tangent its derivatives of
    origin and direction, 6 values each) through the surfaces, in place. Returns (status, surface)."""
    for k in range(kinds.shape[0]):
        ox, oy, oz, dx, dy, dz = s[0], s[1], s[2], s[3], s[4], s[5]
        gx, gy, gz, gw = geometry[k, 0], geometry[k, 1], geometry[k, 2], geometry[k, 3]
        sphere = kinds[k] == 1
        t = 0.0
        hit = False
        if not sphere:
            denominator = dx * gx + dy * gy + dz * gz
            if abs(denominator) > 1e-15:
                t = -(ox * gx + oy * gy + oz * gz + gw) / denominator
                hit = t > min_advance
        else:
            fx, fy, fz = ox - gx, oy - gy, oz - gz
            u = dx * fx + dy * fy + dz * fz
            w = u * u - (fx * fx + fy * fy + fz * fz - gw * gw)
            if w >= 0.0:
                root = math.sqrt(w)
                t = -u - root
                if not t > min_advance:
                    t = -u + root
                hit = t > min_advance
        if not hit:
            return MISSED_SURFACE, k
        px, py, pz = ox + t * dx, oy + t * dy, oz + t * dz
        if sphere:
            nx, ny, nz = (px - gx) / gw, (py - gy) / gw, (pz - gz) / gw
        else:
            nx, ny, nz = gx, gy, gz
        slope = nx * dx + ny * dy + nz * dz
        sign = -1.0 if slope < 0.0 else 1.0
        cos_in = slope * sign
        ratio = indices[k] / indices[k + 1]
        radicand = 1.0 - ratio * ratio * (1.0 - cos_in * cos_in)
        if radicand < 0.0:
            return TOTAL_INTERNAL_REFLECTION, k
        cos_out = math.sqrt(radicand)
        bend = (cos_out - ratio * cos_in) * sign
        factor = ratio * ratio * cos_in / cos_out
        safe_slope = slope if abs(slope) > 1e-300 else 1e-300
        for j in range(tangents):
            b = 6 + 6 * j
            aox, aoy, aoz, adx, ady, adz = s[b], s[b + 1], s[b + 2], s[b + 3], s[b + 4], s[b + 5]
            d_t = -((nx * aox + ny * aoy + nz * aoz) + t * (nx * adx + ny * ady + nz * adz)) / safe_slope
            qx, qy, qz = aox + d_t * dx + t * adx, aoy + d_t * dy + t * ady, aoz + d_t * dz + t * adz
            d_cos_in = adx * nx + ady * ny + adz * nz
            if sphere:
                mx, my, mz = qx / gw, qy / gw, qz / gw
                d_cos_in += dx * mx + dy * my + dz * mz
            else:
                mx, my, mz = 0.0, 0.0, 0.0
            d_cos_in *= sign
            along_normal = (factor * d_cos_in - ratio * d_cos_in) * sign
            s[b], s[b + 1], s[b + 2] = qx, qy, qz
            s[b + 3] = ratio * adx + along_normal * nx + bend * mx
            s[b + 4] = ratio * ady + along_normal * ny + bend * my
            s[b + 5] = ratio * adz + along_normal * nz + bend * mz
        s[0], s[1], s[2] = px, py, pz
        s[3] = ratio * dx + bend * nx
        s[4] = ratio * dy + bend * ny
        s[5] = ratio * dz + bend * nz
    return OK, -1


@njit(cache=True, error_model="numpy", fastmath=_FAST)
def _start_ray(s, u, v, du0, dv0, du1, dv1):
    """Load the camera-frame ray (u, v, −1) from the centre and the derivatives of (u, v) per variable
    into ``s``, normalised as ``Housing.trace_with_tangents`` does."""
    length = math.sqrt(u * u + v * v + 1.0)
    dx, dy, dz = u / length, v / length, -1.0 / length
    s[0], s[1], s[2], s[3], s[4], s[5] = 0.0, 0.0, 0.0, dx, dy, dz
    for j in range(2):
        a = (du0 if j == 0 else du1) / length
        c = (dv0 if j == 0 else dv1) / length
        along = a * dx + c * dy
        b = 6 + 6 * j
        s[b], s[b + 1], s[b + 2] = 0.0, 0.0, 0.0
        s[b + 3], s[b + 4], s[b + 5] = a - along * dx, c - along * dy, -along * dz


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
def back_project(points, start, warm, kinds, geometry, indices, proxy, min_advance):
    """``camera._back_project_general`` per point: Gauss–Newton on (u, v) so that the traced ray passes
    through the camera-frame point, halving a step whose ray fails; returns uv (N, 2) and a status."""
    n = points.shape[0]
    uv = np.empty((n, 2))
    status = np.zeros(n, dtype=np.uint8)
    _back_project_range(0, n, points, start, warm, kinds, geometry, indices, proxy, min_advance, uv, status)
    return uv, status


@njit(cache=True, error_model="numpy", fastmath=_FAST)
def _back_project_range(lo, hi, points, start, warm, kinds, geometry, indices, proxy, min_advance, uv, status):
    s = np.empty(18)
    for i in range(lo, hi):
        px, py, pz = points[i, 0], points[i, 1], points[i, 2]
        if math.isfinite(warm[i, 0]) and math.isfinite(warm[i, 1]):
            u, v = warm[i, 0], warm[i, 1]
        else:
            u, v = _proxy_start(px, py, pz, indices, proxy)
            if not (math.isfinite(u) and math.isfinite(v)):
                u, v = start[i, 0], start[i, 1]
        good_u, good_v = math.nan, math.nan
        step_u, step_v = 0.0, 0.0
        halvings = 0
        previous = math.inf
        code = NOT_CONVERGED
        for _ in range(80):
            _start_ray(s, u, v, 1.0, 0.0, 0.0, 1.0)
            traced, _surface = _trace_state(s, kinds, geometry, indices, min_advance, 2)
            if traced != OK:
                if math.isfinite(good_u) and halvings < 40:
                    step_u *= 0.5
                    step_v *= 0.5
                    u, v = good_u + step_u, good_v + step_v
                    halvings += 1
                    previous = math.inf
                    continue
                if math.isnan(good_u) and halvings == 0:  # a failing start: the pinhole direction, once
                    u, v = start[i, 0], start[i, 1]
                    halvings = 1
                    continue
                code = traced
                break
            wx, wy, wz = px - s[0], py - s[1], pz - s[2]
            dx, dy, dz = s[3], s[4], s[5]
            along = wx * dx + wy * dy + wz * dz
            mx, my, mz = wx - along * dx, wy - along * dy, wz - along * dz
            # columns of ∂miss/∂(u, v)
            d_along = -(s[6] * dx + s[7] * dy + s[8] * dz) + (wx * s[9] + wy * s[10] + wz * s[11])
            ux = -s[6] - d_along * dx - along * s[9]
            uy = -s[7] - d_along * dy - along * s[10]
            uz = -s[8] - d_along * dz - along * s[11]
            d_along = -(s[12] * dx + s[13] * dy + s[14] * dz) + (wx * s[15] + wy * s[16] + wz * s[17])
            vx = -s[12] - d_along * dx - along * s[15]
            vy = -s[13] - d_along * dy - along * s[16]
            vz = -s[14] - d_along * dz - along * s[17]
            a11 = ux * ux + uy * uy + uz * uz
            a12 = ux * vx + uy * vy + uz * vz
            a22 = vx * vx + vy * vy + vz * vz
            b1 = ux * mx + uy * my + uz * mz
            b2 = vx * mx + vy * my + vz * mz
            det = a11 * a22 - a12 * a12
            if not det > 1e-300:
                code = NOT_CONVERGED
                break
            step_u = -(a22 * b1 - a12 * b2) / det
            step_v = -(a11 * b2 - a12 * b1) / det
            good_u, good_v = u, v
            halvings = 0
            u += step_u
            v += step_v
            # quadratic convergence: a step below 1e-10 leaves the next below 1e-18; and a step that,
            # with the one before it, predicts a next one below 1e-13 (1e-10 px at f = 1000 px) ends the
            # solve without tracing the ray once more
            size = max(abs(step_u), abs(step_v))
            if size < 1e-10 or (size < 1e-5 and size * size * size < 1e-13 * previous * previous):
                code = BEHIND_CAMERA if along <= 0.0 else OK
                break
            previous = size
        uv[i, 0], uv[i, 1] = u, v
        status[i] = code


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
