"""The block-arrow normal equations (the Schur complement of the further stations' poses) against the
dense ones: the algebra on random block-sparse Jacobians, and whole adjustments of random board rigs in
air and through flat and dome ports (robust start, data snooping of a planted blunder, variance
components, statistics), the same problem solved both ways."""

from __future__ import annotations

import numpy as np
import pytest

from usvips.bench.board_views import board_views, start_parameters
from usvips.core import normal_equations
from usvips.core.adjustment import Parameter, adjust
from usvips.core.errors import DegenerateGeometryError
from usvips.core.observations import StereoObservations


def _arrow_problem(rng: np.random.Generator):
    """A random Jacobian of g globals and s groups of m locals: each group owns one to three blocks, each
    block touching a random subset of the globals and some of its group's locals; plus global-only blocks."""
    g, s, m = int(rng.integers(2, 9)), int(rng.integers(2, 9)), int(rng.integers(1, 7))
    width = g + s * m
    rows, columns, values, block_group = [], [], [], []
    start = 0
    for group in range(-1, s):
        for _ in range(4 if group < 0 else int(rng.integers(1, 4))):
            size = int(rng.integers(m + 3, 30))
            # four global-only blocks touch every global (more blocks than a local group may have)
            chosen = list(range(g) if group < 0 else rng.choice(g, int(rng.integers(1, g + 1)), replace=False))
            if group >= 0:
                chosen += list(g + group * m + np.arange(m))
            chosen = np.sort(np.array(chosen, dtype=int))
            rows.append(slice(start, start + size))
            columns.append(chosen)
            values.append(rng.normal(0, 1, (size, chosen.size)) * 10 ** rng.uniform(-2, 2, chosen.size))
            block_group.append(group)
            start += size
    jac = normal_equations.BlockJacobian(start, width, rows, columns, values)
    return jac, g, s, m


def test_the_arrow_system_is_the_dense_system():
    rng = np.random.default_rng(11)
    for _ in range(40):
        jac, g, s, m = _arrow_problem(rng)
        weights = rng.uniform(0.2, 5.0, jac.n)
        weights[rng.random(jac.n) < 0.1] = 0.0
        residual = rng.normal(0, 1, jac.n)
        partition = normal_equations.Partition.of(jac.pattern, np.ones(jac.width, bool), max_blocks=3)
        assert partition is not None and partition.local.shape[0] == s  # every group found local
        assert np.array_equal(partition.glob, np.arange(g))
        arrow = normal_equations.ArrowSystem(jac, weights, residual, partition)
        diagonal = np.where(rng.random(jac.width) < 0.3, rng.uniform(0.1, 10, jac.width), 0.0)
        prior_rhs = diagonal * rng.normal(0, 1, jac.width)
        root = rng.normal(size=(2, 2))
        members = np.array([0, g - 1])  # a correlated prior on two globals
        groups = [(members, root @ root.T + np.eye(2))]
        arrow.add_priors(diagonal, prior_rhs, groups)
        dense = jac.dense()
        data = dense.T @ (dense * weights[:, None])
        prior = np.diag(diagonal)
        prior[np.ix_(groups[0][0], groups[0][0])] += groups[0][1]
        normal = data + prior
        rhs = dense.T @ (weights * residual) + prior_rhs
        scale = np.sqrt(np.diag(normal))
        for damping in (0.0, 1e-3, 10.0):
            damped = normal / np.outer(scale, scale) + damping * np.eye(jac.width)
            expected = np.linalg.solve(damped, rhs / scale) / scale
            assert np.allclose(arrow.step(damping), expected, rtol=1e-8, atol=1e-10 * np.abs(expected).max())
        for factor in (1.0, 0.3):
            q = np.linalg.inv(data + factor * prior)
            inverse = arrow.inverse(factor)
            assert np.allclose(inverse.diagonal(), np.diag(q), rtol=1e-8)
            assert np.allclose(inverse.qgg, q[:g, :g], rtol=1e-8, atol=1e-10 * np.abs(q).max())
            for k in range(s):
                cols = g + k * m + np.arange(m)
                assert np.allclose(inverse.qll[k], q[np.ix_(cols, cols)], rtol=1e-8, atol=1e-10 * np.abs(q).max())
                assert np.allclose(inverse.qgl[k], q[:g, cols], rtol=1e-8, atol=1e-10 * np.abs(q).max())
            assert np.allclose(inverse.leverage(jac), np.einsum("ij,jk,ik->i", dense, q, dense), rtol=1e-8,
                               atol=1e-10)
            assert arrow.trace_with_observations(inverse) == pytest.approx(float(np.sum(q * data)), rel=1e-8)
        # correlations over a limit: every pair it reports is a dense one, and it misses only pairs of two groups
        names = [f"p{j}" for j in range(jac.width)]
        q = np.linalg.inv(normal)
        corr = q / np.sqrt(np.outer(np.diag(q), np.diag(q)))
        limit = 0.5
        found = {(a, b): r for a, b, r in arrow.inverse().correlations_over(names, limit)}
        group_of = {j: (j - g) // m for j in range(g, jac.width)}
        for a in range(jac.width):
            for b in range(a + 1, jac.width):
                between_groups = a >= g and b >= g and group_of[a] != group_of[b]
                if abs(corr[a, b]) > limit and not between_groups:
                    assert found.pop((names[a], names[b])) == pytest.approx(corr[a, b], rel=1e-8)
        assert not found


def _solve(scene, structure: str, seed: int, blunder: bool):
    parameters = start_parameters(scene, np.random.default_rng(seed), "air" if scene.kind == "air" else "water")
    model = scene.model()
    if blunder:
        model.observation_set.values[7] += 4.0  # 20 sigma on one corner's x in the first view's left image
    problem = model.problem(parameters)
    problem.structure = structure
    return adjust(problem, snoop_unit=lambda i: np.array([i - i % 2, i - i % 2 + 1])), parameters


@pytest.mark.parametrize("kind, seeds", [("air", (1, 2, 3)), ("flat-port", (4, 5)), ("dome-port", (6,))])
def test_dense_and_schur_adjustments_agree(kind, seeds):
    for seed in seeds:
        scene = board_views(9, kind, noise=0.2, seed=seed)
        dense, dense_parameters = _solve(scene, "dense", seed, blunder=seed % 2 == 1)
        schur, _ = _solve(scene, "schur", seed, blunder=seed % 2 == 1)
        assert dense.converged and schur.converged
        # the two paths round differently, and a condition number near 1e6 lifts that to ~1e-9 of a value
        # or ~1e-8 of its sigma (the estimates of a value near zero): the tolerance is the sum of both
        for p in dense_parameters:
            spread = 1e-7 * dense.sigmas.get(p.name, 0.0)
            assert schur.value(p.name) == pytest.approx(p.value, rel=1e-9, abs=spread), p.name
        assert set(schur.sigmas) == set(dense.sigmas)
        for name, sigma in dense.sigmas.items():
            assert schur.sigmas[name] == pytest.approx(sigma, rel=1e-6)
        assert schur.sigma0 == pytest.approx(dense.sigma0, rel=1e-8)
        assert np.array_equal(schur.used, dense.used)
        assert [(s.point, s.side, s.coordinate, s.group) for s in schur.excluded] == \
            [(s.point, s.side, s.coordinate, s.group) for s in dense.excluded]
        assert np.allclose(schur.w, dense.w, rtol=1e-6, atol=1e-6)
        assert np.allclose(schur.redundancy_numbers, dense.redundancy_numbers, atol=1e-8)
        # the covariance returned is the global unknowns': the further stations' poses are eliminated
        assert all("@" not in n for n in schur.covariance_names)
        assert any("@" in n for n in dense.covariance_names)
        index = [dense.covariance_names.index(n) for n in schur.covariance_names]
        reference = dense.covariance[np.ix_(index, index)]
        assert np.allclose(schur.covariance, reference, rtol=1e-6, atol=1e-9 * np.abs(reference).max())
        # exactly symmetric on both paths (a calibration file's reader checks it)
        assert np.array_equal(schur.covariance, schur.covariance.T)
        assert np.array_equal(dense.covariance, dense.covariance.T)
        dense_pairs = {(a, b) for a, b, _ in dense.correlations_over}
        assert {(a, b) for a, b, _ in schur.correlations_over} <= dense_pairs
        if seed % 2 == 1:
            assert any(s.point == "c0_3" and s.group == "v0" and s.side == "l" for s in schur.excluded)


def test_a_station_whose_pose_is_undetermined_is_named():
    scene = board_views(9, "air", seed=8)
    obs = scene.observations
    # view v4 keeps one corner: two image points cannot fix its six pose unknowns
    keep = np.array([label != "v4" or pid == "c2_4" for pid, label in zip(obs.ids, obs.pairs, strict=True)])
    scene.observations = StereoObservations(tuple(np.array(obs.ids)[keep]), obs.left[keep], obs.right[keep],
                                            tuple(np.array(obs.pairs)[keep]))
    parameters = start_parameters(scene, np.random.default_rng(8))
    problem = scene.model().problem(parameters)
    problem.structure = "schur"
    with pytest.raises(DegenerateGeometryError, match="@v4"):
        adjust(problem, robust=False, snooping=False)


def test_auto_structure_keeps_small_problems_dense():
    scene = board_views(4, "air", seed=9)
    parameters = start_parameters(scene, np.random.default_rng(9))
    result = adjust(scene.model().problem(parameters), robust=False, snooping=False)
    assert any("@" in n for n in result.covariance_names)  # dense: every unknown in the covariance
    assert isinstance(parameters[0], Parameter)


def test_the_schur_path_recovers_the_truth_with_honest_sigmas():
    """Monte Carlo over random board rigs (12 views, 0.2 px noise, air and flat ports): every free unknown's
    error against the truth in units of its sigma, mean square near 1 (the sigmas are honest)."""
    squares = []
    for seed in range(12):
        kind = "air" if seed % 2 == 0 else "flat-port"
        scene = board_views(12, kind, noise=0.2, seed=100 + seed)
        parameters = start_parameters(scene, np.random.default_rng(200 + seed), "air" if kind == "air" else "water")
        problem = scene.model().problem(parameters)
        problem.structure = "schur"
        result = adjust(problem, robust=False, snooping=False)
        assert result.converged
        for p in parameters:
            # a housing parameter's prior sits at the kind's default start, not at the truth: the prior
            # pulls it (honestly, within its own sigma), so only the data-determined unknowns are scored
            if p.status == "free":
                squares.append(((p.value - scene.truth[p.name]) / result.sigmas[p.name]) ** 2)
    assert len(squares) > 900
    assert 0.7 < float(np.mean(squares)) < 1.4
