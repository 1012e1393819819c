"""Validation with held-out views: spread, seeded choice; held-out reprojection from the rig held fixed;
known distances by range; OpenCV's solution of the same views beside ours."""

from __future__ import annotations

import numpy as np
import pytest

from tests.core.board_scenes import board, observe_views, random_rig, random_views
from usvips.core.calibration import CalibrationOptions, calibrate_air, calibrate_water
from usvips.core.calibration.validation import holdout_views, known_pairs, resect_with_rig, validate
from usvips.core.errors import DegenerateGeometryError, InvalidParameterError

NOISE = 0.3


def test_held_out_views_are_spread_over_the_set_and_seeded():
    labels = [f"v{k}" for k in range(20)]
    chosen = holdout_views(labels, 0.25, seed=3)
    assert len(chosen) == 5 and chosen == holdout_views(labels, 0.25, seed=3)
    index = sorted(labels.index(c) for c in chosen)
    assert np.all(np.diff(index) == 4)  # one in every four, wherever the offset falls
    assert {holdout_views(labels, 0.25, seed=s) for s in range(10)} != {chosen}
    with pytest.raises(InvalidParameterError, match="the share of views held out: must be between 0 and 1"):
        holdout_views(labels, 1.5)
    with pytest.raises(DegenerateGeometryError, match="leaves 2 to calibrate from"):
        holdout_views(labels[:4], 0.5)


def test_known_pairs_of_a_board_are_its_neighbours_and_its_diagonal():
    target = board(4, 3, 0.03)
    adjacent, diagonal = known_pairs(target, target.ids)
    assert len(adjacent) == 3 * 3 + 4 * 2
    assert sorted(diagonal) == [0, 11]


@pytest.fixture(scope="module")
def scene():
    rng = np.random.default_rng(31)
    target = board()
    rig = random_rig(rng)
    observations = observe_views(target, rig, random_views(target, rig, rng, 16), rng, NOISE)
    return target, rig, observations, rng


def test_a_held_out_view_is_predicted_to_its_noise(scene):
    target, rig, observations, _ = scene
    options = CalibrationOptions(sigma_px=NOISE, image_size=rig.size, control_exact=True)
    validation = validate(target, observations, 0.25, lambda o: calibrate_air(target, o, options), seed=2,
                          compare_opencv=True, image_size=rig.size)
    assert len(validation.held_out.views) == 4 and len(validation.fitted.views) == 12
    assert not set(validation.held_out.views) & set(validation.result.calibration.stations)
    # residuals of unseen views, with only their pose fitted: the noise, a little more (6 of ~100 dof used)
    assert 0.8 * NOISE < validation.held_out.rms_px < 1.3 * NOISE
    assert 0.8 * NOISE < validation.fitted.rms_px < 1.2 * NOISE
    for figures in (validation.fitted, validation.held_out):
        counted = [b for b in figures.adjacent if b.count]
        assert counted and all(b.rms_m < 0.003 and abs(b.mean_m) < 0.001 for b in counted)
    ours, theirs = validation.ours, validation.opencv
    for key in ("f_l", "f_r", "baseline_m"):
        assert ours[key] == pytest.approx(theirs[key], rel=0.01)
    assert ours["rms_px"] < 1.2 * theirs["rms_px"]
    text = "\n".join(validation.lines())
    assert "held out" in text and "OpenCV stereoCalibrate" in text and "adjacent distances at" in text


def test_resection_with_the_rig_held_fixed_recovers_the_pose_through_a_housing(scene):
    target, rig, observations, rng = scene
    options = CalibrationOptions(sigma_px=NOISE, image_size=rig.size, control_exact=True)
    base = calibrate_air(target, observations, options).calibration
    water = rig.in_water("flat-port", rng)
    poses = random_views(target, water, rng, 12, (0.5, 1.0))
    views = observe_views(target, water, poses, rng, NOISE, "w")
    calibration = calibrate_water(base, "flat-port", target, views, options).calibration
    # a fresh view, never adjusted
    fresh_pose = random_views(target, water, rng, 1, (0.5, 1.0))[0]
    fresh = observe_views(target, water, [fresh_pose], rng, NOISE, "fresh")
    pose, residuals = resect_with_rig(calibration, target, fresh)
    assert np.linalg.norm(pose.position - fresh_pose.position) < 0.005
    assert np.sqrt(np.mean(residuals**2)) < 1.3 * NOISE
