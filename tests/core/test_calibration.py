"""Two-phase and joint calibration on synthetic rigs with known truth, and on the thesis's tables."""

from pathlib import Path

import numpy as np
import pytest

from tests.core.calibration_scenes import (
    FLAT,
    NOISE_PX,
    control_frame,
    joined,
    observe,
    rig_at,
)
from usvips.core.calibration import CalibrationOptions, calibrate_air, calibrate_water
from usvips.core.errors import DegenerateGeometryError, InvalidParameterError
from usvips.core.intersection import intersect
from usvips.io.calibration_file import calibration_from_dict, calibration_to_dict
from usvips.io.tables import read_control, read_observations

SAMPLE = Path(__file__).resolve().parents[2] / "sample_projects" / "tank_1995"


@pytest.fixture(scope="module")
def control():
    return control_frame()


@pytest.fixture(scope="module")
def air(control):
    pair = observe(rig_at(0), control.xyz, control.ids, "a1", seed=1)
    return calibrate_air(control, pair.observations, CalibrationOptions(sigma_px=NOISE_PX))


@pytest.fixture(scope="module")
def water(control, air):
    pairs = [observe(rig_at(k, FLAT), control.xyz, control.ids, f"w{k}", seed=10 + k) for k in range(2)]
    options = CalibrationOptions(sigma_px=NOISE_PX, interior="weighted", fix_values={"t": 0.016, "n2": 1.65})
    return calibrate_water(air.calibration, "flat-port", control, joined(pairs), options)


def _within(result, truth: dict[str, float], k: float = 3.0) -> None:
    for name, value in truth.items():
        estimate = result.calibration.parameters[name]
        assert estimate.sigma is not None and estimate.sigma > 0, name
        assert abs(estimate.value - value) < k * estimate.sigma, (name, estimate.value, value, estimate.sigma)


def test_phase1_recovers_the_cameras_within_three_sigma(air):
    assert air and air.report.converged
    assert air.report.sigma0_px == pytest.approx(NOISE_PX, rel=0.25)
    _within(air, {"f_l": 1100.0, "xp_l": 652.0, "yp_l": 471.0, "sy_l": 1.02, "k1_l": -0.09,
                  "f_r": 1085.0, "xp_r": 628.0, "yp_r": 488.0, "sy_r": 1.01, "k1_r": -0.07,
                  "X0_l": 0.5, "Y0_l": 0.7, "Z0_l": 2.6, "omega_l": 0.02, "phi_l": 0.03, "kappa_l": 0.01})
    assert air.report.suspects == ()


def test_joint_phase2_recovers_the_flat_ports_within_three_sigma(water):
    assert water and water.calibration.phase == "water"  # stored as phase 2, however many pairs
    assert water.calibration.stations == ("w0", "w1")
    assert water.report.sigma0_px == pytest.approx(NOISE_PX, rel=0.25)
    _within(water, {"d_l": 0.01, "e_l": -0.015, "g_l": 0.06, "d_r": -0.012, "e_r": 0.008, "g_r": 0.07,
                    "n3": 1.34, "X0_l": 0.5, "Y0_l": 0.7, "Z0_l": 2.6, "X0_l@w1": 0.3, "Z0_l@w1": 2.9})
    assert water.calibration.parameters["t"].status == "fixed"
    assert water.calibration.parameters["n3"].status == "prior"


def test_check_points_are_as_precise_as_the_covariance_says(water):
    rng = np.random.default_rng(99)
    n = 400
    truth = np.column_stack([rng.uniform(0, 1.4, n), rng.uniform(0, 1.4, n), rng.uniform(-0.7, 0, n)])
    pair = observe(rig_at(0, FLAT), truth, [str(i) for i in range(n)], "c", seed=77)
    rig = water.calibration.rig(0)
    result = intersect(rig.cameras, [pair.observations.left, pair.observations.right], NOISE_PX)
    assert result.ok.all()
    errors = result.points - truth[[int(i) for i in pair.observations.ids]]
    rms = np.sqrt(np.mean(errors**2, axis=0))
    predicted = np.sqrt(np.mean(result.sigmas**2, axis=0))
    np.testing.assert_allclose(rms, predicted, rtol=0.20)
    normalised = np.einsum("ni,nij,nj->n", errors, np.linalg.inv(result.covariance), errors) / 3
    assert 0.8 < normalised.mean() < 1.35  # the calibration's own error adds a little


def test_a_planted_5_px_blunder_is_named(control):
    pair = observe(rig_at(0), control.xyz, control.ids, "a1", seed=5)
    left = pair.observations.left.copy()
    left[7, 1] += 5.0
    obs = pair.observations.__class__(pair.observations.ids, left, pair.observations.right, pair.observations.pairs)
    result = calibrate_air(control, obs, CalibrationOptions(sigma_px=NOISE_PX))
    named = {(s.point, s.side) for s in result.report.suspects}
    assert named == {(obs.ids[7], "l")}
    suspect = next(s for s in result.report.suspects if s.coordinate == "y")
    assert abs(suspect.w) > 3.29 and suspect.mdb < 5.0
    assert result.report.sigma0_px == pytest.approx(NOISE_PX, rel=0.3)


def test_calibration_file_round_trip(water):
    again = calibration_from_dict(calibration_to_dict(water.calibration))
    points = np.array([[0.7, 0.7, -0.3]])
    for a, b in zip(again.rig(1).cameras, water.calibration.rig(1).cameras, strict=True):
        np.testing.assert_allclose(a.project(points).pixels, b.project(points).pixels, atol=1e-9)
    assert again.parameters["n3"].sigma == water.calibration.parameters["n3"].sigma


def test_bad_problems_are_reported(control):
    pair = observe(rig_at(0), control.xyz, control.ids, "a1", seed=1)
    few = pair.observations.take(np.arange(5))
    with pytest.raises(DegenerateGeometryError, match="at least 6"):
        calibrate_air(control, few)
    with pytest.raises(InvalidParameterError, match="unknown parameter 'k9'"):
        calibrate_air(control, pair.observations, CalibrationOptions(free=("k9",)))
    flat = control.__class__(control.ids, control.xyz * [1, 1, 0])
    with pytest.raises(DegenerateGeometryError, match="coplanar"):
        calibrate_air(flat, pair.observations)


def test_the_thesis_water_tank_run_finds_its_typos():
    """Tables 3.1, 3.2, 3.5: phase 1, phase 2 (System I), check points of Table 3.8."""
    control = read_control(SAMPLE / "control_table3_1.csv")
    air = calibrate_air(control, read_observations(SAMPLE / "air_pair1_table3_2.csv"),
                        CalibrationOptions(image_size=(568, 488)))
    assert air and 0.2 < air.report.sigma0_px < 1.5
    # Table 3.1 prints Z = +100 for target 3: demoted (its Z estimated), its observations kept
    assert [b.point for b in air.report.control_blunders] == ["3"]
    water = calibrate_water(air.calibration, "dome-cover", control,
                            read_observations(SAMPLE / "water_pair2_calibration_table3_5.csv"))
    assert water and water.report.sigma0_px < 1.5
    suspects = {(s.point, s.side, s.coordinate) for s in water.report.suspects if s.w is not None}
    assert ("2", "l", "y") in suspects  # Table 3.5 prints yl = 404 for target 2 (yr = 213)
    values = [p.value for p in water.calibration.parameters.values()]
    assert np.all(np.isfinite(values))
    check = read_observations(SAMPLE / "water_pair2_check_table3_8.csv")
    result = intersect(water.calibration.rig(0).cameras, [check.left, check.right], water.calibration.sigma0_px)
    assert result.ok.all()
    errors = result.points - control.xyz[control.index_of(list(check.ids))]
    rms = np.sqrt(np.mean(errors**2, axis=0))
    assert np.all(rms < [0.15, 0.15, 0.5])  # plausible: centimetres to decimetres at 2.5 m with a 7 cm base


def test_weighted_control_and_several_in_air_pairs(control):
    pairs = [observe(rig_at(k), control.xyz, control.ids, f"a{k}", seed=20 + k) for k in range(2)]
    sigmas = np.full_like(control.xyz, 0.002)
    weighted = control.__class__(control.ids, control.xyz, sigmas)
    result = calibrate_air(weighted, joined(pairs), CalibrationOptions(sigma_px=NOISE_PX))
    assert result and result.calibration.stations == ("a0", "a1")
    estimate = result.calibration.parameters[f"Z@{control.ids[0]}"]
    assert estimate.status == "prior" and 0 < estimate.sigma <= 0.002
    _within(result, {"f_l": 1100.0, "X0_l@a1": 0.3, "Z0_l@a1": 2.9, "f_r": 1085.0})


def test_more_unknowns_than_observations_is_refused(control):
    pair = observe(rig_at(0), control.xyz, control.ids, "a1", seed=1)
    six = pair.observations.take(np.arange(6))
    with pytest.raises(DegenerateGeometryError, match="cannot determine"):
        calibrate_air(control, six, CalibrationOptions(free=("k2", "p1", "p2")))


@pytest.mark.parametrize("kind", ["air", "flat-port", "dome-cover"])
def test_exact_exterior_derivatives_match_differences(control, kind):
    from tests.core.calibration_scenes import dome_housings
    from usvips.core.adjustment import _jacobian
    from usvips.core.calibration.model import StereoModel

    housings = {"air": None, "flat-port": FLAT, "dome-cover": dome_housings()}[kind]
    pairs = [observe(rig_at(k, housings) if housings else rig_at(k), control.xyz, control.ids, f"s{k}", seed=k)
             for k in range(2)]
    model = StereoModel(kind, control, joined(pairs), NOISE_PX)
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
    h_left, h_right = housings or (None, None)
    if kind == "flat-port":
        truth.update({"d_l": h_left.d, "e_l": h_left.e, "g_l": h_left.g, "d_r": h_right.d, "e_r": h_right.e,
                      "g_r": h_right.g, "t": h_left.t, "n2": h_left.n2, "n3": h_left.n3})
    if kind == "dome-cover":
        truth.update({"a_l": h_left.a, "b_l": h_left.b, "c_l": h_left.c, "r_l": h_left.r, "a_r": h_right.a,
                      "b_r": h_right.b, "c_r": h_right.c, "t_r": 0.01, "d": 0.0, "e": 0.0,
                      "t": h_left.g - h_left.r + h_left.c, "n2": h_left.n2, "n3": h_left.n3})
        # the right glass thickness that gives the right sphere its radius under the shared plane
        from usvips.core.calibration.parameter_names import build_housings
        truth["t_r"] = 0.01 + build_housings(kind, truth)[1].r - h_right.r
    from usvips.core.adjustment import Parameter

    parameters = [Parameter(name, value) for name, value in truth.items()]
    problem = model.problem(parameters)
    free = problem.free()
    computed, ok = problem.evaluate(truth, None)
    assert ok.all()
    exact = _jacobian(problem, truth, free, computed)
    problem.analytic = None
    differences = _jacobian(problem, truth, free, computed)
    scale = np.abs(differences).max(axis=0) + 1e-9
    assert np.max(np.abs(exact - differences) / scale) < 2e-3


def test_the_calibrations_own_uncertainty_reaches_the_points():
    """Over 30 calibrations from independent noise, the scatter of noise-free check pixels' points is
    what the propagated calibration covariance says (inside and outside the control volume)."""
    from usvips.core.calibration.uncertainty import intersect_with_calibration

    control = control_frame(14)
    truth = np.array([[0.7, 0.7, -0.35], [0.2, 1.2, -0.6], [1.3, 0.1, 0.3]])
    rig = rig_at(0)
    left, right = rig.left.project(truth).pixels, rig.right.project(truth).pixels
    points, parts = [], []
    for k in range(30):
        pair = observe(rig, control.xyz, control.ids, "a", seed=100 + k)
        result = calibrate_air(control, pair.observations,
                               CalibrationOptions(sigma_px=NOISE_PX, robust=False, snooping=False))
        full = intersect_with_calibration(result.calibration, left, right)
        pointing = intersect_with_calibration(result.calibration, left, right, include_calibration=False)
        points.append(full.points)
        parts.append(full.covariance - pointing.covariance)
        assert np.all(full.sigmas >= pointing.sigmas)
    points = np.array(points)
    for i in range(len(truth)):
        empirical = np.sqrt(np.diag(np.cov(points[:, i].T)))
        predicted = np.sqrt(np.diag(np.mean([p[i] for p in parts], axis=0)))
        np.testing.assert_allclose(empirical, predicted, rtol=0.3)


def test_a_rig_with_no_baseline_is_refused_by_name(control):
    """The same camera's observations given as left and right (a zero baseline) are refused, not
    calibrated into a rig whose every intersection is a pair of parallel rays."""
    pair = observe(rig_at(0), control.xyz, control.ids, "a1", seed=1)
    obs = pair.observations
    one_camera = obs.__class__(obs.ids, obs.left, obs.left.copy(), obs.pairs)
    with pytest.raises(DegenerateGeometryError, match="zero or tiny baseline"):
        calibrate_air(control, one_camera, CalibrationOptions(sigma_px=NOISE_PX))
