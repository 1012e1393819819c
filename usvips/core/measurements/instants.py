"""One object measured on several instants: its figures combined with an honest sigma.

A free-swimming fish bends, so the snout–fork distance it shows differs from instant to instant by more
than the measurement's own sigma. The instants are combined by the random-effects model of meta-analysis:

    y_i = μ + b_i + e_i,   b_i ~ N(0, τ²) (the object's own change between instants),
                           e_i ~ N(0, σ_i²) (the measurement's, σ_i from the one figure function).

τ² is estimated by DerSimonian & Laird's moment estimator (1986), τ̂² = max(0, (Q − (k − 1)) / (S1 − S2/S1)),
with Cochran's Q = Σ w_i (y_i − ȳ_w)², w_i = 1/σ_i², S1 = Σ w_i, S2 = Σ w_i². The combined value is the
weighted mean with w*_i = 1/(σ_i² + τ̂²); its variance is that of Hartung & Knapp (2001) — the
weighted spread of the instants about it, q = Σ w*_i (y_i − μ̂)² / (k − 1), times 1/Σ w*_i — never less than
the plain 1/Σ w*_i (the adjustment's usual floor), so that the few instants a user measures do not give a
sigma that trusts τ̂² more than k instants allow. A part of sigma common to every instant (the calibration's,
which does not average out over instants measured with the same calibration) is added afterwards:
σ² = max(q, 1)/Σ w*_i + σ_common².

Instants TRACKED from one pick are not independent: each carries the pick's error along. Then the whole
sigma of an instant is common (it does not average out) and only what makes the instants differ (the
tracking noise, the object's bending) does, measured by their spread: σ² = q/Σ w*_i + σ_common² (no
floor: the floor assumes every instant carries its own pointing error) — ``shared_pointing``.

Instants a MODEL pointed at on its own on every frame sit between the two: a model errs on one fish much
the same way from frame to frame (the same fin shape, the same colour against the same seabed), but not
exactly so. Their pointing errors correlate between instants with a correlation ρ measured for the model
(``shared_fraction``; :func:`frame_correlation` estimates it from instants with truth): cov(e_i, e_j) =
ρ σ_i σ_j. Of each instant's σ_i², (1 − ρ) σ_i² is its own and averages out (τ̂² and the Hartung–Knapp
factor h = max(q, 1) are estimated on those variances), and the shared part is kept whole for the weights
a_i used: σ² = h Σ a_i² ((1 − ρ) σ_i² + τ̂²) + ρ (Σ a_i σ_i)² + σ_common². ρ = 0 is independent instants; ρ = 1
is ``shared_pointing``. Instants of one object need not all share alike — a reviewer who moves a model's
keypoint to where the fish is makes that point a person's, independent of the model's other frames — so
each instant may have its own ρ_i (one factor shared in part: e_i = √ρ_i σ_i z + √(1 − ρ_i) σ_i z_i, so
cov(e_i, e_j) = √(ρ_i ρ_j) σ_i σ_j): (1 − ρ_i) σ_i² averages out and (Σ a_i √ρ_i σ_i)² is kept whole.
The weights a_i are those of least variance under that covariance — generalised least squares, kept ≥ 0
(:func:`least_variance_weights`) — not the random-effects w*_i, which ignore the shared part: a fish seen at
σ 16.9 and 56.8 mm by a model (ρ 0.4) was combined to 17.8 mm with them, more than its better instant
alone; with the least-variance weights it is 16.9 mm. Without a shared part the two are the same.

What μ is: the mean of the object's figure over its instants (for a bending fish, its mean snout–fork
distance, which is shorter than its straight length; measure straight instants when that is wanted).

The χ² test of agreement is Cochran's: Q ~ χ²(k − 1) when the instants differ by their measurement
sigmas alone. An outlying instant is one whose leave-one-out standardised residual
r_i = (y_i − μ̂_(−i)) / sqrt(σ_i² + τ̂²_(−i) + σ²(μ̂_(−i))) exceeds the two-sided Bonferroni limit
Φ⁻¹(1 − α / (2k)) (α = 0.05 by default): it is named, not dropped.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace
from statistics import NormalDist

import numpy as np

from usvips.core.errors import InvalidParameterError
from usvips.core.measurements.combined_figure import ALPHA, CombinedFigure
from usvips.core.measurements.evaluate import Measurement
from usvips.core.measurements.figures import Figure, QualityRules
from usvips.core.measurements.registry import kind as kind_named


def _random_effects(values: np.ndarray, variances: np.ndarray,
                    floor: bool = True) -> tuple[float, float, float, float, float]:
    """DerSimonian–Laird with the Hartung–Knapp variance: (μ̂, var(μ̂), τ̂², Q, fixed-effect variance);
    ``floor``: var(μ̂) never less than the plain 1/Σ w*_i (each instant carries its own error ``variances``)."""
    k = len(values)
    w = 1.0 / variances
    s1 = w.sum()
    fixed = float(w @ values / s1)
    q = float(w @ (values - fixed) ** 2)
    if k < 2:
        return fixed, 1.0 / s1, 0.0, 0.0, 1.0 / s1
    tau2 = max(0.0, (q - (k - 1)) / (s1 - (w @ w) / s1))
    w_star = 1.0 / (variances + tau2)
    total = w_star.sum()
    mean = float(w_star @ values / total)
    spread = float(w_star @ (values - mean) ** 2) / (k - 1)
    return mean, (max(spread, 1.0) if floor else spread) / total, tau2, q, 1.0 / s1


def least_variance_weights(own: np.ndarray, loading: np.ndarray) -> np.ndarray:
    """The weights a (k,), a_i ≥ 0, Σ a_i = 1, of the weighted mean Σ a_i y_i of least variance when the
    errors of y have the covariance C = diag(``own``) + s sᵀ, s = ``loading`` (one factor shared in part,
    see the module docstring): generalised least squares, C⁻¹1 / 1ᵀC⁻¹1, except that an instant whose GLS
    weight would be negative (a far less precise one sharing the others' error: it would be subtracted to
    cancel that error) gets none — a length is not made by subtracting a frame. Solved by an active set
    (drop the most negative weight, take back an instant that would lower the variance), which ends at the
    constrained minimum: no other weights ≥ 0 give a smaller variance a C aᵀ."""
    own, loading = np.asarray(own, dtype=np.float64), np.asarray(loading, dtype=np.float64)
    k = len(own)
    covariance = np.diag(own) + np.outer(loading, loading)
    free = np.ones(k, dtype=bool)
    weights = np.full(k, 1.0 / k)
    for _ in range(4 * k + 4):
        index = np.flatnonzero(free)
        solved = np.linalg.solve(covariance[np.ix_(index, index)], np.ones(len(index)))
        trial = solved / solved.sum()
        if trial.min() < 0.0:
            free[index[int(np.argmin(trial))]] = False
            continue
        weights = np.zeros(k)
        weights[index] = trial
        gradient = covariance @ weights  # equal to the variance on the free instants
        level = float(weights @ gradient)
        lower = np.flatnonzero(~free & (gradient < level * (1.0 - 1e-12)))
        if lower.size == 0:
            break
        free[lower[int(np.argmin(gradient[lower]))]] = True
    return weights


def combine_figure(values: Sequence[float], sigmas: Sequence[float], common_sigma: float = 0.0,
                   name: str = "length", unit: str = "m", labels: Sequence[str] | None = None,
                   calibrations: Sequence[object] | None = None, alpha: float = ALPHA,
                   shared_pointing: bool = False,
                   shared_fraction: float | Sequence[float] = 0.0) -> CombinedFigure:
    """Combine one figure measured on k instants (see the module docstring).

    ``values`` (k,) and ``sigmas`` (k,) in ``unit``: each instant's figure and its sigma (independent
    between instants); ``common_sigma``: the part (same unit) common to all instants, e.g. the
    calibration's, added to the combined sigma and not reduced by combining; ``labels``: how the instants
    are named (default "instant 1" …); ``calibrations``: what each instant was measured with — instants
    on two different calibrations are refused, naming them. One instant is itself.

    ``shared_pointing``: the instants do NOT each carry their own error ``sigmas`` — they were tracked
    from one pick and carry its error along (give it in ``common_sigma``). What averages out over them is
    only what makes them differ (tracking noise, the object's own change), which their spread measures:
    the Hartung–Knapp variance is taken without its floor 1/Σ w*_i (that floor assumes each instant's own
    error is ``sigmas``); ``sigmas`` still weight them and make the agreement test.

    ``shared_fraction``: ρ in [0, 1), the correlation of two instants' errors ``sigmas`` (a model's keypoints
    on one fish, see the module docstring); (1 − ρ) σ_i² averages out, ρ σ_i σ_j does not. Or one ρ_i per
    instant (k,) — a model's instants with its ρ among instants a person picked (0) — the correlation of
    instants i and j then being √(ρ_i ρ_j). Not with ``shared_pointing`` (which is ρ = 1 with the carried
    error given in ``common_sigma``).
    """
    values = np.asarray(values, dtype=np.float64).ravel()
    sigmas = np.asarray(sigmas, dtype=np.float64).ravel()
    k = len(values)
    if k == 0:
        raise InvalidParameterError("instants", "none given: an object needs at least one instant")
    if sigmas.shape != values.shape:
        raise InvalidParameterError("sigmas", f"expected {k} sigmas for {k} instants, got {sigmas.size}")
    labels = tuple(labels) if labels is not None else tuple(f"instant {i + 1}" for i in range(k))
    if len(labels) != k:
        raise InvalidParameterError("labels", f"expected {k} labels for {k} instants, got {len(labels)}")
    bad = np.flatnonzero(~np.isfinite(values) | ~np.isfinite(sigmas) | (sigmas <= 0))
    if bad.size:
        i = int(bad[0])
        raise InvalidParameterError(name, f"{labels[i]}: {values[i]:g} ± {sigmas[i]:g} {unit} is not a measured "
                                          "value with a positive sigma")
    common_sigma = float(common_sigma)
    if not np.isfinite(common_sigma) or common_sigma < 0:
        raise InvalidParameterError("common_sigma", f"must be ≥ 0 and finite, got {common_sigma:g}")
    if calibrations is not None:
        calibrations = list(calibrations)
        if len(calibrations) != k:
            raise InvalidParameterError("calibrations", f"expected {k} for {k} instants, got {len(calibrations)}")
        first = calibrations[0]
        other = next((i for i, c in enumerate(calibrations) if c != first), None)
        if other is not None:
            raise InvalidParameterError(
                "instants", f"{labels[0]} was measured with calibration {first} but {labels[other]} with "
                            f"calibration {calibrations[other]}: instants of one object must share one calibration "
                            "(re-measure them with one, or keep them as separate objects)")
    fractions = _shared_fractions(shared_fraction, labels)
    if shared_pointing and fractions.any():
        raise InvalidParameterError("shared_fraction", "not with shared pointing, which shares the whole error")
    variances = (1.0 - fractions) * sigmas ** 2
    mean, variance, tau2, q, fixed_variance = _random_effects(values, variances, floor=not shared_pointing)
    weights = 1.0 / (variances + tau2)
    weights = weights / weights.sum()
    shared = 0.0
    if fractions.any():
        # the independent parts' variance for any weights a: scale × Σ a_i² (v_i + τ²), scale the
        # Hartung–Knapp factor (var(μ̂) = scale / Σ w*_i); the shared part (Σ a_i s_i)²
        scale = variance * float((1.0 / (variances + tau2)).sum())
        loading = np.sqrt(fractions) * sigmas
        weights = least_variance_weights(scale * (variances + tau2), loading)
        mean = float(weights @ values)
        variance = scale * float(weights ** 2 @ (variances + tau2))
        shared = float(weights @ loading) ** 2
    total = variance + shared + common_sigma ** 2
    between = max(0.0, variance - fixed_variance) / total if total > 0 else 0.0
    residuals = np.full(k, np.nan)
    if k >= 3:
        for i in range(k):
            keep = np.arange(k) != i
            m, v, t2, _, _ = _random_effects(values[keep], variances[keep])
            residuals[i] = (values[i] - m) / np.sqrt(variances[i] + t2 + v)
    # the normal's quantile (standard library) and the chi-square's tail (scipy.special, ~0.03 s to import):
    # scipy.stats takes ~0.4 s to import, a freeze of the window when its first combined figure is computed on
    # — or waited for by — the window's thread
    from scipy.special import chdtrc

    limit = -NormalDist().inv_cdf(alpha / (2 * k))
    outliers = tuple(int(i) for i in np.flatnonzero(np.abs(residuals) > limit))
    dof = k - 1
    p_value = float(chdtrc(dof, q)) if dof > 0 else 1.0
    return CombinedFigure(name, unit, mean, float(np.sqrt(total)), k, float(np.sqrt(tau2)), float(between), q, dof,
                          p_value, residuals, limit, outliers, labels, weights,
                          np.ones(k) if shared_pointing else fractions, bool(shared_pointing))


def _shared_fractions(shared_fraction: float | Sequence[float], labels: Sequence[str]) -> np.ndarray:
    """ρ_i per instant (k,) from one ρ for all or one per instant, each checked to lie in [0, 1)."""
    k = len(labels)
    fractions = np.asarray(shared_fraction, dtype=np.float64)
    one = fractions.ndim == 0
    if one:
        fractions = np.full(k, float(fractions))
    elif fractions.shape != (k,):
        raise InvalidParameterError("shared_fraction", f"expected one value or {k} for {k} instants, got "
                                                       f"{fractions.size}")
    bad = np.flatnonzero(~((fractions >= 0.0) & (fractions < 1.0)))
    if bad.size:
        i = int(bad[0])
        where = "" if one else f"{labels[i]}: "
        raise InvalidParameterError("shared_fraction", f"{where}must lie in [0, 1) (a correlation between instants; "
                                                       f"1 is shared pointing), got {fractions[i]:g}")
    return fractions


def combine_instants(instants: Sequence[Sequence[Figure]], common_sigmas: dict[str, float] | None = None,
                     labels: Sequence[str] | None = None, calibrations: Sequence[object] | None = None,
                     shared_pointing: bool = False,
                     shared_fraction: float | Sequence[float] = 0.0) -> tuple[CombinedFigure, ...]:
    """Every figure of an object measured on several instants, combined figure by figure.

    ``instants``: per instant the figures of the one figure function (the same names in each);
    ``common_sigmas``: figure name → the sigma common to all instants (default 0); ``labels`` and
    ``calibrations``, ``shared_pointing``, ``shared_fraction`` as :func:`combine_figure`. Returns the combined
    figures in the first instant's order."""
    if not instants:
        raise InvalidParameterError("instants", "none given: an object needs at least one instant")
    names = [f.name for f in instants[0]]
    for i, figures in enumerate(instants[1:], 1):
        if [f.name for f in figures] != names:
            label = labels[i] if labels is not None else f"instant {i + 1}"
            raise InvalidParameterError("instants", f"{label} has the figures {[f.name for f in figures]}, "
                                                    f"the first instant {names}: one object is one kind")
    common_sigmas = common_sigmas or {}
    combined = []
    for j, name in enumerate(names):
        figures = [fs[j] for fs in instants]
        combined.append(combine_figure([f.value for f in figures], [f.sigma for f in figures],
                                       common_sigmas.get(name, 0.0), name, figures[0].unit, labels, calibrations,
                                       shared_pointing=shared_pointing, shared_fraction=shared_fraction))
    return tuple(combined)


def combine_measurements(measurements: Sequence[Measurement], independent: Sequence[Measurement] | None = None,
                         labels: Sequence[str] | None = None, calibrations: Sequence[object] | None = None,
                         rules: QualityRules | None = None, shared_pointing: bool = False,
                         shared_fraction: float | Sequence[float] = 0.0) -> Measurement:
    """One object from its instants' measurements (each from the one figure function): the first
    instant's with its figures replaced by the combined ones and ``combined`` set, its ray RMS and range
    the largest of the instants', and the quality rules checked on the combined main figure.

    ``independent``: the same instants measured with their pointing covariance only (no calibration
    part); each figure's part common to the instants is then the mean of σ²_total − σ²_pointing and the
    instants are weighted by their pointing sigmas. Without it the instants' sigmas are taken as
    independent (correct when the calibration's part is negligible or not known).

    ``shared_pointing``: the instants' pointing errors are one error carried along, not independent ones —
    instants TRACKED from one pick (a tracker follows the point picked, with its pick error, to the other
    frames). Averaging them cannot average that error out, so each figure's whole sigma (the mean of the
    instants' σ²_total: calibration and pointing) is the common part, and what averages out is measured by
    the instants' spread alone (tracking noise, bending: see :func:`combine_figure`).

    ``shared_fraction``: the correlation ρ in [0, 1) of the instants' pointing errors (a model's keypoints on
    one fish, each instant pointed on its own): ρ of each instant's pointing variance does not average out
    (:func:`combine_figure`). One measurement is returned as it is."""
    if not measurements:
        raise InvalidParameterError("instants", "none given: an object needs at least one instant")
    first = measurements[0]
    if len(measurements) == 1:
        return first
    kinds = {m.kind for m in measurements}
    if len(kinds) > 1:
        raise InvalidParameterError("instants", f"of different kinds ({', '.join(sorted(kinds))}): one object is "
                                                "one kind")
    weights = measurements
    common: dict[str, float] = {}
    if independent is not None:
        if len(independent) != len(measurements):
            raise InvalidParameterError("independent", f"expected {len(measurements)} measurements, got "
                                                       f"{len(independent)}")
        weights = independent
        for j, figure in enumerate(first.figures):
            parts = [m.figures[j].sigma ** 2 - p.figures[j].sigma ** 2
                     for m, p in zip(measurements, independent, strict=True)]
            common[figure.name] = float(np.sqrt(max(0.0, float(np.mean(parts)))))
    if shared_pointing:
        for j, figure in enumerate(first.figures):
            common[figure.name] = float(np.sqrt(np.mean([m.figures[j].sigma ** 2 for m in measurements])))
    instants = [tuple(Figure(f.name, f.value, max(p.sigma, 1e-15), f.unit) for f, p in zip(m.figures, w.figures,
                                                                                        strict=True))
                for m, w in zip(measurements, weights, strict=True)]
    combined = combine_instants(instants, common, labels, calibrations, shared_pointing=shared_pointing,
                                shared_fraction=shared_fraction)
    figures = tuple(c.figure for c in combined)
    rms = [m.ray_rms_m for m in measurements if m.ray_rms_m is not None]
    ranges = [m.range_m for m in measurements if m.range_m is not None]
    ray_rms = max(rms) if rms else None
    range_m = max(ranges) if ranges else None
    measurement_kind = kind_named(first.kind)
    main = next(f for f in figures if f.name == measurement_kind.main_name())
    failures = (rules or QualityRules()).check(main, ray_rms, range_m, relative=measurement_kind.relative_rule)
    return replace(first, figures=figures, failures=tuple(failures), ray_rms_m=ray_rms, range_m=range_m,
                   joint=all(m.joint for m in measurements), combined=combined)


@dataclass(frozen=True)
class FrameCorrelation:
    """The correlation ρ of one object's pointing errors between its instants, estimated from instants with
    truth (:func:`frame_correlation`): ``value`` in [0, 1), its jackknife standard ``uncertainty`` over the
    objects, from ``objects`` objects with ``instants`` instants in all; ``bound``: the estimate fell outside
    [0, :data:`MAX_FRAME_CORRELATION`] and ``value`` is that bound."""

    value: float
    uncertainty: float
    objects: int
    instants: int
    bound: bool


#: the largest frame correlation :func:`frame_correlation` gives: instants correlated further are one error
#: carried along (``shared_pointing``), which is a fact of how they were made, not an estimate
MAX_FRAME_CORRELATION = 0.95
#: the fewest objects with two instants or more a frame correlation is estimated from
MIN_FRAME_OBJECTS = 10


def _pooled_correlation(groups: Sequence[np.ndarray]) -> float:
    cross = sum(float(z.sum() ** 2 - z @ z) for z in groups)
    square = sum(float((len(z) - 1) * (z @ z)) for z in groups)
    return cross / square


def frame_correlation(normalised_errors: Sequence[Sequence[float]]) -> FrameCorrelation:
    """ρ of :func:`combine_figure`'s ``shared_fraction``, from each object's instants' normalised errors
    z = (value − truth) / σ (σ: the instant's own sigma, its pointing part), one sequence per object.

    The pooled moment estimator ρ̂ = Σ_objects Σ_{i≠j} z_i z_j / Σ_objects (k − 1) Σ_i z_i²: the mean product
    of two instants' errors of one object over their mean square, so a σ that is too large or too small
    overall does not bias it (it is a correlation). Objects with one instant add nothing and are left out;
    fewer than :data:`MIN_FRAME_OBJECTS` objects with two or more, or a non-finite z, are an
    :class:`InvalidParameterError`. Its standard uncertainty is the jackknife's, leaving out one object at a
    time (the instants of one object are not independent)."""
    groups = [np.asarray(z, dtype=np.float64).ravel() for z in normalised_errors]
    if any(not np.all(np.isfinite(z)) for z in groups):
        raise InvalidParameterError("normalised_errors", "every normalised error must be finite")
    groups = [z for z in groups if len(z) >= 2]
    if len(groups) < MIN_FRAME_OBJECTS:
        raise InvalidParameterError("normalised_errors", f"{len(groups)} objects with two instants or more; at "
                                                         f"least {MIN_FRAME_OBJECTS} are needed to estimate how "
                                                         "their errors correlate")
    if not any(z @ z > 0 for z in groups):
        raise InvalidParameterError("normalised_errors", "every error is zero: no correlation can be estimated")
    estimate = _pooled_correlation(groups)
    n = len(groups)
    leave_one_out = np.array([_pooled_correlation(groups[:i] + groups[i + 1:]) for i in range(n)])
    uncertainty = float(np.sqrt((n - 1) / n * np.sum((leave_one_out - leave_one_out.mean()) ** 2)))
    value = float(np.clip(estimate, 0.0, MAX_FRAME_CORRELATION))
    return FrameCorrelation(value, uncertainty, n, int(sum(len(z) for z in groups)), value != estimate)
