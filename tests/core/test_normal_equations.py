"""The engine's structured fast paths against the straightforward dense computation: the normal matrix
summed block by block, the leverages without an (n × n) hat matrix, the housing columns of a side traced
in one batch; and whole adjustments (robust start, data snooping, variance components, statistics) on
random rigs of both water housings, fast against reference."""

from __future__ import annotations

import numpy as np
import pytest

from tests.core.test_calibration_derivatives import _scene, _symbol
from usvips.core import batch_mode, normal_equations
from usvips.core.adjustment import Parameter, adjust


def _block_sparse(rng: np.random.Generator, blocks: int, width: int):
    """A random Jacobian that is zero outside a random column set per contiguous observation block."""
    sizes = rng.integers(4, 30, blocks)
    starts = np.concatenate([[0], np.cumsum(sizes)])
    jac = np.zeros((starts[-1], width))
    rows, columns = [], []
    for b in range(blocks):
        chosen = np.sort(rng.choice(width, int(rng.integers(1, width)), replace=False))
        index = np.arange(starts[b], starts[b + 1])
        jac[np.ix_(index, chosen)] = rng.normal(0, 10 ** rng.uniform(-3, 3), (index.size, chosen.size))
        rows.append(index if rng.random() < 0.7 else rng.permutation(index))  # slices and index arrays
        columns.append(chosen)
    return jac, normal_equations.Pattern(rows, columns, width)


def test_the_normal_matrix_by_blocks_is_the_dense_product():
    rng = np.random.default_rng(5)
    for _ in range(50):
        width = int(rng.integers(2, 40))
        jac, pattern = _block_sparse(rng, int(rng.integers(1, 12)), width)
        weights = rng.uniform(0.1, 10, len(jac))
        weights[rng.random(len(jac)) < 0.1] = 0.0  # observations left out
        fast = normal_equations.weighted_gram(jac, weights, pattern)
        dense = jac.T @ np.diag(weights) @ jac
        assert np.allclose(fast, dense, rtol=1e-12, atol=1e-12 * np.abs(dense).max())
        with batch_mode.reference():
            reference = normal_equations.weighted_gram(jac, weights, pattern)
        assert np.array_equal(reference, jac.T @ (jac * weights[:, None]))


def test_leverages_are_the_hat_matrix_diagonal():
    rng = np.random.default_rng(6)
    for _ in range(30):
        n, k = int(rng.integers(5, 80)), int(rng.integers(1, 12))
        jac = rng.normal(size=(n, k)) * 10 ** rng.uniform(-2, 2, k)
        root = rng.normal(size=(k, k))
        q = root @ root.T + 0.1 * np.eye(k)
        hat = jac @ q @ jac.T
        assert np.allclose(normal_equations.leverage(jac, q), np.diag(hat), rtol=1e-10, atol=1e-12 * np.abs(hat).max())
        with batch_mode.reference():
            assert np.allclose(normal_equations.leverage(jac, q), np.diag(hat), rtol=1e-10,
                               atol=1e-12 * np.abs(hat).max())


def _parameters(truth: dict[str, float], rng: np.random.Generator) -> list[Parameter]:
    """A perturbed start: interior and poses free, the housing with priors about the truth (as phase 2
    gives them), the interior with priors as well (variance components), fixed k3, t and n2."""
    parameters = []
    for name, value in truth.items():
        symbol = _symbol(name)
        if name in {"t", "n2", "k3_l", "k3_r", "t_r"}:
            parameters.append(Parameter(name, value, "fixed"))
        elif symbol in {"d", "e", "g", "n3", "a", "b", "c", "r"}:
            parameters.append(Parameter(name, value, "prior", value, 0.01))
        elif symbol in {"k2", "p1", "p2"}:
            parameters.append(Parameter(name, value, "prior", value, 1e-3))
        else:
            shift = {"f": 2.0, "xp": 1.0, "yp": 1.0, "X0": 2e-3, "Y0": 2e-3, "Z0": 2e-3, "omega": 1e-3,
                     "phi": 1e-3, "kappa": 1e-3}.get(symbol, 0.0)
            parameters.append(Parameter(name, value + shift * rng.normal(), "free"))
    return parameters


@pytest.mark.parametrize("kind", ["flat-port", "dome-cover"])
def test_adjustments_on_the_fast_path_give_the_dense_reference_numbers(kind):
    rng = np.random.default_rng({"flat-port": 21, "dome-cover": 22}[kind])
    compared = 0
    for _ in range(3):
        model, truth = _scene(rng, kind, stations=int(rng.integers(1, 4)), points=30)
        # a blunder in one image, so that the robust start, the setting aside and the snooping all work
        model.observation_set.values[7] += 25.0
        start = _parameters(truth, np.random.default_rng(int(rng.integers(1 << 30))))
        runs = []
        for reference in (False, True):
            parameters = [Parameter(p.name, p.value, p.status, p.prior, p.sigma) for p in start]
            if reference:
                with batch_mode.reference():
                    runs.append(adjust(model.problem(parameters)))
            else:
                runs.append(adjust(model.problem(parameters)))
        fast, dense = runs
        assert fast.converged and dense.converged
        assert [s.point for s in fast.excluded] == [s.point for s in dense.excluded]
        assert np.array_equal(fast.used, dense.used)
        for name, sigma in dense.sigmas.items():
            assert abs(fast.value(name) - dense.value(name)) <= max(1e-9 * abs(dense.value(name)), 1e-3 * sigma), name
            assert fast.sigmas[name] == pytest.approx(sigma, rel=1e-6), name
            compared += 1
        assert fast.sigma0 == pytest.approx(dense.sigma0, rel=1e-6)
        assert np.allclose(fast.redundancy_numbers, dense.redundancy_numbers, rtol=1e-6, atol=1e-9)
        assert np.allclose(fast.w, dense.w, rtol=1e-6, atol=1e-6)
        # the covariance in units of the sigmas (a correlation's difference)
        scale = np.sqrt(np.outer(np.diag(dense.covariance), np.diag(dense.covariance)))
        assert np.max(np.abs(fast.covariance - dense.covariance) / scale) < 1e-6
    assert compared > 100
