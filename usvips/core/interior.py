"""Interior orientation: pixels ↔ image coordinates ↔ normalised ideal coordinates.

Conventions (ARCHITECTURE.md; thesis 2.2.2, 2.29-2.31):

* Pixel coordinates (x', y'): x right, y down, origin at the centre of the top-left pixel, pixels.
* Image coordinates (x̄, ȳ) in the camera frame: x̄ right, ȳ up, in units of the x pixel spacing,
  relative to the principal point (xp, yp):  x̄ = x' − xp,   ȳ = (yp − y') · sy   (2.29, 2.30).
  The perspective centre is the origin; the image plane lies at z̄ = −f (f in x pixels), so the
  camera looks along −z̄ and a viewing direction in the camera frame is (x̄, ȳ, −f).
* Normalised coordinates: u = x̄ / f, v = ȳ / f (dimensionless; the ray direction is (u, v, −1)).

Lens distortion (Brown 1968, eq. 2.31) is applied to normalised coordinates and maps the *ideal*
(distortion-free, collinear) position to the *observed* one:

    u_d = u + K1·u·r² + K2·u·r⁴ + K3·u·r⁶ + P1·(r² + 2u²) + 2·P2·u·v
    v_d = v + K1·v·r² + K2·v·r⁴ + K3·v·r⁶ + P2·(r² + 2v²) + 2·P1·u·v,        r² = u² + v².

K3 is not in the seeds: it is OpenCV's default third radial term (``cv2.calibrateCamera`` estimates it
unless told not to), carried so that OpenCV calibrations import exactly. It defaults to 0 and the
calibration adjustment keeps it fixed at 0 unless it is freed.

The seeds write δx as a "correction" without saying whether it is added to the measured or to the
computed coordinate; we choose the direction in which projection (object → pixel, the hot path of
every adjustment) is closed-form, as OpenCV does. Parameters published as corrections of *measured*
coordinates are, to first order, the negatives of ours, and in the seeds' (unstated) image units. With
OpenCV's (x right, y down) normalised coordinates: K1 = k1, K2 = k2, K3 = k3, P1 = p2_cv, P2 = −p1_cv,
fx = f, fy = f / sy.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from usvips.core import kernels, validation
from usvips.core.errors import ConvergenceError


@dataclass(frozen=True)
class Interior:
    """Interior orientation of one camera.

    f: principal distance, pixels (x spacing); xp, yp: principal point, pixel coordinates;
    sy: y-scale factor Psy / Psx (dimensionless); k1, k2: radial, p1, p2: decentring distortion
    coefficients on normalised coordinates (dimensionless); k3: OpenCV's third radial coefficient (r⁶
    term, dimensionless, default 0; it comes last so that positional construction keeps its meaning).
    """

    f: float
    xp: float
    yp: float
    sy: float = 1.0
    k1: float = 0.0
    k2: float = 0.0
    p1: float = 0.0
    p2: float = 0.0
    k3: float = 0.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "f", validation.positive("f", self.f))
        object.__setattr__(self, "sy", validation.positive("sy", self.sy))
        for name in ("xp", "yp", "k1", "k2", "p1", "p2", "k3"):
            object.__setattr__(self, name, validation.finite(name, getattr(self, name)))

    @property
    def has_distortion(self) -> bool:
        return any((self.k1, self.k2, self.k3, self.p1, self.p2))

    # pixels <-> image coordinates ------------------------------------------------------------
    def pixels_to_image(self, pixels: np.ndarray) -> np.ndarray:
        """Pixel coordinates (N, 2) → image coordinates x̄, ȳ (N, 2) in x pixels, ȳ up (2.29)."""
        pixels = np.asarray(pixels, dtype=np.float64)
        out = np.empty_like(pixels)
        out[..., 0] = pixels[..., 0] - self.xp
        out[..., 1] = (self.yp - pixels[..., 1]) * self.sy
        return out

    def image_to_pixels(self, image: np.ndarray) -> np.ndarray:
        """Image coordinates x̄, ȳ (N, 2) → pixel coordinates (N, 2)."""
        image = np.asarray(image, dtype=np.float64)
        out = np.empty_like(image)
        out[..., 0] = image[..., 0] + self.xp
        out[..., 1] = self.yp - image[..., 1] / self.sy
        return out

    # distortion ------------------------------------------------------------------------------
    def _distort_components(self, u: np.ndarray, v: np.ndarray, with_jacobian: bool):
        r2 = u * u + v * v
        radial = self.k1 * r2 + (self.k2 + self.k3 * r2) * r2 * r2
        ud = u + u * radial + self.p1 * (r2 + 2 * u * u) + 2 * self.p2 * u * v
        vd = v + v * radial + self.p2 * (r2 + 2 * v * v) + 2 * self.p1 * u * v
        if not with_jacobian:
            return ud, vd
        dradial = 2 * self.k1 + (4 * self.k2 + 6 * self.k3 * r2) * r2  # ∂radial/∂u = dradial·u
        uv_cross = u * v * dradial
        j00 = 1 + radial + u * u * dradial + 6 * self.p1 * u + 2 * self.p2 * v
        j01 = uv_cross + 2 * self.p1 * v + 2 * self.p2 * u
        j10 = uv_cross + 2 * self.p2 * u + 2 * self.p1 * v
        j11 = 1 + radial + v * v * dradial + 6 * self.p2 * v + 2 * self.p1 * u
        return ud, vd, j00, j01, j10, j11

    def distort(self, uv: np.ndarray) -> np.ndarray:
        """Ideal normalised coordinates (N, 2) → observed (distorted) normalised coordinates."""
        uv = np.asarray(uv, dtype=np.float64)
        if not self.has_distortion:
            return uv.copy()
        ud, vd = self._distort_components(uv[..., 0], uv[..., 1], False)
        return np.stack([ud, vd], axis=-1)

    def distortion_jacobian(self, uv: np.ndarray) -> np.ndarray:
        """∂(u_d, v_d)/∂(u, v) at ideal normalised coordinates, shape (N, 2, 2)."""
        _, _, j00, j01, j10, j11 = self._distort_components(uv[..., 0], uv[..., 1], True)
        jac = np.empty(uv.shape[:-1] + (2, 2))
        jac[..., 0, 0], jac[..., 0, 1], jac[..., 1, 0], jac[..., 1, 1] = j00, j01, j10, j11
        return jac

    def folded(self, uv: np.ndarray) -> np.ndarray:
        """True (N,) for ideal normalised coordinates (N, 2) beyond a fold of the distortion polynomial:
        the Jacobian not positive, or the point flipped through the centre. The lens model does not hold
        there (far outside any frame it was calibrated on): its pixel, folded back, can land inside the
        frame, but no observed pixel's ray (:meth:`undistort` refuses such roots) leads to it."""
        uv = np.asarray(uv, dtype=np.float64)
        if not self.has_distortion:
            return np.zeros(uv.shape[0], dtype=bool)
        u, v = uv[:, 0], uv[:, 1]
        ud, vd, j00, j01, j10, j11 = self._distort_components(u, v, True)
        return (j00 * j11 - j01 * j10 <= 0.0) | (u * ud + v * vd < 0.0)

    def undistort(self, uv_distorted: np.ndarray, tolerance: float = 1e-13) -> np.ndarray:
        """Observed normalised coordinates (N, 2) → ideal ones, by Newton's method.

        Converges to ``tolerance`` (normalised units; 1e-13 is ~1e-10 px at f = 1000 px) wherever the
        distortion is invertible. Raises :class:`ConvergenceError` naming the first failing point where
        it is not (a distortion polynomial folding over inside the frame is a bad calibration).
        """
        target = np.asarray(uv_distorted, dtype=np.float64)
        if not self.has_distortion:
            return target.copy()
        if kernels.wanted(len(target)):  # the compiled per-point solve (core/kernels.py)
            solved = kernels.undistort(self, target, tolerance)
            if solved is not None:
                return solved
        tu, tv = target[:, 0], target[:, 1]
        u, v = tu.copy(), tv.copy()
        for _ in range(60):
            ud, vd, j00, j01, j10, j11 = self._distort_components(u, v, True)
            ru, rv = ud - tu, vd - tv
            det = j00 * j11 - j01 * j10
            det = np.where(np.abs(det) > 1e-12, det, 1e-12)
            du = (j11 * ru - j01 * rv) / det
            dv = (j00 * rv - j10 * ru) / det
            u -= du
            v -= dv
            if np.max(np.abs(du)) < tolerance and np.max(np.abs(dv)) < tolerance:
                break
        ud, vd, j00, j01, j10, j11 = self._distort_components(u, v, True)
        residual = np.maximum(np.abs(ud - tu), np.abs(vd - tv))
        # a root on the far side of a fold (Jacobian not positive, or the point flipped through the
        # centre) reproduces the pixel but is not the ray the lens formed
        folded = (j00 * j11 - j01 * j10 <= 0.0) | (u * tu + v * tv < 0.0)
        bad = ~np.isfinite(residual) | (residual > 1e3 * tolerance) | folded
        if np.any(bad):
            first = int(np.flatnonzero(bad)[0])
            raise ConvergenceError(
                f"lens distortion (k1={self.k1:g}, k2={self.k2:g}, k3={self.k3:g}, p1={self.p1:g}, p2={self.p2:g}) "
                f"cannot be inverted at normalised point {target[first].tolist()} (row {first}): "
                "the distortion polynomial folds over there"
            )
        return np.column_stack([u, v])

    # the whole chain ------------------------------------------------------------------------
    def pixels_to_normalised(self, pixels: np.ndarray) -> np.ndarray:
        """Observed pixels (N, 2) → ideal normalised coordinates (u, v); the camera-frame ray is (u, v, −1)."""
        return self.undistort(self.pixels_to_image(pixels) / self.f)

    def normalised_to_pixels(self, uv: np.ndarray) -> np.ndarray:
        """Ideal normalised coordinates (N, 2) → observed pixels (N, 2)."""
        return self.image_to_pixels(self.distort(uv) * self.f)

    def with_values(self, **changes: float) -> Interior:
        """A copy with some parameters changed (parameters are validated again)."""
        values = {name: getattr(self, name) for name in INTERIOR_PARAMETERS}
        values.update(changes)
        return Interior(**values)


INTERIOR_PARAMETERS = ("f", "xp", "yp", "sy", "k1", "k2", "p1", "p2", "k3")
"""Every interior parameter, in the order of :class:`Interior`'s fields (k3 last: older files lack it)."""
