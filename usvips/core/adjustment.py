"""One weighted least-squares engine for every calibration (thesis 2.3.2.3, 2.5, App. C).

A problem is a residual function of named parameters. Each parameter is ``free``, ``fixed`` or
``prior`` (free, but pulled towards a value ± sigma by a pseudo-observation). Observations are pixel
coordinates with a-priori standard deviations; residuals are observed − computed, in pixels.

The solver is Levenberg–Marquardt on the equilibrated normal equations, a Jacobian of the problem's
exact block columns (``Problem.analytic``) or forward differences evaluated group-wise (a parameter
perturbs only the observations that depend on it), a robust start (iteratively reweighted least squares
with Huber weights) so that one gross error cannot drag the solution, and iterated data snooping
(Baarda's w-test) afterwards, each rejection re-adjusted warm (one Gauss–Newton step from the previous
solution with its Jacobian; the run converged in full once, after the last). The Jacobian is stored by
observation block, each block over its own columns (:class:`normal_equations.BlockJacobian`). Small
problems solve the normal equations dense; a problem with many groups of "local" unknowns (each further
station's pose, touching only that station's two blocks) solves them in block-arrow form, the local
groups eliminated by a Schur complement onto the global unknowns (:func:`_partition`,
:class:`normal_equations.ArrowSystem`): every step, statistic and test then costs time and memory linear
in the number of stations. Both paths give the same numbers (tests/core/test_schur.py).

Statistics follow the textbook (Mikhail & Ackermann 1976; Baarda 1968; Förstner):
sigma0² = vᵀPv / r with redundancy r = n_obs + n_prior − n_free; Qxx = N⁻¹; parameter sigma =
sigma0·sqrt(Qxx_ii); redundancy numbers r_i = (Qvv P)_ii; w_i = v_i / (σ_i sqrt(r_i / p_i…)) — see
:func:`_statistics`; minimal detectable blunder ∇_i = δ0 σ̂ σ_i / sqrt(r_i) with δ0 = 4.13 (α = 0.1 %,
power 80 %). The a-priori sigma is a starting value: the observations' variance factor is estimated
(variance-component estimation against the priors, :func:`_variance_component`), and the global test
compares vᵀPv of the observations with χ²(r_obs), reporting an a-priori sigma too optimistic or too
pessimistic instead of rejecting the run; w is Pope's tau with the estimated factor.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from usvips.core import normal_equations
from usvips.core.batch_mode import batch_computation
from usvips.core.errors import ConvergenceError, DegenerateGeometryError, InvalidParameterError
from usvips.core.parameter_status import STATUSES

W_CRITICAL = 3.29          # two-sided normal quantile for α0 = 0.1 % (tau's limit for large redundancy)
ALPHA0 = 0.001             # data snooping's level per observation
DELTA0 = 4.13              # non-centrality for α0 = 0.1 % and power 80 %
HUBER_K = 2.0              # Huber threshold in standard deviations for the robust start
TO_BOUNDARY = 0.9          # a step goes at most this fraction of the way to a parameter's bound
SNOOP_SHARE = 40           # data snooping rejects at most one observation unit per this many observations
GROSS = 10.0               # residuals of the robust start beyond this many robust sigmas are set aside
HUBER_TUNING = 1.345       # Huber's constant of the M-estimator (robust sigmas): 95 % efficiency for Gaussian errors
M_ROUNDS = 4               # M-estimation: rounds of (IRLS to convergence, gross errors set aside) at most
ESTIMATORS = ("least squares", "huber")
BACKTRACKS = 4             # halvings of a step that leaves the valid region before the damping grows


@dataclass(eq=False)
class PriorGroup:
    """A correlated prior on several parameters: ``names``, their prior ``mean`` and ``covariance`` (e.g.
    the phase-1 interior with its full covariance entering phase 2). Every member must be free with status
    ``prior``; each keeps its marginal sigma for display, the group's weight is the inverse covariance."""

    names: tuple[str, ...]
    mean: np.ndarray
    covariance: np.ndarray

    def __post_init__(self) -> None:
        self.mean = np.asarray(self.mean, float)
        self.covariance = np.asarray(self.covariance, float)
        eigen = np.linalg.eigvalsh((self.covariance + self.covariance.T) / 2)
        if not np.all(np.isfinite(eigen)) or eigen.min() <= 1e-12 * max(eigen.max(), 1e-300):
            raise InvalidParameterError(", ".join(self.names[:3]), "the prior covariance is not positive definite")
        self.weight = np.linalg.inv(self.covariance)
        self.weight = (self.weight + self.weight.T) / 2

    def misfit(self, values: dict[str, float]) -> np.ndarray:
        return self.mean - np.array([values[n] for n in self.names])


@dataclass
class Parameter:
    """A named unknown: ``value``; ``status`` free | fixed | prior; for a prior, ``prior`` ± ``sigma``;
    ``step`` is the finite-difference step (in the parameter's unit); ``lower`` / ``upper``: the open
    interval of physical values (e.g. a glass thickness > 0). The solver never steps onto or past a bound
    (it goes at most :data:`TO_BOUNDARY` of the way) and reports a parameter that ends on one."""

    name: str
    value: float
    status: str = "free"
    prior: float | None = None
    sigma: float | None = None
    step: float = 1e-6
    lower: float | None = None
    upper: float | None = None
    group: PriorGroup | None = None

    def __post_init__(self) -> None:
        if self.status not in STATUSES:
            raise InvalidParameterError(self.name, f"status must be one of {STATUSES}, got {self.status!r}")
        if not np.isfinite(self.value):
            raise InvalidParameterError(self.name, f"must be finite, got {self.value}")
        if self.status == "prior":
            if self.sigma is None or not np.isfinite(self.sigma) or self.sigma <= 0:
                raise InvalidParameterError(self.name, f"a prior needs a sigma > 0, got {self.sigma}")
            if self.prior is None:
                self.prior = self.value
        if (self.lower is not None and not self.value > self.lower) or \
                (self.upper is not None and not self.value < self.upper):
            raise InvalidParameterError(self.name, f"{self.value:g} is outside its physical range "
                                        f"({self.lower if self.lower is not None else '-inf'}, "
                                        f"{self.upper if self.upper is not None else 'inf'})")


@dataclass
class Observations:
    """Observed values (n,), their a-priori sigmas (n,), and labels: ``point`` id, ``side`` ('l'/'r'),
    ``coordinate`` ('x'/'y') and ``group`` (station label) per observation."""

    values: np.ndarray
    sigmas: np.ndarray
    point: list[str]
    side: list[str]
    coordinate: list[str]
    group: list[str]

    def __len__(self) -> int:
        return len(self.values)


@dataclass
class Problem:
    """``evaluate(values: dict[str, float], blocks: Sequence[int] | None) -> (computed, ok)`` returns the
    model values of all observations (or of the observations in the given blocks, concatenated in block
    order) and a validity mask. ``blocks`` (list of index arrays) partitions the observations;
    ``depends`` maps each parameter name to the blocks it influences (default: all)."""

    parameters: list[Parameter]
    observations: Observations
    evaluate: Callable[[dict[str, float], Sequence[int] | None], tuple[np.ndarray, np.ndarray]]
    blocks: list[np.ndarray]
    depends: dict[str, list[int]] = field(default_factory=dict)
    #: the solver's last Jacobian, the free values it was taken at, and where it can be non-zero
    last_jacobian: tuple[np.ndarray, tuple[float, ...], normal_equations.Pattern] | None = None
    #: optional exact derivatives: (values, computed) -> {parameter: {block: column over that block}}
    analytic: Callable[[dict[str, float], np.ndarray], dict[str, dict[int, np.ndarray]]] | None = None
    #: how the normal equations are solved: ``dense``; ``schur`` (local groups of unknowns eliminated, see
    #: :func:`_partition`; dense when there are none); ``auto``: schur from :data:`SCHUR_MIN_GROUPS` groups
    structure: str = "auto"

    def free(self) -> list[Parameter]:
        return [p for p in self.parameters if p.status != "fixed"]

    def values(self) -> dict[str, float]:
        return {p.name: p.value for p in self.parameters}


@dataclass
class Suspect:
    """An observation that data snooping rejects: point id, side, coordinate, station, its w-test value,
    residual (px) and minimal detectable blunder (px)."""

    point: str
    side: str
    coordinate: str
    group: str
    w: float | None
    residual: float | None
    mdb: float | None
    reason: str = "w-test"


@dataclass
class Adjustment:
    """The result: falsy when it did not converge (``reason`` says why).

    ``covariance_names`` / ``covariance`` (the parameters' units squared, symmetric): every free unknown
    on the dense path; on the block-arrow path (a problem with local groups eliminated by the Schur
    complement, :func:`_partition`: a calibration from many views) the global unknowns only — interior,
    first-station poses (the rig), housing, control coordinates —, since the full matrix would grow with
    the square of the views. ``sigmas`` hold every free unknown on both paths, further stations' poses
    included; ``correlations_over`` then omit pairs of two different stations' poses. ``condition_number``
    and ``weak_directions`` are those of the full normal matrix (dense) or of the reduced one (Schur)."""

    parameters: list[Parameter]
    converged: bool
    reason: str
    iterations: int
    sigma0: float
    rms: float
    redundancy: int
    residuals: np.ndarray
    covariance_names: list[str]
    covariance: np.ndarray
    sigmas: dict[str, float]
    correlations_over: list[tuple[str, str, float]]
    condition_number: float
    weak_directions: list[list[tuple[str, float]]]
    redundancy_numbers: np.ndarray
    w: np.ndarray
    mdb: np.ndarray
    global_test: dict
    excluded: list[Suspect]
    observations: Observations
    used: np.ndarray
    #: free parameters that end on a bound (within a tenth of their sigma of it): (name, side, bound)
    on_bound: list[tuple[str, str, float]] = field(default_factory=list)
    #: set when data snooping reached its cap with observations still failing: the model is in doubt
    model_doubt: str | None = None
    #: how it was estimated: ``estimator`` (``least squares`` or ``huber``) and, for the M-estimator, its
    #: ``tuning`` constant, ``robust_scale`` (of the normalised residuals, a-priori sigmas), the variance
    #: factors of the ``noise`` (sigma0²) and of the ``parameters`` (the covariance's factor), the share of
    #: kept observations ``down_weighted`` and the ``rounds`` (:func:`_m_estimate`)
    estimation: dict = field(default_factory=dict)

    def __bool__(self) -> bool:
        return self.converged

    @property
    def suspects(self) -> list[Suspect]:
        """The observations left out: unreachable from the start, or rejected by data snooping."""
        return self.excluded

    def value(self, name: str) -> float:
        for p in self.parameters:
            if p.name == name:
                return p.value
        raise KeyError(name)


def _jacobian(problem: Problem, values: dict[str, float], free: list[Parameter], base: np.ndarray
              ) -> np.ndarray:
    """The Jacobian (n_obs × n_free, observation units per parameter unit) as a dense matrix (small
    problems and tests): see :func:`_structured_jacobian`."""
    return _structured_jacobian(problem, values, free, base).dense()


def _structured_jacobian(problem: Problem, values: dict[str, float], free: list[Parameter], base: np.ndarray
                         ) -> normal_equations.BlockJacobian:
    """The Jacobian stored by observation block (each block's rows over its own columns only; never the
    dense n × k matrix, which grows with the square of the stations).

    The problem's exact columns where it gives them (``analytic``, one call per Jacobian), else
    forward differences with each parameter's own step, evaluating only the blocks that depend on it.

    Steps are chosen per parameter kind (``calibration.model``) so that the change they cause is
    ~1e-4 px: far above the back-projection's 1e-7 px convergence noise, far below the non-linearity.
    Where the step leaves the valid region (a ray about to miss a surface), the step is taken backwards.
    """
    all_blocks = list(range(len(problem.blocks)))
    exact = problem.analytic(values, base) if problem.analytic is not None else {}
    columns: list[dict[int, np.ndarray]] = [{} for _ in problem.blocks]
    sizes = np.array([len(block) for block in problem.blocks])
    for j, parameter in enumerate(free):
        blocks = problem.depends.get(parameter.name, all_blocks)
        known = exact.get(parameter.name, {})
        for b, column in known.items():
            columns[b][j] = column
        blocks = [b for b in blocks if b not in known]
        if not blocks:
            continue
        index = np.concatenate([problem.blocks[b] for b in blocks])
        here = base[index]
        h = parameter.step
        ahead = dict(values)
        ahead[parameter.name] = values[parameter.name] + h
        plus, ok_plus = problem.evaluate(ahead, blocks)
        column = (plus - here) / h
        if not ok_plus.all():
            behind = dict(values)
            behind[parameter.name] = values[parameter.name] - h
            minus, ok_minus = problem.evaluate(behind, blocks)
            column = np.where(ok_plus, column, (here - minus) / h)
            column[~ok_plus & ~ok_minus] = 0.0
        for b, piece in zip(blocks, np.split(column, np.cumsum(sizes[blocks])[:-1]), strict=True):
            columns[b][j] = piece
    rows = [normal_equations.as_rows(block) for block in problem.blocks]
    order = [np.array(sorted(c), dtype=int) for c in columns]
    stacked = [np.column_stack([c[j] for j in o]) if o.size else np.zeros((len(block), 0))
               for c, o, block in zip(columns, order, problem.blocks, strict=True)]
    return normal_equations.BlockJacobian(len(problem.observations), len(free), rows, order, stacked)


#: the fewest local groups (further stations' poses) from which ``structure="auto"`` eliminates them
SCHUR_MIN_GROUPS = 8


def _partition(problem: Problem, free: list[Parameter], jac: normal_equations.BlockJacobian
               ) -> normal_equations.Partition | None:
    """The global / local split of the free unknowns for the Schur complement, or None for the dense path.

    Local groups are found in the Jacobian's pattern (:meth:`normal_equations.Partition.of`): unknowns
    that touch the same few observation blocks (at most two, or a quarter of the blocks) and that no
    other group touches — in a calibration, each further station's left pose (its left and right block;
    the right camera follows through the rig). Members of a correlated prior group stay global."""
    if problem.structure == "dense":
        return None
    eligible = np.array([p.group is None for p in free], dtype=bool)
    key = (eligible.tobytes(), len(problem.blocks))
    cached = getattr(jac, "partition_cache", None)
    if cached is not None and cached[0] == key:
        partition = cached[1]
    else:
        partition = normal_equations.Partition.of(jac.pattern, eligible, max(2, len(problem.blocks) // 4))
        jac.partition_cache = (key, partition)
    if partition is None or (problem.structure == "auto" and partition.local.shape[0] < SCHUR_MIN_GROUPS):
        return None
    return partition


def _prior_terms(free: list[Parameter], values: dict[str, float]):
    """The priors' pseudo-observations: diagonal weights (k,), right-hand side (k,), their weighted
    squared misfit, and the correlated groups as (columns, weight matrix)."""
    diagonal, rhs, cost = np.zeros(len(free)), np.zeros(len(free)), 0.0
    for j, parameter in enumerate(free):
        if parameter.status == "prior" and parameter.group is None:
            weight = 1.0 / parameter.sigma**2
            misfit = parameter.prior - values[parameter.name]
            diagonal[j] += weight
            rhs[j] += weight * misfit
            cost += weight * misfit * misfit
    groups = []
    for group, index in _groups(free):
        misfit = group.misfit(values)
        np.add.at(rhs, index, group.weight @ misfit)
        cost += float(misfit @ group.weight @ misfit)
        groups.append((index, group.weight))
    return diagonal, rhs, cost, groups


class _DenseSystem:
    """The damped normal equations of one iteration, dense and equilibrated (small problems)."""

    def __init__(self, jac, residual, weights, free, values) -> None:
        normal, self.rhs, self.cost = _normal_system(jac, residual, weights, free, values)
        self.scale = np.sqrt(np.maximum(np.diag(normal), 1e-300))
        self.scaled = normal / np.outer(self.scale, self.scale)

    def step(self, damping: float) -> np.ndarray:
        return np.linalg.solve(self.scaled + damping * np.eye(len(self.scale)), self.rhs / self.scale) / self.scale

    def marginal(self) -> np.ndarray:
        """sqrt(diag N⁻¹) (k,): each unknown's marginal a-priori sigma."""
        try:
            return np.sqrt(np.maximum(np.diag(np.linalg.inv(self.scaled)), 1e-300)) / self.scale
        except np.linalg.LinAlgError:
            return 1.0 / self.scale


class _SchurSystem:
    """The same in block-arrow form, the local groups eliminated (:class:`normal_equations.ArrowSystem`)."""

    def __init__(self, jac, residual, weights, free, values, partition) -> None:
        self.arrow = normal_equations.ArrowSystem(jac, weights, residual, partition)
        diagonal, rhs, prior_cost, groups = _prior_terms(free, values)
        self.arrow.add_priors(diagonal, rhs, groups)
        self.cost = float(residual @ (weights * residual)) + prior_cost

    def step(self, damping: float) -> np.ndarray:
        return self.arrow.step(damping)

    def marginal(self) -> np.ndarray:
        try:
            return np.sqrt(np.maximum(self.arrow.inverse().diagonal(), 1e-300))
        except np.linalg.LinAlgError:
            return 1.0 / self.arrow.scale()


def _system(problem, jac, residual, weights, free, values):
    partition = _partition(problem, free, jac)
    if partition is None:
        return _DenseSystem(jac, residual, weights, free, values)
    return _SchurSystem(jac, residual, weights, free, values, partition)


def _normal_system(jac: normal_equations.BlockJacobian, residual, weights, free, values, data=None):
    """Dense weighted normal equations including prior pseudo-observations; returns N, b and vᵀPv.
    ``data``: the observations' share JᵀWJ when already formed (else formed here, block by block)."""
    normal = jac.gram(weights) if data is None else data.copy()
    rhs = jac.transpose_times(weights * residual)
    cost = float(residual @ (weights * residual))
    diagonal, prior_rhs, prior_cost, groups = _prior_terms(free, values)
    normal[np.diag_indices_from(normal)] += diagonal
    for index, weight in groups:
        normal[np.ix_(index, index)] += weight
    return normal, rhs + prior_rhs, cost + prior_cost


def _groups(free: list[Parameter]) -> list[tuple[PriorGroup, np.ndarray]]:
    """The correlated prior groups among the free parameters, each restricted to the members still in it
    (free, status prior; the sub-covariance of those is their marginal prior), with their columns."""
    position = {p.name: j for j, p in enumerate(free) if p.group is not None and p.status == "prior"}
    seen: dict[int, PriorGroup] = {}
    for p in free:
        if p.name in position:
            seen.setdefault(id(p.group), p.group)
    out = []
    for group in seen.values():
        keep = [k for k, n in enumerate(group.names) if n in position and free[position[n]].group is group]
        if len(keep) < len(group.names):
            group = PriorGroup(tuple(group.names[k] for k in keep), group.mean[keep],
                               group.covariance[np.ix_(keep, keep)])
        out.append((group, np.array([position[n] for n in group.names], dtype=int)))
    return out


def _prior_cost(free: list[Parameter], values: dict[str, float]) -> float:
    single = sum(((p.prior - values[p.name]) / p.sigma) ** 2 for p in free if p.status == "prior" and p.group is None)
    for group, _ in _groups(free):
        misfit = group.misfit(values)
        single += float(misfit @ group.weight @ misfit)
    return single


def _to_boundary(free: list[Parameter], values: dict[str, float], step: np.ndarray) -> float:
    """The largest factor ≤ 1 that keeps ``values + factor·step`` at most TO_BOUNDARY of the way to
    every bound (1 when no bound is in the way)."""
    factor = 1.0
    for j, parameter in enumerate(free):
        here = values[parameter.name]
        if parameter.lower is not None and step[j] < 0:
            factor = min(factor, TO_BOUNDARY * (here - parameter.lower) / -step[j])
        if parameter.upper is not None and step[j] > 0:
            factor = min(factor, TO_BOUNDARY * (parameter.upper - here) / step[j])
    return max(factor, 0.0)


def _solve(problem: Problem, weights_of: Callable[[np.ndarray], np.ndarray], used: np.ndarray,
           max_iterations: int, tolerance: float, cancelled: Callable[[], bool] | None = None
           ) -> tuple[dict[str, float], bool, str, int]:
    """Levenberg–Marquardt from the problem's current values; returns values, converged, reason, count.

    Every visited state is valid: a step is shortened so that it stops short of each parameter's bound,
    and a trial the model cannot evaluate (a ray missing a surface, a cover plane cutting a sphere) is
    halved along its direction before the damping grows. Converged means the distance still to go is
    below ``tolerance`` of every parameter's marginal a-priori sigma (the square root of the inverse normal
    matrix's diagonal, not the far smaller one it would have with every other parameter held): the last
    step is below a tenth of that, or steps shrink geometrically (Gauss–Newton creeping along a curved
    valley of weakly determined housing parameters) and the sum of those still to come is below it; and
    the last step lowered the weighted squared residuals by less than a hundredth of a χ² unit. A
    run where no valid step lowers the weighted squared residuals is at a minimum (machine precision).
    When the only steps that would lower them leave the valid region, the run is NOT
    converged: it is stuck against the edge of the model's valid region, and the reason says so.
    ``cancelled()`` is asked before each iteration: True raises :class:`InterruptedError`.
    """
    free = problem.free()
    values = problem.values()
    observed = problem.observations.values
    sigmas = problem.observations.sigmas
    computed, ok = problem.evaluate(values, None)
    if not np.all(ok[used]):
        bad = int(np.flatnonzero(~ok & used)[0])
        obs = problem.observations
        raise ConvergenceError(
            f"the starting values cannot reproduce the observation of point {obs.point[bad]!r} "
            f"({obs.side[bad]} image, station {obs.group[bad]}): its ray does not reach the point; "
            "check the housing's starting values and priors")
    lam = 1e-3
    converged, reason = False, f"no convergence in {max_iterations} iterations"
    iteration = 0
    previous = None
    for iteration in range(1, max_iterations + 1):  # noqa: B007 (the count is returned)
        if cancelled is not None and cancelled():
            raise InterruptedError(f"the adjustment was stopped at iteration {iteration}")
        residual = np.where(used, observed - computed, 0.0)
        weights = np.where(used, weights_of(residual / sigmas) / sigmas**2, 0.0)
        jac = _structured_jacobian(problem, values, free, computed)
        problem.last_jacobian = (jac, tuple(values[p.name] for p in free), jac.pattern)
        system = _system(problem, jac, residual, weights, free, values)
        cost = system.cost
        accepted = None
        before = cost
        invalid_tail = False  # the last damping levels tried only produced invalid states
        while lam <= 1e12:
            try:
                full_step = system.step(lam)
            except np.linalg.LinAlgError:
                lam *= 10
                continue
            step = full_step * _to_boundary(free, values, full_step)
            valid_seen = False
            for _ in range(BACKTRACKS + 1):
                trial = dict(values)
                for j, parameter in enumerate(free):
                    trial[parameter.name] = values[parameter.name] + step[j]
                trial_computed, trial_ok = problem.evaluate(trial, None)
                if np.all(trial_ok[used]) and np.all(np.isfinite(trial_computed[used])):
                    valid_seen = True
                    break
                step = step / 2
            if valid_seen:
                trial_residual = np.where(used, observed - trial_computed, 0.0)
                trial_cost = float(trial_residual @ (weights * trial_residual)) + _prior_cost(free, trial)
                if trial_cost < cost:
                    accepted = step
                    values, computed = trial, trial_computed
                    lam = max(lam / 10, 1e-12)
                    break
            invalid_tail = not valid_seen
            lam *= 10
        if accepted is None:
            if invalid_tail:
                reason = ("stuck: every further step leaves the model's valid region (a ray missing a surface "
                          "or a housing surface cutting another); the result is not a minimum")
            else:
                converged, reason = True, "converged (no step lowers the weighted squared residuals further)"
            break
        marginal = system.marginal()
        size = float(np.max(np.abs(accepted) / marginal))
        rate = size / previous if previous is not None and previous > 0 else None
        # the distance still to go: the step itself, or, when steps shrink geometrically (Gauss–Newton
        # creeping along a curved valley of weakly determined housing parameters), the rest of that series
        remaining = size / (1.0 - rate) if rate is not None and rate < 1.0 else np.inf
        previous = size
        # and the objective has settled: the last step lowered it by less than a hundredth of one χ² unit
        # (scaled by the variance factor, so a too optimistic a-priori sigma does not hold the run back)
        left_over = np.where(used, observed - computed, 0.0)
        new_cost = float(left_over @ (weights * left_over)) + _prior_cost(free, values)
        dof = max(int(used.sum()) + sum(1 for p in free if p.status == "prior") - len(free), 1)
        settled = before - new_cost < 0.01 * max(1.0, new_cost / dof)
        if settled and (size < tolerance / 10 or remaining < tolerance):
            converged, reason = True, "converged"
            break
    if not np.all(np.isfinite(list(values.values()))):
        raise ConvergenceError("the adjustment diverged (non-finite parameters)")
    for parameter in problem.parameters:
        parameter.value = values[parameter.name]
    return values, converged, reason, iteration


def _huber(k: float) -> Callable[[np.ndarray], np.ndarray]:
    def weights(normalised: np.ndarray) -> np.ndarray:
        size = np.abs(normalised)
        return np.where(size <= k, 1.0, k / np.maximum(size, 1e-300))
    return weights


def _unit(normalised: np.ndarray) -> np.ndarray:
    return np.ones_like(normalised)


def _reusable_jacobian(problem: Problem, values: dict[str, float], free: list[Parameter]
                       ) -> normal_equations.BlockJacobian | None:
    """The solver's last Jacobian if it was taken within a hair (1e-9 relative) of ``values``: after
    convergence the last step is far below the parameters' precision, and the covariance it gives
    differs from a fresh one only in that order."""
    cached = getattr(problem, "last_jacobian", None)
    if cached is None:
        return None
    jac, at, _ = cached
    now = np.array([values[p.name] for p in free])
    if jac.width != len(free) or not np.allclose(now, at, rtol=1e-9, atol=1e-12):
        return None
    return jac


SINGULAR = 1e14  # condition number of the equilibrated normal matrix beyond which it is singular


def _singular(names: list[str], weakest: np.ndarray) -> DegenerateGeometryError:
    order = np.argsort(-np.abs(weakest))[:4]
    return DegenerateGeometryError(
        "the normal matrix is singular: no information on the combination of "
        + ", ".join(f"{names[i]} ({weakest[i]:+.2f})" for i in order)
        + "; fix one of them or give it a prior")


def _weak_directions(names: list[str], vt: np.ndarray) -> list[list[tuple[str, float]]]:
    weak = []
    for k in range(1, min(3, len(vt)) + 1):
        vector = vt[-k]
        order = np.argsort(-np.abs(vector))[:4]
        weak.append([(names[i], float(vector[i])) for i in order if abs(vector[i]) > 0.1])
    return weak


def _dense_core(jac, residual, weights, free, values, names, n_used, redundancy, variance_start=None,
                variance_fixed=None) -> dict:
    """The dense statistics' linear algebra: N = JᵀWJ + priors, its SVD (condition, weak directions),
    Qxx (pseudo-inverse; prior-weighted after variance components) and every observation's leverage."""
    data = jac.gram(weights)  # JᵀWJ of the observations, formed once
    normal, _, cost = _normal_system(jac, residual, weights, free, values, data=data)
    scale = np.sqrt(np.maximum(np.diag(normal), 1e-300))
    scaled = normal / np.outer(scale, scale)
    _, s_values, vt = np.linalg.svd(scaled, compute_uv=True)
    condition = float(s_values[0] / s_values[-1]) if s_values[-1] > 0 else float("inf")
    if not np.isfinite(condition) or condition > SINGULAR:
        raise _singular(names, vt[-1])
    qxx = ((vt.T / s_values) @ vt) / np.outer(scale, scale)
    variance, observation_cost, observation_redundancy = _variance_component(
        lambda factor: float(np.sum(_prior_weighted_inverse(data, normal, factor) * data)),
        bool(np.any(np.abs(normal - data) > 0)), float(residual @ (weights * residual)), cost, redundancy, n_used,
        variance_start, variance_fixed)
    has_priors = bool(np.any(np.abs(normal - data) > 0))
    qxx = qxx if variance is None or not has_priors else _prior_weighted_inverse(data, normal, variance)
    qxx = (qxx + qxx.T) / 2
    diagonal = np.sqrt(np.maximum(np.diag(qxx), 1e-300))
    correlation = qxx / np.outer(diagonal, diagonal)
    i, j = np.nonzero(np.triu(np.abs(correlation) > 0.95, 1))
    over = [(names[a], names[b], float(correlation[a, b])) for a, b in zip(i, j, strict=True)]
    return dict(cost=cost, variance=variance, observation_cost=observation_cost,
                observation_redundancy=observation_redundancy, names=names, qxx=qxx, diagonal=np.diag(qxx),
                over=over, condition=condition, weak=_weak_directions(names, vt), leverage=jac.leverage(qxx))


def _schur_core(jac, residual, weights, free, values, names, n_used, redundancy, partition, arrow=None,
                variance_start=None, variance_fixed=None) -> dict:
    """The same from the block-arrow normal equations (:class:`normal_equations.ArrowSystem`), linear in
    the number of local groups: each group's block and the reduced system S (the Schur complement onto
    the global unknowns) checked for singularity; condition number and weak directions of S; Qxx in block
    form (globals, each group, globals × group); leverages block by block."""
    diagonal, rhs, prior_cost, groups = _prior_terms(free, values)
    if arrow is None:  # (a system formed for this Jacobian and these weights has the same matrices)
        arrow = normal_equations.ArrowSystem(jac, weights, residual, partition)
        arrow.add_priors(diagonal, rhs, groups)
    observation_cost = float(residual @ (weights * residual))
    cost = observation_cost + prior_cost
    # every local group's block on its own: a station whose pose the data cannot fix is named
    _, v = arrow.matrices()
    scale_l = np.sqrt(np.maximum(np.einsum("sii->si", v), 1e-300))
    eigen, vectors = np.linalg.eigh(v / (scale_l[:, :, None] * scale_l[:, None, :]))
    ratio = eigen[:, -1] / np.maximum(eigen[:, 0], 1e-300)
    if np.any(~np.isfinite(ratio) | (ratio > SINGULAR) | (eigen[:, 0] <= 0)):
        s = int(np.argmax(np.where(np.isfinite(ratio), ratio, np.inf)))
        members = [names[j] if j >= 0 else "-" for j in partition.local[s]]
        raise _singular(members, np.where(partition.mask[s], vectors[s][:, 0], 0.0))
    reduced = arrow.reduced(0.0)
    _, s_values, vt = np.linalg.svd(reduced[1], compute_uv=True)
    condition = float(s_values[0] / s_values[-1]) if s_values[-1] > 0 else float("inf")
    global_names = [names[j] for j in partition.glob]
    if not np.isfinite(condition) or condition > SINGULAR:
        raise _singular(global_names, vt[-1])
    variance, observation_cost, observation_redundancy = _variance_component(
        lambda factor: arrow.trace_with_observations(arrow.inverse(factor)), arrow.has_priors,
        observation_cost, cost, redundancy, n_used, variance_start, variance_fixed)
    inverse = arrow.inverse(reduced=reduced) if variance is None or not arrow.has_priors else arrow.inverse(variance)
    return dict(cost=cost, variance=variance, observation_cost=observation_cost,
                observation_redundancy=observation_redundancy, names=global_names, qxx=inverse.qgg,
                diagonal=inverse.diagonal(), over=inverse.correlations_over(names, 0.95), condition=condition,
                weak=_weak_directions(global_names, vt), leverage=inverse.leverage(jac, arrow.classes))


def _warm_step(problem: Problem, used: np.ndarray, statistics: dict):
    """One undamped Gauss–Newton step for the observations ``used`` from the problem's current values
    with the Jacobian ``statistics`` were computed with (at these values), as data snooping needs after
    setting one observation unit aside: the solution moves little, and the step of the quadratic model
    is the re-adjustment to second order. Taken (parameters updated) when it stays valid and lowers the
    weighted squared residuals, and then its normal equations (the same matrix the statistics at the new
    values need: same Jacobian, same weights) are returned; None otherwise (the caller solves in full)."""
    free = problem.free()
    values = problem.values()
    obs = problem.observations
    computed = statistics["computed"]
    residual = np.where(used, obs.values - computed, 0.0)
    weights = np.where(used, 1.0 / obs.sigmas**2, 0.0)
    try:
        system = _system(problem, statistics["jacobian"], residual, weights, free, values)
        step = system.step(0.0)
    except (np.linalg.LinAlgError, ValueError):
        return None
    step = step * _to_boundary(free, values, step)
    trial = dict(values)
    for j, parameter in enumerate(free):
        trial[parameter.name] = values[parameter.name] + step[j]
    trial_computed, trial_ok = problem.evaluate(trial, None)
    if not (np.all(trial_ok[used]) and np.all(np.isfinite(trial_computed[used]))):
        return None
    trial_residual = np.where(used, obs.values - trial_computed, 0.0)
    if float(trial_residual @ (weights * trial_residual)) + _prior_cost(free, trial) >= system.cost:
        return None
    for parameter in problem.parameters:
        parameter.value = trial[parameter.name]
    system.evaluated = (trial_computed, trial_ok)  # the model at the new values, for the statistics
    return system


def _statistics(problem: Problem, used: np.ndarray, jacobian: normal_equations.BlockJacobian | None = None,
                system=None, variance_start: float | None = None, variance_fixed: float | None = None) -> dict:
    """Sigma0, Qxx, sigmas, correlations, condition, redundancy numbers, w-tests and the global test of the
    adjustment at the problem's current values, by the dense or the block-arrow path (:func:`_partition`).

    Dense: ``names``/``qxx`` cover every free unknown and the condition number and weak directions are
    the full normal matrix's. Block-arrow: ``names``/``qxx`` cover the global unknowns (the local groups'
    covariance blocks exist but are not returned: the blocks between two stations would be quadratic in
    their number), condition and weak directions are those of the reduced system S (the local blocks are
    checked for singularity on their own), correlations over 0.95 are those among the globals, within a
    group and between a group and the globals; sigmas, redundancy numbers and w-tests cover everything.

    ``variance_fixed``: the parameters' variance factor is given (an M-estimator's, :func:`_m_estimate`):
    sigmas and ``parameter_variance`` use it, while sigma0 stays the observations' own, vᵀPv / r_obs (the
    standard deviation of one observation's error, in a-priori sigmas, as a new observation needs it)."""
    free = problem.free()
    names = [p.name for p in free]
    values = problem.values()
    obs = problem.observations
    evaluated = getattr(system, "evaluated", None)
    computed, ok = evaluated if evaluated is not None else problem.evaluate(values, None)
    residual = np.where(used, obs.values - computed, 0.0)
    weights = np.where(used, 1.0 / obs.sigmas**2, 0.0)
    reused = jacobian if jacobian is not None else _reusable_jacobian(problem, values, free)
    jac = reused if reused is not None else _structured_jacobian(problem, values, free, computed)
    n_used = int(used.sum())
    n_prior = sum(1 for p in free if p.status == "prior")
    redundancy = n_used + n_prior - len(free)
    if redundancy <= 0:
        raise DegenerateGeometryError(
            f"{n_used} observations and {n_prior} priors cannot determine {len(free)} unknowns "
            f"(redundancy {redundancy}); measure more points or fix parameters")
    partition = _partition(problem, free, jac)
    if partition is None:
        core = _dense_core(jac, residual, weights, free, values, names, n_used, redundancy, variance_start,
                           variance_fixed)
    else:
        arrow = system.arrow if isinstance(system, _SchurSystem) and system.arrow.partition is partition else None
        core = _schur_core(jac, residual, weights, free, values, names, n_used, redundancy, partition, arrow,
                           variance_start, variance_fixed)
    cost, variance = core["cost"], core["variance"]
    observation_cost, observation_redundancy = core["observation_cost"], core["observation_redundancy"]
    if variance_fixed is not None:
        parameter_variance = float(variance_fixed)
        variance = observation_cost / max(float(observation_redundancy), 1e-9)
    else:
        variance = cost / redundancy if variance is None else variance
        parameter_variance = float(variance)
    sigma0 = float(np.sqrt(variance))
    sigmas = {name: float(np.sqrt(parameter_variance * max(q, 0.0)))
              for name, q in zip(names, core["diagonal"], strict=True)}
    over, condition, weak = core["over"], core["condition"], core["weak"]
    # redundancy numbers r_i = 1 − p_i a_i Qxx a_iᵀ for uncorrelated observations
    leverage = core["leverage"] * weights
    red_numbers = np.where(used, np.clip(1.0 - leverage, 0.0, 1.0), 0.0)
    safe_r = np.maximum(red_numbers, 1e-12)
    standardised = np.where(used, residual / (obs.sigmas * np.sqrt(safe_r)), 0.0)
    # Pope's tau test: the residual standardised by the estimated variance factor (so that a wrong a-priori
    # pixel sigma does not decide what is flagged), against the tau distribution's critical value for
    # α0 = 0.1 % per observation. A robust scale (the median's) would be noisier than the estimate and
    # flag about twice as many blunder-free observations as the level says; the robust start and the
    # setting aside of gross errors keep a blunder from hiding behind the inflated estimate.
    robust_scale = sigma0 if sigma0 > 0 else 1.0
    w = standardised / robust_scale
    mdb = np.where(used, DELTA0 * robust_scale * obs.sigmas / np.sqrt(safe_r), np.inf)
    # an observation left out is tested by its prediction residual: were it included, its redundancy
    # number would be 1/(1 + h) with h = a Qxx aᵀ / σ² (its leverage against the others)
    outside = ~used & ok & np.isfinite(computed)
    if outside.any():
        raw = obs.values - computed
        h = core["leverage"][outside] / obs.sigmas[outside] ** 2
        w[outside] = raw[outside] / (obs.sigmas[outside] * np.sqrt(1.0 + h)) / robust_scale
        mdb[outside] = DELTA0 * robust_scale * obs.sigmas[outside] * np.sqrt(1.0 + h)
    names, qxx = core["names"], core["qxx"]
    chi2 = observation_cost
    from scipy import stats  # deferred: scipy.stats takes most of a second to import (the window's start-up)

    lower, upper = stats.chi2.ppf([0.025, 0.975], observation_redundancy)
    if chi2 > upper:
        verdict = (f"a-priori pointing sigma too optimistic: the residuals say {sigma0:.2f} times it; the "
                   "estimated variance factor is used for every sigma")
    elif chi2 < lower:
        verdict = (f"a-priori pointing sigma too pessimistic: the residuals say {sigma0:.2f} times it; the "
                   "estimated variance factor is used for every sigma")
    else:
        verdict = "a-priori pointing sigma consistent with the residuals (95 %)"
    global_test = {
        "redundancy": redundancy, "observation_redundancy": float(observation_redundancy), "chi2": float(chi2),
        "variance_factor": float(sigma0**2),
        "accepted_95": bool(lower <= chi2 <= upper), "p_value": float(stats.chi2.sf(chi2, observation_redundancy)),
        "interval_95": [float(lower), float(upper)], "verdict": verdict,
        "meaning": "sigma0 is in units of the a-priori pixel sigma: 1 means the residuals are as large as "
                   "the assumed pointing precision. The a-priori sigma is only a starting value: sigma0² is "
                   "the estimated variance factor of the image observations (variance-component estimation; "
                   "priors keep their stated sigmas), and it scales every reported sigma",
    }
    rms = float(np.sqrt(np.mean(residual[used] ** 2)))
    return dict(names=names, qxx=qxx, sigma0=sigma0, robust_scale=robust_scale, jacobian=jac, computed=computed,
                variance=variance, parameter_variance=parameter_variance,
                critical=tau_critical(observation_redundancy), sigmas=sigmas, over=over,
                condition=condition, weak=weak, red_numbers=red_numbers, w=w, mdb=mdb, global_test=global_test,
                redundancy=redundancy, residual=residual, rms=rms)


@batch_computation  # one BLAS thread for its small dense algebra, compiled kernels (core/batch_mode.py)
def adjust(problem: Problem, max_iterations: int = 100, tolerance: float = 1e-2, robust: bool = True,
           snooping: bool = True, max_rejections: int | None = None,
           snoop_unit: Callable[[int], np.ndarray] | None = None, estimator: str = "least squares",
           cancelled: Callable[[], bool] | None = None) -> Adjustment:
    """Adjust ``problem`` (its parameters' values are the start and are updated in place).

    robust: start with IRLS/Huber so that a gross error cannot drag the solution; snooping: then
    iteratively exclude the observation unit with the largest |w| beyond Pope's tau critical value
    (:func:`tau_critical`, α0 = 0.1 % per observation; 3.29 for a large redundancy) and re-adjust, at most
    ``max_rejections`` times (default: one per SNOOP_SHARE observations, at least two); when that cap
    is reached with observations still failing, ``model_doubt`` says the model or set-up is wrong
    rather than removing more data. ``snoop_unit(i)`` returns the
    indices of the observations rejected together with observation i (e.g. both coordinates of a
    point in one image); default: the observation alone. ``cancelled()``: asked before every iteration
    (True stops the run with :class:`InterruptedError`).

    ``estimator="huber"``: M-estimation instead (:func:`_m_estimate`; ``robust`` and ``max_rejections`` do
    not apply): every observation kept and down-weighted by Huber's function of its residual in robust
    standard deviations, only gross errors set aside and named (none with ``snooping=False``: then they are
    only down-weighted), sigma0 the observations' standard deviation and the covariance Huber's asymptotic
    one (:func:`_m_covariance_factor`).
    """
    if estimator not in ESTIMATORS:
        raise InvalidParameterError("estimator", f"must be one of {ESTIMATORS}, got {estimator!r}")
    n = len(problem.observations)
    used = np.ones(n, dtype=bool)
    excluded: list[Suspect] = []
    obs = problem.observations
    # observations the starting model cannot reach at all (e.g. a control point with a wrong sign puts it
    # behind the camera) are excluded at once and reported
    _, reachable = problem.evaluate(problem.values(), None)
    if not reachable.all():
        if reachable.sum() < n / 2:
            bad = int(np.flatnonzero(~reachable)[0])
            raise ConvergenceError(
                f"the starting values cannot reproduce {int((~reachable).sum())} of {n} observations (e.g. point "
                f"{obs.point[bad]!r}, {obs.side[bad]} image, station {obs.group[bad]}): its ray does not reach the "
                "point; check the control coordinates and the housing's starting values and priors")
        for i in np.flatnonzero(~reachable):
            excluded.append(Suspect(obs.point[i], obs.side[i], obs.coordinate[i], obs.group[i], None, None, None,
                                    "the point is not visible from the starting orientation (wrong coordinates?)"))
        used &= reachable
    free = problem.free()
    if n + sum(1 for p in free if p.status == "prior") <= len(free):
        raise DegenerateGeometryError(
            f"{n} observations cannot determine {len(free)} unknowns ({', '.join(p.name for p in free[:6])}"
            f"{'...' if len(free) > 6 else ''}); measure more points or fix parameters")
    if estimator == "huber":
        return _m_estimate(problem, used, excluded, snoop_unit, max_iterations, tolerance, set_aside=snooping,
                           cancelled=cancelled)
    if robust:
        _solve(problem, _huber(HUBER_K), used, max_iterations, 1e-2, cancelled)
        used = _set_aside_gross_errors(problem, used, excluded, snoop_unit)
    _, converged, reason, iterations = _solve(problem, _unit, used, max_iterations, tolerance, cancelled)
    limit = max_rejections if max_rejections is not None else max(2, n // SNOOP_SHARE)
    statistics = _statistics(problem, used)
    rounds = 0
    moved = False
    while snooping and rounds < limit:
        rounds += 1
        w = np.abs(statistics["w"])
        worst = int(np.argmax(np.where(used, w, 0.0)))
        if w[worst] <= statistics["critical"] or statistics["redundancy"] <= 2:
            break
        unit = snoop_unit(worst) if snoop_unit else np.array([worst])
        obs = problem.observations
        for i in unit:
            if used[i]:
                excluded.append(Suspect(obs.point[i], obs.side[i], obs.coordinate[i], obs.group[i],
                                        float(statistics["w"][i]), float(statistics["residual"][i]),
                                        float(statistics["mdb"][i])))
        trial_used = used.copy()
        trial_used[unit] = False
        moved = True
        try:
            # warm and cheap: one Gauss–Newton step from the previous solution with the Jacobian its
            # statistics used (taken there), then the statistics with that Jacobian; the run is converged
            # properly once, after the last rejection (below). Nothing here grows faster than the data.
            system = _warm_step(problem, trial_used, statistics)
            if system is None:
                _, converged, reason, iterations = _solve(problem, _unit, trial_used, max_iterations, tolerance,
                                                          cancelled)
            statistics = _statistics(problem, trial_used, statistics["jacobian"], system, statistics["variance"])
        except DegenerateGeometryError:
            excluded = excluded[: len(excluded) - len(unit)]
            break
        used = trial_used
    if moved:
        _, converged, reason, iterations = _solve(problem, _unit, used, max_iterations, tolerance, cancelled)
        statistics = _statistics(problem, used)
    model_doubt = None
    if snooping and rounds >= limit and np.max(np.abs(np.where(used, statistics["w"], 0.0))) > statistics["critical"]:
        model_doubt = (f"after {rounds} rejections observations still fail the w-test: so many cannot be "
                       "blunders; the model or the set-up is wrong (housing kind, fixed parameters, "
                       "mismatched control or pairs)")
    for suspect in excluded:
        if suspect.mdb is None and suspect.reason.startswith("gross error"):
            i = _index_of(problem.observations, suspect)
            if i is not None and np.isfinite(statistics["mdb"][i]):
                suspect.w, suspect.mdb = float(statistics["w"][i]), float(statistics["mdb"][i])
    return Adjustment(
        parameters=problem.parameters, converged=converged, reason=reason, iterations=iterations,
        sigma0=statistics["sigma0"], rms=statistics["rms"], redundancy=statistics["redundancy"],
        residuals=statistics["residual"], covariance_names=statistics["names"],
        covariance=statistics["qxx"] * statistics["parameter_variance"], sigmas=statistics["sigmas"],
        correlations_over=statistics["over"], condition_number=statistics["condition"],
        weak_directions=statistics["weak"], redundancy_numbers=statistics["red_numbers"], w=statistics["w"],
        mdb=statistics["mdb"], global_test=statistics["global_test"], excluded=excluded,
        observations=problem.observations, used=used,
        on_bound=_on_bound(problem.free(), statistics["sigmas"]), model_doubt=model_doubt,
        estimation={"estimator": "least squares"})


def robust_scale(normalised: np.ndarray, share: float = 1.0) -> float:
    """The robust standard deviation of residuals ``normalised`` by their a-priori sigmas: 1.4826 times
    their median absolute value (the standard deviation for Gaussian errors, and a stable scale for any
    error law), divided by sqrt(``share``), the redundancy's share of the observations (residuals are
    smaller than the errors by about that: each is an error less the fit's share of it)."""
    if not normalised.size:
        return 0.0
    return float(1.4826 * np.median(np.abs(normalised)) / np.sqrt(max(share, 1e-3)))


def _scaled_huber(k: float, used: np.ndarray, share: float) -> Callable[[np.ndarray], np.ndarray]:
    """IRLS weights of Huber's function with the tuning ``k`` in robust standard deviations of the ``used``
    residuals (:func:`robust_scale`), re-estimated from the residuals at every iteration."""
    def weights(normalised: np.ndarray) -> np.ndarray:
        scale = robust_scale(normalised[used], share)
        size = np.abs(normalised) / (scale if scale > 0 else 1.0)
        return np.where(size <= k, 1.0, k / np.maximum(size, 1e-300))
    return weights


def _normalised(problem: Problem, used: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Residuals (observed − computed, the observations' units) and the same divided by their a-priori
    sigmas, at the problem's current values (0 where an observation is not used or not reachable)."""
    obs = problem.observations
    computed, ok = problem.evaluate(problem.values(), None)
    residual = np.where(used & ok, obs.values - computed, 0.0)
    return residual, residual / obs.sigmas


def _m_covariance_factor(normalised: np.ndarray, scale: float, k: float, n_free: int, redundancy: float
                         ) -> float:
    """The M-estimator's variance factor for the parameters (Huber 1981, 7.6; Street, Carroll & Ruppert
    1988): the parameters' covariance is φ (JᵀPJ + priors)⁻¹ with

        φ = K² s² [Σ ψ(u_i)² / r] / [Σ ψ'(u_i) / n]²,   K = 1 + (p / n) var(ψ') / mean(ψ')²,

    u_i = v_i / (σ_i s) the residuals in robust standard deviations s, ψ Huber's function with constant k,
    p the free unknowns, r the redundancy, n the kept observations. For Gaussian errors φ is the variance
    factor / 0.95 (the M-estimate is a little less precise than least squares); for heavy-tailed errors it
    is below the errors' variance (the M-estimate is more precise than least squares would be), which is
    why the covariance uses φ and not sigma0²."""
    u = normalised / scale
    psi = np.clip(u, -k, k)
    slope = (np.abs(u) <= k).astype(float)
    n = max(u.size, 1)
    mean_slope = max(float(np.mean(slope)), 1.0 / n)
    correction = 1.0 + n_free / n * float(np.var(slope)) / mean_slope**2
    return float(correction**2 * scale**2 * (np.sum(psi**2) / max(redundancy, 1.0)) / mean_slope**2)


def _m_estimate(problem: Problem, used: np.ndarray, excluded: list[Suspect],
                snoop_unit: Callable[[int], np.ndarray] | None, max_iterations: int, tolerance: float,
                set_aside: bool = True, cancelled: Callable[[], bool] | None = None) -> Adjustment:
    """M-estimation by iteratively reweighted least squares with Huber's function (thesis practice for
    automatic measurements; docs/calibration.md, "Robust estimation").

    Each round runs the Levenberg–Marquardt solver (:func:`_solve`) with Huber weights: an observation
    whose residual is within :data:`HUBER_TUNING` robust standard deviations (:func:`robust_scale`,
    re-estimated at every iteration) keeps its full weight, one beyond it the weight k / |u|, so that the
    heavy tails of clean measurement noise are down-weighted, not thrown out. Converged means the
    solver's own criteria held in the last round (the step is below the tolerance of every parameter's
    sigma and the weighted squared residuals settled, the weights being those of the residuals at the
    start of the step: at the fixed point of the reweighting). Then observations more than :data:`GROSS`
    robust standard deviations off (with their unit, ``snoop_unit``: both coordinates of a corner) are
    gross errors: set aside, named as suspects, and the next round adjusts without them; at most
    :data:`M_ROUNDS` rounds (one when ``set_aside`` is False). More gross errors at once than one in twenty
    observations cannot be blunders: the model is then in doubt and nothing more is set aside.

    Statistics: sigma0² = vᵀPv / r_obs over the kept observations (the observations' variance factor:
    the standard deviation of one observation's error, which a new observation intersected by least
    squares has); the parameters' covariance is :func:`_m_covariance_factor`'s φ times (JᵀPJ + priors)⁻¹,
    the priors weighted against φ."""
    free = problem.free()
    n_prior = sum(1 for p in free if p.status == "prior")
    model_doubt = None
    rounds, converged, reason, iterations = 0, False, "", 0
    scale, normalised, share = 1.0, np.zeros(len(used)), 1.0
    while True:
        rounds += 1
        n_used = int(used.sum())
        share = max(n_used + n_prior - len(free), 1) / max(n_used, 1)
        _, converged, reason, iterations = _solve(problem, _scaled_huber(HUBER_TUNING, used, share), used,
                                                  max_iterations, tolerance, cancelled)
        _, normalised = _normalised(problem, used)
        scale = robust_scale(normalised[used], share)
        if not scale > 0:
            break
        gross = np.flatnonzero(used & (np.abs(normalised) > GROSS * scale))
        if not gross.size or not set_aside:
            break
        if gross.size > n_used // 20 or rounds >= M_ROUNDS:
            model_doubt = (f"{gross.size} of {n_used} observations lie more than {GROSS:g} robust standard "
                           "deviations off: so many cannot be blunders; the model or the set-up is wrong (housing "
                           "kind, fixed parameters, mismatched control or pairs)")
            break
        used = used.copy()
        obs = problem.observations
        residual = obs.values - problem.evaluate(problem.values(), None)[0]
        for i in gross:
            for k in (snoop_unit(int(i)) if snoop_unit else np.array([i])):
                if used[k]:
                    used[k] = False
                    excluded.append(Suspect(obs.point[k], obs.side[k], obs.coordinate[k], obs.group[k],
                                            float(normalised[k] / scale), float(residual[k]), None,
                                            f"gross error: residual over {GROSS:g} robust standard deviations"))
    n_used = int(used.sum())
    redundancy = n_used + n_prior - len(free)
    factor = _m_covariance_factor(normalised[used], scale if scale > 0 else 1.0, HUBER_TUNING, len(free),
                                  redundancy)
    statistics = _statistics(problem, used, variance_fixed=factor)
    for suspect in excluded:
        i = _index_of(problem.observations, suspect) if suspect.mdb is None else None
        if i is not None and np.isfinite(statistics["mdb"][i]):
            suspect.w, suspect.mdb = float(statistics["w"][i]), float(statistics["mdb"][i])
    size = np.abs(normalised[used]) / (scale if scale > 0 else 1.0)
    estimation = {"estimator": "huber", "tuning": HUBER_TUNING, "robust_scale": float(scale),
                  "noise_variance_factor": float(statistics["sigma0"] ** 2),
                  "parameter_variance_factor": float(factor),
                  "down_weighted": float(np.mean(size > HUBER_TUNING)) if size.size else 0.0, "rounds": rounds,
                  "gross_errors": sum(1 for s in excluded if s.reason.startswith("gross error"))}
    return Adjustment(
        parameters=problem.parameters, converged=converged, reason=reason, iterations=iterations,
        sigma0=statistics["sigma0"], rms=statistics["rms"], redundancy=statistics["redundancy"],
        residuals=statistics["residual"], covariance_names=statistics["names"],
        covariance=statistics["qxx"] * statistics["parameter_variance"], sigmas=statistics["sigmas"],
        correlations_over=statistics["over"], condition_number=statistics["condition"],
        weak_directions=statistics["weak"], redundancy_numbers=statistics["red_numbers"], w=statistics["w"],
        mdb=statistics["mdb"], global_test=statistics["global_test"], excluded=excluded,
        observations=problem.observations, used=used,
        on_bound=_on_bound(problem.free(), statistics["sigmas"]), model_doubt=model_doubt, estimation=estimation)


def tau_critical(redundancy: float, alpha: float = ALPHA0) -> float:
    """Critical value of Pope's tau test (two-sided, level ``alpha`` per observation) for ``redundancy``:
    τ = t·sqrt(r) / sqrt(r − 1 + t²), t the Student quantile with r − 1 degrees of freedom."""
    r = float(redundancy)
    if r <= 1.5:
        return float("inf")
    from scipy import stats  # deferred, as above

    t = float(stats.t.ppf(1.0 - alpha / 2.0, r - 1.0))
    return float(t * np.sqrt(r) / np.sqrt(r - 1.0 + t * t))


def _variance_component(trace_of: Callable[[float], float], has_priors: bool, observation_cost: float,
                        cost: float, redundancy: int, n_used: int, start: float | None = None,
                        fixed: float | None = None):
    """Variance-component estimation (Förstner 1979) for two groups, image observations and priors.

    The priors are statements about the housing and the interior from outside the data; their group has
    almost no redundancy, so its variance component is not estimable and it keeps its stated sigmas. The
    observations' component σ̂² = vᵀPv / r_obs, with r_obs = n − tr(Q N_obs) their share of the redundancy,
    is iterated with the priors reweighted against it. ``trace_of(σ̂²)`` gives tr((N_obs + σ̂² P_prior)⁻¹
    N_obs) (dense or block-arrow). Returns (σ̂², vᵀPv of the observations, r_obs), or (None, cost,
    redundancy) when there are no priors (then σ̂² = vᵀPv / r, the classical estimate). ``start``: the
    first σ̂² (default vᵀPv / r; data snooping's rounds start from the previous round's estimate).
    ``fixed``: the observations' factor is given (the M-estimator's, :func:`_m_covariance_factor`), not
    estimated; the priors are weighted against it and r_obs is their share of the redundancy at it."""
    if fixed is not None:
        share = n_used - trace_of(fixed) if has_priors else float(redundancy)
        return fixed, observation_cost, share if share >= 0.5 else float(redundancy)
    if not has_priors:
        return None, cost, redundancy
    variance = max(cost / redundancy if start is None else start, 1e-12)
    share = float(redundancy)
    for _ in range(20):
        share = n_used - trace_of(variance)
        if share < 0.5:
            return None, cost, redundancy
        new = max(observation_cost / share, 1e-12)
        done = abs(new / variance - 1.0) < 1e-4
        variance = new
        if done:
            break
    return variance, observation_cost, share


def _prior_weighted_inverse(data, normal, variance):
    """Qxx in units of the observations' variance factor: (N_obs + σ̂² P_prior)⁻¹, so that σ̂²·Qxx is the
    covariance with the observations at σ̂ and the priors at their own sigmas (``data`` = N_obs = JᵀWJ,
    ``normal`` = N_obs + P_prior)."""
    matrix = data + variance * (normal - data)
    scale = np.sqrt(np.maximum(np.diag(matrix), 1e-300))
    return np.linalg.pinv(matrix / np.outer(scale, scale), rcond=1e-15) / np.outer(scale, scale)


def _index_of(obs: Observations, suspect: Suspect) -> int | None:
    for i in range(len(obs)):
        if (obs.point[i], obs.side[i], obs.coordinate[i], obs.group[i]) == \
                (suspect.point, suspect.side, suspect.coordinate, suspect.group):
            return i
    return None


def _set_aside_gross_errors(problem: Problem, used: np.ndarray, excluded: list[Suspect],
                            snoop_unit: Callable[[int], np.ndarray] | None) -> np.ndarray:
    """After the robust start, set aside observations whose residual exceeds GROSS robust standard
    deviations (the median absolute residual's scale): the unweighted adjustment that follows would
    otherwise be dragged by them as far as the robust start was not. They are reported as suspects."""
    obs = problem.observations
    computed, ok = problem.evaluate(problem.values(), None)
    normalised = np.where(used & ok, (obs.values - computed) / obs.sigmas, 0.0)
    scale = 1.4826 * float(np.median(np.abs(normalised[used & ok]))) if (used & ok).any() else 0.0
    if not scale > 0:
        return used
    gross = np.flatnonzero(used & (np.abs(normalised) > GROSS * scale))
    if len(gross) > len(obs) // 20:  # many at once: a wrong model or start, not blunders; snooping decides
        return used
    used = used.copy()
    for i in gross:
        for k in (snoop_unit(int(i)) if snoop_unit else np.array([i])):
            if used[k]:
                used[k] = False
                excluded.append(Suspect(obs.point[k], obs.side[k], obs.coordinate[k], obs.group[k],
                                        float(normalised[k] / scale), float(obs.values[k] - computed[k]), None,
                                        f"gross error: residual over {GROSS:g} robust standard deviations"))
    return used


def _on_bound(free: list[Parameter], sigmas: dict[str, float]) -> list[tuple[str, str, float]]:
    """Free parameters whose value lies within a tenth of its a-posteriori sigma of a bound: the data
    push them against the edge of the physical range, and their sigma (from a quadratic model about an
    interior minimum) does not describe them."""
    out = []
    for p in free:
        near = 0.1 * sigmas.get(p.name, 0.0)
        if p.lower is not None and p.value - p.lower <= near:
            out.append((p.name, "lower", float(p.lower)))
        if p.upper is not None and p.upper - p.value <= near:
            out.append((p.name, "upper", float(p.upper)))
    return out
