"""The numba code behind :mod:`usvips.core.kernels` (imported only through it; needs numba).

One module on purpose: numba's cache (``cache=True``, next to this file) notices a change to the file
of a cached function but not to functions it calls from another file, so kernels that share code
(``_distort``, ``_proxy_start``) live together.

**Block kernels**, for blocks of :data:`BLOCK` rows at a time: pixels → undistortion → refractive trace
with the pixel derivatives → weighted intersection with covariance (:func:`intersect_pixels`), the trace
alone (:func:`trace_pixels`), the intersection of traced rays (:func:`intersect_rays`) and the
non-axial back-projection (:func:`back_project`).

Why blocks. One point at a time in scalars the CPU runs one long chain of dependent operations per ray
(Newton steps, divisions, square roots) and waits on each; a point of the intersection cost 800-900 ns
whatever the memory traffic. Here every stage is one loop over a block of rows whose state lives in
rows of a flat scratch array at constant offsets (structure of arrays, in the L1/L2 cache): the loops
have no early exits and no aliasing the compiler cannot see through, so LLVM runs them four rows at a
time (AVX2), and independent rows hide each other's latency. Iterative solves run in passes over the
block while any row is open: the Newton undistortion takes the fixed-point start and three steps in
its first pass (enough for a usual lens: the start is within 4e-3, three steps bring it below 1e-12),
the back-projection one Gauss–Newton step per pass.

**Per-point kernels**, a point at a time in scalars: the flat port's 1-D Newton back-projection
(:func:`back_project_planar`), the outer plane's start of the non-axial one (:func:`_proxy_start`) and
the batch undistortion (:func:`undistort`).

The arithmetic is that of the numpy reference (``Interior.undistort``, ``Housing.trace_with_tangents``,
``intersection.intersect``, ``camera._back_project_general``, ``camera._back_project_planar``), which the
tests compare the kernels with. Conventions: camera frame looking along −z, normalised coordinates
(u, v) with the ray (u, v, −1), metres, pixels; status codes are :class:`usvips.core.rays.RayStatus`'s.
The kernels run on one thread (``prange`` over blocks did not pay on two shared cores); the entry points
release the GIL (``nogil``), so a worker thread running one does not freeze the window.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

OK, MISSED_SURFACE, TOTAL_INTERNAL_REFLECTION, BEHIND_CAMERA = 0, 1, 2, 3
NOT_CONVERGED, PARALLEL_RAYS, FAILED_RAY, DIVERGING_RAYS = 4, 6, 7, 8

#: LLVM fast-math flags that keep IEEE semantics for NaN and infinity (the status logic tests them):
#: fused multiply-add, reciprocal multiplication, no signed zeros.
_FAST = {"contract", "arcp", "nsz"}
_OPTIONS = {"cache": True, "error_model": "numpy", "fastmath": _FAST}


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


# -------------------------------------------------------------------------------------------------
# block kernels
# -------------------------------------------------------------------------------------------------

#: Rows per block (a multiple of the SIMD width; the scratch of two cameras then fits the L2 cache).
BLOCK = 256
_B = BLOCK
# rows of one camera's scratch, each BLOCK long: the ray (origin, direction), its derivatives per pixel x
# (A: origin, direction) and per pixel y (B), the status so far, the undistortion's state, the rows of
# the pixel Jacobian a0, a1 (Q0, Q1)
OX, OY, OZ, DX, DY, DZ = 0 * _B, 1 * _B, 2 * _B, 3 * _B, 4 * _B, 5 * _B
AOX, AOY, AOZ, ADX, ADY, ADZ = 6 * _B, 7 * _B, 8 * _B, 9 * _B, 10 * _B, 11 * _B
BOX, BOY, BOZ, BDX, BDY, BDZ = 12 * _B, 13 * _B, 14 * _B, 15 * _B, 16 * _B, 17 * _B
CODE, U, V, I00, I01, I10, I11, STEP, RES, DET, TU, TV = (18 * _B, 19 * _B, 20 * _B, 21 * _B, 22 * _B, 23 * _B,
                                                        24 * _B, 25 * _B, 26 * _B, 27 * _B, 28 * _B, 29 * _B)
Q0X, Q0Y, Q0Z, Q1X, Q1Y, Q1Z = 30 * _B, 31 * _B, 32 * _B, 33 * _B, 34 * _B, 35 * _B
SURFACE = 36 * _B
# the back-projection's Gauss–Newton state: last good (u, v), last step, halvings, previous step size,
# state (−1 open, else the final status), the pinhole start
GOOD_U, GOOD_V, STEP_U, STEP_V, HALVINGS, PREVIOUS, STATE, START_U, START_V = (
    37 * _B, 38 * _B, 39 * _B, 40 * _B, 41 * _B, 42 * _B, 43 * _B, 44 * _B, 45 * _B)
CAMERA_ROWS = 46 * _B
# rows of the scratch the cameras share: the normal equations (A, r), the point X, the inverse C, flags
A00, A01, A02, A11, A12, A22, R0, R1, R2 = 0, _B, 2 * _B, 3 * _B, 4 * _B, 5 * _B, 6 * _B, 7 * _B, 8 * _B
X0, X1, X2 = 9 * _B, 10 * _B, 11 * _B
C00, C01, C02, C11, C12, C22 = 12 * _B, 13 * _B, 14 * _B, 15 * _B, 16 * _B, 17 * _B
GOOD, BEHIND, FAILED = 18 * _B, 19 * _B, 20 * _B
SHARED_ROWS = 21 * _B

@njit(**_OPTIONS)
def _distorted(u, v, k1, k2, k3, p1, p2):
    """Observed normalised (u_d, v_d) of ideal (u, v) (Interior's model), without the Jacobian."""
    r2 = u * u + v * v
    radial = k1 * r2 + (k2 + k3 * r2) * r2 * r2
    return (u + u * radial + p1 * (r2 + 2 * u * u) + 2 * p2 * u * v,
            v + v * radial + p2 * (r2 + 2 * v * v) + 2 * p1 * u * v)


@njit(**_OPTIONS)
def _normalise(m, pix, f, xp, yp, sy, s):
    """Observed normalised coordinates (TU, TV) of a block of pixels (m, 2) (thesis 2.29, divided by f)."""
    for i in range(m):
        s[TU + i] = (pix[i, 0] - xp) / f
        s[TV + i] = (yp - pix[i, 1]) * sy / f


@njit(**_OPTIONS)
def _newton_first(m, s, k1, k2, k3, p1, p2):
    """From one fixed-point step (which removes the first-order distortion), three Newton steps on every
    row: the ideal (U, V), the inverse distortion Jacobian (I00..I11) and the last step's size, residual
    and determinant. The Jacobian is taken one step before the end: within the last step (below 1e-12
    once converged) of the root's. Returns how many rows have not converged."""
    open_rows = 0
    for i in range(m):
        a, b = s[TU + i], s[TV + i]
        ud, vd = _distorted(a, b, k1, k2, k3, p1, p2)
        x, y = a - (ud - a), b - (vd - b)
        su = sv = ru = rv = 0.0
        j00 = j11 = det = inv = 1.0
        j01 = j10 = 0.0
        for _ in range(3):
            ud, vd, j00, j01, j10, j11 = _distort(x, y, k1, k2, k3, p1, p2)
            ru, rv = ud - a, vd - b
            det = j00 * j11 - j01 * j10
            inv = 1.0 / (det if abs(det) > 1e-12 else 1e-12)
            su = (j11 * ru - j01 * rv) * inv
            sv = (j00 * rv - j10 * ru) * inv
            x -= su
            y -= sv
        s[U + i], s[V + i] = x, y
        s[I00 + i], s[I01 + i], s[I10 + i], s[I11 + i] = j11 * inv, -j01 * inv, -j10 * inv, j00 * inv
        step = max(abs(su), abs(sv))
        s[STEP + i], s[RES + i], s[DET + i] = step, max(abs(ru), abs(rv)), det
        open_rows += not step < 1e-12
    return open_rows


@njit(**_OPTIONS)
def _newton_again(m, s, k1, k2, k3, p1, p2):
    """One more Newton step on every row of the block (a converged row stays where it is); returns how
    many rows have not converged."""
    open_rows = 0
    for i in range(m):
        a, b, x, y = s[TU + i], s[TV + i], s[U + i], s[V + i]
        ud, vd, j00, j01, j10, j11 = _distort(x, y, k1, k2, k3, p1, p2)
        ru, rv = ud - a, vd - b
        det = j00 * j11 - j01 * j10
        inv = 1.0 / (det if abs(det) > 1e-12 else 1e-12)
        su = (j11 * ru - j01 * rv) * inv
        sv = (j00 * rv - j10 * ru) * inv
        s[U + i], s[V + i] = x - su, y - sv
        s[I00 + i], s[I01 + i], s[I10 + i], s[I11 + i] = j11 * inv, -j01 * inv, -j10 * inv, j00 * inv
        step = max(abs(su), abs(sv))
        s[STEP + i], s[RES + i], s[DET + i] = step, max(abs(ru), abs(rv)), det
        open_rows += not step < 1e-12
    return open_rows


@njit(**_OPTIONS)
def _count_unusable(m, s):
    """Rows whose distortion cannot be inverted: no convergence, a residual over 1e-10, a fold (Jacobian
    not positive) or a point flipped through the centre (the reference path then names the first)."""
    bad = 0
    for i in range(m):
        good = (s[STEP + i] < 1e-12 and s[RES + i] <= 1e-10 and s[DET + i] > 0.0
                and s[U + i] * s[TU + i] + s[V + i] * s[TV + i] >= 0.0)
        bad += not good
    return bad


@njit(**_OPTIONS)
def _start_rays(m, s, f, sy, distorted):
    """The camera-frame rays (u, v, −1) from the perspective centre, normalised, with their derivatives
    per pixel x (A) and y (B) projected off the direction (as ``Housing.trace_with_tangents``); with
    ``f`` = 0 the derivatives per u (A) and v (B) of the rays of (U, V)."""
    per_uv = f == 0.0
    fx, fy = (1.0, 1.0) if per_uv else (1.0 / f, -sy / f)
    for i in range(m):
        if per_uv:
            uu, vv = s[U + i], s[V + i]
            ux, vx, uy, vy = 1.0, 0.0, 0.0, 1.0
        elif distorted:  # d(u, v)/d(pixel) = J⁻¹ · (1/f, 0) and J⁻¹ · (0, −sy/f)
            uu, vv = s[U + i], s[V + i]
            ux, vx, uy, vy = s[I00 + i] * fx, s[I10 + i] * fx, s[I01 + i] * fy, s[I11 + i] * fy
        else:
            uu, vv = s[TU + i], s[TV + i]
            ux, vx, uy, vy = fx, 0.0, 0.0, fy
        inv_length = 1.0 / math.sqrt(uu * uu + vv * vv + 1.0)
        ex, ey, ez = uu * inv_length, vv * inv_length, -inv_length
        s[OX + i], s[OY + i], s[OZ + i], s[DX + i], s[DY + i], s[DZ + i] = 0.0, 0.0, 0.0, ex, ey, ez
        a, c = ux * inv_length, vx * inv_length
        along = a * ex + c * ey
        s[AOX + i], s[AOY + i], s[AOZ + i] = 0.0, 0.0, 0.0
        s[ADX + i], s[ADY + i], s[ADZ + i] = a - along * ex, c - along * ey, -along * ez
        a, c = uy * inv_length, vy * inv_length
        along = a * ex + c * ey
        s[BOX + i], s[BOY + i], s[BOZ + i] = 0.0, 0.0, 0.0
        s[BDX + i], s[BDY + i], s[BDZ + i] = a - along * ex, c - along * ey, -along * ez
        s[CODE + i] = 0.0
        s[SURFACE + i] = -1.0


@njit(**_OPTIONS)
def _refract_block(m, s, surface, sphere, gx, gy, gz, gw, ratio, inv_r, min_advance):
    """Every live ray of the block through one surface (number ``surface``): a plane (unit normal g, offset
    gw) or a sphere (centre g, radius gw, 1/radius ``inv_r``), from index n_in to n_out (``ratio`` =
    n_in/n_out), with both tangents. A ray that misses (code 1) or is totally reflected (2) keeps its
    state and records the surface."""
    for i in range(m):
        o0, o1, o2, d0, d1, d2 = s[OX + i], s[OY + i], s[OZ + i], s[DX + i], s[DY + i], s[DZ + i]
        if sphere:  # the first crossing strictly ahead of the origin
            f0, f1, f2 = o0 - gx, o1 - gy, o2 - gz
            w = d0 * f0 + d1 * f1 + d2 * f2
            disc = w * w - (f0 * f0 + f1 * f1 + f2 * f2 - gw * gw)
            root = math.sqrt(max(disc, 0.0))
            near = -w - root
            t = near if near > min_advance else -w + root
            hit = disc >= 0.0 and t > min_advance
            n0, n1, n2 = (f0 + t * d0) * inv_r, (f1 + t * d1) * inv_r, (f2 + t * d2) * inv_r
            slope = n0 * d0 + n1 * d1 + n2 * d2
        else:
            slope = d0 * gx + d1 * gy + d2 * gz
            usable = abs(slope) > 1e-15
            t = -(o0 * gx + o1 * gy + o2 * gz + gw) / (slope if usable else 1.0)
            hit = usable and t > min_advance
            n0, n1, n2 = gx, gy, gz
        # vector Snell (2.13) with the normal oriented along the ray
        sign = -1.0 if slope < 0.0 else 1.0
        cos_in = slope * sign
        radicand = 1.0 - ratio * ratio * (1.0 - cos_in * cos_in)
        cos_out = math.sqrt(max(radicand, 1e-300))
        bend = (cos_out - ratio * cos_in) * sign
        gain = ratio * ratio * cos_in / cos_out - ratio  # d(refracted)/d(cos_in) along the normal
        inv_slope = 1.0 / (slope if abs(slope) > 1e-300 else 1e-300)
        # tangent A: the crossing moves by q, the normal (sphere) by q / r, the direction by na
        a0, a1, a2, a3, a4, a5 = s[AOX + i], s[AOY + i], s[AOZ + i], s[ADX + i], s[ADY + i], s[ADZ + i]
        d_t = -((n0 * a0 + n1 * a1 + n2 * a2) + t * (n0 * a3 + n1 * a4 + n2 * a5)) * inv_slope
        q0, q1, q2 = a0 + d_t * d0 + t * a3, a1 + d_t * d1 + t * a4, a2 + d_t * d2 + t * a5
        d_cos = a3 * n0 + a4 * n1 + a5 * n2
        if sphere:
            m0, m1, m2 = q0 * inv_r, q1 * inv_r, q2 * inv_r
            d_cos += d0 * m0 + d1 * m1 + d2 * m2
        else:
            m0 = m1 = m2 = 0.0
        normal_part = gain * d_cos
        na3 = ratio * a3 + normal_part * n0 + bend * m0
        na4 = ratio * a4 + normal_part * n1 + bend * m1
        na5 = ratio * a5 + normal_part * n2 + bend * m2
        # tangent B, the same
        b0, b1, b2, b3, b4, b5 = s[BOX + i], s[BOY + i], s[BOZ + i], s[BDX + i], s[BDY + i], s[BDZ + i]
        d_t = -((n0 * b0 + n1 * b1 + n2 * b2) + t * (n0 * b3 + n1 * b4 + n2 * b5)) * inv_slope
        r0, r1, r2 = b0 + d_t * d0 + t * b3, b1 + d_t * d1 + t * b4, b2 + d_t * d2 + t * b5
        d_cos = b3 * n0 + b4 * n1 + b5 * n2
        if sphere:
            m0, m1, m2 = r0 * inv_r, r1 * inv_r, r2 * inv_r
            d_cos += d0 * m0 + d1 * m1 + d2 * m2
        normal_part = gain * d_cos
        nb3 = ratio * b3 + normal_part * n0 + bend * m0
        nb4 = ratio * b4 + normal_part * n1 + bend * m1
        nb5 = ratio * b5 + normal_part * n2 + bend * m2
        code = s[CODE + i]
        live = code == 0.0
        good = live and hit and radicand >= 0.0
        s[CODE + i] = code if not live else (0.0 if good else (1.0 if not hit else 2.0))
        s[SURFACE + i] = s[SURFACE + i] if good or not live else float(surface)
        if good:
            scale = ratio
        else:  # keep the state the ray had
            q0, q1, q2, na3, na4, na5, r0, r1, r2, nb3, nb4, nb5 = a0, a1, a2, a3, a4, a5, b0, b1, b2, b3, b4, b5
            t, bend, scale = 0.0, 0.0, 1.0
        s[OX + i], s[OY + i], s[OZ + i] = o0 + t * d0, o1 + t * d1, o2 + t * d2
        s[DX + i], s[DY + i], s[DZ + i] = scale * d0 + bend * n0, scale * d1 + bend * n1, scale * d2 + bend * n2
        s[AOX + i], s[AOY + i], s[AOZ + i], s[ADX + i], s[ADY + i], s[ADZ + i] = q0, q1, q2, na3, na4, na5
        s[BOX + i], s[BOY + i], s[BOZ + i], s[BDX + i], s[BDY + i], s[BDZ + i] = r0, r1, r2, nb3, nb4, nb5


@njit(**_OPTIONS)
def _trace_block(m, pix, camera, table, count, min_advance, s):
    """Pixels (m, 2) of one camera (a camera row, its surface rows, how many) → camera-frame rays with
    their derivatives in the scratch ``s``; returns how many rows cannot be undistorted."""
    f, xp, yp, sy = camera[0], camera[1], camera[2], camera[3]
    k1, k2, p1, p2, k3 = camera[4], camera[5], camera[6], camera[7], camera[8]
    _normalise(m, pix, f, xp, yp, sy, s)
    distorted = k1 != 0.0 or k2 != 0.0 or k3 != 0.0 or p1 != 0.0 or p2 != 0.0
    unusable = 0
    if distorted:
        left = _newton_first(m, s, k1, k2, k3, p1, p2)
        steps = 3
        while left > 0 and steps < 60:
            left = _newton_again(m, s, k1, k2, k3, p1, p2)
            steps += 1
        unusable = _count_unusable(m, s)
    _start_rays(m, s, f, sy, distorted)
    for q in range(count):
        _refract_block(m, s, q, table[q, 0] == 1.0, table[q, 1], table[q, 2], table[q, 3], table[q, 4],
                       table[q, 5], table[q, 6], min_advance)
    return unusable


@njit(**_OPTIONS)
def _to_object(m, s, camera):
    """The block's rays and derivatives from the camera frame into object space (in place): origins
    X0 + Mᵀ p, vectors Mᵀ v."""
    m00, m01, m02, m10, m11, m12 = camera[9], camera[10], camera[11], camera[12], camera[13], camera[14]
    m20, m21, m22, p0, p1, p2 = camera[15], camera[16], camera[17], camera[18], camera[19], camera[20]
    for i in range(m):
        x, y, z = s[OX + i], s[OY + i], s[OZ + i]
        s[OX + i] = p0 + m00 * x + m10 * y + m20 * z
        s[OY + i] = p1 + m01 * x + m11 * y + m21 * z
        s[OZ + i] = p2 + m02 * x + m12 * y + m22 * z
        x, y, z = s[DX + i], s[DY + i], s[DZ + i]
        s[DX + i] = m00 * x + m10 * y + m20 * z
        s[DY + i] = m01 * x + m11 * y + m21 * z
        s[DZ + i] = m02 * x + m12 * y + m22 * z
        x, y, z = s[AOX + i], s[AOY + i], s[AOZ + i]
        s[AOX + i] = m00 * x + m10 * y + m20 * z
        s[AOY + i] = m01 * x + m11 * y + m21 * z
        s[AOZ + i] = m02 * x + m12 * y + m22 * z
        x, y, z = s[ADX + i], s[ADY + i], s[ADZ + i]
        s[ADX + i] = m00 * x + m10 * y + m20 * z
        s[ADY + i] = m01 * x + m11 * y + m21 * z
        s[ADZ + i] = m02 * x + m12 * y + m22 * z
        x, y, z = s[BOX + i], s[BOY + i], s[BOZ + i]
        s[BOX + i] = m00 * x + m10 * y + m20 * z
        s[BOY + i] = m01 * x + m11 * y + m21 * z
        s[BOZ + i] = m02 * x + m12 * y + m22 * z
        x, y, z = s[BDX + i], s[BDY + i], s[BDZ + i]
        s[BDX + i] = m00 * x + m10 * y + m20 * z
        s[BDY + i] = m01 * x + m11 * y + m21 * z
        s[BDZ + i] = m02 * x + m12 * y + m22 * z


@njit(**_OPTIONS)
def _add_midpoint_rows(m, s, shared, first):
    """Add one camera's rays to the midpoint's normal equations Σ (I − d dᵀ) x = Σ (I − d dᵀ) o (set them
    when ``first``), and its failures to the shared FAILED flags."""
    for i in range(m):
        o0, o1, o2, d0, d1, d2 = s[OX + i], s[OY + i], s[OZ + i], s[DX + i], s[DY + i], s[DZ + i]
        along = d0 * o0 + d1 * o1 + d2 * o2
        e00, e01, e02, e11, e12, e22 = 1.0 - d0 * d0, -d0 * d1, -d0 * d2, 1.0 - d1 * d1, -d1 * d2, 1.0 - d2 * d2
        f0, f1, f2 = o0 - along * d0, o1 - along * d1, o2 - along * d2
        failed = s[CODE + i] != 0.0
        if not first:
            e00 += shared[A00 + i]
            e01 += shared[A01 + i]
            e02 += shared[A02 + i]
            e11 += shared[A11 + i]
            e12 += shared[A12 + i]
            e22 += shared[A22 + i]
            f0 += shared[R0 + i]
            f1 += shared[R1 + i]
            f2 += shared[R2 + i]
            failed = failed or shared[FAILED + i] != 0.0
        shared[A00 + i], shared[A01 + i], shared[A02 + i] = e00, e01, e02
        shared[A11 + i], shared[A12 + i], shared[A22 + i] = e11, e12, e22
        shared[R0 + i], shared[R1 + i], shared[R2 + i] = f0, f1, f2
        shared[FAILED + i] = 1.0 if failed else 0.0


@njit(**_OPTIONS)
def _solve_block(m, shared, first):
    """Solve the block's symmetric 3×3 normal equations by the adjugate (as ``intersection._solve3``):
    the points X, the inverse C (zeros where ill-conditioned) and the GOOD flags (set when ``first``,
    else combined)."""
    for i in range(m):
        a00, a01, a02 = shared[A00 + i], shared[A01 + i], shared[A02 + i]
        a11, a12, a22 = shared[A11 + i], shared[A12 + i], shared[A22 + i]
        c00 = a11 * a22 - a12 * a12
        c01 = a12 * a02 - a01 * a22
        c02 = a01 * a12 - a11 * a02
        c11 = a00 * a22 - a02 * a02
        c12 = a01 * a02 - a00 * a12
        c22 = a00 * a11 - a01 * a01
        det = a00 * c00 + a01 * c01 + a02 * c02
        scale = max(a00 * a00 + a11 * a11 + a22 * a22 + 2.0 * (a01 * a01 + a02 * a02 + a12 * a12), 1e-300)
        well = abs(det) > 1e-12 * scale * math.sqrt(scale)
        inv = (1.0 / det) if well else 0.0
        c00, c01, c02, c11, c12, c22 = c00 * inv, c01 * inv, c02 * inv, c11 * inv, c12 * inv, c22 * inv
        b0, b1, b2 = shared[R0 + i], shared[R1 + i], shared[R2 + i]
        shared[X0 + i] = c00 * b0 + c01 * b1 + c02 * b2
        shared[X1 + i] = c01 * b0 + c11 * b1 + c12 * b2
        shared[X2 + i] = c02 * b0 + c12 * b1 + c22 * b2
        shared[C00 + i], shared[C01 + i], shared[C02 + i] = c00, c01, c02
        shared[C11 + i], shared[C12 + i], shared[C22 + i] = c11, c12, c22
        good = well if first else (well and shared[GOOD + i] != 0.0)
        shared[GOOD + i] = 1.0 if good else 0.0


@njit(**_OPTIONS)
def _add_weighted_rows(m, s, shared, weights, first):
    """Add one camera's rays, each weighted by its pixel Jacobian at the depth of the points X and by
    ``weights`` (m,) = 1/σ² (1/px²), to the normal equations (set them when ``first``). The Jacobian's
    rows a0, a1 (∂pixel/∂X, pixels per metre) go to the camera's Q rows: a pixel step moves the ray at
    depth s by B = (I − d dᵀ)(∂o/∂p + s ∂d/∂p), and the point's pixel moves by A = (BᵀB)⁻¹Bᵀ."""
    for i in range(m):
        o0, o1, o2, d0, d1, d2 = s[OX + i], s[OY + i], s[OZ + i], s[DX + i], s[DY + i], s[DZ + i]
        along = (shared[X0 + i] - o0) * d0 + (shared[X1 + i] - o1) * d1 + (shared[X2 + i] - o2) * d2
        m0x = s[AOX + i] + along * s[ADX + i]
        m0y = s[AOY + i] + along * s[ADY + i]
        m0z = s[AOZ + i] + along * s[ADZ + i]
        m1x = s[BOX + i] + along * s[BDX + i]
        m1y = s[BOY + i] + along * s[BDY + i]
        m1z = s[BOZ + i] + along * s[BDZ + i]
        p0 = d0 * m0x + d1 * m0y + d2 * m0z
        p1 = d0 * m1x + d1 * m1y + d2 * m1z
        b0x, b0y, b0z = m0x - p0 * d0, m0y - p0 * d1, m0z - p0 * d2
        b1x, b1y, b1z = m1x - p1 * d0, m1y - p1 * d1, m1z - p1 * d2
        g00 = b0x * b0x + b0y * b0y + b0z * b0z
        g01 = b0x * b1x + b0y * b1y + b0z * b1z
        g11 = b1x * b1x + b1y * b1y + b1z * b1z
        det = g00 * g11 - g01 * g01
        valid = det > 1e-30 * max(g00 * g11, 1e-300)
        inv = 1.0 / (det if valid else 1.0)
        e00, e01, e11 = g11 * inv, -g01 * inv, g00 * inv
        q0x, q0y, q0z = e00 * b0x + e01 * b1x, e00 * b0y + e01 * b1y, e00 * b0z + e01 * b1z
        q1x, q1y, q1z = e01 * b0x + e11 * b1x, e01 * b0y + e11 * b1y, e01 * b0z + e11 * b1z
        s[Q0X + i], s[Q0Y + i], s[Q0Z + i], s[Q1X + i], s[Q1Y + i], s[Q1Z + i] = q0x, q0y, q0z, q1x, q1y, q1z
        w = weights[i]
        c0 = w * (q0x * o0 + q0y * o1 + q0z * o2)
        c1 = w * (q1x * o0 + q1y * o1 + q1z * o2)
        e0 = w * (q0x * q0x + q1x * q1x)
        e1 = w * (q0x * q0y + q1x * q1y)
        e2 = w * (q0x * q0z + q1x * q1z)
        e3 = w * (q0y * q0y + q1y * q1y)
        e4 = w * (q0y * q0z + q1y * q1z)
        e5 = w * (q0z * q0z + q1z * q1z)
        f0, f1, f2 = c0 * q0x + c1 * q1x, c0 * q0y + c1 * q1y, c0 * q0z + c1 * q1z
        if not first:
            e0 += shared[A00 + i]
            e1 += shared[A01 + i]
            e2 += shared[A02 + i]
            e3 += shared[A11 + i]
            e4 += shared[A12 + i]
            e5 += shared[A22 + i]
            f0 += shared[R0 + i]
            f1 += shared[R1 + i]
            f2 += shared[R2 + i]
        shared[A00 + i], shared[A01 + i], shared[A02 + i] = e0, e1, e2
        shared[A11 + i], shared[A12 + i], shared[A22 + i] = e3, e4, e5
        shared[R0 + i], shared[R1 + i], shared[R2 + i] = f0, f1, f2
        shared[GOOD + i] = 1.0 if valid and shared[GOOD + i] != 0.0 else 0.0


@njit(**_OPTIONS)
def _residuals_block(m, s, shared, residuals_m, residuals_px, first):
    """Each point's perpendicular miss of one camera's ray, in metres and (through the Q rows) in pixels,
    into the (m,) outputs; a point not ahead of the ray's origin sets BEHIND (set when ``first``)."""
    for i in range(m):
        d0, d1, d2 = s[DX + i], s[DY + i], s[DZ + i]
        w0, w1, w2 = shared[X0 + i] - s[OX + i], shared[X1 + i] - s[OY + i], shared[X2 + i] - s[OZ + i]
        along = w0 * d0 + w1 * d1 + w2 * d2
        behind = along <= 0.0 if first else (along <= 0.0 or shared[BEHIND + i] != 0.0)
        shared[BEHIND + i] = 1.0 if behind else 0.0
        q0, q1, q2 = w0 - along * d0, w1 - along * d1, w2 - along * d2
        residuals_m[i] = math.sqrt(q0 * q0 + q1 * q1 + q2 * q2)
        e0 = s[Q0X + i] * q0 + s[Q0Y + i] * q1 + s[Q0Z + i] * q2
        e1 = s[Q1X + i] * q0 + s[Q1Y + i] * q1 + s[Q1Z + i] * q2
        residuals_px[i] = math.sqrt(e0 * e0 + e1 * e1)


@njit(**_OPTIONS)
def _write_points(m, shared, points, covariance, status):
    """The block's status (FAILED_RAY, else PARALLEL_RAYS, else DIVERGING_RAYS, else OK), points (m, 3)
    and covariances (m, 3, 3); rows that are not OK get zeros."""
    for i in range(m):
        failed, good, behind = shared[FAILED + i] != 0.0, shared[GOOD + i] != 0.0, shared[BEHIND + i] != 0.0
        code = FAILED_RAY if failed else (PARALLEL_RAYS if not good else (DIVERGING_RAYS if behind else OK))
        ok = code == OK
        status[i] = code
        x0, x1, x2 = (shared[X0 + i], shared[X1 + i], shared[X2 + i]) if ok else (0.0, 0.0, 0.0)
        points[i, 0], points[i, 1], points[i, 2] = x0, x1, x2
        c00, c01, c02 = (shared[C00 + i], shared[C01 + i], shared[C02 + i]) if ok else (0.0, 0.0, 0.0)
        c11, c12, c22 = (shared[C11 + i], shared[C12 + i], shared[C22 + i]) if ok else (0.0, 0.0, 0.0)
        covariance[i, 0, 0], covariance[i, 0, 1], covariance[i, 0, 2] = c00, c01, c02
        covariance[i, 1, 0], covariance[i, 1, 1], covariance[i, 1, 2] = c01, c11, c12
        covariance[i, 2, 0], covariance[i, 2, 1], covariance[i, 2, 2] = c02, c12, c22


@njit(**_OPTIONS)
def _zero_failed(m, status, residuals_m, residuals_px):
    """Zero one camera's residuals (m,) where the point is not OK."""
    for i in range(m):
        ok = status[i] == OK
        residuals_m[i] = residuals_m[i] if ok else 0.0
        residuals_px[i] = residuals_px[i] if ok else 0.0


@njit(**_OPTIONS)
def _intersect_block(m, k, scratch, shared, weight_rows, points, covariance, residuals_m, residuals_px, status):
    """The block's points from the k cameras' rays in ``scratch`` (object space) whose midpoint rows are in
    ``shared``: the midpoint, the weighted solution with covariance, residuals and statuses into the
    block's slices of the outputs (points (m, 3), covariance (m, 3, 3), residuals (k, m), status (m,))."""
    _solve_block(m, shared, True)
    for j in range(k):
        _add_weighted_rows(m, scratch[j], shared, weight_rows[j], j == 0)
    _solve_block(m, shared, False)
    for j in range(k):
        _residuals_block(m, scratch[j], shared, residuals_m[j], residuals_px[j], j == 0)
    _write_points(m, shared, points, covariance, status)
    for j in range(k):
        _zero_failed(m, status, residuals_m[j], residuals_px[j])


@njit(cache=True, error_model="numpy", fastmath=_FAST, nogil=True)
def intersect_pixels(pixels, cameras, surfaces, counts, weights, min_advance):
    """Pixels of k cameras → intersected points with covariance, block by block (the compiled
    ``intersection.intersect``): ``pixels`` a tuple of k (N, 2) arrays, ``cameras`` (k, 21) rows (f, xp,
    yp, sy, k1, k2, p1, p2, k3, M row by row, X0, Y0, Z0), ``surfaces`` (k, m, 7) rows (kind 0 plane /
    1 sphere, normal or centre, offset or radius, n_in/n_out, 1/radius), ``counts`` (k,) surfaces per
    camera, ``weights`` (1 or N, k) 1/σ² (1/px²). Returns points (N, 3), covariance (N, 3, 3),
    residuals in metres and pixels (N, k), status (N,) and how many pixels cannot be undistorted (the
    caller then lets the reference path name them)."""
    k, n = len(pixels), pixels[0].shape[0]
    points = np.empty((n, 3))
    covariance = np.empty((n, 3, 3))
    residuals_m = np.empty((k, n))
    residuals_px = np.empty((k, n))
    status = np.empty(n, dtype=np.uint8)
    scratch = np.empty((k, CAMERA_ROWS))
    shared = np.empty(SHARED_ROWS)
    weight_rows = np.empty((k, BLOCK))
    unusable = 0
    for lo in range(0, n, BLOCK):
        m = min(BLOCK, n - lo)
        for j in range(k):
            s = scratch[j]
            unusable += _trace_block(m, pixels[j][lo:lo + m], cameras[j], surfaces[j], counts[j], min_advance, s)
            _to_object(m, s, cameras[j])
            _add_midpoint_rows(m, s, shared, j == 0)
            if weights.shape[0] > 1:
                weight_rows[j, :m] = weights[lo:lo + m, j]
            else:
                weight_rows[j, :m] = weights[0, j]
        _intersect_block(m, k, scratch, shared, weight_rows, points[lo:lo + m], covariance[lo:lo + m],
                         residuals_m[:, lo:lo + m], residuals_px[:, lo:lo + m], status[lo:lo + m])
    return points, covariance, residuals_m.T.copy(), residuals_px.T.copy(), status, unusable


@njit(**_OPTIONS)
def _load_rays(m, origins, directions, d_origins, d_directions, ok, s):
    """Traced object-space rays (m, 3), their derivatives per pixel (m, 3, 2) and validity (m,) into the
    scratch ``s``."""
    for i in range(m):
        s[OX + i], s[OY + i], s[OZ + i] = origins[i, 0], origins[i, 1], origins[i, 2]
        s[DX + i], s[DY + i], s[DZ + i] = directions[i, 0], directions[i, 1], directions[i, 2]
        s[AOX + i], s[AOY + i], s[AOZ + i] = d_origins[i, 0, 0], d_origins[i, 1, 0], d_origins[i, 2, 0]
        s[ADX + i], s[ADY + i], s[ADZ + i] = d_directions[i, 0, 0], d_directions[i, 1, 0], d_directions[i, 2, 0]
        s[BOX + i], s[BOY + i], s[BOZ + i] = d_origins[i, 0, 1], d_origins[i, 1, 1], d_origins[i, 2, 1]
        s[BDX + i], s[BDY + i], s[BDZ + i] = d_directions[i, 0, 1], d_directions[i, 1, 1], d_directions[i, 2, 1]
        s[CODE + i] = 0.0 if ok[i] else 1.0


@njit(cache=True, error_model="numpy", fastmath=_FAST, nogil=True)
def intersect_rays(origins, directions, d_origins, d_directions, ray_ok, weights):
    """``intersection.intersect_traced`` block by block: tuples over the k cameras of object-space
    origins, unit directions (N, 3), their derivatives per pixel (N, 3, 2) and whether each ray is valid
    (N,); ``weights`` (1 or N, k) 1/σ² (1/px²). Returns points, covariance, residuals (metres, pixels)
    and status."""
    k, n = len(origins), origins[0].shape[0]
    points = np.empty((n, 3))
    covariance = np.empty((n, 3, 3))
    residuals_m = np.empty((k, n))
    residuals_px = np.empty((k, n))
    status = np.empty(n, dtype=np.uint8)
    scratch = np.empty((k, CAMERA_ROWS))
    shared = np.empty(SHARED_ROWS)
    weight_rows = np.empty((k, BLOCK))
    for lo in range(0, n, BLOCK):
        m = min(BLOCK, n - lo)
        for j in range(k):
            s = scratch[j]
            _load_rays(m, origins[j][lo:lo + m], directions[j][lo:lo + m], d_origins[j][lo:lo + m],
                       d_directions[j][lo:lo + m], ray_ok[j][lo:lo + m], s)
            _add_midpoint_rows(m, s, shared, j == 0)
            if weights.shape[0] > 1:
                weight_rows[j, :m] = weights[lo:lo + m, j]
            else:
                weight_rows[j, :m] = weights[0, j]
        _intersect_block(m, k, scratch, shared, weight_rows, points[lo:lo + m], covariance[lo:lo + m],
                         residuals_m[:, lo:lo + m], residuals_px[:, lo:lo + m], status[lo:lo + m])
    return points, covariance, residuals_m.T.copy(), residuals_px.T.copy(), status


@njit(**_OPTIONS)
def _write_rays(m, s, origins, directions, d_origins, d_directions, status, failed):
    """The block's object-space rays and derivatives from the scratch into (m, 3) and (m, 3, 2) outputs,
    with the ray status and the surface where a ray failed (−1)."""
    for i in range(m):
        origins[i, 0], origins[i, 1], origins[i, 2] = s[OX + i], s[OY + i], s[OZ + i]
        directions[i, 0], directions[i, 1], directions[i, 2] = s[DX + i], s[DY + i], s[DZ + i]
        d_origins[i, 0, 0], d_origins[i, 1, 0], d_origins[i, 2, 0] = s[AOX + i], s[AOY + i], s[AOZ + i]
        d_directions[i, 0, 0], d_directions[i, 1, 0], d_directions[i, 2, 0] = s[ADX + i], s[ADY + i], s[ADZ + i]
        d_origins[i, 0, 1], d_origins[i, 1, 1], d_origins[i, 2, 1] = s[BOX + i], s[BOY + i], s[BOZ + i]
        d_directions[i, 0, 1], d_directions[i, 1, 1], d_directions[i, 2, 1] = s[BDX + i], s[BDY + i], s[BDZ + i]
        status[i] = np.uint8(s[CODE + i])
        failed[i] = np.int16(s[SURFACE + i])


@njit(cache=True, error_model="numpy", fastmath=_FAST, nogil=True)
def trace_pixels(pixels, camera, table, count, min_advance, origins, directions, d_origins, d_directions, status,
                 failed):
    """``Camera.rays_with_derivatives`` block by block: pixels (N, 2) of one camera (its row, surface rows
    and their count, as for :func:`intersect_pixels`) → object-space origins, unit directions (N, 3) and
    their derivatives per pixel (N, 3, 2), status (N,) and failed surface (N,), written into the given
    arrays. Returns how many pixels cannot be undistorted (the reference path then names them)."""
    scratch = np.empty(CAMERA_ROWS)
    unusable = 0
    for lo in range(0, pixels.shape[0], BLOCK):
        m = min(BLOCK, pixels.shape[0] - lo)
        unusable += _trace_block(m, pixels[lo:lo + m], camera, table, count, min_advance, scratch)
        _to_object(m, scratch, camera)
        _write_rays(m, scratch, origins[lo:lo + m], directions[lo:lo + m], d_origins[lo:lo + m],
                    d_directions[lo:lo + m], status[lo:lo + m], failed[lo:lo + m])
    return unusable


@njit(**_OPTIONS)
def _gauss_newton_pass(m, s, points):
    """One Gauss–Newton step on (u, v) for every open row of the block, whose rays (U, V) were just traced
    with their derivatives per u and v, so that the ray passes through the camera-frame point (m, 3): a
    ray that failed backs off half-way towards the last good iterate (at most 40 times), a failing start
    falls back to the pinhole direction once, else the row ends with the ray's status; a singular
    Jacobian ends it NOT_CONVERGED; a step below 1e-10, or one that with the step before predicts the
    next below 1e-13 (quadratic convergence), ends it OK (BEHIND_CAMERA where the point lies behind the
    ray's origin). Returns how many rows are still open."""
    open_rows = 0
    for i in range(m):
        state, code = s[STATE + i], s[CODE + i]
        u, v, good_u, good_v = s[U + i], s[V + i], s[GOOD_U + i], s[GOOD_V + i]
        step_u, step_v, halvings, previous = s[STEP_U + i], s[STEP_V + i], s[HALVINGS + i], s[PREVIOUS + i]
        live = state < 0.0
        traced = code == 0.0
        # the miss of the point by the ray and its columns per u and v
        dx, dy, dz = s[DX + i], s[DY + i], s[DZ + i]
        wx, wy, wz = points[i, 0] - s[OX + i], points[i, 1] - s[OY + i], points[i, 2] - s[OZ + i]
        along = wx * dx + wy * dy + wz * dz
        mx, my, mz = wx - along * dx, wy - along * dy, wz - along * dz
        a0, a1, a2, a3, a4, a5 = s[AOX + i], s[AOY + i], s[AOZ + i], s[ADX + i], s[ADY + i], s[ADZ + i]
        d_along = -(a0 * dx + a1 * dy + a2 * dz) + (wx * a3 + wy * a4 + wz * a5)
        ux, uy, uz = -a0 - d_along * dx - along * a3, -a1 - d_along * dy - along * a4, -a2 - d_along * dz - along * a5
        b0, b1, b2, b3, b4, b5 = s[BOX + i], s[BOY + i], s[BOZ + i], s[BDX + i], s[BDY + i], s[BDZ + i]
        d_along = -(b0 * dx + b1 * dy + b2 * dz) + (wx * b3 + wy * b4 + wz * b5)
        vx, vy, vz = -b0 - d_along * dx - along * b3, -b1 - d_along * dy - along * b4, -b2 - d_along * dz - along * b5
        a11 = ux * ux + uy * uy + uz * uz
        a12 = ux * vx + uy * vy + uz * vz
        a22 = vx * vx + vy * vy + vz * vz
        r1 = ux * mx + uy * my + uz * mz
        r2 = vx * mx + vy * my + vz * mz
        det = a11 * a22 - a12 * a12
        regular = det > 1e-300
        inv = 1.0 / (det if regular else 1.0)
        du = -(a22 * r1 - a12 * r2) * inv
        dv = -(a11 * r2 - a12 * r1) * inv
        size = max(abs(du), abs(dv))
        converged = size < 1e-10 or (size < 1e-5 and size * size * size < 1e-13 * previous * previous)
        known = good_u == good_u  # a good iterate exists (not NaN)
        retry = live and not traced and known and halvings < 40.0
        restart = live and not traced and not known and halvings == 0.0
        advance = live and traced and regular
        if retry:
            step_u, step_v = 0.5 * step_u, 0.5 * step_v
            u, v = good_u + step_u, good_v + step_v
            halvings += 1.0
            previous = math.inf
        elif restart:
            u, v = s[START_U + i], s[START_V + i]
            halvings = 1.0
        elif advance:
            good_u, good_v = u, v
            step_u, step_v = du, dv
            u, v = u + du, v + dv
            halvings = 0.0
            previous = size
        if live and not traced and not retry and not restart:
            state = code
        elif live and traced and not regular:
            state = float(NOT_CONVERGED)
        elif advance and converged:
            state = float(BEHIND_CAMERA) if along <= 0.0 else float(OK)
        s[U + i], s[V + i], s[GOOD_U + i], s[GOOD_V + i] = u, v, good_u, good_v
        s[STEP_U + i], s[STEP_V + i], s[HALVINGS + i], s[PREVIOUS + i] = step_u, step_v, halvings, previous
        s[STATE + i] = state
        open_rows += state < 0.0
    return open_rows


@njit(cache=True, error_model="numpy", fastmath=_FAST, nogil=True)
def back_project(points, start, warm, table, count, indices, proxy, min_advance):
    """``camera._back_project_general`` block by block: the ideal normalised (u, v) (N, 2) of the rays
    through camera-frame points (N, 3) and a status (N,); ``start`` the pinhole (u, v), ``warm`` given
    starts (rows of NaN: none), ``table`` and ``count`` the surface rows (as for
    :func:`intersect_pixels`), ``indices`` the media's refractive indices, ``proxy`` the outer plane
    whose air-to-water solve starts the others (axis, distance; distance 0: the pinhole start). At most
    80 Gauss–Newton passes over a block."""
    n = points.shape[0]
    uv = np.empty((n, 2))
    status = np.empty(n, dtype=np.uint8)
    s = np.empty(CAMERA_ROWS)
    for lo in range(0, n, BLOCK):
        m = min(BLOCK, n - lo)
        for i in range(m):
            r = lo + i
            u, v = warm[r, 0], warm[r, 1]
            if not (math.isfinite(u) and math.isfinite(v)):
                u, v = _proxy_start(points[r, 0], points[r, 1], points[r, 2], indices, proxy)
                if not (math.isfinite(u) and math.isfinite(v)):
                    u, v = start[r, 0], start[r, 1]
            s[U + i], s[V + i] = u, v
            s[START_U + i], s[START_V + i] = start[r, 0], start[r, 1]
            s[GOOD_U + i] = s[GOOD_V + i] = math.nan
            s[STEP_U + i] = s[STEP_V + i] = s[HALVINGS + i] = 0.0
            s[PREVIOUS + i] = math.inf
            s[STATE + i] = -1.0
        block = points[lo:lo + m]
        for _ in range(80):
            _start_rays(m, s, 0.0, 1.0, False)
            for q in range(count):
                _refract_block(m, s, q, table[q, 0] == 1.0, table[q, 1], table[q, 2], table[q, 3], table[q, 4],
                               table[q, 5], table[q, 6], min_advance)
            if _gauss_newton_pass(m, s, block) == 0:
                break
        for i in range(m):
            state = s[STATE + i]
            uv[lo + i, 0], uv[lo + i, 1] = s[U + i], s[V + i]
            status[lo + i] = NOT_CONVERGED if state < 0.0 else np.uint8(state)
    return uv, status


# -------------------------------------------------------------------------------------------------
# rays of given camera-frame directions, without derivatives
# -------------------------------------------------------------------------------------------------

@njit(cache=True, error_model="numpy", fastmath=_FAST, nogil=True)
def trace_ideal(uv, camera, table, count, min_advance, origins, directions, status, failed):
    """``Camera.rays`` of ideal normalised coordinates (N, 2) (the camera-frame rays (u, v, −1), no lens),
    without derivatives: through the surface rows of ``table`` (``count`` of them) as
    :func:`_refract_block` does, then into object space with the camera row's rotation and centre.
    Writes origins, unit directions (N, 3), a status per ray (0 OK, 1 missed, 2 totally reflected) and the
    surface where it failed (−1); a failed ray keeps the state it had before that surface."""
    m00, m01, m02, m10, m11, m12 = camera[9], camera[10], camera[11], camera[12], camera[13], camera[14]
    m20, m21, m22, c0, c1, c2 = camera[15], camera[16], camera[17], camera[18], camera[19], camera[20]
    for i in range(uv.shape[0]):
        uu, vv = uv[i, 0], uv[i, 1]
        inv_length = 1.0 / math.sqrt(uu * uu + vv * vv + 1.0)
        o0, o1, o2, d0, d1, d2 = 0.0, 0.0, 0.0, uu * inv_length, vv * inv_length, -inv_length
        code, where = 0, -1
        for q in range(count):
            gx, gy, gz, gw = table[q, 1], table[q, 2], table[q, 3], table[q, 4]
            ratio, inv_r = table[q, 5], table[q, 6]
            if table[q, 0] == 1.0:  # a sphere: the first crossing strictly ahead of the origin
                f0, f1, f2 = o0 - gx, o1 - gy, o2 - gz
                w = d0 * f0 + d1 * f1 + d2 * f2
                disc = w * w - (f0 * f0 + f1 * f1 + f2 * f2 - gw * gw)
                root = math.sqrt(max(disc, 0.0))
                near = -w - root
                t = near if near > min_advance else -w + root
                hit = disc >= 0.0 and t > min_advance
                n0, n1, n2 = (f0 + t * d0) * inv_r, (f1 + t * d1) * inv_r, (f2 + t * d2) * inv_r
                slope = n0 * d0 + n1 * d1 + n2 * d2
            else:
                slope = d0 * gx + d1 * gy + d2 * gz
                usable = abs(slope) > 1e-15
                t = -(o0 * gx + o1 * gy + o2 * gz + gw) / (slope if usable else 1.0)
                hit = usable and t > min_advance
                n0, n1, n2 = gx, gy, gz
            sign = -1.0 if slope < 0.0 else 1.0
            cos_in = slope * sign
            radicand = 1.0 - ratio * ratio * (1.0 - cos_in * cos_in)
            if not hit or radicand < 0.0:
                code, where = (1 if not hit else 2), q
                break
            bend = (math.sqrt(radicand) - ratio * cos_in) * sign
            o0, o1, o2 = o0 + t * d0, o1 + t * d1, o2 + t * d2
            d0, d1, d2 = ratio * d0 + bend * n0, ratio * d1 + bend * n1, ratio * d2 + bend * n2
        origins[i, 0] = c0 + m00 * o0 + m10 * o1 + m20 * o2
        origins[i, 1] = c1 + m01 * o0 + m11 * o1 + m21 * o2
        origins[i, 2] = c2 + m02 * o0 + m12 * o1 + m22 * o2
        directions[i, 0] = m00 * d0 + m10 * d1 + m20 * d2
        directions[i, 1] = m01 * d0 + m11 * d1 + m21 * d2
        directions[i, 2] = m02 * d0 + m12 * d1 + m22 * d2
        status[i] = code
        failed[i] = where


# -------------------------------------------------------------------------------------------------
# the pixel motions of a calibration's parameters (core/calibration/point_derivatives.pixel_motions)
# -------------------------------------------------------------------------------------------------

@njit(cache=True, error_model="numpy", fastmath=_FAST, nogil=True)
def add_pose_shifts(rows, origins, directions, along, centre, turns, shifts, columns, out):
    """Add to ``out`` (N, 2, m) the pixel motions A m of rigid camera motions: for each e, column
    ``columns[e]`` gains A ((Q − C_b) T_e + c_e), with A = ``rows`` (N, 2, 3), Q = origin + along·direction
    the ray's point at the point's depth, C_b = ``centre``, T_e = ``turns[e]`` (3, 3) and c_e =
    ``shifts[e]`` (3,) (object vectors are rows)."""
    for n in range(rows.shape[0]):
        q0 = origins[n, 0] + along[n] * directions[n, 0] - centre[0]
        q1 = origins[n, 1] + along[n] * directions[n, 1] - centre[1]
        q2 = origins[n, 2] + along[n] * directions[n, 2] - centre[2]
        for e in range(columns.shape[0]):
            k = columns[e]
            m0 = q0 * turns[e, 0, 0] + q1 * turns[e, 1, 0] + q2 * turns[e, 2, 0] + shifts[e, 0]
            m1 = q0 * turns[e, 0, 1] + q1 * turns[e, 1, 1] + q2 * turns[e, 2, 1] + shifts[e, 1]
            m2 = q0 * turns[e, 0, 2] + q1 * turns[e, 1, 2] + q2 * turns[e, 2, 2] + shifts[e, 2]
            out[n, 0, k] += rows[n, 0, 0] * m0 + rows[n, 0, 1] * m1 + rows[n, 0, 2] * m2
            out[n, 1, k] += rows[n, 1, 0] * m0 + rows[n, 1, 1] * m1 + rows[n, 1, 2] * m2


@njit(cache=True, error_model="numpy", fastmath=_FAST, nogil=True)
def add_housing_shift(rows, along, minus_origins, minus_directions, minus_status, plus_origins, plus_directions,
                      plus_status, span, column, out):
    """Add to column ``column`` of ``out`` (N, 2, m) the pixel motion A m / span of a housing parameter
    stepped by ``span``: m = (plus − minus) ray points at the point's depth ``along``; zero where either
    stepped ray failed (status ≠ 0)."""
    for n in range(rows.shape[0]):
        if minus_status[n] != 0 or plus_status[n] != 0:
            continue
        m0 = (plus_directions[n, 0] - minus_directions[n, 0]) * along[n] + plus_origins[n, 0] - minus_origins[n, 0]
        m1 = (plus_directions[n, 1] - minus_directions[n, 1]) * along[n] + plus_origins[n, 1] - minus_origins[n, 1]
        m2 = (plus_directions[n, 2] - minus_directions[n, 2]) * along[n] + plus_origins[n, 2] - minus_origins[n, 2]
        out[n, 0, column] += (rows[n, 0, 0] * m0 + rows[n, 0, 1] * m1 + rows[n, 0, 2] * m2) / span
        out[n, 1, column] += (rows[n, 1, 0] * m0 + rows[n, 1, 1] * m1 + rows[n, 1, 2] * m2) / span
