"""The calibration's exact block derivatives (core/calibration/derivatives.py) against central differences
of the model, and whole adjustments through them against the reference path (forward differences with
the exterior-only derivatives), over random rigs of every housing kind."""

from __future__ import annotations

import numpy as np
import pytest

from tests.core.calibration_scenes import FLAT, LEFT, RIGHT, dome_housings, joined, observe
from usvips.core.adjustment import Parameter, adjust
from usvips.core.calibration.derivatives import stereo_derivatives
from usvips.core.calibration.model import StereoModel
from usvips.core.calibration.parameter_names import build_housings, housing_parameter_names
from usvips.core.camera import Camera, Exterior
from usvips.core.observations import ControlPoints
from usvips.core.rig import RelativeOrientation, StereoRig

#: central-difference steps per parameter symbol: a change of ~0.01-0.1 px, far above the back-projection's
#: convergence noise and where the truncation error is ~1e-8 of the column
STEPS = {"f": 1e-2, "xp": 1e-2, "yp": 1e-2, "sy": 1e-5, "k1": 1e-5, "k2": 1e-5, "k3": 1e-5, "p1": 1e-6, "p2": 1e-6,
         "X0": 1e-5, "Y0": 1e-5, "Z0": 1e-5, "omega": 1e-6, "phi": 1e-6, "kappa": 1e-6,
         "a": 1e-5, "b": 1e-5, "c": 1e-5, "r": 1e-5, "d": 1e-5, "e": 1e-5, "g": 1e-5, "t": 1e-5, "n2": 1e-5,
         "n3": 1e-5}


def _scene(rng: np.random.Generator, kind: str, stations: int = 3, points: int = 30):
    """A random rig (baseline, toe-in, poses) of ``kind`` seen from ``stations`` stations, with the truth."""
    xyz = np.column_stack([rng.uniform(0, 1.4, points), rng.uniform(0, 1.4, points), rng.uniform(-0.7, 0, points)])
    control = ControlPoints(tuple(f"T{i}" for i in range(points)), xyz)
    relative = RelativeOrientation(rng.uniform(0.3, 0.5), rng.normal(0, 0.01), rng.normal(0, 0.01),
                                   rng.normal(0, 0.01), rng.uniform(-0.15, -0.05), rng.normal(0, 0.01))
    housings = {"air": None, "flat-port": FLAT, "dome-cover": dome_housings()}[kind]
    pairs = []
    for k in range(stations):
        pose = Exterior(rng.uniform(0.4, 0.8), rng.uniform(0.5, 0.9), rng.uniform(2.4, 2.9),
                        rng.normal(0, 0.04), rng.normal(0, 0.04), rng.normal(0, 0.05))
        left = Camera(LEFT, pose, housings[0]) if housings else Camera(LEFT, pose)
        right = Camera(RIGHT, pose, housings[1]) if housings else Camera(RIGHT, pose)
        rig = StereoRig.from_relative(left, right, relative)
        pairs.append(observe(rig, xyz, control.ids, f"s{k}", seed=int(rng.integers(1 << 30))))
    model = StereoModel(kind, control, joined(pairs), 0.3)
    truth = {}
    for k, station in enumerate(model.stations):
        rig = pairs[k].rig
        for side, camera in (("l", rig.left), ("r", rig.right)):
            if k == 0 or side == "l":
                suffix = f"_{side}" + ("" if k == 0 else f"@{station}")
                for name in ("X0", "Y0", "Z0", "omega", "phi", "kappa"):
                    truth[name + suffix] = getattr(camera.exterior, name)
            if k == 0:
                for name in ("f", "xp", "yp", "sy", "k1", "k2", "p1", "p2", "k3"):
                    truth[f"{name}_{side}"] = getattr(camera.interior, name)
    if kind == "flat-port":
        h_left, h_right = housings
        truth.update({"d_l": h_left.d, "e_l": h_left.e, "g_l": h_left.g, "d_r": h_right.d, "e_r": h_right.e,
                      "g_r": h_right.g, "t": h_left.t, "n2": h_left.n2, "n3": h_left.n3})
    if kind == "dome-cover":
        h_left, h_right = housings
        truth.update({"a_l": h_left.a, "b_l": h_left.b, "c_l": h_left.c, "r_l": h_left.r, "a_r": h_right.a,
                      "b_r": h_right.b, "c_r": h_right.c, "t_r": 0.01, "d": 0.0, "e": 0.0,
                      "t": h_left.g - h_left.r + h_left.c, "n2": h_left.n2, "n3": h_left.n3})
        truth["t_r"] = 0.01 + build_housings(kind, truth)[1].r - h_right.r
    return model, truth


def _symbol(name: str) -> str:
    return name.split("@")[0].rsplit("_", 1)[0]


def _central_difference(model, truth: dict, name: str, block: int) -> tuple[np.ndarray, np.ndarray]:
    """The model's central difference of block ``block``'s observations in parameter ``name`` (its step
    from STEPS), and where both evaluations were valid."""
    h = STEPS[_symbol(name)]
    ahead, behind = dict(truth), dict(truth)
    ahead[name] += h
    behind[name] -= h
    plus, ok_plus = model.evaluate(ahead, [block])
    minus, ok_minus = model.evaluate(behind, [block])
    return (plus - minus) / (2 * h), ok_plus & ok_minus


@pytest.mark.parametrize("kind", ["air", "flat-port", "dome-cover"])
def test_block_derivatives_match_central_differences_over_random_rigs(kind):
    rng = np.random.default_rng({"air": 1, "flat-port": 2, "dome-cover": 3}[kind])
    checked = 0
    for _ in range(4):
        model, truth = _scene(rng, kind)
        computed, ok = model.evaluate(truth)
        assert ok.all()
        exact = stereo_derivatives(model, truth, computed, frozenset(truth))
        # every interior column of every block, every housing column; every pose column but the shared
        # plane's right camera's
        expected = {f"{p}_{s}" for p in ("f", "xp", "yp", "sy", "k1", "k2", "p1", "p2", "k3") for s in "lr"}
        expected |= set(housing_parameter_names(kind))
        assert expected <= set(exact)
        for name, blocks in exact.items():
            for b, column in blocks.items():
                reference, ok_both = _central_difference(model, truth, name, b)
                assert ok_both.all()
                # (plus 1e-6: the differences' own rounding, ~1e-13 px over 2h, where a column is about
                # zero, as the left camera's first kappa is for the right camera's block under a shared cover)
                scale = float(np.abs(reference).max())
                assert np.max(np.abs(column - reference)) < 1e-5 * scale + 1e-6, (name, b)
                checked += 1
        # a right camera at a further station follows the rig: its block has columns for the first
        # station's poses (under System I's shared cover plane with the housing's motion added)
        right_further = [b for b, (st, side) in enumerate(model.block_keys) if side == "r" and st != model.stations[0]]
        assert right_further[0] in exact.get("omega_l", {})
    assert checked > 100


def _adjusted(model: StereoModel, truth: dict[str, float], rng: np.random.Generator, reference: bool):
    """Adjust from a perturbed start (the same for both paths): interior and poses free, the housing's
    d, e, g and n3 with priors about the truth (as phase 2 gives them), t and n2 fixed."""
    start_rng = np.random.default_rng(rng.integers(1 << 30))
    parameters = []
    for name, value in truth.items():
        symbol = _symbol(name)
        if name in {"t", "n2", "k3_l", "k3_r"}:
            parameters.append(Parameter(name, value, "fixed"))
            continue
        if symbol in {"d", "e", "g", "n3"}:
            parameters.append(Parameter(name, value, "prior", value, 0.01))
            continue
        shift = {"f": 2.0, "xp": 1.0, "yp": 1.0, "X0": 2e-3, "Y0": 2e-3, "Z0": 2e-3, "omega": 1e-3, "phi": 1e-3,
                 "kappa": 1e-3}.get(symbol, 0.0)
        parameters.append(Parameter(name, value + shift * start_rng.normal(), "free"))
    problem = model.problem(parameters)
    if reference:
        problem.analytic = model.exterior_derivatives
    return adjust(problem, robust=False, snooping=False)


@pytest.mark.parametrize("kind", ["air", "flat-port"])
def test_adjustments_through_the_block_derivatives_give_the_reference_numbers(kind):
    rng = np.random.default_rng(11 if kind == "air" else 12)
    for _ in range(3):
        model, truth = _scene(rng, kind, stations=2, points=36)
        state = rng.bit_generator.state
        fast = _adjusted(model, truth, rng, reference=False)
        rng.bit_generator.state = state
        model_ref = StereoModel(kind, model.control, model.observations, 0.3)
        slow = _adjusted(model_ref, truth, rng, reference=True)
        assert fast.converged and slow.converged
        for p in fast.parameters:
            if p.status == "fixed":
                continue
            sigma = slow.sigmas[p.name]
            assert abs(p.value - slow.value(p.name)) < 1e-3 * sigma, p.name
            assert fast.sigmas[p.name] == pytest.approx(sigma, rel=1e-3), p.name
        assert fast.sigma0 == pytest.approx(slow.sigma0, rel=1e-6)


@pytest.mark.parametrize("kind", ["flat-port", "dome-cover"])
def test_housing_columns_traced_per_side_match_the_per_block_reference(kind):
    from usvips.core import batch_mode

    rng = np.random.default_rng({"flat-port": 31, "dome-cover": 32}[kind])
    compared = 0
    for _ in range(4):
        model, truth = _scene(rng, kind, stations=int(rng.integers(1, 4)))
        computed, ok = model.evaluate(truth)
        assert ok.all()
        fast = stereo_derivatives(model, truth, computed, frozenset(truth))
        with batch_mode.reference():
            reference = stereo_derivatives(model, truth, computed, frozenset(truth))
        assert set(fast) == set(reference)
        for name in housing_parameter_names(kind):
            assert set(fast.get(name, {})) == set(reference.get(name, {})), name
            for b, column in reference.get(name, {}).items():
                scale = max(float(np.abs(column).max()), 1e-9)
                assert np.max(np.abs(fast[name][b] - column)) < 1e-7 * scale, (name, b)
                compared += 1
    assert compared > 40


def test_system_one_adjustments_with_the_right_cameras_exact_columns_give_the_reference_numbers():
    """System I's right camera follows the rig with its housing: its first-station pose columns (camera
    motion plus housing motion) against the reference path (forward differences for them)."""
    rng = np.random.default_rng(13)
    for _ in range(3):
        model, truth = _scene(rng, "dome-cover", stations=int(rng.integers(1, 4)), points=36)
        start_rng = np.random.default_rng(int(rng.integers(1 << 30)))
        start = []
        for name, value in truth.items():
            symbol = _symbol(name)
            if name in {"t", "n2", "k3_l", "k3_r", "t_r"}:
                start.append(Parameter(name, value, "fixed"))
            elif symbol in {"a", "b", "c", "r", "d", "e", "n3", "k2", "p1", "p2"}:
                start.append(Parameter(name, value, "prior", value, 0.01 if symbol in "abcrden3" else 1e-3))
            else:
                shift = {"f": 2.0, "xp": 1.0, "yp": 1.0, "X0": 2e-3, "Y0": 2e-3, "Z0": 2e-3, "omega": 1e-3,
                         "phi": 1e-3, "kappa": 1e-3}.get(symbol, 0.0)
                start.append(Parameter(name, value + shift * start_rng.normal(), "free"))
        runs = []
        for reference in (False, True):
            problem = StereoModel("dome-cover", model.control, model.observations, 0.3).problem(
                [Parameter(p.name, p.value, p.status, p.prior, p.sigma) for p in start])
            if reference:
                problem.analytic = problem.analytic and model.exterior_derivatives
            # converged a thousand times closer than by default: on a single System I station the default
            # criterion lets the reference path stop up to 0.1 sigma short along the weak housing valley
            runs.append(adjust(problem, robust=False, snooping=False, tolerance=1e-5))
        fast, slow = runs
        assert fast.converged and slow.converged
        # the reference's forward differences through the dome's iterative back-projection err by ~1e-4
        # of a column, which moves its stationary point by ~1e-3 sigma (measured: up to 1.2e-3)
        for name, sigma in slow.sigmas.items():
            assert abs(fast.value(name) - slow.value(name)) < 5e-3 * sigma, name
            assert fast.sigmas[name] == pytest.approx(sigma, rel=1e-3), name
        assert fast.sigma0 == pytest.approx(slow.sigma0, rel=1e-5)


@pytest.mark.parametrize("kind", ["air", "flat-port", "dome-cover"])
def test_a_point_no_ray_reaches_keeps_the_other_rows_exact_and_its_own_rows_zero(kind):
    """A control point the cameras cannot image (here behind them, as a misprinted target can be) gives an
    invalid observation in every block, with whatever pixel its failed solve left, often beyond the lens
    distortion's fold. The exact columns still cover every block (forward differences of every parameter
    and block were what the thesis tank's phase 2 spent its time on), the other rows match central
    differences of the model, and the unreached rows are zero, as forward differences give a row that stays
    invalid on both sides of the step (the adjustment leaves those observations out)."""
    rng = np.random.default_rng({"air": 41, "flat-port": 42, "dome-cover": 43}[kind])
    checked = 0
    for _ in range(3):
        model, truth = _scene(rng, kind, stations=int(rng.integers(1, 4)), points=24)
        clean = stereo_derivatives(model, truth, model.evaluate(truth)[0], frozenset(truth))
        xyz = model.control.xyz.copy()
        xyz[5] = [rng.uniform(8.0, 12.0), rng.uniform(-12.0, -8.0), rng.uniform(8.0, 12.0)]  # behind, far off-axis
        model = StereoModel(kind, ControlPoints(model.control.ids, xyz), model.observations, 0.3)
        computed, ok = model.evaluate(truth)
        unreached = ~ok
        assert unreached.any() and ok.sum() > 0.9 * len(ok)
        exact = stereo_derivatives(model, truth, computed, frozenset(truth))
        # the same columns as without the unreached point (they were none of its sides' before)
        assert {n: set(b) for n, b in exact.items()} == {n: set(b) for n, b in clean.items()}
        # under a shared cover plane the left camera's first pose moves the right housing: the right
        # camera's block at the first station has those columns too
        first_right = model.block_keys.index((model.stations[0], "r"))
        assert kind != "dome-cover" or all(first_right in exact[f"{p}_l"] for p in ("X0", "Y0", "Z0", "omega"))
        for name, blocks in exact.items():
            for b, column in blocks.items():
                rows = model.blocks[b]
                reference, ok_both = _central_difference(model, truth, name, b)
                fine = ok[rows] & ok_both
                # (plus 1e-6: the differences' own rounding, ~1e-13 px over 2h, where a column is zero)
                scale = float(np.abs(reference[fine]).max())
                assert np.max(np.abs(column[fine] - reference[fine])) < 1e-5 * scale + 1e-6, (name, b)
                assert np.all(column[unreached[rows]] == 0.0), (name, b)
                checked += 1
    assert checked > 100
