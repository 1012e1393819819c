"""The adjustment engine on problems with closed-form truth."""

import numpy as np
import pytest

from usvips.core.adjustment import Observations, Parameter, Problem, adjust
from usvips.core.errors import DegenerateGeometryError


def _line_problem(x, y, sigma, parameters):
    """y = a + b·x, observations y."""
    n = len(x)
    obs = Observations(np.asarray(y, float), np.full(n, sigma), [str(i) for i in range(n)], ["l"] * n,
                       ["y"] * n, ["1"] * n)

    def evaluate(values, blocks=None):
        return values["a"] + values["b"] * x, np.ones(n, dtype=bool)

    return Problem(parameters, obs, evaluate, [np.arange(n)])


def test_linear_fit_matches_closed_form_with_honest_statistics():
    rng = np.random.default_rng(1)
    x = np.linspace(0, 10, 60)
    y = 2.0 + 0.5 * x + rng.normal(0, 0.2, x.size)
    result = adjust(_line_problem(x, y, 0.2, [Parameter("a", 0.0), Parameter("b", 0.0)]), robust=False,
                    snooping=False)
    design = np.column_stack([np.ones_like(x), x])
    expected, *_ = np.linalg.lstsq(design, y, rcond=None)
    assert result.converged
    assert result.value("a") == pytest.approx(expected[0], abs=1e-8)
    assert result.value("b") == pytest.approx(expected[1], abs=1e-9)
    residual = y - design @ expected
    sigma0 = np.sqrt(residual @ residual / (x.size - 2)) / 0.2
    assert result.sigma0 == pytest.approx(sigma0, rel=1e-6)
    covariance = np.linalg.inv(design.T @ design) * (0.2 * sigma0) ** 2
    assert result.sigmas["b"] == pytest.approx(np.sqrt(covariance[1, 1]), rel=1e-5)
    assert result.redundancy_numbers.sum() == pytest.approx(x.size - 2, abs=1e-6)
    assert result.global_test["redundancy"] == 58


def test_fixed_and_prior_parameters():
    x = np.linspace(0, 1, 10)
    y = 1.0 + 3.0 * x
    fixed = adjust(_line_problem(x, y + 0.1, 0.01, [Parameter("a", 1.0, "fixed"), Parameter("b", 0.0)]),
                   robust=False, snooping=False)
    assert fixed.value("a") == 1.0
    assert "a" not in fixed.sigmas
    # a tight prior on b wins over the data's slope: the estimate lies between, weighted by precision
    prior = adjust(_line_problem(x, y, 0.01, [Parameter("a", 0.0), Parameter("b", 2.0, "prior", 2.0, 1e-6)]),
                   robust=False, snooping=False)
    assert prior.value("b") == pytest.approx(2.0, abs=1e-5)


def test_a_planted_blunder_is_named_by_data_snooping():
    rng = np.random.default_rng(4)
    x = np.linspace(0, 10, 40)
    y = 1.0 - 0.2 * x + rng.normal(0, 0.1, x.size)
    y[17] += 1.5  # 15 sigma
    result = adjust(_line_problem(x, y, 0.1, [Parameter("a", 0.0), Parameter("b", 0.0)]))
    assert [s.point for s in result.suspects] == ["17"]
    assert abs(result.suspects[0].w) > 3.29
    assert result.suspects[0].mdb == pytest.approx(4.13 * 0.1, rel=0.5)
    assert result.value("b") == pytest.approx(-0.2, abs=0.01)
    assert not result.used[17]


def test_too_few_observations_and_singular_problems_are_reported():
    x = np.array([1.0])
    with pytest.raises(DegenerateGeometryError, match="cannot determine 2 unknowns"):
        adjust(_line_problem(x, x, 0.1, [Parameter("a", 0.0), Parameter("b", 0.0)]))
    n = 5
    obs = Observations(np.ones(n), np.ones(n), [str(i) for i in range(n)], ["l"] * n, ["y"] * n, ["1"] * n)
    # a and b enter only as their sum: the normal matrix is singular
    problem = Problem([Parameter("a", 0.0), Parameter("b", 0.0)], obs,
                      lambda v, blocks=None: (np.full(n, v["a"] + v["b"]), np.ones(n, bool)), [np.arange(n)])
    with pytest.raises(DegenerateGeometryError, match="singular.*a .*b|singular.*b .*a"):
        adjust(problem, robust=False, snooping=False)


def test_snooping_false_alarm_rate_on_blunder_free_data_matches_its_level():
    """400 blunder-free fits of 60 observations: the share flagged is the w-test's level (α0 = 0.1 %
    two-sided per observation); 24 000 tests expect 24 alarms, Poisson 99.9 % range about 10-42."""
    rng = np.random.default_rng(11)
    x = np.linspace(0, 10, 60)
    flagged = 0
    for _ in range(400):
        y = 1.0 + 0.3 * x + rng.normal(0, 0.2, x.size)
        result = adjust(_line_problem(x, y, 0.2, [Parameter("a", 0.0), Parameter("b", 0.0)]))
        flagged += len(result.suspects)
    assert 8 <= flagged <= 45


def test_the_variance_factor_is_estimated_and_the_global_test_names_the_wrong_a_priori_sigma():
    """True noise 0.3 with an a-priori 0.1 (too optimistic) and 0.9 (too pessimistic): sigma0 finds 3 and
    1/3, the sigmas are those of the true noise, and a prior keeps its own stated sigma."""
    rng = np.random.default_rng(5)
    x = np.linspace(0, 10, 200)
    y = 2.0 + 0.5 * x + rng.normal(0, 0.3, x.size)
    reference = adjust(_line_problem(x, y, 0.3, [Parameter("a", 0.0), Parameter("b", 0.0)]), snooping=False)
    for assumed, word in ((0.1, "optimistic"), (0.9, "pessimistic")):
        result = adjust(_line_problem(x, y, assumed, [Parameter("a", 0.0), Parameter("b", 0.0)]), snooping=False)
        assert result.sigma0 * assumed == pytest.approx(reference.sigma0 * 0.3, rel=1e-6)
        assert result.sigmas["b"] == pytest.approx(reference.sigmas["b"], rel=1e-6)
        assert word in result.global_test["verdict"]
    # with a prior: the observations' variance component is estimated, the prior keeps its sigma
    prior = Parameter("a", 2.0, "prior", 2.0, 0.01)
    for assumed in (0.1, 0.3, 0.9):
        result = adjust(_line_problem(x, y, assumed, [Parameter("a", 2.0, "prior", 2.0, 0.01), Parameter("b", 0.0)]),
                        snooping=False)
        assert result.sigma0 * assumed == pytest.approx(0.3, rel=0.15)
        assert result.sigmas["a"] < prior.sigma
        if assumed == 0.3:
            same = result.sigmas
    for assumed in (0.1, 0.9):
        result = adjust(_line_problem(x, y, assumed, [Parameter("a", 2.0, "prior", 2.0, 0.01), Parameter("b", 0.0)]),
                        snooping=False)
        assert result.sigmas["a"] == pytest.approx(same["a"], rel=2e-2)
        assert result.sigmas["b"] == pytest.approx(same["b"], rel=2e-2)


def test_snooping_stops_at_its_cap_and_says_the_model_is_wrong():
    """A fifth of the observations spoiled: snooping removes at most 1/40 of them and says the model or
    the set-up is wrong instead of removing a tenth of the data; a single blunder raises no such doubt."""
    rng = np.random.default_rng(2)
    x = np.linspace(0, 10, 200)
    y = 1.0 + 0.3 * x + rng.normal(0, 0.05, x.size)
    y[rng.choice(x.size, 40, replace=False)] += rng.choice([-1.0, 1.0], 40) * rng.uniform(0.5, 2.0, 40)
    result = adjust(_line_problem(x, y, 0.05, [Parameter("a", 0.0), Parameter("b", 0.0)]))
    assert len(result.suspects) <= 200 // 40
    assert result.model_doubt and "model or the set-up is wrong" in result.model_doubt
    y = 1.0 + 0.3 * x + rng.normal(0, 0.05, x.size)
    y[50] += 1.0
    single = adjust(_line_problem(x, y, 0.05, [Parameter("a", 0.0), Parameter("b", 0.0)]))
    assert [s.point for s in single.suspects] == ["50"] and single.model_doubt is None


def test_a_parameter_never_steps_past_its_bound_and_ending_on_it_is_reported():
    """y = a + b·x with b bounded below by 1 while the data say 0.5: every evaluated b stays above 1, the
    run ends against the bound and says so; an interior optimum is not flagged."""
    x = np.linspace(0, 10, 30)
    y = 2.0 + 0.5 * x + np.random.default_rng(3).normal(0, 0.1, x.size)
    seen = []
    problem = _line_problem(x, y, 0.1, [Parameter("a", 0.0), Parameter("b", 3.0, lower=1.0)])
    evaluate = problem.evaluate

    def recording(values, blocks=None):
        seen.append(values["b"])
        return evaluate(values, blocks)

    problem.evaluate = recording
    result = adjust(problem, robust=False, snooping=False)
    assert min(seen) > 1.0
    assert [(name, side) for name, side, _ in result.on_bound] == [("b", "lower")]
    free = adjust(_line_problem(x, y, 0.1, [Parameter("a", 0.0), Parameter("b", 3.0, lower=0.0)]), robust=False,
                  snooping=False)
    assert free.on_bound == [] and free.value("b") == pytest.approx(0.5, abs=0.05)
    with pytest.raises(Exception, match="outside its physical range"):
        Parameter("t", -0.1, lower=0.0)


def test_a_cancel_asked_each_iteration_stops_the_adjustment():
    """The window's Stop: ``cancelled()`` is asked before each iteration; True stops the run there."""
    x = np.linspace(0, 10, 30)
    y = 2.0 + 0.5 * x
    asked = []

    def cancelled():
        asked.append(True)
        return len(asked) >= 2

    with pytest.raises(InterruptedError, match="stopped"):
        adjust(_line_problem(x, y, 0.1, [Parameter("a", 0.0), Parameter("b", 0.0)]), cancelled=cancelled)
    assert len(asked) == 2
    # never cancelled: the same result as without the hook
    plain = adjust(_line_problem(x, y, 0.1, [Parameter("a", 0.0), Parameter("b", 0.0)]))
    hooked = adjust(_line_problem(x, y, 0.1, [Parameter("a", 0.0), Parameter("b", 0.0)]), cancelled=lambda: False)
    assert hooked.value("b") == plain.value("b") and hooked.converged


def test_the_cancel_also_stops_m_estimation():
    x = np.linspace(0, 10, 30)
    with pytest.raises(InterruptedError):
        adjust(_line_problem(x, 2.0 + 0.5 * x, 0.1, [Parameter("a", 0.0), Parameter("b", 0.0)]), estimator="huber",
               cancelled=lambda: True)
