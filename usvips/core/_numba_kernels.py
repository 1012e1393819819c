"""The numba code behind :mod:`usvips.core.kernels` (imported only through it; needs numba).

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


@njit(cache=True, error_model="numpy", fastmath=_FAST, nogil=True)
def trace_pixels(pixels, interior, rotation, position, kinds, geometry, indices, min_advance,
                 origins, directions, d_origins, d_directions, status, failed):
    """Pixels (N, 2) → object-space rays with their derivatives per pixel, written into the given
    arrays (origins, directions (N, 3); d_origins, d_directions (N, 3, 2); status, failed (N,)).
    Returns how many rows have a distortion that cannot be inverted there (the caller lets the reference
    path say which and why)."""
    return _trace_pixels_range(0, pixels.shape[0], pixels, interior, rotation, position, kinds, geometry, indices,
                               min_advance, origins, directions, d_origins, d_directions, status, failed)


@njit(cache=True, error_model="numpy", fastmath=_FAST)
def _trace_pixels_range(lo, hi, pixels, interior, rotation, position, kinds, geometry, indices, min_advance,
                        origins, directions, d_origins, d_directions, status, failed):
    unusable = 0
    f, xp, yp, sy, k1, k2, p1, p2, k3 = (interior[0], interior[1], interior[2], interior[3], interior[4],
                                         interior[5], interior[6], interior[7], interior[8])
    distorted = k1 != 0.0 or k2 != 0.0 or k3 != 0.0 or p1 != 0.0 or p2 != 0.0
    s = np.empty(18)
    for i in range(lo, hi):
        tu = (pixels[i, 0] - xp) / f
        tv = (yp - pixels[i, 1]) * sy / f
        u, v = tu, tv
        du0, dv0, du1, dv1 = 1.0 / f, 0.0, 0.0, -sy / f
        if distorted:
            # start one fixed-point step from the observed point (removes the first-order distortion),
            # then Newton to the reference's tolerance
            ud, vd, j00, j01, j10, j11 = _distort(u, v, k1, k2, k3, p1, p2)
            u, v = tu - (ud - tu), tv - (vd - tv)
            u, v = _undistort_newton(u, v, tu, tv, k1, k2, k3, p1, p2, 1e-13)
            ud, vd, j00, j01, j10, j11 = _distort(u, v, k1, k2, k3, p1, p2)
            residual = max(abs(ud - tu), abs(vd - tv))
            det = j00 * j11 - j01 * j10
            if not residual <= 1e-10 or det <= 0.0 or u * tu + v * tv < 0.0:
                unusable += 1
            # d(uv)/d(uv_d) = J⁻¹ applied to the pixel steps
            du0, dv0 = j11 * (1.0 / f) / det, -j10 * (1.0 / f) / det
            du1, dv1 = -j01 * (-sy / f) / det, j00 * (-sy / f) / det
        _start_ray(s, u, v, du0, dv0, du1, dv1)
        code, surface = _trace_state(s, kinds, geometry, indices, min_advance, 2)
        status[i] = code
        failed[i] = surface
        for c in range(3):  # camera frame → object space: X0 + Mᵀ p, directions dᵀ M
            origins[i, c] = position[c] + s[0] * rotation[0, c] + s[1] * rotation[1, c] + s[2] * rotation[2, c]
            directions[i, c] = s[3] * rotation[0, c] + s[4] * rotation[1, c] + s[5] * rotation[2, c]
            for j in range(2):
                b = 6 + 6 * j
                d_origins[i, c, j] = s[b] * rotation[0, c] + s[b + 1] * rotation[1, c] + s[b + 2] * rotation[2, c]
                d_directions[i, c, j] = (s[b + 3] * rotation[0, c] + s[b + 4] * rotation[1, c]
                                         + s[b + 5] * rotation[2, c])
    return unusable


@njit(cache=True, error_model="numpy", fastmath=_FAST)
def _solve3(m, b, x, inverse):
    """Solve the symmetric 3×3 system m (6: xx, xy, xz, yy, yz, zz) x = b into ``x`` and ``inverse``
    (9, row-major) by the adjugate, as ``intersection._solve3``; returns whether it is well-conditioned."""
    a00, a01, a02, a11, a12, a22 = m[0], m[1], m[2], m[3], m[4], m[5]
    c00 = a11 * a22 - a12 * a12
    c01 = a12 * a02 - a01 * a22
    c02 = a01 * a12 - a11 * a02
    c11 = a00 * a22 - a02 * a02
    c12 = a01 * a02 - a00 * a12
    c22 = a00 * a11 - a01 * a01
    det = a00 * c00 + a01 * c01 + a02 * c02
    scale = a00 * a00 + a11 * a11 + a22 * a22 + 2.0 * (a01 * a01 + a02 * a02 + a12 * a12)
    scale = max(scale, 1e-300)
    good = abs(det) > 1e-12 * scale * math.sqrt(scale)
    if not good:
        for q in range(9):
            inverse[q] = 0.0
        x[0], x[1], x[2] = 0.0, 0.0, 0.0
        return False
    inverse[0], inverse[1], inverse[2] = c00 / det, c01 / det, c02 / det
    inverse[3], inverse[4], inverse[5] = c01 / det, c11 / det, c12 / det
    inverse[6], inverse[7], inverse[8] = c02 / det, c12 / det, c22 / det
    for r in range(3):
        x[r] = inverse[3 * r] * b[0] + inverse[3 * r + 1] * b[1] + inverse[3 * r + 2] * b[2]
    return True


@njit(cache=True, error_model="numpy", fastmath=_FAST, nogil=True)
def intersect_weighted(origins, directions, d_origins, d_directions, ray_ok, sigma):
    """The two passes of ``intersection.intersect`` per point, over tuples of the k cameras' arrays:
    the midpoint, then each ray weighted by its pixel Jacobian at the midpoint's depth; covariance,
    residuals (metres, pixels) and status."""
    k, n = len(origins), origins[0].shape[0]
    points = np.empty((n, 3))  # every row is written below (zeros where the point failed)
    covariance = np.empty((n, 3, 3))
    residuals_m = np.empty((n, k))
    residuals_px = np.empty((n, k))
    status = np.empty(n, dtype=np.uint8)
    _intersect_range(0, n, origins, directions, d_origins, d_directions, ray_ok, sigma, points, covariance,
                     residuals_m, residuals_px, status)
    return points, covariance, residuals_m, residuals_px, status


@njit(cache=True, error_model="numpy", fastmath=_FAST)
def _intersect_range(lo, hi, origins, directions, d_origins, d_directions, ray_ok, sigma,
                     points, covariance, residuals_m, residuals_px, status):
    k = len(origins)
    m = np.empty(6)
    b = np.empty(3)
    x = np.empty(3)
    inverse = np.empty(9)
    rows = np.empty((k, 6))
    for i in range(lo, hi):
        code = OK
        for j in range(k):
            if not ray_ok[j][i]:
                code = FAILED_RAY
        m[:] = 0.0
        b[:] = 0.0
        for j in range(k):
            dx, dy, dz = directions[j][i, 0], directions[j][i, 1], directions[j][i, 2]
            ox, oy, oz = origins[j][i, 0], origins[j][i, 1], origins[j][i, 2]
            m[0] += 1 - dx * dx
            m[1] -= dx * dy
            m[2] -= dx * dz
            m[3] += 1 - dy * dy
            m[4] -= dy * dz
            m[5] += 1 - dz * dz
            along = dx * ox + dy * oy + dz * oz
            b[0] += ox - along * dx
            b[1] += oy - along * dy
            b[2] += oz - along * dz
        good = _solve3(m, b, x, inverse)
        m[:] = 0.0
        b[:] = 0.0
        for j in range(k):
            dx, dy, dz = directions[j][i, 0], directions[j][i, 1], directions[j][i, 2]
            ox, oy, oz = origins[j][i, 0], origins[j][i, 1], origins[j][i, 2]
            along = (x[0] - ox) * dx + (x[1] - oy) * dy + (x[2] - oz) * dz
            m0x = d_origins[j][i, 0, 0] + along * d_directions[j][i, 0, 0]
            m0y = d_origins[j][i, 1, 0] + along * d_directions[j][i, 1, 0]
            m0z = d_origins[j][i, 2, 0] + along * d_directions[j][i, 2, 0]
            m1x = d_origins[j][i, 0, 1] + along * d_directions[j][i, 0, 1]
            m1y = d_origins[j][i, 1, 1] + along * d_directions[j][i, 1, 1]
            m1z = d_origins[j][i, 2, 1] + along * d_directions[j][i, 2, 1]
            p0 = dx * m0x + dy * m0y + dz * m0z
            p1 = dx * m1x + dy * m1y + dz * m1z
            b0x, b0y, b0z = m0x - p0 * dx, m0y - p0 * dy, m0z - p0 * dz
            b1x, b1y, b1z = m1x - p1 * dx, m1y - p1 * dy, m1z - p1 * dz
            g00 = b0x * b0x + b0y * b0y + b0z * b0z
            g01 = b0x * b1x + b0y * b1y + b0z * b1z
            g11 = b1x * b1x + b1y * b1y + b1z * b1z
            det = g00 * g11 - g01 * g01
            if not det > 1e-30 * max(g00 * g11, 1e-300):
                good = False
                det = 1.0
            a0x, a0y, a0z = (g11 * b0x - g01 * b1x) / det, (g11 * b0y - g01 * b1y) / det, (g11 * b0z - g01 * b1z) / det
            a1x, a1y, a1z = (g00 * b1x - g01 * b0x) / det, (g00 * b1y - g01 * b0y) / det, (g00 * b1z - g01 * b0z) / det
            rows[j, 0], rows[j, 1], rows[j, 2], rows[j, 3], rows[j, 4], rows[j, 5] = a0x, a0y, a0z, a1x, a1y, a1z
            weight = 1.0 / (sigma[i, j] * sigma[i, j])
            m[0] += weight * (a0x * a0x + a1x * a1x)
            m[1] += weight * (a0x * a0y + a1x * a1y)
            m[2] += weight * (a0x * a0z + a1x * a1z)
            m[3] += weight * (a0y * a0y + a1y * a1y)
            m[4] += weight * (a0y * a0z + a1y * a1z)
            m[5] += weight * (a0z * a0z + a1z * a1z)
            c0 = weight * (a0x * ox + a0y * oy + a0z * oz)
            c1 = weight * (a1x * ox + a1y * oy + a1z * oz)
            b[0] += c0 * a0x + c1 * a1x
            b[1] += c0 * a0y + c1 * a1y
            b[2] += c0 * a0z + c1 * a1z
        if not _solve3(m, b, x, inverse):
            good = False
        behind = False
        for j in range(k):
            dx, dy, dz = directions[j][i, 0], directions[j][i, 1], directions[j][i, 2]
            wx, wy, wz = x[0] - origins[j][i, 0], x[1] - origins[j][i, 1], x[2] - origins[j][i, 2]
            along = wx * dx + wy * dy + wz * dz
            if along <= 0.0:
                behind = True
            qx, qy, qz = wx - along * dx, wy - along * dy, wz - along * dz
            residuals_m[i, j] = math.sqrt(qx * qx + qy * qy + qz * qz)
            e0 = rows[j, 0] * qx + rows[j, 1] * qy + rows[j, 2] * qz
            e1 = rows[j, 3] * qx + rows[j, 4] * qy + rows[j, 5] * qz
            residuals_px[i, j] = math.sqrt(e0 * e0 + e1 * e1)
        if code == OK and not good:
            code = PARALLEL_RAYS
        if code == OK and behind:
            code = BEHIND_CAMERA
        status[i] = code
        if code != OK:
            for j in range(k):
                residuals_m[i, j] = 0.0
                residuals_px[i, j] = 0.0
            for r in range(3):
                points[i, r] = 0.0
                for c in range(3):
                    covariance[i, r, c] = 0.0
            continue
        for r in range(3):
            points[i, r] = x[r]
            for c in range(3):
                covariance[i, r, c] = inverse[3 * r + c]


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
