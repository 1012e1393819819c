"""Figures with standard deviations, and the quality rules every measured object meets.

A figure is ``value ± sigma`` in ``unit`` ("m", "m²", "rad", or "1" for a dimensionless number such as a
unit-normal component). ``value`` is the plain estimate, the figure's formula at the measured vertices
(N, 3) m; ``sigma`` is its root mean square error, σ² = J Σ Jᵀ + ½ tr(HΣHΣ) + b², b = ½ tr(HΣ): the
first-order variance (J by central differences of the formula over the vertices; Σ the vertices' joint
(3N, 3N) covariance in m², so the correlation a common calibration puts between the vertices of one
object is kept), plus the second-order variance and the squared second-order bias that a figure
nonlinear in its vertices has (H its Hessian) — a short length far away: an error across the segment
lengthens it by about |δ⊥|²/2L, and its first-order σ, taken at a noisy estimate, can say nothing of the
depth errors at all. That is the posterior mean squared error of the figure about the estimate to second
order, the bias included because the value is not corrected for it (values stay what the formula gives).

The second-order part is skipped when the vertices' total σ is below :data:`NEGLIGIBLE_SPREAD` of their
spread (its share of σ² is then of the order of (σ/spread)² ≈ 10⁻⁴ times the ratio of the largest
variance to the figure's own first-order one: ≲ 1 % for a stereo vertex, whose depth σ is ~10 times its
lateral σ). Else it is taken in the subspace of Σ's :data:`SUBSPACE` largest eigen-directions
s_i = √λ_i v_i (those holding at least :data:`EIGEN_SHARE` of the largest variance): H's entries
A_ij = s_iᵀ H s_j come from the formula at x ± h s_i and x ± h s_i ± h s_j, h = √3 — the three-point
Gauss–Hermite rule along each principal direction (exact for the mean of a polynomial up to degree five
in a Gaussian error), so a figure whose curvature changes over the σ-ellipsoid (a length as its σ
approaches it) is measured over that ellipsoid rather than at one point — and ½ tr(HΣ) = ½ Σ A_ii,
½ tr(HΣHΣ) = ½ Σ A_ij². Angles ("rad") are differenced modulo 2π. Should the formula be degenerate at
one of those points (a polygon collapsed by h·σ), the figure keeps its first-order σ. A linear figure (a
point's coordinates) has no second-order part. Of the second-order part, the calibration's share of σ² is
what its covariance alone gives, the pointing's share the rest (what would go with perfect pointing: its
own part and the cross terms), so the calibration's share does not depend on the pointing σ.

How honest: tests/core/test_second_order_sigma.py (Monte Carlo over rigs of every housing kind, fish
1-6 m away, 0.1-0.6 m long). Where the vertices' largest σ is below 0.15 of the length, NEES ≈ 1; beyond
it this σ is conservative (NEES ≈ 0.5-0.8) while first order alone has errors of 5-15 σ for the fish the
noise turned across the depth direction; docs/design.md ("A figure's σ") says why no σ taken from the
estimate alone can be exact there.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from functools import cache

import numpy as np

from usvips.core.errors import InvalidParameterError, UsvipsError


@dataclass(frozen=True)
class Figure:
    """A measured quantity: ``value`` ± ``sigma`` in ``unit``. ``name`` is the column-safe key
    (``length``, ``planarity_rms``, ``centre_X``); :attr:`label` is how a person reads it.

    ``sigma`` is the root mean square error of ``value`` (first order, plus the second-order variance and
    bias where the figure's nonlinearity matters: see the module's text). The sigma's breakdown, when known
    (None otherwise): ``sigma_pointing``, the part the pixels' pointing precision gives, and
    ``sigma_calibration``, the calibration's part; they add in variance,
    sigma² = sigma_pointing² + sigma_calibration², because both come from the one Jacobian of the figure
    applied to the two parts of the vertices' joint covariance, and the second-order part is split between
    them as the module's text says (:func:`figures_of`)."""

    name: str
    value: float
    sigma: float
    unit: str
    sigma_pointing: float | None = None
    sigma_calibration: float | None = None

    @property
    def relative_precision(self) -> float:
        return self.sigma / abs(self.value) if self.value else float("inf")

    @property
    def label(self) -> str:
        return self.name.replace("_", " ")


def block_diagonal(covariances: np.ndarray) -> np.ndarray:
    """(N, 3, 3) per-vertex covariances → the (3N, 3N) matrix with no correlation between vertices."""
    covariances = np.asarray(covariances, dtype=np.float64).reshape(-1, 3, 3)
    n = len(covariances)
    full = np.zeros((3 * n, 3 * n))
    for i, c in enumerate(covariances):
        full[3 * i:3 * i + 3, 3 * i:3 * i + 3] = c
    return full


def full_covariance(points: np.ndarray, covariance: np.ndarray) -> np.ndarray:
    """The (3N, 3N) covariance of N vertices from either (N, 3, 3) or (3N, 3N); checked for shape and
    finiteness (a wrong one is an :class:`InvalidParameterError` on ``covariance``)."""
    covariance = np.asarray(covariance, dtype=np.float64)
    n = len(points)
    full = block_diagonal(covariance) if covariance.ndim == 3 else covariance
    if full.shape != (3 * n, 3 * n):
        raise InvalidParameterError("covariance", f"expected (N, 3, 3) or ({3 * n}, {3 * n}) for {n} vertices, "
                                                  f"got {covariance.shape}")
    if not np.all(np.isfinite(full)):
        raise InvalidParameterError("covariance", "holds a non-finite value")
    return full


#: no second-order part when the vertices' total σ, √tr Σ, is below this fraction of their RMS distance from
#: their centroid (see the module's text)
NEGLIGIBLE_SPREAD = 0.01
#: how many of Σ's largest eigen-directions the second-order part is taken in, and the least variance
#: (as a share of the largest) of one that counts
SUBSPACE = 3
EIGEN_SHARE = 1e-3
#: the Gauss–Hermite step along each principal direction, in its σ
SIGMA_STEP = float(np.sqrt(3.0))


def _wrapped(differences: np.ndarray, periodic: np.ndarray | None) -> np.ndarray:
    """``differences`` (..., K) with those of the angles (``periodic``: their indices) taken into [−π, π)."""
    if periodic is not None and periodic.size:
        differences[..., periodic] = (differences[..., periodic] + np.pi) % (2 * np.pi) - np.pi
    return differences


def _principal_directions(points: np.ndarray, full: np.ndarray) -> np.ndarray | None:
    """The scaled eigen-directions s_i = √λ_i v_i (r, 3N) m of Σ the second-order part is taken in, or None
    when it is negligible (the vertices' σ tiny against their spread, see :data:`NEGLIGIBLE_SPREAD`)."""
    centred = (points - points.sum(axis=0) / len(points)).ravel()
    total = float(full.trace())
    if total <= 0.0 or total * len(points) < NEGLIGIBLE_SPREAD ** 2 * float(centred @ centred):
        return None
    variances, vectors = np.linalg.eigh(full)
    count = min(SUBSPACE, int(np.count_nonzero(variances >= EIGEN_SHARE * variances[-1])))
    return (vectors[:, :-count - 1:-1] * np.sqrt(variances[:-count - 1:-1])).T


def _evaluated(function, many, points: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """The formula at every row (M, 3N) of vertex coordinates: (M, K)."""
    if many is not None:
        return np.asarray(many(rows.reshape(-1, *points.shape)), dtype=np.float64).reshape(len(rows), -1)
    return np.array([np.atleast_1d(np.asarray(function(p.reshape(points.shape)), dtype=np.float64)) for p in rows])


def _hessians(differences: np.ndarray, r: int) -> np.ndarray | None:
    """From the formula's differences (M, K) at the second-order points of r directions: each figure's
    Hessian in the subspace, A_ij = s_iᵀ H s_j (K, r, r); None when one is not finite."""
    if not np.all(np.isfinite(differences)):
        return None
    return (_stencil(r)[1] @ differences).T.reshape(-1, r, r)


def _addition(hessian: np.ndarray, spread: np.ndarray | None = None) -> np.ndarray:
    """The second-order addition (K, K) to the figures' mean squared error, ½ tr(H_k Σ' H_l Σ') + b_k b_l
    with b_k = ½ tr(H_k Σ'), from their Hessians (K, r, r) in the subspace's scaled directions and Σ' there,
    ``spread`` (r, r) (None: Σ itself, the identity in that basis)."""
    weighted = hessian if spread is None else hessian @ spread
    bias = 0.5 * np.trace(weighted, axis1=1, axis2=2)
    return 0.5 * np.einsum("kij,lji->kl", weighted, weighted) + np.outer(bias, bias)


@cache
def _stencil(r: int) -> tuple[np.ndarray, np.ndarray]:
    """For r directions: the points' offsets (M, r) in steps of h along them (±e_i, then ±e_i ± e_j for
    i < j), and the (r², M) map from the formula's differences at those points to the Hessian's entries
    A_ij (row-major): (f₊ᵢ + f₋ᵢ − 2f)/h² and (f₊₊ − f₊₋ − f₋₊ + f₋₋)/(4h²)."""
    pairs = [(i, j) for i in range(r) for j in range(i + 1, r)]
    eye = np.eye(r)
    offsets = [sign * eye[i] for i in range(r) for sign in (1.0, -1.0)]
    offsets += [a * eye[i] + b * eye[j] for i, j in pairs for a, b in ((1, 1), (1, -1), (-1, 1), (-1, -1))]
    hessian_of = np.zeros((r * r, len(offsets)))
    for i in range(r):
        hessian_of[i * r + i, 2 * i:2 * i + 2] = 1.0 / SIGMA_STEP ** 2
    for p, (i, j) in enumerate(pairs):
        weights = np.array([1.0, -1.0, -1.0, 1.0]) / (4 * SIGMA_STEP ** 2)
        hessian_of[i * r + j, 2 * r + 4 * p:2 * r + 4 * p + 4] = weights
        hessian_of[j * r + i, 2 * r + 4 * p:2 * r + 4 * p + 4] = weights
    return np.array(offsets), hessian_of


def propagate_all(function: Callable[[np.ndarray], np.ndarray], points: np.ndarray, covariance: np.ndarray,
                  step: float = 1e-6, many: Callable[[np.ndarray], np.ndarray] | None = None,
                  parts: tuple[np.ndarray, ...] | None = None, periodic: np.ndarray | None = None,
                  nonlinear: bool = True, axial: np.ndarray | None = None) -> tuple[np.ndarray, ...]:
    """Values (K,) of a vector-valued ``function(points)`` and their (K, K) mean squared error about them:
    J Σ Jᵀ plus, with ``nonlinear`` (the default), the second-order variance and the outer product of the
    second-order bias (see the module's text; ``periodic`` (K,) marks angles, differenced modulo 2π).
    ``points`` (N, 3) m; ``covariance`` (N, 3, 3) or (3N, 3N) m²; ``step`` (m) of the central differences;
    ``many``: the same function of a stack of vertex sets (M, N, 3) → (M, K), when there is one (then
    called once, for the values, every shifted set and the second-order points). ``parts``: further
    (3N, 3N) covariances that add up to ``covariance`` (its pointing and calibration parts), their (K, K)
    shares returned after it: J·part·Jᵀ each, plus of the second-order addition what would go without that
    part (the addition less that of ``covariance`` − part, within [0, the addition] for each figure) — with
    one part given, the rest (covariance − part) is then the second-order addition of the rest alone, and
    the two still add up to the whole. ``axial`` (K,): marks the components of a unit vector without a sign
    of its own (a circle's normal): at every shifted set it is taken on the side of the estimate's, so a
    normal that the "upward" rule flips there is differenced as the direction it is."""
    points = np.asarray(points, dtype=np.float64)
    full = full_covariance(points.reshape(-1, 3), covariance)
    periodic = None if periodic is None else np.flatnonzero(periodic)
    flat = points.ravel()
    shifted = np.repeat(flat[None], 2 * flat.size, axis=0)  # row 2k: coordinate k ahead, 2k + 1: behind
    k = np.arange(flat.size)
    shifted[2 * k, k] += step
    shifted[2 * k + 1, k] -= step
    directions = _principal_directions(points.reshape(-1, 3), full) if nonlinear else None
    rows = np.concatenate([flat[None], shifted])
    if directions is not None:  # the second-order points, evaluated with the Jacobian's
        rows = np.concatenate([rows, flat + _stencil(len(directions))[0] @ (SIGMA_STEP * directions)])
    try:
        out = _evaluated(function, many, points, rows)
    except UsvipsError:
        if directions is None:
            raise
        # degenerate somewhere: the object itself raises again here; else only at a second-order point
        out = _evaluated(function, many, points, rows[:1 + 2 * flat.size])
        directions = None
    if axial is not None and np.any(axial):
        out[(out[:, axial] @ out[0, axial]) < 0.0, np.flatnonzero(axial)[:, None]] *= -1.0
    values = out[0]
    jacobian = (_wrapped(out[1:1 + 2 * flat.size:2] - out[2:2 + 2 * flat.size:2], periodic) / (2 * step)).T
    first = jacobian @ full @ jacobian.T
    shares = [jacobian @ part @ jacobian.T for part in parts or ()]
    hessian = None if directions is None else _hessians(_wrapped(out[1 + 2 * flat.size:] - values, periodic),
                                                        len(directions))
    if hessian is None:
        return values, first, *shares
    addition = _addition(hessian)
    # a part's share of the addition: what would go if that part were not there (Σ − part, in the subspace)
    unscaled = directions / np.sum(directions ** 2, axis=1)[:, None]  # v_i / √λ_i
    split = []
    for share, part in zip(shares, parts or (), strict=True):
        without = _addition(hessian, np.eye(len(directions)) - unscaled @ full_covariance(
            points.reshape(-1, 3), part) @ unscaled.T)
        gone = addition - without
        index = np.arange(len(gone))
        gone[index, index] = np.clip(np.diag(gone), 0.0, np.diag(addition))
        split.append(share + gone)
    return values, first + addition, *split


def propagate(function: Callable[[np.ndarray], float], points: np.ndarray, covariance: np.ndarray,
              step: float = 1e-6) -> tuple[float, float]:
    """Value and standard deviation (root mean square error, second-order terms included where they matter)
    of a scalar ``function(points)`` (see :func:`propagate_all`)."""
    values, covariance_f = propagate_all(function, points, covariance, step)[:2]
    return float(values[0]), float(np.sqrt(max(covariance_f[0, 0], 0.0)))


def figures_of(function: Callable[[np.ndarray], np.ndarray], names_units: tuple[tuple[str, str], ...],
               points: np.ndarray, covariance: np.ndarray,
               many: Callable[[np.ndarray], np.ndarray] | None = None,
               pointing: np.ndarray | None = None, nonlinear: bool = True,
               axial: tuple[str, ...] = ()) -> tuple[Figure, ...]:
    """Every figure a vector-valued formula gives, each with its sigma, from one Jacobian (``many``: the
    formula over a stack of vertex sets, see :func:`propagate_all`). ``pointing``: the pointing part
    (3N, 3N) m² of ``covariance`` (the rest is the calibration's): then each figure also carries its
    sigma's breakdown, J·pointing·Jᵀ and J·(covariance − pointing)·Jᵀ with the same Jacobian, each with its
    share of the second-order part (:func:`propagate_all`). Figures in "rad" are angles (differenced
    modulo 2π); ``axial`` names the components of a sign-free unit vector (:func:`propagate_all`).
    ``nonlinear=False``: first-order sigmas alone (to compare with; no figure shown is so)."""
    parts = None if pointing is None else (full_covariance(np.asarray(points).reshape(-1, 3), pointing),)
    periodic = np.array([unit == "rad" for _, unit in names_units])
    values, covariance_f, *shares = propagate_all(
        function, points, covariance, many=many, parts=parts, periodic=periodic, nonlinear=nonlinear,
        axial=np.array([name in axial for name, _ in names_units]) if axial else None)
    sigmas = np.sqrt(np.clip(np.diag(covariance_f), 0.0, None))
    if not shares:
        return tuple(Figure(name, float(v), float(s), unit)
                     for (name, unit), v, s in zip(names_units, values, sigmas, strict=True))
    pointing_variance = np.clip(np.diag(shares[0]), 0.0, None)
    calibration = np.sqrt(np.clip(np.diag(covariance_f) - pointing_variance, 0.0, None))
    return tuple(Figure(name, float(v), float(s), unit, float(p), float(c))
                 for (name, unit), v, s, p, c in zip(names_units, values, sigmas, np.sqrt(pointing_variance),
                                                     calibration, strict=True))


@dataclass(frozen=True)
class Breach:
    """One quality rule a measurement breaks: ``rule`` (``ray_rms``, ``precision``, ``range``,
    ``max_sigma``), its ``value`` and ``limit`` (in ``unit``: "m", or "1" for precision/value), and
    ``text``, how a person reads it."""

    rule: str
    value: float
    limit: float
    unit: str
    text: str


@dataclass(frozen=True)
class QualityRules:
    """Acceptance rules applied to every measured object. Defaults: the stereo-video fish-survey ones —
    ray-intersection RMS ≤ 20 mm, precision/length ≤ 10 %, range ≤ 8 m. ``extra``: ``max_sigma_m``
    (the largest sigma, m, of a figure in metres)."""

    max_ray_rms_m: float = 0.020
    max_relative_precision: float = 0.10
    max_range_m: float = 8.0
    extra: dict[str, float] = field(default_factory=dict)

    def breaches(self, figure: Figure, ray_rms_m: float | None, range_m: float | None,
                 relative: bool = True) -> list[Breach]:
        """The rules a measurement breaks, each with its value and limit (empty when it passes).
        ``relative``: whether the precision/value rule applies to ``figure`` (not to a coordinate); an
        unknown ray RMS or range (None) is not checked."""
        found = []
        if ray_rms_m is not None and ray_rms_m > self.max_ray_rms_m:
            found.append(Breach("ray_rms", ray_rms_m, self.max_ray_rms_m, "m",
                                f"ray-intersection RMS {ray_rms_m * 1000:.1f} mm > {self.max_ray_rms_m * 1000:.0f} mm"))
        if relative and figure.relative_precision > self.max_relative_precision:
            found.append(Breach("precision", figure.relative_precision, self.max_relative_precision, "1",
                                f"precision {figure.relative_precision:.1%} of the {figure.label} > "
                                f"{self.max_relative_precision:.0%}"))
        if range_m is not None and range_m > self.max_range_m:
            found.append(Breach("range", range_m, self.max_range_m, "m",
                                f"range {range_m:.2f} m > {self.max_range_m:g} m"))
        for name, limit in self.extra.items():
            if name == "max_sigma_m" and figure.unit == "m" and figure.sigma > limit:
                found.append(Breach("max_sigma", figure.sigma, limit, "m",
                                    f"sigma {figure.sigma * 1000:.1f} mm > {limit * 1000:.1f} mm"))
        return found

    def check(self, figure: Figure, ray_rms_m: float | None, range_m: float | None,
              relative: bool = True) -> list[str]:
        """The rules a measurement breaks as a person reads them (empty when it passes); see
        :meth:`breaches`."""
        return [b.text for b in self.breaches(figure, ray_rms_m, range_m, relative)]
