"""Board calibrations that know their noise: heavy-tailed corner noise down-weighted, not trimmed.

Monte Carlo over random rigs in air and behind flat and dome ports: board views whose corners carry
Student-t noise (4 degrees of freedom, as detected corners' errors have heavier tails than a Gaussian) of
known standard deviation, and three planted gross blunders (a corner 6-20 px off) in the views that are
fitted. A quarter of the views is held out (:func:`validate`). The blunders must be named, the clean
corners kept (the share set aside is reported), sigma0 must be the noise's standard deviation, and the
held-out known distances' mean squared normalised error (NEES: error over the sigma the calibration gives
the length, pointing and calibration parts together) must lie in 0.7-1.5. Least squares with data
snooping on the same data is the reference: it trims several per cent of the clean corners."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from tests.core.board_scenes import board, observe_views, random_rig, random_views
from usvips.core.calibration import CalibrationOptions, calibrate_air, calibrate_water
from usvips.core.calibration.validation import holdout_views, validate
from usvips.core.observations import StereoObservations

DEGREES = 4.0
VIEWS = 20
HOLDOUT = 0.25
RIGS = {"air": 6, "flat-port": 5, "dome-port": 4}


def _plant(observations: StereoObservations, rng, avoid: tuple[str, ...], count: int = 3):
    """``count`` gross blunders (a corner 6-20 px off in one image) in views not labelled in ``avoid``;
    returns the observations and the blunders as (id, side, view)."""
    left, right = observations.left.copy(), observations.right.copy()
    rows = rng.choice(np.flatnonzero([p not in avoid for p in observations.pairs]), count, replace=False)
    planted = []
    for row in rows:
        side = int(rng.integers(2))
        angle = rng.uniform(0.0, 2.0 * np.pi)
        (left if side == 0 else right)[row] += rng.uniform(6.0, 20.0) * np.array([np.cos(angle), np.sin(angle)])
        planted.append((observations.ids[row], "lr"[side], observations.pairs[row]))
    return StereoObservations(observations.ids, left, right, observations.pairs), planted


def _one_rig(kind: str, seed: int, estimator: str = "auto") -> dict:
    rng = np.random.default_rng(seed)
    target = board(int(rng.integers(7, 11)), int(rng.integers(5, 8)), rng.uniform(0.02, 0.04))
    rig = random_rig(rng)
    noise = rng.uniform(0.15, 0.4)  # the corners' standard deviation (px)
    options = CalibrationOptions(sigma_px=0.5, image_size=rig.size, control_exact=True, estimator=estimator)
    held = holdout_views([f"v{k}" for k in range(VIEWS)], HOLDOUT, seed)
    views = observe_views(target, rig, random_views(target, rig, rng, VIEWS), rng, noise, "v", DEGREES)
    if kind == "air":
        observations, planted = _plant(views, rng, held)

        def fit(obs):
            return calibrate_air(target, obs, options)
    else:
        base = calibrate_air(target, views, options).calibration
        rig = rig.in_water(kind, rng)
        water = observe_views(target, rig, random_views(target, rig, rng, VIEWS, (0.5, 1.0)), rng, noise, "v",
                              DEGREES)
        observations, planted = _plant(water, rng, held)

        def fit(obs):
            return calibrate_water(base, kind, target, obs, options)
    validation = validate(target, observations, HOLDOUT, fit, seed=seed)
    report = validation.result.report
    if report.sigma0_px_estimated is None:  # the fit's own, before any scaling by the held-out views
        report = dataclasses.replace(report, sigma0_px_estimated=report.sigma0_px)
    suspects = {(s.point, s.side, s.group) for s in report.suspects}
    coordinates = 2 * len(report.residuals)
    return dict(report=report, noise=noise, planted=planted, missed=[b for b in planted if b not in suspects],
                clean_set_aside=2 * len(suspects - set(planted)) / coordinates, honesty=validation.honesty,
                validation=validation)


def _pooled(runs: list[dict]) -> float:
    """The held-out distances' NEES over every rig (each rig's mean weighted by its count)."""
    return sum(r["honesty"].distance_nees * r["honesty"].distances for r in runs) / sum(
        r["honesty"].distances for r in runs)


def test_heavy_tailed_corners_are_kept_and_blunders_named_in_air():
    """The quick form, one rig in air: against least squares with data snooping on the same data."""
    robust = _one_rig("air", 7100)
    trimmed = _one_rig("air", 7100, estimator="least squares")
    estimated = {name: run["report"].sigma0_px_estimated / run["noise"] for name, run in
                 (("robust", robust), ("trimmed", trimmed))}
    print(f"set aside: M-estimation {100 * robust['clean_set_aside']:.3f} %, least squares "
          f"{100 * trimmed['clean_set_aside']:.2f} %; sigma0 / noise {estimated}; held-out NEES "
          f"{robust['honesty'].distance_nees:.2f} against {trimmed['honesty'].distance_nees:.2f}")
    assert robust["report"].converged and not robust["missed"]
    assert robust["report"].estimation["estimator"] == "huber"
    assert robust["clean_set_aside"] < 0.005 < trimmed["clean_set_aside"]
    assert 0.9 < estimated["robust"] < 1.1
    assert estimated["trimmed"] < 0.92  # trimming the tails understates the noise
    honesty = robust["honesty"]
    assert honesty.distances > 50 and honesty.views == 5 and 0.5 < honesty.reprojection_nees < 1.6


@pytest.mark.slow
@pytest.mark.parametrize("kind", list(RIGS))
def test_held_out_distances_are_honest_over_many_rigs(kind):
    runs = [_one_rig(kind, 7200 + k) for k in range(RIGS[kind])]
    nees = _pooled(runs)
    factors = [(round(r["honesty"].pointing_factor, 2), round(r["honesty"].covariance_factor, 2)) for r in runs]
    print(f"{kind}: held-out distances' NEES {nees:.2f} over {sum(r['honesty'].distances for r in runs)}, "
          f"reprojections' {np.mean([r['honesty'].reprojection_nees for r in runs]):.2f}; clean set aside "
          f"{100 * np.mean([r['clean_set_aside'] for r in runs]):.3f} %; sigma0 / noise "
          f"{[round(r['report'].sigma0_px_estimated / r['noise'], 3) for r in runs]}; factors (sigma0², "
          f"covariance) {factors}")
    for k, run in enumerate(runs):
        assert run["report"].converged, f"{kind} rig {k}: {run['report'].reason}"
        assert not run["missed"], f"{kind} rig {k}: planted blunders not named: {run['missed']}"
        assert run["clean_set_aside"] < 0.005, f"{kind} rig {k}: {100 * run['clean_set_aside']:.2f} % set aside"
        assert 0.85 < run["report"].sigma0_px_estimated / run["noise"] < 1.15, f"{kind} rig {k}"
    assert 0.7 <= nees <= 1.5, f"{kind}: held-out distances' NEES {nees:.2f}"


def test_a_calibration_that_understates_its_noise_is_scaled_and_says_so():
    """A fit whose stated sigmas are a third of the truth (variance factor 1/9): the held-out reprojections'
    and distances' NEES are far outside their intervals, so the validation scales sigma0 and the covariance
    back and says by what factor, why and on how many held-out observations."""
    rng = np.random.default_rng(7300)
    target = board()
    rig = random_rig(rng)
    observations = observe_views(target, rig, random_views(target, rig, rng, 16), rng, 0.3, "v", DEGREES)
    options = CalibrationOptions(sigma_px=0.5, image_size=rig.size, control_exact=True)

    def overconfident(obs):
        result = calibrate_air(target, obs, options)
        names, matrix = result.calibration.covariance
        result.calibration = dataclasses.replace(result.calibration, sigma0_px=result.calibration.sigma0_px / 3,
                                                 covariance=(names, matrix / 9))
        result.report = dataclasses.replace(result.report, sigma0_px=result.calibration.sigma0_px)
        return result

    validation = validate(target, observations, HOLDOUT, overconfident, seed=1)
    honesty = validation.honesty
    assert honesty.distance_nees > 4.0 and not honesty.interval[0] <= 1.0 <= honesty.interval[1]
    assert honesty.scaled and 6.0 < honesty.pointing_factor < 13.0
    assert 0.6 < honesty.distance_nees_after < 1.6
    calibration = validation.result.calibration
    scale = calibration.statistics["variance_scale"]
    assert scale["pointing_factor"] == honesty.pointing_factor
    assert calibration.sigma0_px == pytest.approx(scale["sigma0_px_estimated"] * np.sqrt(honesty.pointing_factor))
    report = validation.result.report
    assert report.variance_scale["reprojection_dof"] == honesty.reprojection_dof > 100
    assert report.sigma0_px == calibration.sigma0_px and report.sigma0_px_estimated < report.sigma0_px
    assert any("scaled by a variance factor" in note for note in report.notes)
    text = "\n".join(validation.lines())
    assert "honesty on held-out views" in text and "larger than sigma0 says" in text
