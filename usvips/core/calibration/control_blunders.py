"""Control points whose coordinates, not their image observations, are wrong: found, named, kept useful.

A misprinted control coordinate (Table 3.1 of the thesis prints Z = +100 m for target 3 of a frame at
Z = −100 m) spoils the point in *every* image that sees it, whereas a pointing blunder spoils one image.
So a control point is a candidate when observations of it fail (set aside as gross, unreachable from the
start, or rejected by the tau test) in at least two images. The candidate is then demoted: its X, Y, Z
become free unknowns (a tie point), started by intersecting its own rays, and the calibration is
adjusted again with all of its image observations. The demotion is kept only when

* every image observation of the point then passes the tau test (its images agree with each other), and
* the fitted coordinates differ from the control coordinates significantly: the squared Mahalanobis
  distance ΔXᵀ Σ⁻¹ ΔX (Σ the fitted coordinates' covariance, metres) exceeds the χ²(3) quantile at the
  snooping level α0 (so blunder-free data demotes a point about once in 1/α0 candidates, and a
  candidate needs two failing images first).

Otherwise the point stays a control point and its failing observations stay set aside as observation
blunders. The message names each coordinate that is off by more than the tau test's critical value of
its sigma (or the worst one): "control Z of target 3 is 200 m off its fitted value (−100.000 ± 0.004 m)".

It scales: the candidates are scored from the ONE adjustment by a test statistic of a shift of each
point's control coordinates (:func:`shift_statistics`: the share of the point's weighted image residuals,
prediction residuals of set-aside observations included, that moving the point explains; about χ²(3)
for a correct point), and only the few worst above that χ²(3) quantile at α0 are re-adjusted
(:data:`MAX_TRIALS` in all) — never one full adjustment per point. Each trial is first screened by one
adjustment without snooping in which the observations already set aside are weighted out; only a
demotion that passes there is adjusted in full (with snooping) and judged. A target whose geometry is exact by
construction (a printed board) is not searched at all (``CalibrationOptions.control_exact``).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from usvips.core.adjustment import ALPHA0, Adjustment, Parameter, adjust, tau_critical
from usvips.core.calibration.model import StereoModel
from usvips.core.errors import UsvipsError
from usvips.core.intersection import intersect
from usvips.core.observations import ControlPoints

AXES = ("X", "Y", "Z")


@dataclass
class ControlBlunder:
    """A control point (partly) demoted to a tie point: its ``point`` id; the coordinates ``freed`` (estimated
    now), their ``control`` and ``fitted`` values and the fitted ones' ``sigma`` (metres, object frame); the
    ``axes`` named as off; the test statistic ``chi2`` (len(freed) degrees of freedom); the ``message``."""

    point: str
    control: np.ndarray
    fitted: np.ndarray
    sigma: np.ndarray
    axes: tuple[str, ...]
    freed: tuple[str, ...]
    chi2: float
    message: str

    @property
    def offset(self) -> np.ndarray:
        """The fitted coordinates' offsets from the control (metres, fitted − control)."""
        return self.fitted - self.control

    def as_dict(self) -> dict:
        return {"id": self.point, "axes": list(self.axes), "freed": list(self.freed),
                "control": [float(v) for v in self.control],
                "fitted": [float(v) for v in self.fitted], "sigma": [float(v) for v in self.sigma],
                "offset": [float(v) for v in self.fitted - self.control], "chi2": self.chi2,
                "message": self.message}


def is_control_coordinate(name: str) -> bool:
    """``X@7`` (a control point's coordinate), not ``X0_l@2`` (a station's pose)."""
    return "@" in name and name.split("@")[0] in AXES


def _distance(metres: float) -> str:
    size = abs(metres)
    return f"{size:.3g} m" if size >= 1.0 else f"{size * 1000:.3g} mm"


def _troubled_images(adjustment: Adjustment, critical: float) -> dict[str, set[tuple[str, str]]]:
    """Per point id, the images (station, side) in which an observation of it is set aside or fails tau."""
    obs = adjustment.observations
    out: dict[str, set[tuple[str, str]]] = {}
    for s in adjustment.excluded:
        out.setdefault(s.point, set()).add((s.group, s.side))
    failing = np.flatnonzero(adjustment.used & (np.abs(adjustment.w) > critical))
    for i in failing:
        out.setdefault(obs.point[i], set()).add((obs.group[i], obs.side[i]))
    return out


def _critical(adjustment: Adjustment) -> float:
    return tau_critical(adjustment.global_test.get("observation_redundancy", adjustment.redundancy))


def _start_point(model: StereoModel, values: dict[str, float], point: str) -> np.ndarray | None:
    """The point's coordinates from its own rays with the current cameras (every image that sees it)."""
    cameras, pixels = [], []
    obs = model.observations
    for row in np.flatnonzero([pid == point for pid in obs.ids]):
        left, right = model.cameras(values, obs.pairs[row], bounded=False)
        cameras += [left, right]
        pixels += [obs.left[row][None, :], obs.right[row][None, :]]
    if len(cameras) < 2:
        return None
    try:
        result = intersect(cameras, pixels, model.sigma_px)
    except UsvipsError:
        return None
    return result.points[0] if result.ok[0] else None


def _demoted_control(control: ControlPoints, point: str) -> ControlPoints:
    """The control with ``point``'s coordinates turned into parameters (the model makes every control
    coordinate a parameter as soon as one has a sigma; the demoted point's are then set free)."""
    sigmas = np.zeros_like(control.xyz) if control.sigmas is None else np.array(control.sigmas, float)
    sigmas[control.ids.index(point)] = 1.0
    return ControlPoints(control.ids, control.xyz, sigmas, control.source, control.lines)


def _trial(model: StereoModel, demoted: StereoModel, parameters: list[Parameter], point: str,
           axes: tuple[str, ...], start: np.ndarray, others: str) -> list[Parameter]:
    """The parameters with the coordinates ``axes`` of ``point`` free (at ``start``); every other
    non-control parameter keeps its state (``others="keep"``) or is held (``"fixed"``)."""
    trial = [replace(p) for p in parameters if not is_control_coordinate(p.name)]
    if others == "fixed":
        for p in trial:
            p.status, p.group = "fixed", None
    old = {p.name: p for p in parameters if is_control_coordinate(p.name)}
    xyz = model.control_xyz({p.name: p.value for p in parameters})
    for i, pid in enumerate(demoted.control.ids):
        for k, axis in enumerate(AXES):
            name = f"{axis}@{pid}"
            if pid == point and axis in axes:
                trial.append(Parameter(name, float(start[k]), "free"))
            elif name in old and others == "keep":  # a control file with sigmas: keep its state
                trial.append(replace(old[name]))
            else:
                trial.append(Parameter(name, float(xyz[i, k]), "fixed"))
    return trial


def _own_misfit(model: StereoModel, demoted: StereoModel, parameters: list[Parameter], point: str,
                axes: tuple[str, ...], start: np.ndarray) -> float | None:
    """The point's own weighted squared residuals when only its coordinates ``axes`` are fitted to its
    image observations with the cameras held: a cheap test of which coordinates explain its images."""
    trial = _trial(model, demoted, parameters, point, axes, start, "fixed")
    try:
        result = adjust(demoted.problem(trial), robust=False, snooping=False)
    except UsvipsError:
        return None
    mine = np.array([pid == point for pid in result.observations.point])
    if not result.used[mine].all():
        return None  # that coordinate alone cannot bring the point in front of its cameras
    return float(np.sum((result.residuals[mine] / result.observations.sigmas[mine]) ** 2))


#: A-priori sigma factor that takes an observation out of a quick trial (its weight ~1e-12 of the others).
SET_ASIDE_SCALE = 1e6


def _without_set_aside(demoted: StereoModel, adjustment: Adjustment, point: str) -> StereoModel:
    """The demoted model with the observations the adjustment set aside (other than ``point``'s own)
    weighted out, so that a quick trial needs no data snooping (the layouts of both models agree)."""
    obs = demoted.observation_set
    out = ~np.asarray(adjustment.used, bool) & np.array([pid != point for pid in obs.point])
    quick = replace(demoted)
    quick.observation_set = replace(obs, sigmas=np.where(out, obs.sigmas * SET_ASIDE_SCALE, obs.sigmas))
    return quick


def _try_demotion(model: StereoModel, demoted: StereoModel, parameters: list[Parameter], point: str,
                  axes: tuple[str, ...], start: np.ndarray, robust: bool, snoop_unit_of: Callable,
                  quick: Adjustment | None = None) -> tuple[list[Parameter], Adjustment] | None:
    """Adjust everything with the coordinates ``axes`` of ``point`` free; None when that fails or leaves
    any of the point's image observations failing the tau test. ``quick``: the current adjustment, whose
    set-aside observations are then weighted out and the trial run without snooping (a cheap pre-screen:
    one adjustment instead of one per rejection)."""
    trial = _trial(model, demoted, parameters, point, axes, start, "keep")
    try:
        if quick is not None:
            result = adjust(_without_set_aside(demoted, quick, point).problem(trial), robust=False, snooping=False)
        else:
            result = adjust(demoted.problem(trial), robust=robust, snooping=True, snoop_unit=snoop_unit_of(demoted))
    except UsvipsError:
        return None
    if not result.converged:
        return None
    mine = np.array([pid == point for pid in result.observations.point])
    if not result.used[mine].all() or np.any(np.abs(result.w[mine]) > _critical(result)):
        return None  # its images disagree with each other too: an observation blunder, not the control
    return trial, result


def _significance(model: StereoModel, result: Adjustment, point: str, axes: tuple[str, ...]):
    """The fitted coordinates ``axes`` of ``point``, their sigmas (fitted ⊕ the control's own), offsets from
    the control (metres) and the χ² of those offsets with len(axes) degrees of freedom."""
    names = [f"{a}@{point}" for a in axes]
    index = [result.covariance_names.index(n) for n in names]
    row = model.control.ids.index(point)
    k = [AXES.index(a) for a in axes]
    covariance = result.covariance[np.ix_(index, index)]
    if model.control.sigmas is not None:
        covariance = covariance + np.diag(np.asarray(model.control.sigmas[row], float)[k] ** 2)
    fitted = np.array([result.value(n) for n in names])
    offset = fitted - model.control.xyz[row, k]
    try:
        chi2 = float(offset @ np.linalg.solve(covariance, offset))
    except np.linalg.LinAlgError:
        chi2 = float("nan")
    return fitted, np.sqrt(np.maximum(np.diag(covariance), 0.0)), offset, chi2


def _demote(model: StereoModel, parameters: list[Parameter], adjustment: Adjustment, point: str, robust: bool,
            snoop_unit_of: Callable) -> tuple[StereoModel, list[Parameter], Adjustment, ControlBlunder] | None:
    """The smallest change to ``point``'s control that lets its images agree. A misprint hits one number:
    each coordinate alone is fitted to the point's images with the cameras held, and the one whose fit
    leaves the smallest residuals is freed in a full adjustment; when the point's images still disagree
    there (or that coordinate is not significantly off), all three are freed. None when no demotion
    explains the images or the freed coordinates are not significantly off their control values."""
    values = {p.name: p.value for p in parameters}
    start = _start_point(model, values, point)
    if start is None:
        return None
    demoted = StereoModel(model.kind, _demoted_control(model.control, point), model.observations, model.sigma_px,
                          model.size)
    fits = {}
    for axis in AXES:
        first = model.control.xyz[model.control.ids.index(point)].copy()
        first[AXES.index(axis)] = start[AXES.index(axis)]
        misfit = _own_misfit(model, demoted, parameters, point, (axis,), first)
        if misfit is not None:
            fits[axis] = (misfit, first)
    attempts = [((axis,), fits[axis][1]) for axis in sorted(fits, key=lambda a: fits[a][0])[:1]]
    attempts.append((AXES, start))
    from scipy import stats  # deferred: scipy.stats is slow to import (the window's start-up)

    for axes, first in attempts:
        # a cheap pre-screen with the set-aside observations weighted out, then the full adjustment
        screened = _try_demotion(model, demoted, parameters, point, axes, first, robust, snoop_unit_of, adjustment)
        if screened is None or not _significance(model, screened[1], point, axes)[3] > stats.chi2.ppf(
                1.0 - ALPHA0, len(axes)):
            continue
        outcome = _try_demotion(model, demoted, parameters, point, axes, first, robust, snoop_unit_of)
        if outcome is None:
            continue
        trial, result = outcome
        fitted, sigma, offset, chi2 = _significance(model, result, point, axes)
        if not chi2 > stats.chi2.ppf(1.0 - ALPHA0, len(axes)):
            continue
        ratio = np.abs(offset) / np.maximum(sigma, 1e-300)
        named = [k for k, q in enumerate(ratio) if q > _critical(result)] or [int(np.argmax(ratio))]
        parts = [f"control {axes[k]} of target {point} is {_distance(offset[k])} off its fitted value "
                 f"({fitted[k]:.4f} ± {sigma[k]:.4f} m)" for k in named]
        message = ("; ".join(parts) + ": its images agree with each other but not with its control coordinates, "
                   f"so {'that coordinate is' if len(axes) == 1 else 'its coordinates are'} estimated (a tie "
                   "point) and its image observations are kept")
        row = model.control.ids.index(point)
        blunder = ControlBlunder(point, model.control.xyz[row, [AXES.index(a) for a in axes]], fitted, sigma,
                                 tuple(axes[k] for k in named), tuple(axes), chi2, message)
        return demoted, trial, result, blunder
    return None


#: Full re-adjustments the search may spend in one calibration (each tries one candidate's demotion).
MAX_TRIALS = 4

#: Step (metres) of the numerical derivative of a point's pixels with respect to its coordinates.
SHIFT_STEP = 1e-5


def shift_statistics(model: StereoModel, values: dict[str, float], adjustment: Adjustment,
                     points: list[str]) -> dict[str, float]:
    """Per point id, the test statistic of a shift of its control coordinates from the one adjustment:
    T = gᵀ N⁻¹ g with g = Jᵀ W r and N = Jᵀ W J over every image observation of the point (r: residuals,
    observed − computed at the adjusted values, set-aside ones included; J: ∂pixel/∂(X, Y, Z) by central
    differences; W: 1 / (σ0 σ)²). About χ²(3) for a correct point (a little less: the adjustment has
    absorbed part of its residuals); large when its images agree on a different position."""
    obs = model.observation_set
    computed, ok = model.evaluate(values)
    residual = obs.values - computed
    scale = max(adjustment.sigma0, 1e-12)
    weights = 1.0 / (obs.sigmas * scale) ** 2
    xyz = model.control_xyz(values)
    wanted = set(points)
    rows_of: dict[str, list[int]] = {}
    for i, pid in enumerate(obs.point):
        if pid in wanted and ok[i] and np.isfinite(computed[i]):
            rows_of.setdefault(pid, []).append(i)
    jacobian = np.zeros((len(obs), 3))
    shared: dict = {}
    cameras: dict[str, tuple] = {}
    for pid, rows in rows_of.items():
        point = xyz[model.control.ids.index(pid)]
        for start in rows[::2]:  # x and y rows of one image follow each other
            station, side = obs.group[start], obs.side[start]
            if station not in cameras:
                cameras[station] = model.cameras(values, station, bounded=False, shared=shared)
            camera = cameras[station][0 if side == "l" else 1]
            probes = np.repeat(point[None, :], 6, axis=0)
            for k in range(3):
                probes[2 * k, k] += SHIFT_STEP
                probes[2 * k + 1, k] -= SHIFT_STEP
            try:
                projection = camera.project(probes)
            except UsvipsError:
                continue
            if not np.all(projection.status == 0):
                continue
            derivative = (projection.pixels[0::2] - projection.pixels[1::2]).T / (2 * SHIFT_STEP)  # (2, 3)
            jacobian[start:start + 2] = derivative
    out = {}
    for pid, rows in rows_of.items():
        j = jacobian[rows]
        w = weights[rows]
        normal = j.T @ (w[:, None] * j)
        gradient = j.T @ (w * residual[rows])
        try:
            out[pid] = float(gradient @ np.linalg.solve(normal, gradient))
        except np.linalg.LinAlgError:
            continue
    return out


def demote_control_blunders(model: StereoModel, parameters: list[Parameter], adjustment: Adjustment,
                            robust: bool, snoop_unit_of: Callable
                            ) -> tuple[StereoModel, list[Parameter], Adjustment, list[ControlBlunder]]:
    """Demote, one at a time (worst first), every control point that fails in two or more images and whose
    images agree once its coordinates are free (module docstring). Returns the model, parameters and
    adjustment to use (the originals when nothing is demoted) and the demotions. ``snoop_unit_of(model)``
    gives the model's snooping unit. The parameters of the returned adjustment hold its values."""
    from scipy import stats  # deferred: scipy.stats is slow to import (the window's start-up)

    critical = float(stats.chi2.ppf(1.0 - ALPHA0, 3))
    blunders: list[ControlBlunder] = []
    tried: set[str] = set()
    while len(tried) < MAX_TRIALS:
        free = {p.name.split("@")[1] for p in parameters if is_control_coordinate(p.name) and p.status == "free"}
        troubled = _troubled_images(adjustment, _critical(adjustment))
        candidates = [pid for pid, images in troubled.items()
                      if len(images) >= 2 and pid in model.control.ids and pid not in free and pid not in tried]
        if not candidates:
            break
        scores = shift_statistics(model, {p.name: p.value for p in parameters}, adjustment, candidates)
        ranked = sorted((pid for pid in candidates if scores.get(pid, np.inf) > critical),
                        key=lambda pid: -scores.get(pid, np.inf))
        if not ranked:
            break
        for point in ranked[:MAX_TRIALS - len(tried)]:
            tried.add(point)
            outcome = _demote(model, parameters, adjustment, point, robust, snoop_unit_of)
            if outcome is not None:
                model, parameters, adjustment, blunder = outcome
                blunders.append(blunder)
                break  # the adjustment changed: score the rest again
        else:
            break
    return model, parameters, adjustment, blunders
