"""Estimates of the pointing precision σ (px, one image coordinate) from what a team already has.

Each estimator takes pixel arrays and returns a :class:`PointingEstimate`: σ with its own 95 % interval,
the degrees of freedom and the number of things it came from.

- :func:`from_repeats` — the same point picked several times (e.g. a snout picked again on the same
  frame): the pooled spread of each group about its own mean, σ² = Σ‖x − x̄_g‖² / (2 Σ (k_g − 1)).
- :func:`from_double_readings` — the same vertex picked by two annotators on the same image (paired
  objects' vertices): a difference of two independent picks has variance 2σ² in each coordinate, so
  σ² = Σ d² / (2 · 2M) over M differences. Any systematic difference between the two annotators counts
  as error (it is not removed); the figure is the σ of one pick of an average annotator of the two.
- :func:`from_tracks` — a point tracked through consecutive, equally spaced frames: over a short
  stretch the motion is smooth, so the second difference x_{i−1} − 2x_i + x_{i+1} of three frames is
  the tracker's noise (variance 6σ²) plus the motion's curvature; the triples are taken without
  overlap, so they are independent. Motion adds to it: an upper bound for slow, smooth motion. A tracker
  whose error drifts slowly (the same error on neighbouring frames) is not seen: then a lower bound.
  This is the σ of a *tracked* point about the track; the error of the pick a track started from is
  carried to every frame and is not in it.
- :func:`from_pointing_test` — clicks on rendered targets whose true centres are known: σ² = Σ e² /
  (2N) over the N clicks' errors e (not centred: a constant offset of the clicks counts as error, and
  is reported as :attr:`PointingEstimate.bias_px`).

The interval: for Gaussian errors, ν·s²/σ² ~ χ²(ν). Clicks have heavier tails than a Gaussian (a
slip of the hand, an edge taken for the snout); then the variance estimate is still unbiased but
varies more: Var(s²)/σ⁴ ≈ 2/ν + κ/N (κ the excess kurtosis of the errors, N the number of values). The
interval is the χ² one with the effective degrees of freedom ν_eff = 2 / (2/ν + κ̂/N), κ̂ the sample
excess kurtosis (≥ 0): wider when the tails are heavy, and the estimate says so
(:attr:`PointingEstimate.heavy_tailed`). σ is the root mean square, not a robust scale: a figure's σ
must hold its errors' variance, tails included.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from usvips.core.errors import InvalidParameterError

#: the interval's level
LEVEL = 0.95

#: the estimators, by the name an estimate records as its method
METHODS = ("repeats", "double reading", "tracking", "pointing test")

#: excess kurtosis above which the errors are called heavy-tailed (a Gaussian's is 0; a Student t with 6
#: degrees of freedom has 3)
HEAVY_KURTOSIS = 1.5


@dataclass(frozen=True)
class PointingEstimate:
    """A pointing σ (px, one image coordinate) estimated by ``method`` (one of :data:`METHODS`) from ``n``
    things (groups of repeats, vertex differences, triples of frames, clicks): ``low_px``..``high_px`` its
    95 % interval on ``dof`` degrees of freedom (``effective_dof`` after the tails, see the module
    docstring), ``excess_kurtosis`` of the standardised errors (0 for a Gaussian; NaN with fewer than 8
    values), ``bias_px`` the mean error (x, y) where a truth is known (pointing test), else None."""

    sigma_px: float
    low_px: float
    high_px: float
    dof: int
    effective_dof: float
    n: int
    method: str
    excess_kurtosis: float
    bias_px: tuple[float, float] | None = None

    @property
    def heavy_tailed(self) -> bool:
        return bool(np.isfinite(self.excess_kurtosis) and self.excess_kurtosis > HEAVY_KURTOSIS)

    @property
    def relative_uncertainty(self) -> float:
        """Half the interval's width over σ: how well σ itself is known."""
        return (self.high_px - self.low_px) / (2 * self.sigma_px) if self.sigma_px > 0 else float("inf")

    def summary(self) -> str:
        """One line: σ, its interval, what it came from, and the tails when heavy."""
        text = (f"{self.sigma_px:.3f} px (95 % {self.low_px:.3f}–{self.high_px:.3f}) from {self.n} "
                f"{_NOUNS[self.method]}{'' if self.n == 1 else 's'} ({self.method}, {self.dof} dof)")
        if self.bias_px is not None:
            text += f", mean offset ({self.bias_px[0]:+.2f}, {self.bias_px[1]:+.2f}) px"
        if self.heavy_tailed:
            text += f"; heavy tails (excess kurtosis {self.excess_kurtosis:.1f}): interval widened"
        return text


_NOUNS = {"repeats": "repeated point", "double reading": "vertex pair", "tracking": "frame triple",
          "pointing test": "click"}


def _chi2_interval(variance: float, dof: float, level: float) -> tuple[float, float]:
    from scipy import stats  # deferred: scipy.stats is slow to import (the window's start-up)

    tail = (1.0 - level) / 2.0
    return (float(np.sqrt(variance * dof / stats.chi2.isf(tail, dof))),
            float(np.sqrt(variance * dof / stats.chi2.ppf(tail, dof))))


def estimate(sum_of_squares: float, dof: int, standardised: np.ndarray, n: int, method: str,
             bias_px: tuple[float, float] | None = None, level: float = LEVEL) -> PointingEstimate:
    """The estimate σ² = ``sum_of_squares`` / ``dof`` (px²) with its interval (see the module docstring):
    ``standardised`` are the error values each divided by its own expected σ-multiple (unit variance
    under the model), from which the excess kurtosis is taken; ``n`` what it came from."""
    if method not in METHODS:
        raise InvalidParameterError("method", f"{method!r} is none of {', '.join(METHODS)}")
    if dof < 1:
        raise InvalidParameterError(method, "nothing to estimate from: at least one degree of freedom is needed")
    variance = float(sum_of_squares) / dof
    values = np.asarray(standardised, dtype=np.float64).ravel()
    if variance <= 0 or not np.isfinite(variance):
        raise InvalidParameterError(method, "every error is zero: the picks are identical copies, not repeats")
    kurtosis = float("nan")
    effective = float(dof)
    if values.size >= 8:
        z = values / np.sqrt(np.mean(values ** 2))
        kurtosis = float(np.mean(z ** 4) - 3.0)
        effective = 2.0 / (2.0 / dof + max(kurtosis, 0.0) / values.size)
    low, high = _chi2_interval(variance, effective, level)
    return PointingEstimate(float(np.sqrt(variance)), low, high, int(dof), effective, int(n), method, kurtosis,
                            bias_px)


def _pixels(name: str, value, minimum_rows: int = 1) -> np.ndarray:
    array = np.asarray(value, dtype=np.float64)
    if array.ndim != 2 or array.shape[1] != 2:
        raise InvalidParameterError(name, f"must be (N, 2) pixels, got shape {array.shape}")
    if not np.all(np.isfinite(array)):
        raise InvalidParameterError(name, "holds a non-finite pixel")
    if len(array) < minimum_rows:
        raise InvalidParameterError(name, f"needs at least {minimum_rows} pixels, got {len(array)}")
    return array


def from_repeats(groups: Sequence[np.ndarray], level: float = LEVEL) -> PointingEstimate:
    """σ from repeated picks: ``groups`` each (k, 2) px, k ≥ 2 picks of one point (a group of one pick
    is refused, naming it)."""
    squares, values, dof = 0.0, [], 0
    for g, group in enumerate(groups):
        picks = _pixels(f"repeats {g + 1}", group, 2)
        k = len(picks)
        residual = picks - picks.mean(axis=0)
        squares += float(np.sum(residual ** 2))
        dof += 2 * (k - 1)
        values.append((residual * np.sqrt(k / (k - 1))).ravel())
    if not values:
        raise InvalidParameterError("repeats", "none given: pick one point at least twice")
    return estimate(squares, dof, np.concatenate(values), len(values), "repeats", level=level)


def from_double_readings(first: np.ndarray, second: np.ndarray, level: float = LEVEL) -> PointingEstimate:
    """σ from two annotators' picks of the same vertices on the same images: ``first`` and ``second``
    (M, 2) px, row by row the same vertex (left and right image alike: stack both)."""
    a, b = _pixels("first", first), _pixels("second", second)
    if a.shape != b.shape:
        raise InvalidParameterError("second", f"expected {len(a)} picks as the first annotator's, got {len(b)}")
    difference = a - b
    return estimate(float(np.sum(difference ** 2)) / 2.0, difference.size, difference / np.sqrt(2.0), len(a),
                    "double reading", level=level)


def second_differences(track: np.ndarray) -> np.ndarray:
    """(T, 2) second differences x_{i−1} − 2x_i + x_{i+1} of non-overlapping triples of a track (M, 2) px
    sampled at equal steps (T = M // 3)."""
    track = _pixels("track", track)
    t = len(track) // 3
    triples = track[:3 * t].reshape(t, 3, 2)
    return triples[:, 0] - 2.0 * triples[:, 1] + triples[:, 2]


def from_tracks(tracks: Sequence[np.ndarray], level: float = LEVEL) -> PointingEstimate:
    """σ of tracked points: ``tracks`` each (M, 2) px of one point on consecutive, equally spaced frames
    (a track shorter than three frames gives nothing)."""
    differences = [second_differences(t) for t in tracks]
    differences = [d for d in differences if len(d)]
    if not differences:
        raise InvalidParameterError("tracks", "no track reaches three frames: nothing to estimate from")
    d = np.concatenate(differences)
    return estimate(float(np.sum(d ** 2)) / 6.0, d.size, d / np.sqrt(6.0), len(d), "tracking", level=level)


def from_pointing_test(clicks: np.ndarray, truth: np.ndarray, level: float = LEVEL) -> PointingEstimate:
    """σ from a pointing test: ``clicks`` (N, 2) px where the user clicked, ``truth`` (N, 2) px the targets'
    true centres (in the same pixels: the image's, not the screen's)."""
    clicks, truth = _pixels("clicks", clicks), _pixels("truth", truth)
    if clicks.shape != truth.shape:
        raise InvalidParameterError("truth", f"expected {len(clicks)} centres for {len(clicks)} clicks, "
                                             f"got {len(truth)}")
    errors = clicks - truth
    bias = errors.mean(axis=0)
    return estimate(float(np.sum(errors ** 2)), errors.size, errors, len(errors), "pointing test",
                    (float(bias[0]), float(bias[1])), level)

