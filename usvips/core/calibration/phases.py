"""The two calibration phases of the thesis (2.3, 3.4.4), and their joint multi-pair form.

Phase 1 (``calibrate_air``): both cameras from one or more in-air pairs by collinearity with distortion
and y-scale (the model of ``camera.py`` with no housing), started by the DLT. Phase 2
(``calibrate_water``): the phase-1 interior fixed (or weighted by its phase-1 sigmas), the housing and
the exterior orientations by ray tracing. Observations with several pair labels adjust all those
stations at once, sharing the interior, the housing and the rig's relative orientation (the joint mode
the thesis recommends, 4.2).

Port tilt and decentring correlate almost perfectly with the principal point and decentring
distortion, and a sphere centred near the perspective centre hardly bends the rays, so its radius is
barely observable: the housing parameters enter with priors (value ± sigma) by default. The report
names every correlation above 0.95 and the parameters of the weakest directions, so a user sees which
figures the data did not determine.

Where the default housing priors (``DEFAULT_HOUSING``, camera frame, metres) come from — the physics of a
housing, not any data set. System I (dome cover): a dome is mounted to be concentric with the lens, so
its sphere centre a, b, c lies within a few centimetres of the perspective centre (0 ± 3 cm; the entrance
pupil of a small lens is not exactly known); camera domes of small underwater housings have radii of
7-11 cm (r 9 ± 2 cm); a cover plate of glass or acrylic that carries a pressure is 1-5 cm thick at its
thinnest point (t 3 ± 2 cm); window glass and acrylic have n2 between 1.49 and 1.65 (1.6 ± 0.02 for the
thesis's glass, widen it for acrylic), water 1.33 (fresh, warm) to 1.345 (sea water, cold): 1.34 ± 0.01.
On the thesis tank with target 3 kept (its misprinted Z demoted, :mod:`control_blunders`) the data put
t at 16 ± 19 mm and t_r at 45 ± 19 mm, inside those priors; without a prior on t the fit runs to t → 0
(thickness, radius and axial offset trade off along a valley the 9 targets do not close), so the prior
is needed rather than widened. (With target 3 dropped, 26 observations for 25 unknowns, the fit had
looked as if it wanted the plane far beyond the sphere.) Starts: several physically distinct housings
are tried (each housing kind's ``start_grid``) and the best by the objective is kept.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np

from usvips.core import housing as housings
from usvips.core.adjustment import ALPHA0, GROSS, Adjustment, Parameter, PriorGroup, adjust
from usvips.core.calibration.control_blunders import ControlBlunder, demote_control_blunders, is_control_coordinate
from usvips.core.calibration.figures import baseline_sigma
from usvips.core.calibration.model import SIDES, StereoModel
from usvips.core.calibration.parameter_names import housing_parameter_names, symbol
from usvips.core.calibration.planar import is_coplanar, planar_start, resect_views
from usvips.core.calibration.report import BoundHit, CalibrationReport, Correlation, ResidualRow
from usvips.core.camera import EXTERIOR_PARAMETERS, Camera, Exterior
from usvips.core.dlt import robust_dlt
from usvips.core.errors import DegenerateGeometryError, InvalidParameterError, UsvipsError
from usvips.core.interior import INTERIOR_PARAMETERS
from usvips.core.observations import ControlPoints, StereoObservations
from usvips.core.rig import relative_orientation, right_exterior
from usvips.core.stereo_calibration import ParameterEstimate, StereoCalibration

#: Phase 1 frees these interior parameters by default; the others stay fixed (at 0, or sy at 1 → DLT).
DEFAULT_AIR_FREE = ("f", "xp", "yp", "sy", "k1")

#: Phase 2 defaults per housing kind: symbol → (start value, prior sigma or None for fixed), camera frame,
#: metres; each kind states and documents its own (``usvips/core/housing/kinds/``).
DEFAULT_HOUSING = {name: housings.kind(name).priors() for name in housings.water_names()}


@dataclass
class CalibrationOptions:
    """free / fix: parameter names (or seeds' symbols applying to both cameras, e.g. ``k2``); fix_values
    and priors: name → value and name → (value, sigma); sigma_px: a-priori pointing precision (px);
    interior: ``fixed`` or ``weighted`` (phase 2); robust, snooping: blunder handling of least squares;
    control_exact: the target's geometry is exact by construction (a printed board:
    ``CalibrationTarget.exact``), so its control coordinates are not searched for misprints
    (:mod:`.control_blunders`); estimator: ``least squares`` (a robust start, then Baarda's data snooping),
    ``huber`` (M-estimation: heavy-tailed noise down-weighted, gross errors set aside and named;
    :func:`usvips.core.adjustment.adjust`) or ``auto``: :func:`estimator_for`. cancelled: asked before each
    iteration of the adjustment (True stops the calibration with :class:`InterruptedError`; the window's
    Stop).

    Phase 2 only: ``cameras_unmoved``: the cameras did not move between the air and the water images (a
    target photographed in a tank before and after filling it, through its wall): each view's poses are
    held at phase 1's (:func:`held_poses`), so the refraction cannot hide in the pose; ``air_through_glass``:
    the air images were taken through the same flat glass (the empty tank's wall, the port), whose shift of
    the poses is then undone (:func:`_through_glass_in_air`). ``housing_geometry``:
    what the user knows of the housing, quantity (:data:`usvips.core.housing.base.GEOMETRY`: ``distance``,
    ``thickness``, ``n_glass``, ``n_water``) → (value, sigma or None to hold it fixed); the housing kind
    names the parameter each sets (:func:`geometry_options`)."""

    free: tuple[str, ...] = ()
    fix: tuple[str, ...] = ()
    fix_values: dict[str, float] = field(default_factory=dict)
    priors: dict[str, tuple[float, float]] = field(default_factory=dict)
    sigma_px: float = 0.5
    interior: str = "weighted"
    robust: bool = True
    snooping: bool = True
    control_exact: bool = False
    estimator: str = "auto"
    image_size: tuple[int | None, int | None] = (None, None)
    cancelled: Callable[[], bool] | None = None
    cameras_unmoved: bool = False
    air_through_glass: bool = True
    housing_geometry: dict[str, tuple[float, float | None]] = field(default_factory=dict)


@dataclass
class CalibrationResult:
    calibration: StereoCalibration
    adjustment: Adjustment
    model: StereoModel
    report: CalibrationReport
    #: control points demoted to tie points (:class:`ControlBlunder`), in the order found
    control_blunders: list = field(default_factory=list)

    def __bool__(self) -> bool:
        return bool(self.adjustment)


#: the calibration options that name parameters, in words (``what`` of :func:`_expand`)
_OPTION_WORDS = {"free": "parameters to free", "fix": "parameters to fix", "prior": "priors"}


def _expand(names, all_names: list[str], what: str) -> set[str]:
    """Names or seeds' symbols (``k2`` = k2_l and k2_r) → parameter names; unknown names raise."""
    out: set[str] = set()
    for name in names:
        matches = [n for n in all_names if n == name or symbol(n) == name and "@" not in n]
        if not matches:
            raise InvalidParameterError(what, f"unknown parameter {name!r}; known: {', '.join(all_names[:40])}",
                                        label=_OPTION_WORDS[what])
        out.update(matches)
    return out


def _dlt_starts(control: ControlPoints, observations: StereoObservations) -> dict:
    """Robust DLT of every (station, side): interior and exterior starting values."""
    starts = {}
    for station in observations.pair_labels:
        pair = observations.pair(station)
        xyz = control.xyz[control.index_of(list(pair.ids), "observation")]
        for side in SIDES:
            try:
                starts[(station, side)] = robust_dlt(xyz, pair.left if side == "l" else pair.right)
            except DegenerateGeometryError as error:
                raise DegenerateGeometryError(f"pair {station!r}, {'left' if side == 'l' else 'right'} image: "
                                              f"{error}") from None
    return starts


def _exterior_values(starts: dict, stations: tuple[str, ...]) -> dict[str, float]:
    values = {}
    first = stations[0]
    for side in SIDES:
        ext = starts[(first, side)].exterior
        values.update({f"{p}_{side}": getattr(ext, p) for p in EXTERIOR_PARAMETERS})
    for station in stations[1:]:
        ext = starts[(station, "l")].exterior
        values.update({f"{p}_l@{station}": getattr(ext, p) for p in EXTERIOR_PARAMETERS})
    return values


def _apply_options(parameters: list[Parameter], options: CalibrationOptions) -> None:
    names = [p.name for p in parameters]
    by_name = {p.name: p for p in parameters}
    for name in _expand(options.free, names, "free"):
        by_name[name].status = "free"
    for name in _expand(options.fix, names, "fix"):
        by_name[name].status = "fixed"
    for key, value in options.fix_values.items():
        for name in _expand([key], names, "fix"):
            _refuse_non_positive("fix", key, name, value)
            by_name[name].status, by_name[name].value = "fixed", float(value)
            by_name[name].group = None
    for key, (value, sigma) in options.priors.items():
        if not sigma > 0:
            raise InvalidParameterError("prior", f"{key}: the sigma must be > 0, got {sigma}", label="prior")
        for name in _expand([key], names, "prior"):
            _refuse_non_positive("prior", key, name, value)
            p = by_name[name]
            p.status, p.value, p.prior, p.sigma = "prior", float(value), float(value), float(sigma)
            p.group = None  # the user's own prior replaces phase 1's


#: interior parameters (by the name before a camera's suffix) that only a positive value makes a camera of
POSITIVE_INTERIOR = ("f", "sy")


def _refuse_non_positive(option: str, key: str, name: str, value: float) -> None:
    """A fixed or prior value of a focal length or pixel aspect that is not > 0: no camera has it."""
    if name.split("_")[0] in POSITIVE_INTERIOR and not float(value) > 0:
        which = name if key == name else f"{key} ({name})"
        raise InvalidParameterError(option, f"{which} must be > 0 (a focal length or a pixel aspect), got "
                                    f"{float(value):g}", label=option)


def _snoop_unit(model: StereoModel):
    obs = model.observation_set

    def unit(i: int) -> np.ndarray:
        # a pointing blunder spoils a point in one image: reject its x and y together
        start = i - (i % 2)
        return np.array([start, start + 1]) if obs.coordinate[start] == "x" else np.array([i])

    return unit


#: the estimators a calibration may ask for (``auto``: :func:`estimator_for`)
CALIBRATION_ESTIMATORS = ("auto", "least squares", "huber")


def estimator_for(options: CalibrationOptions) -> str:
    """The estimator of a calibration: the one asked for, or for ``auto`` the M-estimator (``huber``) when
    the target's geometry is exact (a printed board: hundreds to thousands of corners found by a detector,
    whose errors have heavier tails than a Gaussian, and no control coordinate to doubt), else least
    squares with data snooping (a target field measured by hand: tens of observations, too few for a
    robust scale, and misprinted control found through the tau tests, :mod:`.control_blunders`)."""
    if options.estimator not in CALIBRATION_ESTIMATORS:
        raise InvalidParameterError("estimator", f"must be one of {', '.join(CALIBRATION_ESTIMATORS)}, got "
                                    f"{options.estimator!r}")
    if options.estimator != "auto":
        return options.estimator
    return "huber" if options.control_exact else "least squares"


def _solve(model: StereoModel, parameters: list[Parameter], options: CalibrationOptions, phase: str,
           source: dict) -> CalibrationResult:
    require_unknowns(parameters)
    problem = model.problem(parameters)
    estimator = estimator_for(options)
    adjustment = adjust(problem, robust=options.robust, snooping=options.snooping, snoop_unit=_snoop_unit(model),
                        estimator=estimator, cancelled=options.cancelled)
    blunders: list[ControlBlunder] = []
    if options.snooping and not options.control_exact and estimator == "least squares":
        model, parameters, adjustment, blunders = demote_control_blunders(model, parameters, adjustment, options.robust,
                                                                          _snoop_unit)
        problem = model.problem(parameters)
    values = problem.values()
    left, right = model.cameras(values)
    _require_baseline(left, right, model.control.xyz, adjustment)
    poses = [left.exterior] + [model.cameras(values, s)[0].exterior for s in model.stations[1:]]
    sigma0_px = adjustment.sigma0 * options.sigma_px
    residuals = prediction_residuals(model, adjustment)
    # a fixed control coordinate is the control file's value, not an estimate
    estimates = {p.name: ParameterEstimate(p.value, adjustment.sigmas.get(p.name), p.status) for p in parameters
                 if not (p.status == "fixed" and is_control_coordinate(p.name))}
    rms_all = _rms(residuals)
    statistics = {"rms_px": adjustment.rms, "rms_px_all": rms_all if np.isfinite(rms_all) else None,
                  "redundancy": adjustment.redundancy,
                  "condition_number": adjustment.condition_number, "iterations": adjustment.iterations,
                  "converged": adjustment.converged, "global_test": adjustment.global_test,
                  "excluded": [dict(s.__dict__) for s in adjustment.excluded], "sigma_px_a_priori": options.sigma_px,
                  "on_bound": [{"parameter": n, "bound": side, "value": b} for n, side, b in adjustment.on_bound],
                  "control_blunders": [b.as_dict() for b in blunders], "estimation": adjustment.estimation}
    calibration = StereoCalibration(
        left, right, model.stations, tuple(poses), relative_orientation(left.exterior, right.exterior), phase,
        max(sigma0_px, 1e-12), estimates, (tuple(adjustment.covariance_names), adjustment.covariance),
        statistics, source)
    return CalibrationResult(calibration, adjustment, model, build_report(calibration, adjustment, model, blunders),
                             blunders)


def require_unknowns(parameters: list[Parameter]) -> None:
    """Refuse a calibration in which every parameter is held fixed: there is nothing to adjust."""
    if not any(p.status != "fixed" for p in parameters):
        raise InvalidParameterError("fix", "every parameter is held fixed, so there is nothing to calibrate; "
                                    "free at least one")


#: A rig whose baseline is below this share of its range to the control (an intersection angle of about
#: 0.3°) has no usable stereo geometry: a depth is then 200 ranges per pixel of parallax, whatever the data.
MIN_BASELINE_TO_RANGE = 1 / 200

#: A baseline within this many of its own sigmas of zero is not established by the data. (Phase 1 resects
#: each camera on its own: over 20 System I rigs of the thesis's design, 568 x 488 px, the weakest real
#: 6-9 cm baseline came out 2.6 sigmas from zero; a zero baseline comes out below 2 sigmas three times in four.)
BASELINE_SIGMAS = 2.0

def _require_baseline(left: Camera, right: Camera, control_xyz: np.ndarray, adjustment: Adjustment | None = None
                      ) -> None:
    """Refuse a rig whose two perspective centres (m) coincide or nearly so: every intersection would be a
    pair of (nearly) parallel rays. Refused when the baseline is below :data:`MIN_BASELINE_TO_RANGE` of the
    median range to the control points (so that it holds for a tank and a survey alike), or within
    :data:`BASELINE_SIGMAS` of its own sigma (from the adjustment's covariance of both centres) of zero:
    then the data cannot tell the two centres apart."""
    base = right.exterior.position - left.exterior.position
    baseline = float(np.linalg.norm(base))
    ranges = np.linalg.norm(np.asarray(control_xyz, float) - left.exterior.position, axis=1)
    reach = float(np.median(ranges)) if ranges.size else 0.0
    sigma = _baseline_sigma(base, adjustment) if adjustment is not None else 0.0
    if not baseline >= MIN_BASELINE_TO_RANGE * reach or not baseline > BASELINE_SIGMAS * sigma:
        spread = f" ± {sigma * 1000:.2g}" if sigma > 0 else ""
        raise DegenerateGeometryError(
            f"zero or tiny baseline: the left and right cameras come out {baseline * 1000:.3g}{spread} mm apart at "
            f"a range of {reach:.3g} m (base-to-range 1:{reach / max(baseline, 1e-12):.0f}; a usable intersection "
            f"angle needs at least 1:{1 / MIN_BASELINE_TO_RANGE:.0f} and a baseline at least {BASELINE_SIGMAS:g} of "
            "its sigmas from zero), so their rays cannot intersect (are the left and right observations of one "
            "camera?)")


def _baseline_sigma(base: np.ndarray, adjustment: Adjustment) -> float:
    """The sigma (m) of the baseline's length from the covariance of the first station's two centres."""
    return baseline_sigma(base, adjustment.covariance_names, adjustment.covariance)


def _require_rays(model: StereoModel, parameters: list[Parameter]) -> None:
    """Refuse a housing (at its starting or fixed values) that no ray can cross: a grid of pixels over each
    image is traced, and a camera none of whose rays reaches the water is named with its housing values."""
    values = {p.name: p.value for p in parameters}
    housing = [p.name for p in parameters if p.name in housing_parameter_names(model.kind)]
    described = ", ".join(f"{n} = {values[n]:.4g}" for n in housing)
    try:
        cameras = model.cameras(values, bounded=False)
    except UsvipsError as error:
        raise DegenerateGeometryError(f"the {model.kind} housing lets no ray through ({error}); its values: "
                                      f"{described}") from None
    for side, camera in zip(("left", "right"), cameras, strict=True):
        width = model.size[0] or 2 * camera.interior.xp
        height = model.size[1] or 2 * camera.interior.yp
        grid = np.array([(x, y) for x in np.linspace(0, width, 7) for y in np.linspace(0, height, 7)])
        try:
            passed = bool(camera.rays(grid).ok.any())
        except UsvipsError:
            passed = False
        if not passed:
            raise DegenerateGeometryError(
                f"the {model.kind} housing of the {side} camera lets no ray through (every ray misses or is "
                f"turned back by a surface): check its fixed or starting values ({described})")


def prediction_residuals(model: StereoModel, adjustment: Adjustment) -> np.ndarray:
    """Every observation's residual, observed − computed (pixels), at the adjusted values: the adjustment's
    own for the kept ones, the prediction residual for those set aside (NaN where no ray reaches one)."""
    residuals = np.array(adjustment.residuals, dtype=np.float64)
    outside = ~np.asarray(adjustment.used, bool)
    if outside.any():
        computed, ok = model.evaluate({p.name: p.value for p in adjustment.parameters})
        predicted = np.where(ok & np.isfinite(computed), model.observation_set.values - computed, np.nan)
        residuals[outside] = predicted[outside]
    return residuals


def _rms(residuals: np.ndarray) -> float:
    """RMS (pixels, per coordinate) of the finite residuals."""
    finite = residuals[np.isfinite(residuals)]
    return float(np.sqrt(np.mean(finite**2))) if finite.size else float("nan")


def build_report(cal: StereoCalibration, adj: Adjustment, model: StereoModel,
                 control_blunders: list[ControlBlunder]) -> CalibrationReport:
    """The adjustment's report: sigma0, RMS, parameters, correlations over 0.95, condition number, suspects,
    convergence, and the details (residuals, redundancy numbers, global test, weak directions, notes)."""
    obs = adj.observations
    predicted = prediction_residuals(model, adj)
    residuals = []
    for i in range(0, len(obs), 2):
        vx, vy = (None if not np.isfinite(predicted[k]) else float(predicted[k]) for k in (i, i + 1))
        used = bool(adj.used[i] and adj.used[i + 1])
        # set aside: its residual is a prediction (the adjustment did not use it)
        note = "no ray of the adjusted camera reaches it: no residual" if not used and (vx is None or vy is None) \
            else ""
        residuals.append(ResidualRow(str(obs.point[i]), str(obs.side[i]), str(obs.group[i]), vx, vy, float(adj.w[i]),
                                     float(adj.w[i + 1]), float(adj.redundancy_numbers[i]),
                                     float(adj.redundancy_numbers[i + 1]), used, note))
    notes = []
    set_aside = int(np.sum(~np.asarray(adj.used, bool)))
    rms_all = _rms(predicted)
    if set_aside:
        notes.append(f"{set_aside} of {len(obs)} image coordinates are set aside (not used): RMS {adj.rms:.3f} px "
                     f"over the kept ones, {rms_all:.3f} px over all (the set-aside ones by their prediction "
                     "residuals, in the residual table flagged set_aside).")
    if model.housing_kind.report_note:
        notes.append(model.housing_kind.report_note)
    for name, side, bound in adj.on_bound:
        notes.append(f"{name} ends on its {side} bound ({bound:g}): the data push it to the edge of its physical "
                     "range, so the housing model or its priors do not fit the data there; its sigma (and those of "
                     "the parameters correlated with it) assume an interior minimum and understate the doubt.")
    notes += [blunder.message for blunder in control_blunders]
    if adj.estimation.get("estimator") == "huber":
        notes.append(estimation_note(adj.estimation, len(obs)))
    if adj.model_doubt:
        notes.append(adj.model_doubt)
    interior = [n for n, p in cal.parameters.items() if symbol(n) in INTERIOR_PARAMETERS and "@" not in n]
    if cal.phase != "air" and interior and all(cal.parameters[n].status == "fixed" for n in interior):
        notes.append("The interior orientation is held fixed: the reported sigmas (and every point's) leave its "
                     "uncertainty out; weight the interior (phase 1's figures as priors) to carry it.")
    notes.append(f"global test: {adj.global_test['verdict']}.")
    if not adj.converged:
        notes.append(f"NOT converged: {adj.reason}. Do not use this calibration for measurement.")
    if adj.correlations_over:
        notes.append(f"{len(adj.correlations_over)} parameter pairs correlate above 0.95: their individual values "
                     "are not determined by the data (their combination is); see the correlations over 0.95.")
    return CalibrationReport(
        phase=cal.phase, housing=model.kind, stations=tuple(model.stations), converged=adj.converged,
        reason=adj.reason, iterations=adj.iterations, sigma0_px=cal.sigma0_px, rms_px=adj.rms,
        rms_px_all=rms_all if np.isfinite(rms_all) else None, set_aside=set_aside, redundancy=adj.redundancy,
        parameters={name: ParameterEstimate(p.value, p.sigma, p.status) for name, p in cal.parameters.items()},
        correlations=tuple(Correlation(a, b, r) for a, b, r in adj.correlations_over),
        condition_number=adj.condition_number,
        weak_directions=tuple(tuple((n, float(w)) for n, w in d) for d in adj.weak_directions),
        control_blunders=tuple(control_blunders), suspects=tuple(adj.suspects),
        on_bound=tuple(BoundHit(n, side, b) for n, side, b in adj.on_bound), model_doubt=adj.model_doubt,
        global_test=adj.global_test, estimation=adj.estimation, residuals=tuple(residuals), notes=tuple(notes))


def estimation_note(estimation: dict, observations: int) -> str:
    """One line on an M-estimated calibration (:func:`usvips.core.adjustment.adjust`, ``huber``): how many
    observations were down-weighted and set aside, and what its sigma0 and covariance mean."""
    ratio = estimation["parameter_variance_factor"] / max(estimation["noise_variance_factor"], 1e-300)
    return (f"robust estimation (Huber M-estimator, k = {estimation['tuning']:g} robust sigmas): "
            f"{100 * estimation['down_weighted']:.1f} % of the kept image coordinates down-weighted (the heavy tails "
            f"of clean noise), {estimation['gross_errors']} of {observations} set aside as gross errors (over "
            f"{GROSS:g} robust sigmas); sigma0 is the standard deviation of one coordinate's error, the parameters' "
            f"covariance the M-estimate's ({ratio:.2f} times least squares' for these residuals).")


def _interior_from_dlt(starts: dict, side: str) -> dict[str, float]:
    results = [r for (station, s), r in starts.items() if s == side]
    values = {p: float(np.median([getattr(r, p) for r in results])) for p in ("f", "xp", "yp", "sy")}
    values.update({"k1": 0.0, "k2": 0.0, "p1": 0.0, "p2": 0.0, "k3": 0.0})
    return values


def observes_a_plane(control: ControlPoints, observations: StereoObservations) -> bool:
    """Whether the observed control points lie (nearly) in one plane (a board): the start is then planar
    (:mod:`.planar`), since the DLT needs 3-D spread."""
    return is_coplanar(control.xyz[control.index_of(list(dict.fromkeys(observations.ids)), "observation")])


def _planar_values(control: ControlPoints, observations: StereoObservations, stations: tuple[str, ...],
                   image_size: tuple[int | None, int | None]) -> dict[str, float]:
    """Phase 1's starting values from a planar target: pinhole interiors (sy = 1, no distortion), each
    view's left pose and the first view's right pose from the median relative orientation."""
    start = planar_start(control, observations, image_size)
    values: dict[str, float] = {}
    for side, interior in zip(SIDES, start.interiors, strict=True):
        values.update({f"{p}_{side}": float(getattr(interior, p)) for p in INTERIOR_PARAMETERS})
    first = stations[0]
    for side, pose in (("l", start.poses[(first, "l")]), ("r", start.right_at(first))):
        values.update({f"{p}_{side}": getattr(pose, p) for p in EXTERIOR_PARAMETERS})
    for station in stations[1:]:
        values.update({f"{p}_l@{station}": getattr(start.poses[(station, "l")], p) for p in EXTERIOR_PARAMETERS})
    return values


def air_start(control: ControlPoints, observations: StereoObservations,
              options: CalibrationOptions | None = None) -> tuple[StereoModel, list[Parameter]]:
    """Phase 1's model and its parameters at their DLT starting values, options applied."""
    options = options or CalibrationOptions()
    model = StereoModel("air", control, observations, options.sigma_px, options.image_size)
    if observes_a_plane(control, observations):
        values = _planar_values(control, observations, model.stations, options.image_size)
    else:
        starts = _dlt_starts(control, observations)
        values = _exterior_values(starts, model.stations)
        for side in SIDES:
            values.update({f"{p}_{side}": v for p, v in _interior_from_dlt(starts, side).items()})
    parameters = []
    for name in model.parameter_names():
        status = "free"
        if symbol(name) in INTERIOR_PARAMETERS and symbol(name) not in DEFAULT_AIR_FREE:
            status = "fixed"
        if "@" in name and symbol(name) in "XYZ":
            continue
        parameters.append(Parameter(name, values[name], status))
    parameters += _control_parameters(model)
    _apply_options(parameters, options)
    return model, parameters


def calibrate_air(control: ControlPoints, observations: StereoObservations,
                  options: CalibrationOptions | None = None, source: dict | None = None) -> CalibrationResult:
    """Phase 1: both cameras in air from one or more pairs (collinearity with distortion), DLT start."""
    options = options or CalibrationOptions()
    model, parameters = air_start(control, observations, options)
    return _solve(model, parameters, options, "air", source or {})


def _interior_prior(base: StereoCalibration) -> PriorGroup | None:
    """Phase 1's estimated interior with its full covariance (both cameras, every free interior parameter,
    their correlations kept) as one correlated prior for phase 2; None when phase 1 has no covariance."""
    if base.covariance is None:
        return None
    names, matrix = base.covariance
    chosen = [i for i, n in enumerate(names) if symbol(n) in INTERIOR_PARAMETERS and "@" not in n
              and n in base.parameters and base.parameters[n].sigma]
    if not chosen:
        return None
    matrix = np.asarray(matrix, float)
    return PriorGroup(tuple(names[i] for i in chosen), np.array([base.parameters[names[i]].value for i in chosen]),
                      matrix[np.ix_(chosen, chosen)])


def _control_parameters(model: StereoModel) -> list[Parameter]:
    out = []
    if model.control_parameters:
        for i, pid in enumerate(model.control.ids):
            for k, axis in enumerate("XYZ"):
                sigma = float(model.control.sigmas[i, k])
                value = float(model.control.xyz[i, k])
                out.append(Parameter(f"{axis}@{pid}", value, "prior" if sigma > 0 else "fixed", value,
                                     sigma if sigma > 0 else None))
    return out


def calibrate_water(base: StereoCalibration, housing: str, control: ControlPoints,
                    observations: StereoObservations, options: CalibrationOptions | None = None,
                    source: dict | None = None) -> CalibrationResult:
    """Phase 2 (and joint): housing and exterior orientations by ray tracing, phase-1 interior fixed or
    weighted. Observations with several pair labels adjust all those stations together."""
    options = options or CalibrationOptions()
    if options.interior not in ("fixed", "weighted"):
        raise InvalidParameterError("interior", f"must be 'fixed' or 'weighted', got {options.interior!r}",
                                    label="the interior's treatment")
    if housing not in DEFAULT_HOUSING:
        raise InvalidParameterError("housing", f"must be one of {', '.join(DEFAULT_HOUSING)}, got {housing!r}",
                                    label="housing")
    housing_kind = housings.kind(housing)
    size = options.image_size if options.image_size != (None, None) else (base.left.width, base.left.height)
    model = StereoModel(housing, control, observations, options.sigma_px, size)
    if observes_a_plane(control, observations):
        # a board: each view's left pose by a pinhole resection with the phase-1 interior (the housing's
        # refraction is then fitted from the housing kind's starts); the interior is known, so one view will do
        poses = resect_views(control, observations, base.left.interior, "l", minimum_views=1)
        values = {}
        for k, station in enumerate(model.stations):
            suffix = "_l" if k == 0 else f"_l@{station}"
            values.update({f"{p}{suffix}": getattr(poses[station], p) for p in EXTERIOR_PARAMETERS})
    else:
        values = _exterior_values(_dlt_starts(control, observations), model.stations)
    # the cameras are rigidly mounted: start the right camera from the left one's pose and the phase-1
    # relative orientation (a pinhole start through a housing is a poor start on its own)
    right_start = right_exterior(exterior_of(values, "l"), base.relative)
    values.update({f"{p}_r": getattr(right_start, p) for p in EXTERIOR_PARAMETERS})
    parameters = []
    group = _interior_prior(base) if options.interior == "weighted" else None
    for side, camera in (("l", base.left), ("r", base.right)):
        for p in INTERIOR_PARAMETERS:
            name = f"{p}_{side}"
            value = getattr(camera.interior, p)
            estimate = base.parameters.get(name)
            if group is not None and name in group.names:
                parameters.append(Parameter(name, value, "prior", value, estimate.sigma, group=group))
            elif options.interior == "weighted" and estimate is not None and estimate.sigma:
                parameters.append(Parameter(name, value, "prior", value, estimate.sigma))
            else:
                parameters.append(Parameter(name, value, "fixed"))
    for name in model.parameter_names():
        if name in values:
            parameters.append(Parameter(name, values[name], "free"))
    for name in housing_parameter_names(housing):
        spec = housing_kind.spec(symbol(name))
        value, sigma, lower, upper = spec.start, spec.sigma, spec.lower, spec.upper
        parameters.append(Parameter(name, value, "prior" if sigma else "fixed", value, sigma, lower=lower,
                                    upper=upper))
    parameters += _control_parameters(model)
    if options.cameras_unmoved:
        held = held_poses(base, model.stations)
        for p in parameters:
            if p.name in held:
                p.value, p.status, p.prior, p.sigma, p.group = held[p.name], "fixed", None, None, None
    _apply_options(parameters, geometry_options(housing, options))
    if options.cameras_unmoved and options.air_through_glass:
        _through_glass_in_air(parameters, housing_kind, model.stations)
    _require_rays(model, parameters)
    merged = dict(source or {})
    merged.setdefault("base_calibration", base.source)
    # phase 2 is stored as phase 2 ("water") whether from one station or several jointly ("joint" is still
    # read from older files)
    return _solve_from_starts(model, parameters, options, "water", merged, _pointing_in_air(base))


def geometry_options(housing: str, options: CalibrationOptions) -> CalibrationOptions:
    """``options`` with its ``housing_geometry`` turned into the housing kind's fixed values and priors
    (both cameras' parameter of each quantity); a quantity the kind does not have, a value that is not
    finite or a sigma that is not positive is an :class:`InvalidParameterError` naming it."""
    if not options.housing_geometry:
        return options
    kind = housings.kind(housing)
    fix_values, priors = dict(options.fix_values), dict(options.priors)
    for quantity, (value, sigma) in options.housing_geometry.items():
        if quantity not in kind.geometry:
            raise InvalidParameterError(quantity, f"the {kind.kind} housing has no {quantity} (it knows "
                                        f"{', '.join(kind.geometry) or 'none'})")
        if not np.isfinite(value):
            raise InvalidParameterError(quantity, f"must be a finite number, got {value}")
        if sigma is not None and not (np.isfinite(sigma) and sigma > 0):
            raise InvalidParameterError(quantity, f"its sigma must be > 0, got {sigma}")
        name = kind.geometry[quantity]
        spec = kind.spec(name)
        if (spec.lower is not None and value <= spec.lower) or (spec.upper is not None and value >= spec.upper):
            raise InvalidParameterError(quantity, f"{value:g} is outside its physical range "
                                        f"({spec.lower}, {spec.upper})")
        if sigma is None:
            fix_values[name] = float(value)
        else:
            priors[name] = (float(value), float(sigma))
    return replace(options, fix_values=fix_values, priors=priors, housing_geometry={})


def _through_glass_in_air(parameters: list[Parameter], kind, stations: tuple[str, ...]) -> None:
    """Correct held poses for the flat glass the air images were taken through: a plate of thickness t and
    index n2 (air on both sides) brings what lies behind it t·(1 − 1/n2) closer along its normal, so phase 1's
    poses from those images put each camera that much too near the target. Each held camera is moved back by
    that along its optical axis (the glass is about square to it). Only kinds with a flat wall or port
    (``distance`` in their geometry) and only the held (fixed) poses."""
    if "distance" not in kind.geometry:
        return
    by_name = {p.name: p for p in parameters}
    thickness = by_name.get(kind.geometry["thickness"])
    glass = by_name.get(kind.geometry["n_glass"])
    if thickness is None or glass is None:
        return
    shift = thickness.value * (1.0 - 1.0 / glass.value)
    suffixes = ["_l", "_r"] + [f"_l@{s}" for s in stations[1:]]
    for suffix in suffixes:
        names = [f"{p}{suffix}" for p in EXTERIOR_PARAMETERS]
        if any(n not in by_name or by_name[n].status != "fixed" for n in names):
            continue
        pose = Exterior(*(by_name[n].value for n in names))
        # the camera looks along −z̄ of its frame: back is +z̄ (the rotation's third row in object space)
        position = pose.position + shift * pose.rotation[2]
        for axis, n in zip(position, names[:3], strict=True):
            by_name[n].value = float(axis)


def held_poses(base: StereoCalibration, stations: tuple[str, ...]) -> dict[str, float]:
    """The exterior parameters of phase 2's ``stations`` held at phase 1's poses (the cameras did not move
    between the air and the water images): each station takes the phase-1 station of the same label, or —
    when each phase has a single view — phase 1's only one. The first station's right camera is phase 1's
    right camera there (so the rig's relative orientation is phase 1's too). A station phase 1 did not
    see is an :class:`InvalidParameterError` naming it."""
    if len(stations) == 1 and len(base.stations) == 1:  # the same view, whatever its labels
        matched = {stations[0]: base.stations[0]}
    else:
        missing = [s for s in stations if s not in base.stations]
        if missing:
            raise InvalidParameterError(
                "cameras unmoved", f"view {missing[0]!r} has no view of the same label in the phase-1 calibration "
                f"(its views: {', '.join(base.stations[:8])}); with the cameras unmoved each water view needs its "
                "air view, labelled alike")
        matched = {s: s for s in stations}
    out: dict[str, float] = {}
    for k, station in enumerate(stations):
        left = base.poses[base.station_index(matched[station])]
        suffix = "_l" if k == 0 else f"_l@{station}"
        out.update({f"{p}{suffix}": float(getattr(left, p)) for p in EXTERIOR_PARAMETERS})
        if k == 0:
            # from the rig (the left pose and the relative orientation): a calibration read from a file
            # places its right camera there, not at its own exterior
            right = base.rig(matched[station]).right.exterior
            out.update({f"{p}_r": float(getattr(right, p)) for p in EXTERIOR_PARAMETERS})
    return out


#: A phase-2 fit whose variance factor exceeds phase 1's by this factor (in sigma0) — beyond chance — does not
#: describe the water and the housing at all: e.g. a wrong fixed refractive index, whose residuals reach tens
#: of pixels. (Turbid water blurs the pointing too, but not by a factor of five.)
IMPLAUSIBLE_SIGMA_RATIO = 5.0

#: The housing quantities a person recognises, for the messages.
_QUANTITIES = {"g": "port distance", "t": "glass thickness", "n2": "glass index", "n3": "water index",
               "r": "radius"}


def physical_problems(result: CalibrationResult, base: StereoCalibration | None = None) -> list[str]:
    """Why a phase-2 result is physically impossible and must not be used (empty when none): a housing
    parameter on the bound of its physical range (a port distance at 0: the refraction went into the pose),
    or residuals far above phase 1's with the same cameras (:data:`IMPLAUSIBLE_SIGMA_RATIO`; a wrong fixed
    index). Each reason names the parameter and its value."""
    problems = []
    model = result.model
    housing_names = set(model.housing_kind.calibration_names)
    for name, side, bound in result.adjustment.on_bound:
        if name in housing_names:
            what = _QUANTITIES.get(symbol(name), "housing parameter")
            problems.append(f"the {what} {name} ends on the {side} bound of its physical range ({bound:g}): the "
                            "data cannot be explained by this housing with these fixed values")
    in_air = _pointing_in_air(base) if base is not None else None
    sigma = result.calibration.sigma0_px
    if (in_air is not None and np.isfinite(sigma) and sigma > IMPLAUSIBLE_SIGMA_RATIO * in_air[0]
            and _fits_worse_than_in_air(result, in_air)):
        fixed = [f"{n} = {p.value:g}" for n, p in result.calibration.parameters.items()
                 if n in housing_names and p.status == "fixed"]
        problems.append(f"the residuals (sigma0 {sigma:.3g} px) are {sigma / in_air[0]:.0f} times phase 1's "
                        f"({in_air[0]:.3g} px) with the same cameras: the images are not explained (a wrong fixed "
                        "value, or gross errors left in the data)"
                        + (f"; check the fixed values: {', '.join(fixed)}" if fixed else ""))
    return problems


def require_physical(result: CalibrationResult, base: StereoCalibration | None, consequence: str) -> None:
    """Refuse a physically impossible phase-2 result (:func:`physical_problems`): a
    :class:`DegenerateGeometryError` naming the first reason, then ``consequence`` (e.g. "nothing written")."""
    problems = physical_problems(result, base)
    if problems:
        more = f" (and {len(problems) - 1} more)" if len(problems) > 1 else ""
        raise DegenerateGeometryError(f"the phase-2 calibration is physically impossible: {problems[0]}{more}; "
                                      f"{consequence}")


#: Mean squared normalised residual below which the default housing start is good enough (σ0 < 2).
GOOD_START = 4.0


def _cost(model: StereoModel, values: dict[str, float]) -> float:
    """The mean squared normalised residual of the reachable observations at ``values`` (inf when none)."""
    computed, ok = model.evaluate(values)
    normalised = (model.observation_set.values - computed) / model.observation_set.sigmas
    reached = ok & np.isfinite(normalised)
    return float(np.mean(normalised[reached] ** 2)) if reached.any() else np.inf


def _fit_exteriors(model: StereoModel, parameters: list[Parameter]) -> float:
    """Adjust the exterior orientations alone (everything else held) and return the weighted cost. When the
    user holds every exterior orientation (the cameras did not move, or ``fix``), nothing is adjusted: the
    cost is that of the values as they are."""
    if not any(p.status != "fixed" and symbol(p.name) in EXTERIOR_PARAMETERS for p in parameters):
        try:
            return _cost(model, {p.name: p.value for p in parameters})
        except UsvipsError:
            return np.inf
    held = {p.name: p.status for p in parameters}
    saved = {p.name: p.value for p in parameters}
    for p in parameters:
        if symbol(p.name) not in EXTERIOR_PARAMETERS:
            p.status = "fixed"
    try:
        result = adjust(model.problem(parameters), max_iterations=15, robust=True, snooping=False)
        cost = float(np.sum((result.residuals[result.used] / model.observation_set.sigmas[result.used]) ** 2))
        cost /= max(int(result.used.sum()), 1)
        return cost if np.isfinite(cost) else np.inf
    except UsvipsError:
        for p in parameters:
            p.value = saved[p.name]
        return np.inf
    finally:
        for p in parameters:
            p.status = held[p.name]


def _candidates(model: StereoModel, parameters: list[Parameter]) -> list[dict[str, float]]:
    """The physically distinct housing starts: the default ({}), then every combination of the housing
    kind's start grid (:attr:`start_grid`) for the free parameters it names (both cameras' alike)."""
    grid = model.housing_kind.start_grid
    by_name = {p.name: p for p in parameters}
    candidates: list[dict[str, float]] = [{}]
    for symbol_name, starts in grid.items():
        names = [n for n in by_name if symbol(n) == symbol_name and by_name[n].status != "fixed"]
        if names:
            candidates = [dict(c, **{n: v for n in names}) for c in candidates for v in starts]
    return [{}] + [c for c in candidates if c] if grid else [{}]


def _start(model: StereoModel, parameters: list[Parameter], initial: dict[str, float],
           candidate: dict[str, float]) -> tuple[float, dict[str, float]]:
    """The exterior-only fit from the initial values with ``candidate``'s housing values: (cost, values)."""
    for p in parameters:
        p.value = initial[p.name]
    for name, value in candidate.items():
        next(p for p in parameters if p.name == name).value = value
    cost = _fit_exteriors(model, parameters)
    return cost, {p.name: p.value for p in parameters}


#: Further full adjustments from the next-best distinct starts when the first run is not clean.
EXTRA_STARTS = 2


#: Probability with which blunder-free data may reach :func:`chance_rejections`'s count of tau rejections.
CHANCE_REJECTIONS_LEVEL = 0.05


def chance_rejections(observations: int) -> int:
    """The number of observation units whose tau rejection says more than chance: at least two (one clear
    blunder is the data's, not the start's), and more than blunder-free data reach with probability
    :data:`CHANCE_REJECTIONS_LEVEL`. The tau test rejects a correct observation with probability
    :data:`~usvips.core.adjustment.ALPHA0`, so ``observations`` of them give about Poisson(n·α0) false
    alarms: none to speak of at a tank's hundred observations, about ten at a survey's ten thousand,
    which would otherwise send every survey-size run to the further starts."""
    from scipy.stats import poisson  # deferred, as every scipy.stats import

    expected = observations * ALPHA0
    count = 2
    while poisson.sf(count - 1, expected) > CHANCE_REJECTIONS_LEVEL:
        count += 1
    return count


def _needs_other_starts(result: CalibrationResult) -> bool:
    """The symptoms of a run caught in a local minimum or against the valid region's edge: not converged,
    a parameter on a bound, the model in doubt, or more observation units rejected by the tau test than
    chance explains (:func:`chance_rejections`: two or more at a tank's size)."""
    adj = result.adjustment
    rejected = {(s.point, s.side, s.group) for s in adj.excluded if s.reason == "w-test"}
    return (not adj.converged or bool(adj.on_bound) or bool(adj.model_doubt)
            or len(rejected) >= chance_rejections(len(adj.observations)))


def _significantly_smaller(a: CalibrationResult, b: CalibrationResult) -> bool:
    """``a``'s variance factor is smaller than ``b``'s beyond chance (F test at :data:`POINTING_TEST_ALPHA`)."""
    ra, rb = a.adjustment.redundancy, b.adjustment.redundancy
    sa, sb = a.calibration.sigma0_px, b.calibration.sigma0_px
    if ra <= 0 or rb <= 0 or not (np.isfinite(sa) and np.isfinite(sb)) or sa <= 0:
        return False
    from scipy.stats import f as f_distribution

    return (sb / sa) ** 2 > f_distribution.ppf(1 - POINTING_TEST_ALPHA, rb, ra)


def _better(a: CalibrationResult, b: CalibrationResult) -> bool:
    """Whether run ``a`` beats run ``b``: converged first, then fewer parameters on a bound, then a variance
    factor smaller beyond chance (a local minimum leaves residuals several times the noise, and its data
    snooping may set aside fewer observations than the true fit's), then :func:`_rank`."""
    ka, kb = _rank(a), _rank(b)
    if ka[:2] != kb[:2]:
        return ka[:2] < kb[:2]
    if _significantly_smaller(a, b) or _significantly_smaller(b, a):
        return _significantly_smaller(a, b)
    return ka < kb


def _rank(result: CalibrationResult) -> tuple:
    """The objective by which runs from different starts compare (smaller is better): converged first,
    then fewer parameters on a bound, fewer observations set aside, then the estimated variance factor."""
    adj = result.adjustment
    return (not adj.converged, len(adj.on_bound), len(adj.excluded), adj.sigma0)


def _pointing_in_air(base: StereoCalibration) -> tuple[float, int] | None:
    """Phase 1's estimated pointing sigma (px) and its redundancy, when the base calibration has them."""
    redundancy = base.statistics.get("redundancy")
    if base.sigma0_px is None or not redundancy or not np.isfinite(base.sigma0_px) or base.sigma0_px <= 0:
        return None
    return float(base.sigma0_px), int(redundancy)


#: Significance of the test "phase 2 explains the pixels worse than phase 1 explained the same cameras'
#: pointing in air" (an F test of the two variance factors), which sends phase 2 to further starts.
POINTING_TEST_ALPHA = 0.01


def _fits_worse_than_in_air(result: CalibrationResult, in_air: tuple[float, int] | None) -> bool:
    """The same cameras point at the same kind of targets in air and under water, so phase 2's variance
    factor should not exceed phase 1's beyond chance; a fit far worse is a local minimum of the housing
    (a converged run, nothing on a bound, yet residuals several times the noise). Murky water that truly
    blurs the targets also fails this test: then the further starts cost time, never the result (the
    best run by :func:`_better` is kept)."""
    redundancy, sigma_water = result.adjustment.redundancy, result.calibration.sigma0_px
    if in_air is None or redundancy <= 0 or not np.isfinite(sigma_water):
        return False
    from scipy.stats import f as f_distribution  # scipy.stats is slow to import; only phase 2 needs it

    sigma_air, redundancy_air = in_air
    critical = f_distribution.ppf(1 - POINTING_TEST_ALPHA, redundancy, redundancy_air)
    return (sigma_water / sigma_air) ** 2 > critical


def _solve_from_starts(model: StereoModel, parameters: list[Parameter], options: CalibrationOptions, phase: str,
                       source: dict, in_air: tuple[float, int] | None = None) -> CalibrationResult:
    """Phase 2 from several physically distinct starts, keeping the best by :func:`_better`.

    Each start (:func:`_candidates`: the default housing and the housing kind's start grid) is first
    fitted by the exterior orientations alone (the DLT ignores refraction); the full adjustment runs from
    the start with the smallest residuals — or from the default when it already explains the pixels to
    about their noise (:data:`GOOD_START`). When that run shows the symptoms of a poor start
    (:func:`_needs_other_starts`, or residuals significantly larger than phase 1's with the same cameras:
    :func:`_fits_worse_than_in_air`), it is repeated from up to :data:`EXTRA_STARTS` of the next-best
    starts."""
    initial = {p.name: p.value for p in parameters}
    candidates = _candidates(model, parameters)
    fitted: dict[int, tuple[float, dict[str, float]]] = {0: _start(model, parameters, initial, candidates[0])}
    if not fitted[0][0] < GOOD_START:
        for k in range(1, len(candidates)):
            fitted[k] = _start(model, parameters, initial, candidates[k])
    first = min(fitted, key=lambda k: fitted[k][0])

    def run(k: int) -> CalibrationResult:
        trial = [replace(p) for p in parameters]
        values = fitted[k][1] if np.isfinite(fitted[k][0]) else initial
        for p in trial:
            p.value = values[p.name]
        return _solve(model, trial, options, phase, source)

    best = run(first)
    if not (_needs_other_starts(best) or _fits_worse_than_in_air(best, in_air)) or len(candidates) == 1:
        return best
    for k in range(len(candidates)):
        if k not in fitted:
            fitted[k] = _start(model, parameters, initial, candidates[k])
    others = sorted((k for k in fitted if k != first and np.isfinite(fitted[k][0])), key=lambda k: fitted[k][0])
    for k in others[:EXTRA_STARTS]:
        try:
            result = run(k)
        except UsvipsError:
            continue
        if _better(result, best):
            best = result
    return best


def exterior_of(values: dict[str, float], side: str) -> Exterior:
    return Exterior(*(values[f"{p}_{side}"] for p in EXTERIOR_PARAMETERS))
