"""Whether a calibration's stated uncertainty holds on views it never saw, and the variance components
that make it hold.

A held-out view (:mod:`.validation`) gives two kinds of figures. Its **reprojection residuals** (its pose
resected with the calibrated rig held fixed) test sigma0, the corners' pointing precision: their mean
squared normalised error (NEES) is Σ v² / (sigma0² · dof), dof the view's coordinates less its six pose
numbers. Its **known distances** (adjacent corners, the diagonal), intersected with the calibration, test
everything a measured length's sigma holds: each length's variance is a pointing part p (both corners at
sigma0, independent) plus the calibration's part c (its parameter covariance propagated to the two
corners, correlated); their NEES is the mean of e² / (p + c), e the length's error (metres).

Two variance components are estimated from them (Förstner 1979's idea, on data the adjustment did not
use), each with its 95 % sampling interval: the widest of a bootstrap over the held-out views (which knows
the correlation of one view's figures and heavy tails), the Gaussian theory's (χ² for the pointing, the
estimator's variance for the calibration) and, for the calibration, the χ² interval with as many degrees
of freedom as held-out views (its error is one draw, seen through each view's geometry: the views, not
the distances, are the samples):

* the pointing factor a = Σ v² / (sigma0² Σ dof). Where its interval excludes 1, sigma0² and the
  covariance are multiplied by a (least squares has them share one variance factor; an M-estimate's
  covariance factor grows with the noise's scale as well);
* the calibration factor b of the covariance on top of that, from E[e²] = a p + b a c, by weighted least
  squares of e² − a p on a c (weights 1 / (a p + b a c)², iterated). Where its interval excludes 1 and b
  is positive, the covariance is multiplied by b as well. A distance dominated by pointing says little
  about b (a wide interval: nothing is scaled); errors smaller than the pointing alone explains (b ≤ 0:
  neighbouring corners' errors are correlated on a real detector) are reported, not used.

The report says what was scaled, by how much, why and on how many held-out observations.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from usvips.core.stereo_calibration import StereoCalibration

#: resamples of the held-out views for the bootstrap intervals (seeded)
BOOTSTRAP = 400
#: iterations of the calibration factor's reweighting
ITERATIONS = 8


@dataclass
class HeldOutView:
    """One held-out view's figures: ``chi2`` = Σ v² / sigma0² of its kept reprojection residuals over
    ``dof`` degrees of freedom; per known distance its ``errors`` (estimated − true, metres), ``pointing``
    and ``calibration`` variance parts (m²); ``gross``: corners set aside (reprojected far off);
    ``fourth``: Σ v⁴ / sigma0⁴ of the same residuals over ``coordinates`` of them (their spread: heavy
    tails widen the interval of the pointing factor; 0: not known)."""

    chi2: float
    dof: int
    errors: np.ndarray
    pointing: np.ndarray
    calibration: np.ndarray
    gross: int = 0
    fourth: float = 0.0
    coordinates: int = 0


@dataclass
class Honesty:
    """The held-out NEES figures and the variance components applied (module docstring).

    ``reprojection_nees`` over ``reprojection_dof`` with its ``reprojection_interval``; ``distance_nees``
    of ``distances`` in ``views`` views with its ``interval``, and after the factors,
    ``distance_nees_after``; ``calibration_share``: the calibration's mean share of a distance's variance;
    ``calibration_estimate`` (b) with its ``calibration_interval``; ``pointing_factor`` and
    ``covariance_factor``: the factors applied to sigma0² and to the covariance (1: none); ``gross``:
    held-out corners set aside; ``why``: one line per decision."""

    reprojection_nees: float
    reprojection_dof: int
    reprojection_interval: tuple[float, float]
    distance_nees: float
    distances: int
    views: int
    interval: tuple[float, float]
    calibration_share: float
    calibration_estimate: float
    calibration_interval: tuple[float, float]
    distance_nees_after: float
    pointing_factor: float = 1.0
    covariance_factor: float = 1.0
    gross: int = 0
    why: list[str] = field(default_factory=list)

    @property
    def scaled(self) -> bool:
        return self.pointing_factor != 1.0 or self.covariance_factor != 1.0

    def as_dict(self) -> dict:
        """JSON-able: a figure that could not be estimated (not finite) is None."""
        return _finite({"reprojection_nees": self.reprojection_nees, "reprojection_dof": self.reprojection_dof,
                "reprojection_interval_95": list(self.reprojection_interval),
                "distance_nees": self.distance_nees, "distances": self.distances, "views": self.views,
                "interval_95": list(self.interval), "calibration_share": self.calibration_share,
                "calibration_factor_estimate": self.calibration_estimate,
                "calibration_factor_interval_95": list(self.calibration_interval),
                "pointing_factor": self.pointing_factor, "covariance_factor": self.covariance_factor,
                "distance_nees_after": self.distance_nees_after, "scaled": self.scaled,
                "gross_corners_set_aside": self.gross, "why": list(self.why)})

    def lines(self) -> list[str]:
        low, high = self.interval
        r_low, r_high = self.reprojection_interval
        out = [f"  honesty on held-out views (NEES 1: the stated sigmas hold): known distances "
               f"{self.distance_nees:.2f} over {self.distances} in {self.views} views (95 % interval "
               f"{low:.2f}-{high:.2f}; the calibration's "
               f"share of their variance {_percent(self.calibration_share)}), reprojections "
               f"{self.reprojection_nees:.2f} over {self.reprojection_dof} degrees of freedom "
               f"({r_low:.2f}-{r_high:.2f})"
               + (f"; {self.gross} held-out corners set aside as gross errors" if self.gross else "")]
        out += [f"  {line}" for line in self.why]
        return out


def _percent(share: float) -> str:
    return "under 1 %" if share < 0.01 else f"{100 * share:.0f} %"


def _finite(value):
    """``value`` with every non-finite float (in lists and dicts too) replaced by None."""
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_finite(v) for v in value]
    if isinstance(value, float) and not np.isfinite(value):
        return None
    return value


def _chi2_interval(value: float, dof: float) -> tuple[float, float]:
    """The 95 % interval of a variance factor estimated as χ²(dof) / dof around ``value``."""
    from scipy import stats  # deferred: scipy.stats is slow to import

    low, high = stats.chi2.ppf([0.975, 0.025], max(dof, 1.0))
    return float(value * dof / low), float(value * dof / high)


def _wider(one: tuple[float, float], other: tuple[float, float]) -> tuple[float, float]:
    return min(one[0], other[0]), max(one[1], other[1])


def _bootstrap(numerators: np.ndarray, denominators: np.ndarray, seed: int) -> tuple[float, float] | None:
    """The 95 % percentile interval of Σ numerators / Σ denominators over views resampled with replacement;
    None with fewer than two views."""
    if numerators.size < 2:
        return None
    draws = np.random.default_rng(seed).integers(0, numerators.size, (BOOTSTRAP, numerators.size))
    below = denominators[draws].sum(axis=1)
    ratios = numerators[draws].sum(axis=1) / np.where(below > 0, below, np.nan)
    if not np.isfinite(ratios).any():
        return None
    low, high = np.nanquantile(ratios, [0.025, 0.975])
    return float(low), float(high)


def _from_spread(views: list[HeldOutView]) -> tuple[float, float] | None:
    """The 95 % interval of the pointing factor from the residuals' own spread (the sample variance of
    v² / sigma0²): it knows heavy tails, which the χ² interval (Gaussian errors) does not. None when the
    fourth powers are not known."""
    count = sum(v.coordinates for v in views)
    dof = sum(v.dof for v in views)
    if count < 2 or dof <= 0 or not all(v.coordinates for v in views):
        return None
    mean = sum(v.chi2 for v in views) / count
    variance = max(sum(v.fourth for v in views) / count - mean * mean, 0.0)
    estimate, half = mean * count / dof, 1.96 * np.sqrt(variance / count) * count / dof
    return estimate - half, estimate + half


def _between_views(denominators: np.ndarray, estimate: float) -> tuple[float, float] | None:
    """The 95 % interval of the calibration factor as a variance factor with as many degrees of freedom as
    there are (effective) held-out views: the calibration's error is one draw, seen through each view's
    geometry, so a view's distances share it and the views, not the distances, are the samples (about one
    degree of freedom each; the effective count weights them by their information). None below 2 views."""
    use = denominators > 0
    if use.sum() < 2 or not estimate > 0:
        return None
    weight = denominators[use]
    effective = weight.sum() ** 2 / float(np.sum(weight**2))
    return _chi2_interval(estimate, effective)


def _calibration_factor(views: list[HeldOutView], a: float) -> tuple[float, np.ndarray, np.ndarray, float]:
    """b from E[e²] = a p + b a c by iterated weighted least squares: (b, per-view Σ w c (e² − a p), per-view
    Σ w c² at the last weights, the Gaussian theory's variance of b)."""
    b = 1.0
    numerators = denominators = np.zeros(len(views))
    for _ in range(ITERATIONS):
        numerators, denominators = np.zeros(len(views)), np.zeros(len(views))
        for k, view in enumerate(views):
            c = a * view.calibration
            weight = 1.0 / (a * view.pointing + max(b, 1e-3) * c) ** 2
            numerators[k] = np.sum(weight * c * (view.errors**2 - a * view.pointing))
            denominators[k] = np.sum(weight * c * c)
        total = denominators.sum()
        if not total > 0:
            return float("nan"), numerators, denominators, float("inf")
        b = float(numerators.sum() / total)
    return b, numerators, denominators, 2.0 / float(denominators.sum())


def variance_components(views: list[HeldOutView], seed: int = 0) -> Honesty | None:
    """The NEES figures of held-out ``views`` and the factors to apply (module docstring); None when no
    held-out distance was measured."""
    views = [v for v in views if v.errors.size]
    if not views:
        return None
    errors = np.concatenate([v.errors for v in views])
    pointing = np.concatenate([v.pointing for v in views])
    calibration = np.concatenate([v.calibration for v in views])
    squares = [v.errors**2 / (v.pointing + v.calibration) for v in views]
    nees = float(np.mean(np.concatenate(squares)))
    interval = _chi2_interval(nees, errors.size)
    sums, sizes = np.array([s.sum() for s in squares]), np.array([float(s.size) for s in squares])
    spread = _bootstrap(sums, sizes, seed)
    interval = _wider(interval, spread) if spread else interval
    chi2, dof = np.array([v.chi2 for v in views]), np.array([float(v.dof) for v in views])
    reprojection = float(chi2.sum() / dof.sum()) if dof.sum() > 0 else float("nan")
    reprojection_interval = _chi2_interval(reprojection, dof.sum())
    spread = _bootstrap(chi2, dof, seed + 1)
    reprojection_interval = _wider(reprojection_interval, spread) if spread else reprojection_interval
    spread = _from_spread(views)
    reprojection_interval = _wider(reprojection_interval, spread) if spread else reprojection_interval
    why = []
    a = 1.0
    if np.isfinite(reprojection) and not reprojection_interval[0] <= 1.0 <= reprojection_interval[1]:
        a = reprojection
        why.append(f"sigma0 and the covariance are scaled by a variance factor of {a:.2f} (sigmas x {np.sqrt(a):.2f}): "
                   f"on {int(dof.sum())} degrees of freedom of held-out reprojections the corners' errors were "
                   f"{'larger' if a > 1 else 'smaller'} than sigma0 says beyond chance (NEES {reprojection:.2f}, 95 % "
                   f"interval {reprojection_interval[0]:.2f}-{reprojection_interval[1]:.2f})")
    b, numerators, denominators, variance = _calibration_factor(views, a)
    half = 1.96 * np.sqrt(variance)
    b_interval = (b - half, b + half) if np.isfinite(b) else (float("-inf"), float("inf"))
    spread = _bootstrap(numerators, denominators, seed + 2)
    b_interval = _wider(b_interval, spread) if spread and np.isfinite(b) else b_interval
    spread = _between_views(denominators, b)
    b_interval = _wider(b_interval, spread) if spread and np.isfinite(b) else b_interval
    covariance = a
    share = float(np.mean(calibration / (pointing + calibration)))
    with_pointing = float(np.mean(errors**2 / (a * (pointing + calibration))))  # the NEES with sigma0 scaled
    departs = np.isfinite(b) and not b_interval[0] <= 1.0 <= b_interval[1]
    if departs and b > 0:
        covariance = a * b
        why.append(f"the calibration's covariance is scaled by a further {b:.2f} (its sigmas x "
                   f"{np.sqrt(b):.2f}): on {errors.size} held-out distances in {len(views)} views its part of "
                   f"their errors was {'larger' if b > 1 else 'smaller'} than stated beyond chance (95 % interval "
                   f"{b_interval[0]:.2f}-{b_interval[1]:.2f})")
    elif departs or not interval[0] <= nees / with_pointing <= interval[1]:
        why.append(f"the held-out distances' NEES is {with_pointing:.2f} with that sigma0, but the calibration's "
                   f"part is {_percent(share)} of their variance and cannot be told from them: the departure lies in "
                   "the corners' pointing, not the calibration (e.g. a detector's neighbouring corners' errors "
                   "correlate, so that a short distance varies less than two independent corners would); the "
                   "calibration's covariance is kept")
    if not why:
        why.append("the stated sigmas hold on the held-out views within their sampling intervals: sigma0 and the "
                   "covariance are kept as estimated")
    after = float(np.mean(errors**2 / (a * pointing + covariance * calibration)))
    return Honesty(reprojection, int(dof.sum()), reprojection_interval, nees, int(errors.size), len(views), interval,
                   share, b, b_interval, after, a, covariance, sum(v.gross for v in views), why)


def scaled(calibration: StereoCalibration, pointing_factor: float, covariance_factor: float, why: list[str]
           ) -> StereoCalibration:
    """``calibration`` with sigma0² times ``pointing_factor`` and its parameters' covariance times
    ``covariance_factor`` (parameter sigmas by the square root), the factors and ``why`` in its
    statistics (``variance_scale``)."""
    root = float(np.sqrt(covariance_factor))
    parameters = {name: replace(p, sigma=p.sigma * root if p.sigma else p.sigma)
                  for name, p in calibration.parameters.items()}
    covariance = None
    if calibration.covariance is not None:
        names, matrix = calibration.covariance
        covariance = (names, np.asarray(matrix) * covariance_factor)
    statistics = dict(calibration.statistics)
    statistics["variance_scale"] = {"pointing_factor": float(pointing_factor),
                                    "covariance_factor": float(covariance_factor), "why": list(why),
                                    "sigma0_px_estimated": calibration.sigma0_px}
    return replace(calibration, sigma0_px=calibration.sigma0_px * float(np.sqrt(pointing_factor)),
                   parameters=parameters, covariance=covariance, statistics=statistics)


def apply_honesty(result, figures: Honesty) -> None:
    """Apply the held-out views' factors to a calibration result (its ``calibration`` and ``report``: sigma0,
    the parameters' sigmas, ``variance_scale``, a note per decision); the report keeps the fit's own sigma0
    as ``sigma0_px_estimated``. Nothing changes when no factor departs from 1 (then only the note)."""
    report = result.report
    report = replace(report, sigma0_px_estimated=report.sigma0_px,
                     notes=report.notes + tuple(line + "." for line in figures.why))
    if not figures.scaled:
        result.report = report
        return
    result.calibration = scaled(result.calibration, figures.pointing_factor, figures.covariance_factor, figures.why)
    sigmas = result.calibration.parameters
    result.report = replace(
        report, sigma0_px=result.calibration.sigma0_px,
        parameters={name: replace(p, sigma=sigmas[name].sigma) if name in sigmas else p
                    for name, p in report.parameters.items()},
        variance_scale={"pointing_factor": figures.pointing_factor, "covariance_factor": figures.covariance_factor,
                        "why": list(figures.why), "distances": figures.distances,
                        "reprojection_dof": figures.reprojection_dof, "views": figures.views})
