"""Variance components from held-out views: honest figures are kept, a sigma0 or a calibration covariance
that is off by a known factor is found and scaled back, and a departure that lies in the corners' pointing
is not blamed on the calibration (Monte Carlo with known variances)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from usvips.core.calibration.honesty import HeldOutView, variance_components

VIEWS, DISTANCES, DOF = 5, 80, 200


def _views(rng, pointing_true: float = 1.0, calibration_true: float = 1.0, calibration_share: float = 0.3,
           common: bool = True) -> list[HeldOutView]:
    """Held-out views whose stated pointing and calibration variances are off by the given true factors:
    reprojection χ² of DOF degrees of freedom per view, distances whose errors have the variance
    pointing_true · p + calibration_true · c (the calibration's part common to the view's distances when
    ``common``, as one calibration error shifts every distance of a view alike)."""
    out = []
    for _ in range(VIEWS):
        p = rng.uniform(0.5, 1.5, DISTANCES) * 1e-8
        c = p * calibration_share / (1 - calibration_share)
        chi2 = pointing_true * rng.chisquare(DOF)
        shared = rng.normal() if common else rng.normal(size=DISTANCES)
        errors = (np.sqrt(pointing_true * p) * rng.normal(size=DISTANCES)
                  + np.sqrt(pointing_true * calibration_true * c) * shared)
        out.append(HeldOutView(float(chi2), DOF, errors, p, c))
    return out


def test_honest_figures_are_kept_most_of_the_time():
    rng = np.random.default_rng(1)
    runs = [variance_components(_views(rng), seed=k) for k in range(200)]
    assert np.mean([r.distance_nees for r in runs]) == pytest.approx(1.0, abs=0.08)
    assert np.mean([r.reprojection_nees for r in runs]) == pytest.approx(1.0, abs=0.02)
    kept = np.mean([not r.scaled for r in runs])
    assert kept > 0.85, kept  # two 95 % intervals: about 90 % of honest runs keep everything
    assert "hold" in " ".join(runs[0].why) or runs[0].scaled


@pytest.mark.parametrize("factor", [0.25, 4.0])
def test_a_sigma0_off_by_a_factor_is_scaled_back(factor):
    rng = np.random.default_rng(2)
    figures = variance_components(_views(rng, pointing_true=factor), seed=3)
    assert figures.pointing_factor == pytest.approx(factor, rel=0.15)
    assert figures.covariance_factor == pytest.approx(factor, rel=0.35)
    assert figures.distance_nees == pytest.approx(factor, rel=0.35)
    assert figures.distance_nees_after == pytest.approx(1.0, abs=0.3)
    assert "sigma0 and the covariance are scaled" in figures.why[0]


def test_a_calibration_covariance_off_by_a_factor_is_scaled_back():
    rng = np.random.default_rng(4)
    found = [variance_components(_views(rng, calibration_true=6.0, calibration_share=0.5, common=False), seed=k)
             for k in range(20)]
    assert all(f.pointing_factor == 1.0 or abs(f.pointing_factor - 1) < 0.3 for f in found)
    assert np.median([f.covariance_factor for f in found]) == pytest.approx(6.0, rel=0.3)
    assert np.mean([f.distance_nees_after for f in found]) == pytest.approx(1.0, abs=0.25)
    assert any("covariance is scaled by a further" in line for line in found[0].why)


def test_a_departure_in_the_pointing_is_not_blamed_on_the_calibration():
    """Distances varying far less than two independent corners would (correlated corner errors) while the
    calibration's part is tiny: reported, the covariance kept."""
    rng = np.random.default_rng(5)
    views = _views(rng, calibration_share=0.002)
    for view in views:
        view.errors *= np.sqrt(0.3)
    figures = variance_components(views, seed=1)
    assert figures.distance_nees == pytest.approx(0.3, rel=0.25)
    assert figures.covariance_factor == figures.pointing_factor
    assert any("lies in the corners' pointing" in line for line in figures.why)


def test_no_distance_no_figures_and_no_calibration_part_no_factor():
    empty = np.zeros(0)
    assert variance_components([HeldOutView(10.0, 10, empty, empty, empty)]) is None
    rng = np.random.default_rng(6)
    views = _views(rng)
    for view in views:
        view.calibration = np.zeros_like(view.calibration)  # a calibration without a covariance
    figures = variance_components(views)
    assert figures.covariance_factor == figures.pointing_factor and not np.isfinite(figures.calibration_estimate)
    json.dumps(figures.as_dict(), allow_nan=False)  # what cannot be estimated is None, not NaN
