"""A calibration's figures with their σ (the wizard's table and the report): every interior term, the
baseline with its σ from the covariance, the housing's values; the baseline σ against Monte Carlo."""

import numpy as np
import pytest

from usvips.core.calibration.figures import baseline_sigma, parameter_table
from usvips.core.camera import Camera, Exterior
from usvips.core.housing import kind as housing_kind
from usvips.core.interior import Interior
from usvips.core.stereo_calibration import ParameterEstimate, StereoCalibration


def _calibration(housing="air", covariance=None, parameters=None):
    values = {} if housing == "air" else {"t": 0.01, "n2": 1.49, "d": 0.0, "e": 0.0, "g": 0.05}
    case = housing_kind(housing).from_values(values) if housing != "air" else housing_kind("air").from_values({})
    left = Camera(Interior(800.0, 320.0, 240.0), Exterior(0.0, 0.0, 0.0), case, 640, 480)
    right = Camera(Interior(810.0, 322.0, 238.0), Exterior(0.12, 0.01, 0.0), case, 640, 480)
    return StereoCalibration.from_cameras(left, right, "air" if housing == "air" else "water", 0.3,
                                          parameters=parameters or {}, covariance=covariance)


def test_every_interior_term_and_the_baseline_are_listed_with_units():
    parameters = {"f_l": ParameterEstimate(800.0, 0.7, "free"), "k2_l": ParameterEstimate(0.0, None, "fixed")}
    figures = {f.name: f for f in parameter_table(_calibration(parameters=parameters))}
    for side in "lr":
        for symbol in ("f", "xp", "yp", "sy", "k1", "k2", "k3", "p1", "p2"):
            assert f"{symbol}_{side}" in figures
    assert figures["f_l"].sigma == 0.7 and figures["f_l"].unit == "px" and "± 0.70 px" in figures["f_l"].text()
    assert figures["k2_l"].sigma is None and "fixed" in figures["k2_l"].text()
    assert figures["f_r"].value == 810.0 and figures["f_r"].status == "fixed"  # not in the parameters: as held
    assert figures["baseline"].value == pytest.approx(np.hypot(0.12, 0.01)) and figures["baseline"].unit == "m"
    assert not any(f.group.endswith("housing") for f in figures.values())


def test_a_housing_lists_its_values_per_camera():
    figures = parameter_table(_calibration("flat-port"))
    housing = [f for f in figures if f.group == "left housing"]
    assert {f.name for f in housing} >= {"d_l", "g_l"}
    assert {f.name for f in figures if f.group == "housing (both cameras)"} >= {"t", "n2", "n3"}
    assert all(f.label for f in housing)


def test_the_baseline_sigma_agrees_with_monte_carlo():
    rng = np.random.default_rng(3)
    names = ("X0_l", "Y0_l", "Z0_l", "X0_r", "Y0_r", "Z0_r", "f_l")
    for _ in range(20):
        a = rng.normal(size=(7, 7)) * rng.uniform(1e-4, 1e-3)
        covariance = a @ a.T
        base = rng.normal(size=3) * 0.1 + np.array([0.15, 0.0, 0.0])
        sigma = baseline_sigma(base, names, covariance)
        draws = rng.multivariate_normal(np.zeros(7), covariance, 4000)
        lengths = np.linalg.norm(base + draws[:, 3:6] - draws[:, 0:3], axis=1)
        assert sigma == pytest.approx(np.std(lengths), rel=0.1)
    assert baseline_sigma(np.array([0.1, 0, 0]), ("f_l",), np.eye(1)) == 0.0


def test_the_table_s_baseline_sigma_comes_from_the_calibration_covariance():
    names = ("X0_l", "Y0_l", "Z0_l", "X0_r", "Y0_r", "Z0_r")
    covariance = np.diag([1e-6, 1e-6, 1e-6, 4e-6, 1e-6, 1e-6])
    figure = next(f for f in parameter_table(_calibration(covariance=(names, covariance))) if f.name == "baseline")
    unit = np.array([0.12, 0.01, 0.0]) / np.hypot(0.12, 0.01)
    expected = np.sqrt(unit @ np.diag([1e-6, 1e-6, 1e-6]) @ unit + unit @ np.diag([4e-6, 1e-6, 1e-6]) @ unit)
    assert figure.sigma == pytest.approx(expected)
