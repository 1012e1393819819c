"""Figures with first-order standard deviations, and the quality rules every measured object meets.

A figure is ``value ± sigma`` in ``unit`` ("m", "m²", "rad", or "1" for a dimensionless number such as a
unit-normal component). Propagation is first order, Σ_f = J Σ Jᵀ, with J by central differences of the
figure's own formula over the vertices (N, 3) in metres; Σ is the vertices' joint (3N, 3N) covariance in
m², so the correlation a common calibration puts between the vertices of one object is kept.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from usvips.core.errors import InvalidParameterError


@dataclass(frozen=True)
class Figure:
    """A measured quantity: ``value`` ± ``sigma`` in ``unit``. ``name`` is the column-safe key
    (``length``, ``planarity_rms``, ``centre_X``); :attr:`label` is how a person reads it.

    The sigma's breakdown, when known (None otherwise): ``sigma_pointing``, the part the pixels' pointing
    precision gives, and ``sigma_calibration``, the calibration's part; they add in variance,
    sigma² = sigma_pointing² + sigma_calibration², because both come from the one Jacobian of the figure
    applied to the two parts of the vertices' joint covariance (:func:`figures_of`)."""

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


def propagate_all(function: Callable[[np.ndarray], np.ndarray], points: np.ndarray, covariance: np.ndarray,
                  step: float = 1e-6, many: Callable[[np.ndarray], np.ndarray] | None = None,
                  parts: tuple[np.ndarray, ...] | None = None) -> tuple[np.ndarray, ...]:
    """Values (K,) of a vector-valued ``function(points)`` and their (K, K) first-order covariance.
    ``points`` (N, 3) m; ``covariance`` (N, 3, 3) or (3N, 3N) m²; ``step`` (m) of the central differences;
    ``many``: the same function of a stack of vertex sets (M, N, 3) → (M, K), when there is one (then
    called once for the values and every shifted set). ``parts``: further (3N, 3N) covariances (parts of
    ``covariance``) propagated with the same Jacobian, their (K, K) covariances returned after it."""
    points = np.asarray(points, dtype=np.float64)
    full = full_covariance(points.reshape(-1, 3), covariance)
    flat = points.ravel()
    shifted = np.repeat(flat[None], 2 * flat.size, axis=0)  # row 2k: coordinate k ahead, 2k + 1: behind
    k = np.arange(flat.size)
    shifted[2 * k, k] += step
    shifted[2 * k + 1, k] -= step
    shifted = shifted.reshape(-1, *points.shape)
    if many is not None:
        stack = np.concatenate([points[None], shifted])
        out = np.asarray(many(stack), dtype=np.float64).reshape(len(stack), -1)
        jacobian = ((out[1::2] - out[2::2]) / (2 * step)).T
        return out[0], jacobian @ full @ jacobian.T, *(jacobian @ part @ jacobian.T for part in parts or ())
    values = np.atleast_1d(np.asarray(function(points), dtype=np.float64))
    jacobian = np.empty((values.size, flat.size))
    for k in range(flat.size):
        jacobian[:, k] = (np.atleast_1d(function(shifted[2 * k])) - np.atleast_1d(function(shifted[2 * k + 1]))) \
            / (2 * step)
    return values, jacobian @ full @ jacobian.T, *(jacobian @ part @ jacobian.T for part in parts or ())


def propagate(function: Callable[[np.ndarray], float], points: np.ndarray, covariance: np.ndarray,
              step: float = 1e-6) -> tuple[float, float]:
    """Value and first-order standard deviation of a scalar ``function(points)`` (see :func:`propagate_all`)."""
    values, covariance_f = propagate_all(function, points, covariance, step)[:2]
    return float(values[0]), float(np.sqrt(max(covariance_f[0, 0], 0.0)))


def figures_of(function: Callable[[np.ndarray], np.ndarray], names_units: tuple[tuple[str, str], ...],
               points: np.ndarray, covariance: np.ndarray,
               many: Callable[[np.ndarray], np.ndarray] | None = None,
               pointing: np.ndarray | None = None) -> tuple[Figure, ...]:
    """Every figure a vector-valued formula gives, each with its sigma, from one Jacobian (``many``: the
    formula over a stack of vertex sets, see :func:`propagate_all`). ``pointing``: the pointing part
    (3N, 3N) m² of ``covariance`` (the rest is the calibration's): then each figure also carries its
    sigma's breakdown, J·pointing·Jᵀ and J·(covariance − pointing)·Jᵀ with the same Jacobian."""
    parts = None if pointing is None else (full_covariance(np.asarray(points).reshape(-1, 3), pointing),)
    values, covariance_f, *shares = propagate_all(function, points, covariance, many=many, parts=parts)
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
