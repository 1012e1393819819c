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
