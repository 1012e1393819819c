"""The report's residual figures: RMS over all observations and over the kept ones, and the set-aside
observations' prediction residuals (not 0) in the residual table, flagged as not used."""

from __future__ import annotations

import numpy as np
import pytest

from tests.core.calibration.test_blunder_search_scales import NOISE, _field
from usvips.core.calibration import CalibrationOptions, calibrate_air
from usvips.core.observations import StereoObservations


@pytest.mark.parametrize("seed", range(3))
def test_set_aside_observations_show_their_prediction_residuals(seed):
    control, observations, rng = _field(800 + seed, stations=4)
    row = int(rng.integers(len(observations)))
    blunder = rng.choice([-1, 1], 2) * rng.uniform(6, 12, 2)  # px, in the left image
    left = observations.left.copy()
    left[row] += blunder
    planted = StereoObservations(observations.ids, left, observations.right, observations.pairs)
    report = calibrate_air(control, planted, CalibrationOptions(sigma_px=NOISE)).report
    aside = [r for r in report.residuals if not r.used]
    mine = [r for r in aside if r.id == observations.ids[row] and r.station == observations.pairs[row]
            and r.side == "l"]
    assert len(mine) == 1 and mine[0].set_aside
    # the prediction residual is the planted blunder (observed − computed), to within the noise
    assert mine[0].vx == pytest.approx(blunder[0], abs=5 * NOISE)
    assert mine[0].vy == pytest.approx(blunder[1], abs=5 * NOISE)
    kept = np.array([[r.vx, r.vy] for r in report.residuals if r.used])
    every = np.array([[r.vx, r.vy] for r in report.residuals])
    assert report.rms_px == pytest.approx(np.sqrt(np.mean(kept**2)), rel=1e-9)
    assert report.rms_px_all == pytest.approx(np.sqrt(np.mean(every**2)), rel=1e-9)
    assert report.rms_px_all > report.rms_px
    assert report.set_aside == 2 * len(aside)
    assert any("set aside (not used)" in note for note in report.notes)


def test_without_set_aside_observations_both_figures_agree():
    control, observations, _ = _field(820, stations=3)
    report = calibrate_air(control, observations, CalibrationOptions(sigma_px=NOISE, snooping=False)).report
    assert report.set_aside == 0
    assert report.rms_px_all == pytest.approx(report.rms_px, rel=1e-12)
