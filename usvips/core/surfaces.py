"""Refracting surfaces, ray–surface intersection and vector refraction (thesis 2.2.3, eq. 2.6-2.13).

Every surface lives in one Cartesian frame (metres) and answers, for N rays at once:
``intersect(origins, directions) -> (t, hit)`` — the distance along each unit direction to the
physically right crossing (the first one strictly ahead of the origin) and whether there is one — and
``normals(points)`` — unit normals (any orientation; :func:`refract` orients them itself).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from usvips.core import validation
from usvips.core.errors import InvalidParameterError

#: Crossings closer than this to a ray's origin (metres) are the surface the ray starts on.
MIN_ADVANCE = 1e-12


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise dot product of (N, 3) arrays (faster than einsum for three columns)."""
    return a[:, 0] * b[:, 0] + a[:, 1] * b[:, 1] + a[:, 2] * b[:, 2]


def refract(
    directions: np.ndarray, normals: np.ndarray, n_in: float, n_out: float
) -> tuple[np.ndarray, np.ndarray]:
    """Vector form of Snell's law (thesis eq. 2.13 / A.7) for unit ``directions`` and ``normals`` (N, 3).

    ``n_in`` is the index of the medium the ray comes from, ``n_out`` of the one it enters. The normal
    may point either way. Returns the unit refracted directions (N, 3) and a mask of rays that are
    totally internally reflected (their direction is returned unchanged and must not be used).
    """
    refracted, tir, _ = refract_with_derivatives(directions, normals, n_in, n_out)
    return refracted, tir


def refract_with_derivatives(
    directions: np.ndarray, normals: np.ndarray, n_in: float, n_out: float,
    tangents: tuple[tuple[np.ndarray, np.ndarray | None], ...] = (),
) -> tuple[np.ndarray, np.ndarray, list[np.ndarray]]:
    """:func:`refract`, and the derivative of the refracted direction for each (d_direction, d_normal)
    pair in ``tangents`` (each (N, 3); d_normal None where the normal does not turn); totally reflected
    rays get zero derivatives."""
    cos_in = _dot(directions, normals)
    # orient the normal along the ray, so that cos_in >= 0 (2.13 assumes this orientation)
    sign = np.where(cos_in < 0.0, -1.0, 1.0)
    cos_in *= sign
    ratio = n_in / n_out
    k = 1.0 - ratio * ratio * (1.0 - cos_in * cos_in)
    tir = k < 0.0
    any_tir = bool(tir.any())
    cos_out = np.sqrt(np.where(tir, 1.0, k) if any_tir else k)
    # unit by construction (|ratio·d|² + ... = 1): no renormalisation needed
    refracted = ratio * directions + ((cos_out - ratio * cos_in) * sign)[:, None] * normals
    derivatives = []
    if tangents:
        factor = ratio * ratio * cos_in / cos_out
        bend = ((cos_out - ratio * cos_in) * sign)[:, None]
        for d_directions, d_normals in tangents:
            # d_normals is None for a plane (its normal does not turn)
            d_cos_in = _dot(d_directions, normals)
            if d_normals is not None:
                d_cos_in += _dot(directions, d_normals)
            d_cos_in *= sign
            d_cos_out = factor * d_cos_in
            out = ratio * d_directions + ((d_cos_out - ratio * d_cos_in) * sign)[:, None] * normals
            if d_normals is not None:
                out += bend * d_normals
            if any_tir:
                out[tir] = 0.0
            derivatives.append(out)
    if any_tir:
        refracted[tir] = directions[tir]
    return refracted, tir, derivatives


@dataclass(frozen=True)
class Plane:
    """The plane n·p + h = 0 with unit normal ``normal`` and offset ``offset`` (metres)."""

    normal: np.ndarray
    offset: float

    def __post_init__(self) -> None:
        normal = validation.finite_vector("plane normal", self.normal, 3)
        length = float(np.linalg.norm(normal))
        if length == 0.0:
            raise InvalidParameterError("plane normal", "must not be the zero vector")
        object.__setattr__(self, "normal", normal / length)
        object.__setattr__(self, "offset", validation.finite("plane offset", self.offset) / length)

    @classmethod
    def from_coefficients(cls, d: float, e: float, g: float) -> Plane:
        """The seeds' plane d·X + e·Y + Z + g = 0 (thesis eq. 2.21)."""
        return cls(np.array([validation.finite("d", d), validation.finite("e", e), 1.0]),
                   validation.finite("g", g))

    def intersect(self, origins: np.ndarray, directions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        # The thesis's eq. 2.22 prints rho2 = (dX1 + eY1 + Z1 + g) / (d·a2 + e·b2 + g2); substituting
        # P1 + rho2·s into eq. 2.21 gives the opposite sign, which is what we use.
        denominator = directions @ self.normal
        numerator = -(origins @ self.normal + self.offset)
        usable = np.abs(denominator) > 1e-15
        t = np.where(usable, numerator / np.where(usable, denominator, 1.0), 0.0)
        hit = usable & (t > MIN_ADVANCE)
        return np.where(hit, t, 0.0), hit

    def normals(self, points: np.ndarray) -> np.ndarray:
        return np.broadcast_to(self.normal, points.shape)

    def normal_derivative(self, points: np.ndarray, normals: np.ndarray, d_points: np.ndarray) -> None:
        """Derivative of the unit normal when the point moves along the surface: zero (None)."""
        return None

    def evaluate(self, points: np.ndarray) -> np.ndarray:
        """Signed distance n·p + h (metres)."""
        return points @ self.normal + self.offset

    def transformed(self, rotation: np.ndarray, translation: np.ndarray) -> Plane:
        """The same plane in a frame where p_new = rotation · p + translation."""
        normal = rotation @ self.normal
        return Plane(normal, self.offset - float(normal @ translation))


@dataclass(frozen=True)
class Sphere:
    """The sphere |p − center| = radius (thesis eq. 2.15), metres."""

    center: np.ndarray
    radius: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "center", validation.finite_vector("sphere center (a, b, c)",
                                                                    self.center, 3))
        object.__setattr__(self, "radius", validation.positive("r", self.radius))

    def intersect(self, origins: np.ndarray, directions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        # thesis eq. 2.16: rho = −U ± sqrt(U² − V); take the nearest crossing ahead of the origin
        offset = origins - self.center
        u = _dot(directions, offset)
        v = _dot(offset, offset) - self.radius * self.radius
        w = u * u - v
        real = w >= 0.0
        root = np.sqrt(np.where(real, w, 0.0))
        near, far = -u - root, -u + root
        t = np.where(near > MIN_ADVANCE, near, far)
        hit = real & (t > MIN_ADVANCE)
        return np.where(hit, t, 0.0), hit

    def normals(self, points: np.ndarray) -> np.ndarray:
        return (points - self.center) / self.radius

    def normal_derivative(self, points: np.ndarray, normals: np.ndarray, d_points: np.ndarray) -> np.ndarray:
        """Derivative of the unit normal (p − c) / r when the point moves by ``d_points``."""
        return d_points / self.radius

    def evaluate(self, points: np.ndarray) -> np.ndarray:
        return np.linalg.norm(points - self.center, axis=1) - self.radius

    def transformed(self, rotation: np.ndarray, translation: np.ndarray) -> Sphere:
        return Sphere(rotation @ self.center + translation, self.radius)


@dataclass(frozen=True)
class ImplicitSurface:
    """A general surface F(p) = 0 (thesis eq. 2.7) with its gradient (2.11), both vectorised.

    ``function`` maps (N, 3) points to (N,) values, ``gradient`` to (N, 3). Crossings are found by
    marching ``steps`` equal steps over (0, ``reach``] metres along each ray to bracket the first sign
    change, then refining it by safeguarded Newton–bisection to ``tolerance`` metres.
    """

    function: Callable[[np.ndarray], np.ndarray]
    gradient: Callable[[np.ndarray], np.ndarray]
    reach: float = 10.0
    steps: int = 200
    tolerance: float = 1e-13
    name: str = field(default="implicit surface")

    def __post_init__(self) -> None:
        validation.positive("reach", self.reach)
        if int(self.steps) < 1:
            raise InvalidParameterError("steps", f"must be >= 1, got {self.steps}")

    def intersect(self, origins: np.ndarray, directions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        n = origins.shape[0]
        ts = np.linspace(0.0, self.reach, int(self.steps) + 1)
        previous = self.function(origins + MIN_ADVANCE * 10 * directions)
        lower = np.zeros(n)
        upper = np.zeros(n)
        found = np.zeros(n, dtype=bool)
        for a, b in zip(ts[:-1], ts[1:], strict=True):
            current = self.function(origins + b * directions)
            crossing = ~found & (np.sign(current) != np.sign(previous)) & (previous != 0.0)
            lower[crossing], upper[crossing] = a, b
            found |= crossing
            previous = current
            if found.all():
                break
        t = 0.5 * (lower + upper)
        idx = np.flatnonzero(found)
        lo, hi, tt = lower[idx], upper[idx], t[idx]
        o, d = origins[idx], directions[idx]
        f_lo = self.function(o + lo[:, None] * d)
        for _ in range(100):
            p = o + tt[:, None] * d
            value = self.function(p)
            slope = _dot(self.gradient(p), d)
            same = np.sign(value) == np.sign(f_lo)
            lo = np.where(same, tt, lo)
            f_lo = np.where(same, value, f_lo)
            hi = np.where(same, hi, tt)
            newton = tt - value / np.where(slope != 0.0, slope, np.inf)
            inside = (newton > lo) & (newton < hi) & np.isfinite(newton)
            new_t = np.where(inside, newton, 0.5 * (lo + hi))
            converged = np.abs(new_t - tt) < self.tolerance
            tt = new_t
            if converged.all():
                break
        t[idx] = tt
        hit = found & (t > MIN_ADVANCE)
        return np.where(hit, t, 0.0), hit

    def normals(self, points: np.ndarray) -> np.ndarray:
        grad = self.gradient(points)
        return grad / np.linalg.norm(grad, axis=1, keepdims=True)

    def normal_derivative(self, points: np.ndarray, normals: np.ndarray, d_points: np.ndarray) -> np.ndarray:
        """Derivative of the unit normal along ``d_points`` by a central difference of :meth:`normals`."""
        scale = np.linalg.norm(d_points, axis=1, keepdims=True)
        step = 1e-6 / np.where(scale > 0, scale, 1.0)
        ahead = self.normals(points + step * d_points)
        behind = self.normals(points - step * d_points)
        return (ahead - behind) / (2 * step)

    def evaluate(self, points: np.ndarray) -> np.ndarray:
        return self.function(points)

    def transformed(self, rotation: np.ndarray, translation: np.ndarray) -> ImplicitSurface:
        rotation = np.asarray(rotation, dtype=np.float64)
        translation = np.asarray(translation, dtype=np.float64)
        original_f, original_g = self.function, self.gradient

        def function(points: np.ndarray) -> np.ndarray:
            return original_f((points - translation) @ rotation)

        def gradient(points: np.ndarray) -> np.ndarray:
            return original_g((points - translation) @ rotation) @ rotation.T

        return ImplicitSurface(function, gradient, self.reach, self.steps, self.tolerance, self.name)


Surface = Plane | Sphere | ImplicitSurface
