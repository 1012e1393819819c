"""Omega-phi-kappa rotations, as in the thesis (Li 1995, eq. 2.3 and App. B, eq. B.1).

``rotation_matrix(omega, phi, kappa)`` returns M, the matrix of the collinearity equations (2.3):
it rotates object-space vectors into the camera's image coordinate system,

    (x̄, ȳ, z̄)ᵀ = M · (X − X0, Y − Y0, Z − Z0)ᵀ,        M = R_κ · R_φ · R_ω,

with angles in radians: ω about the object X axis first, then φ about the once-rotated Y axis, then κ
about the twice-rotated Z axis (Wolf 1974). The element formulas printed in App. B (B.1) are exactly
these of M; B.1 applies them to (x, y, −f) to reach object space, which needs the transpose Mᵀ
(an index slip in the print). We use M for object → image and Mᵀ for image → object, as eq. 2.3 and
eq. 2.14 ("R, the rotation from the image to the object system") require.
"""

from __future__ import annotations

import numpy as np


def rotation_matrix(omega, phi, kappa) -> np.ndarray:
    """M (object → image) for angles in radians; scalars give (3, 3), arrays of shape S give S + (3, 3)."""
    omega, phi, kappa = np.broadcast_arrays(
        np.asarray(omega, dtype=np.float64),
        np.asarray(phi, dtype=np.float64),
        np.asarray(kappa, dtype=np.float64),
    )
    so, co = np.sin(omega), np.cos(omega)
    sp, cp = np.sin(phi), np.cos(phi)
    sk, ck = np.sin(kappa), np.cos(kappa)
    m = np.empty(omega.shape + (3, 3))
    m[..., 0, 0] = cp * ck
    m[..., 0, 1] = co * sk + so * sp * ck
    m[..., 0, 2] = so * sk - co * sp * ck
    m[..., 1, 0] = -cp * sk
    m[..., 1, 1] = co * ck - so * sp * sk
    m[..., 1, 2] = so * ck + co * sp * sk
    m[..., 2, 0] = sp
    m[..., 2, 1] = -so * cp
    m[..., 2, 2] = co * cp
    return m


def angles_from_matrix(m: np.ndarray) -> tuple[float, float, float]:
    """(omega, phi, kappa) in radians of an object → image rotation M; phi in [−π/2, π/2].

    Inverse of :func:`rotation_matrix` (exact for |phi| < π/2; at the gimbal lock phi = ±π/2 only
    omega + kappa is defined and kappa is returned as 0).
    """
    m = np.asarray(m, dtype=np.float64)
    phi = float(np.arcsin(np.clip(m[2, 0], -1.0, 1.0)))
    if abs(m[2, 0]) < 1.0 - 1e-12:
        omega = float(np.arctan2(-m[2, 1], m[2, 2]))
        kappa = float(np.arctan2(-m[1, 0], m[0, 0]))
    else:  # gimbal lock: cos(phi) = 0
        omega = float(np.arctan2(m[0, 1], m[1, 1]))
        kappa = 0.0
    return omega, phi, kappa


def object_to_image(m: np.ndarray, vectors: np.ndarray) -> np.ndarray:
    """Rotate object-space vectors (N, 3) into the image (camera) frame: M · v."""
    return vectors @ m.T


def image_to_object(m: np.ndarray, vectors: np.ndarray) -> np.ndarray:
    """Rotate camera-frame vectors (N, 3) into object space: Mᵀ · v."""
    return vectors @ m
