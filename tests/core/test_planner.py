"""The precision planner against Monte Carlo: simulated measurements of a point and of a length (pointing
noise, and the calibration's own error drawn from its covariance) scatter as the planner predicts, to 10 %."""

from pathlib import Path

import numpy as np
import pytest

from usvips.core.calibration.model import stereo_cameras
from usvips.core.errors import DegenerateGeometryError, InvalidParameterError
from usvips.core.housing import FlatPortHousing
from usvips.core.intersection import intersect
from usvips.core.planner import planned_rig, precision_map, rig_axes, sphere_directions
from usvips.io.calibration_file import load_calibration

SAMPLES = Path(__file__).resolve().parents[2] / "sample_projects"
TRIALS = 3000


def _cell_geometry(calibration, across, range_m, length, orientations):
    axes = rig_axes(calibration)
    centre = axes.positions(np.array([across]), np.array([range_m]))[0, 0]
    d = sphere_directions(orientations)
    directions = d[:, :1] * axes.across + d[:, 1:2] * axes.up + d[:, 2:] * axes.view
    frame = np.vstack([axes.across, axes.up, axes.view])
    return centre, directions, frame


def _monte_carlo(calibration, centre, directions, length, rng, with_calibration):
    """Std of the point (across, up, view) and of the length along each direction over simulated trials."""
    rig = calibration.rig(frame="rig")
    ends = np.concatenate([centre[None, :], (centre + 0.5 * length * directions),
                           (centre - 0.5 * length * directions)])
    left, right = rig.left.project(ends), rig.right.project(ends)
    assert (left.status == 0).all() and (right.status == 0).all()
    sigma = calibration.sigma0_px
    if with_calibration:
        names, covariance = calibration.covariance
        values = {name: p.value for name, p in calibration.parameters.items()}
        draws = rng.multivariate_normal(np.zeros(len(names)), covariance, TRIALS)
        points = []
        for draw in draws:
            moved = dict(values)
            for name, delta in zip(names, draw, strict=True):
                moved[name] += delta
            cameras = stereo_cameras(calibration.left.housing.kind, moved, calibration.stations,
                                     calibration.stations[0], (None, None), "rig")
            noisy = [p + rng.normal(0, sigma, p.shape) for p in (left.pixels, right.pixels)]
            points.append(intersect(cameras, noisy, sigma).require_ok().points)
        points = np.array(points)  # (trials, 1 + 2K, 3)
    else:
        n = len(ends)
        noisy = [np.tile(p, (TRIALS, 1)) + rng.normal(0, sigma, (TRIALS * n, 2)) for p in (left.pixels, right.pixels)]
        points = intersect(rig.cameras, noisy, sigma).require_ok().points.reshape(TRIALS, n, 3)
    k = len(directions)
    lengths = np.linalg.norm(points[:, 1:1 + k] - points[:, 1 + k:], axis=2)
    return points[:, 0], lengths.std(axis=0)


def _random_planned_rig(seed):
    rng = np.random.default_rng(seed)
    housing = FlatPortHousing(0.0, 0.0, rng.uniform(0.02, 0.08), 0.01, 1.5, 1.34) if seed % 2 else None
    return planned_rig(rng.uniform(900, 2000), 1920, 1080, rng.uniform(0.3, 0.9), np.radians(rng.uniform(0, 8)),
                       housing, sigma_px=rng.uniform(0.2, 0.6)), rng


@pytest.mark.parametrize("seed", range(4))
def test_planned_rigs_agree_with_monte_carlo(seed):
    calibration, rng = _random_planned_rig(seed)
    range_m, across, length = rng.uniform(1.5, 3.5), rng.uniform(-0.3, 0.3), 0.3
    plan = precision_map(calibration, np.array([across]), np.array([range_m]), length, orientations=8)
    assert plan.visible[0, 0] and plan.orientations_seen[0, 0] == 8
    centre, directions, frame = _cell_geometry(calibration, across, range_m, length, 8)
    points, length_std = _monte_carlo(calibration, centre, directions, length, rng, False)
    point_std = (points @ frame.T).std(axis=0)
    np.testing.assert_allclose(plan.point_sigma[0, 0], point_std, rtol=0.1)
    assert plan.length_rms[0, 0] == pytest.approx(np.sqrt(np.mean(length_std ** 2)), rel=0.1)
    assert plan.length_worst[0, 0] == pytest.approx(length_std.max(), rel=0.1)


@pytest.mark.slow
def test_a_calibrations_own_uncertainty_agrees_with_monte_carlo():
    # the in-air calibration: a Gaussian draw of a housing's priors can leave the physical region (g < 0)
    calibration = load_calibration(SAMPLES / "rov_flatport" / "calibration_air.json")
    rng = np.random.default_rng(5)
    plan = precision_map(calibration, np.array([0.1]), np.array([1.0]), 0.3, orientations=4)
    pointing = precision_map(calibration, np.array([0.1]), np.array([1.0]), 0.3, orientations=4,
                             include_calibration=False)
    assert plan.with_calibration and not pointing.with_calibration
    assert plan.length_rms[0, 0] > 1.5 * pointing.length_rms[0, 0]  # the calibration's part matters here
    centre, directions, frame = _cell_geometry(calibration, 0.1, 1.0, 0.3, 4)
    points, length_std = _monte_carlo(calibration, centre, directions, 0.3, rng, True)
    np.testing.assert_allclose(plan.point_sigma[0, 0], (points @ frame.T).std(axis=0), rtol=0.1)
    assert plan.length_rms[0, 0] == pytest.approx(np.sqrt(np.mean(length_std ** 2)), rel=0.1)


def test_the_map_covers_the_common_view_and_grows_with_range():
    calibration = planned_rig(1400, 1920, 1080, 0.7, np.radians(4), sigma_px=0.3)
    plan = precision_map(calibration, np.linspace(-1.5, 1.5, 7), np.array([1.0, 2.0, 4.0]), 0.3)
    assert plan.visible[0].sum() < plan.visible[2].sum()          # the common view widens with range
    centre = plan.point_sigma[:, 3, 2]
    assert np.all(np.diff(centre) > 0)                            # depth precision falls with range
    assert centre[2] / centre[1] == pytest.approx(4.0, rel=0.25)  # ... about as the square of range
    summary = plan.summary()
    assert summary["ranges"][0]["positions_seen"] == int(plan.visible[0].sum())


def test_a_range_no_ray_reaches_is_one_line():
    calibration = planned_rig(1400, 1920, 1080, 0.7, np.radians(4), sigma_px=0.3)
    with pytest.raises(DegenerateGeometryError, match=r"range 0.05 m: no position .* seen by both cameras "
                                                      r"\(positions are seen from 1 m to 3 m\)") as caught:
        precision_map(calibration, np.linspace(-0.2, 0.2, 3), np.array([0.05, 1.0, 3.0]))
    assert "\n" not in str(caught.value)
    with pytest.raises(InvalidParameterError, match="length"):
        precision_map(calibration, np.zeros(1), np.ones(1), length=-0.3)
    with pytest.raises(InvalidParameterError, match="baseline"):
        planned_rig(1400, 1920, 1080, 0.0)
