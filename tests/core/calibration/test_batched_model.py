"""The calibration model evaluated and differentiated in one batch per side (every station's points carried
into its camera frame, one back-projection / one trace) against the per-block reference path, over random
board scenes of every housing kind; and data snooping's warm rounds ending at the full adjustment."""

from __future__ import annotations

import numpy as np
import pytest

from usvips.bench.board_views import board_views, start_parameters
from usvips.core import batch_mode
from usvips.core.adjustment import _solve, _unit, adjust
from usvips.core.calibration.derivatives import stereo_derivatives
from usvips.core.calibration.parameter_names import housing_parameter_names
from usvips.core.normal_equations import BlockJacobian

KINDS = ["air", "flat-port", "dome-port", "dome-cover"]


@pytest.mark.parametrize("kind", KINDS)
def test_batched_pixels_and_columns_are_the_per_block_ones(kind):
    rng = np.random.default_rng(KINDS.index(kind) + 40)
    for _ in range(2):
        scene = board_views(int(rng.integers(2, 6)), kind, seed=int(rng.integers(1 << 30)))
        # the truth with the cameras moved and their interiors changed (the housing at its true values: a
        # perturbed dome cover may cut its own sphere, which both paths refuse alike)
        values = {p.name: p.value for p in start_parameters(scene, rng, "air")}
        values.update({n: scene.truth[n] for n in housing_parameter_names(kind)})
        model, reference_model = scene.model(), scene.model()
        pixels, ok = model.evaluate(values)
        with batch_mode.reference():
            expected, expected_ok = reference_model.evaluate(values)
        assert np.array_equal(ok, expected_ok) and ok.all()
        assert np.max(np.abs(pixels - expected)) < 1e-9
        blocks = list(rng.permutation(len(model.blocks))[: max(1, len(model.blocks) // 2)])
        part, _ = model.evaluate(values, blocks)
        with batch_mode.reference():
            reference_part, _ = reference_model.evaluate(values, blocks)
        assert np.max(np.abs(part - reference_part)) < 1e-9
        fast = stereo_derivatives(model, values, pixels, frozenset(values))
        with batch_mode.reference():
            slow = stereo_derivatives(model, values, pixels, frozenset(values))
        assert set(fast) == set(slow)
        for name, columns in slow.items():
            assert set(fast[name]) == set(columns), name
            for b, column in columns.items():
                scale = max(float(np.abs(column).max()), 1e-9)
                # housing columns are central differences of traces of slightly different rays: 1e-7
                assert np.max(np.abs(fast[name][b] - column)) < 1e-7 * scale, (name, b)


def test_snooping_ends_at_the_full_adjustment_of_the_kept_observations():
    scene = board_views(12, "flat-port", seed=77)
    model = scene.model()
    values = model.observation_set.values
    values[[40, 41]] += 3.0          # a corner 15 sigma off in one image
    values[700] -= 2.5
    result = adjust(model.problem(start_parameters(scene, np.random.default_rng(3), "water")),
                    snoop_unit=lambda i: np.array([i - i % 2, i - i % 2 + 1]))
    assert result.converged
    assert not result.used[[40, 41, 700]].any()
    # the same problem (the same start and priors), the kept observations adjusted in full from the start
    again = model.problem(start_parameters(scene, np.random.default_rng(3), "water"))
    _solve(again, _unit, result.used, 100, 1e-3)
    for p in again.parameters:
        if p.status != "fixed":
            assert abs(p.value - result.value(p.name)) < 0.01 * result.sigmas[p.name], p.name


def test_the_jacobian_is_stored_by_block_not_dense():
    scene = board_views(40, "air", seed=5)
    problem = scene.model().problem(start_parameters(scene, np.random.default_rng(5)))
    result = adjust(problem, robust=False, snooping=False)
    jac = problem.last_jacobian[0]
    assert isinstance(jac, BlockJacobian)
    stored = sum(v.size for v in jac.values)
    # every block holds its interior, its camera's pose (composed with the rig's for a right camera)
    assert stored < 0.1 * jac.n * jac.width
    assert all("@" not in n for n in result.covariance_names)  # 40 views: the Schur path by default
    assert len(result.sigmas) == len(problem.free())
