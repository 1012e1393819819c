"""The control-point blunder search scales: an exact target is not searched; a surveyed field's candidates
are scored from the one adjustment and only the few worst are re-adjusted."""

from __future__ import annotations

import numpy as np
import pytest

from tests.core.board_scenes import board, observe_views, random_rig, random_views
from tests.core.calibration_scenes import HEIGHT, LEFT, RELATIVE, RIGHT, WIDTH
from usvips.core.calibration import CalibrationOptions, calibrate_air, control_blunders, phases
from usvips.core.camera import Camera, Exterior
from usvips.core.housing import AirHousing
from usvips.core.observations import ControlPoints, StereoObservations
from usvips.core.rig import StereoRig

NOISE = 0.3


def _field(seed: int, stations: int = 8, n: int = 30):
    """A surveyed 1.4 × 1.4 × 0.7 m field seen from ``stations`` random stations 2.4-2.9 m away."""
    rng = np.random.default_rng(seed)
    xyz = np.column_stack([rng.uniform(0, 1.4, n), rng.uniform(0, 1.4, n), rng.uniform(-0.7, 0.0, n)])
    control = ControlPoints(tuple(f"T{i}" for i in range(n)), xyz)
    ids, left, right, pairs = [], [], [], []
    for k in range(stations):
        pose = Exterior(0.5 + rng.normal(0, 0.15), 0.7 + rng.normal(0, 0.15), rng.uniform(2.4, 2.9),
                        *rng.normal(0, 0.05, 3))
        rig = StereoRig.from_relative(Camera(LEFT, pose, AirHousing(), WIDTH, HEIGHT),
                                      Camera(RIGHT, pose, AirHousing(), WIDTH, HEIGHT), RELATIVE)
        pl, pr = rig.left.project(xyz), rig.right.project(xyz)
        seen = np.flatnonzero(pl.ok & pr.ok)
        ids += [control.ids[i] for i in seen]
        left.append(pl.pixels[seen] + rng.normal(0, NOISE, (seen.size, 2)))
        right.append(pr.pixels[seen] + rng.normal(0, NOISE, (seen.size, 2)))
        pairs += [f"s{k}"] * seen.size
    return control, StereoObservations(tuple(ids), np.vstack(left), np.vstack(right), tuple(pairs)), rng


@pytest.mark.parametrize("seed", range(3))
def test_a_misprint_in_a_many_station_field_is_found_with_few_readjustments(seed, monkeypatch):
    control, observations, rng = _field(700 + seed)
    point, axis = int(rng.integers(len(control))), int(rng.integers(3))
    xyz = control.xyz.copy()
    xyz[point, axis] += rng.choice([-1, 1]) * rng.uniform(0.05, 0.2)
    trials = []
    original = control_blunders._try_demotion

    def counted(*args, **kwargs):
        trials.append(args[3])
        return original(*args, **kwargs)

    monkeypatch.setattr(control_blunders, "_try_demotion", counted)
    result = calibrate_air(ControlPoints(control.ids, xyz), observations, CalibrationOptions(sigma_px=NOISE))
    assert [b.point for b in result.report.control_blunders] == [control.ids[point]]
    # the misprinted point is scored worst and tried first; the search stays within its budget of full
    # adjustments (each _demote tries at most two of them) however many points and stations there are
    assert trials[0] == control.ids[point]
    assert len(set(trials)) <= control_blunders.MAX_TRIALS


def test_the_shift_statistic_is_about_chi2_3_for_correct_points():
    control, observations, _ = _field(710, stations=6)
    result = calibrate_air(control, observations, CalibrationOptions(sigma_px=NOISE, control_exact=True))
    values = {p.name: p.value for p in result.adjustment.parameters}
    scores = control_blunders.shift_statistics(result.model, values, result.adjustment, list(control.ids))
    mean = float(np.mean(list(scores.values())))
    # χ²(3) has mean 3; the adjustment absorbs part of each point's residuals, so somewhat less
    assert 1.0 < mean < 3.5, mean


def test_an_exact_target_is_not_searched_for_misprints(monkeypatch):
    rng = np.random.default_rng(21)
    target = board()
    rig = random_rig(rng)
    observations = observe_views(target, rig, random_views(target, rig, rng, 8), rng, NOISE)

    def refuse(*args, **kwargs):
        raise AssertionError("the blunder search ran for an exact target")

    monkeypatch.setattr(phases, "demote_control_blunders", refuse)
    result = calibrate_air(target, observations, CalibrationOptions(sigma_px=NOISE, image_size=rig.size,
                                                                    control_exact=True))
    assert result.adjustment.converged and result.report.control_blunders == ()
