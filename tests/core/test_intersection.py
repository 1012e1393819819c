import numpy as np
import pytest

from tests.core.scenes import HOUSINGS, make_interior
from usvips.core.camera import Camera, Exterior
from usvips.core.errors import DegenerateGeometryError, InvalidParameterError
from usvips.core.housing import GeneralHousing
from usvips.core.interior import Interior
from usvips.core.intersection import intersect, intersect_rays, intersect_traced, retrace, trace
from usvips.core.rays import RayStatus
from usvips.core.rig import RelativeOrientation, StereoRig
from usvips.core.surfaces import Plane


def make_rig(housing_name: str, baseline: float = 0.3) -> StereoRig:
    housing = HOUSINGS[housing_name]
    left = Camera(make_interior(), Exterior(0.1, -0.05, 0.2, 0.02, 0.03, -0.01), housing, 1280, 960)
    return StereoRig.from_relative(left, left, RelativeOrientation(baseline, 0.01, -0.02, 0.01, -0.06, 0.005))


def scene_points(n: int, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return np.column_stack([rng.uniform(-0.3, 0.6, n), rng.uniform(-0.4, 0.3, n), rng.uniform(-3.0, -1.2, n)])


@pytest.mark.parametrize("name", sorted(HOUSINGS))
def test_noise_free_rays_intersect_at_the_true_point(name):
    rig = make_rig(name)
    points = scene_points(300)
    left, right = rig.left.project(points), rig.right.project(points)
    keep = left.ok & right.ok
    assert keep.sum() > 100
    result = intersect(rig.cameras, [left.pixels[keep], right.pixels[keep]], sigma_px=0.5)
    assert result.ok.all()
    assert np.max(np.linalg.norm(result.points - points[keep], axis=1)) < 1e-9
    assert np.max(result.residuals_px) < 1e-5


@pytest.mark.parametrize("name", ["air", "flat-port", "dome-cover"])
def test_covariance_matches_a_monte_carlo_of_2000_noisy_trials(name):
    rig = make_rig(name)
    truth = np.array([[0.15, -0.05, -2.2], [0.4, 0.2, -1.5]])
    sigma = 0.4
    pl, pr = rig.left.project(truth).pixels, rig.right.project(truth).pixels
    rng = np.random.default_rng(11)
    trials = 2000
    noisy_l = (pl[None] + rng.normal(0, sigma, (trials,) + pl.shape)).reshape(-1, 2)
    noisy_r = (pr[None] + rng.normal(0, sigma, (trials,) + pr.shape)).reshape(-1, 2)
    result = intersect(rig.cameras, [noisy_l, noisy_r], sigma_px=sigma)
    assert result.ok.all()
    points = result.points.reshape(trials, len(truth), 3)
    predicted = intersect(rig.cameras, [pl, pr], sigma_px=sigma).covariance
    for k in range(len(truth)):
        empirical = np.cov(points[:, k].T)
        sd_emp, sd_pred = np.sqrt(np.diag(empirical)), np.sqrt(np.diag(predicted[k]))
        np.testing.assert_allclose(sd_emp, sd_pred, rtol=0.10)
        # the shape too: correlation of the depth with the lateral coordinates
        corr_emp = empirical / np.outer(sd_emp, sd_emp)
        corr_pred = predicted[k] / np.outer(sd_pred, sd_pred)
        np.testing.assert_allclose(corr_emp, corr_pred, atol=0.08)
        # chi-square of the errors against the predicted covariance averages 3 (dimensions)
        errors = points[:, k] - truth[k]
        chi2 = np.einsum("ni,ij,nj->n", errors, np.linalg.inv(predicted[k]), errors)
        assert 2.7 < chi2.mean() < 3.3
        # and the pixel residuals of the two rays follow from 4 observations - 3 unknowns
    residual_sq = (result.residuals_px**2).sum(axis=1) / sigma**2
    assert 0.9 < residual_sq.mean() < 1.1


def test_three_rays_are_intersected_too():
    rig = make_rig("flat-port")
    third = rig.left.with_exterior(Exterior(0.5, 0.4, 0.3, -0.1, -0.1, 0.0))
    points = scene_points(50, seed=2)
    cams = [rig.left, rig.right, third]
    pix = [c.project(points) for c in cams]
    keep = np.all([p.ok for p in pix], axis=0)
    result = intersect(cams, [p.pixels[keep] for p in pix], sigma_px=np.array([0.3, 0.3, 1.0]))
    assert result.residuals_px.shape == (keep.sum(), 3)
    assert np.max(np.linalg.norm(result.points - points[keep], axis=1)) < 1e-9


def test_parallel_and_diverging_rays_are_reported():
    origins = np.array([[[0.0, 0, 0], [1.0, 0, 0]]])
    directions = np.array([[[0.0, 0, -1], [0.0, 0, -1]]])
    _, _, good = intersect_rays(origins, directions)
    assert not good[0]
    rig = make_rig("air", baseline=0.3)
    # a point seen 'in front' by the left camera but matched to the right camera's far side
    left = rig.left.project(np.array([[0.1, 0.0, -2.0]])).pixels
    right = rig.right.project(np.array([[0.1, 0.0, -2.0]])).pixels + [[-400.0, 0.0]]
    result = intersect(rig.cameras, [left, right], 0.5)
    assert result.status[0] in (RayStatus.DIVERGING_RAYS, RayStatus.OK)
    assert np.all(np.isfinite(result.points))


def test_failed_rays_mark_the_point():
    rig = make_rig("air")
    window = GeneralHousing((Plane.from_coefficients(0, 0, 0.05),), (1.33, 1.0))  # from water out into air
    left = Camera(Interior(300.0, 640.0, 480.0), rig.left.exterior, window)
    result = intersect([left, rig.right], [np.array([[1279.0, 959.0]]), np.array([[600.0, 400.0]])], 0.5)
    assert result.status[0] == RayStatus.FAILED_RAY
    with pytest.raises(DegenerateGeometryError, match="could not be traced"):
        result.require_ok()


def test_bad_arguments():
    rig = make_rig("air")
    with pytest.raises(DegenerateGeometryError, match="at least two cameras"):
        intersect([rig.left], [np.zeros((1, 2))])
    with pytest.raises(InvalidParameterError, match="sigma_px"):
        intersect(rig.cameras, [np.zeros((1, 2)), np.zeros((1, 2))], sigma_px=0.0)
    with pytest.raises(InvalidParameterError, match="same number of rows"):
        intersect(rig.cameras, [np.zeros((1, 2)), np.zeros((2, 2))])


@pytest.mark.parametrize("name", ["flat-port", "dome-cover", "implicit"])
def test_traced_rays_are_kept_for_an_unchanged_camera_and_retraced_for_a_changed_one(name):
    rig = make_rig(name)
    points = scene_points(200, seed=3)
    left, right = rig.left.project(points), rig.right.project(points)
    keep = left.ok & right.ok
    pixels = [left.pixels[keep], right.pixels[keep]]
    traced = [trace(camera, pix) for camera, pix in zip(rig.cameras, pixels, strict=True)]
    direct = intersect(rig.cameras, pixels, 0.4)
    again = intersect_traced(traced, 0.4)
    np.testing.assert_array_equal(again.points, direct.points)
    np.testing.assert_array_equal(again.covariance, direct.covariance)
    # an equal camera (not the same object) keeps the rays; a moved one gets its own
    same = rig.left.with_exterior(rig.left.exterior.with_values())
    assert retrace(traced[0], same) is traced[0] or name == "implicit"
    moved = rig.right.with_exterior(rig.right.exterior.with_values(X0=rig.right.exterior.X0 + 0.01))
    fresh = retrace(traced[1], moved)
    assert fresh is not traced[1]
    shifted = intersect_traced([traced[0], fresh], 0.4)
    expected = intersect([rig.left, moved], pixels, 0.4)
    np.testing.assert_array_equal(shifted.points, expected.points)
    assert np.all(np.abs(shifted.points - direct.points).max(axis=1) > 1e-4)


@pytest.mark.parametrize("name", sorted(HOUSINGS))
def test_the_misfit_of_right_picks_follows_its_chi_square_and_a_mismatched_pair_is_beyond_the_limit(name):
    """Normal pixel noise of the stated sigma: the misfit averages 1 (one degree of freedom for two rays)
    and exceeds the 1 % limit about 1 % of the time (a binomial 4-sigma band); pairing each left pick
    with the right pick of another point is beyond the default limit for nearly every point."""
    from usvips.core.intersection import MISFIT_SIGNIFICANCE, misfit_limit, ray_misfit

    rig = make_rig(name)
    rng = np.random.default_rng(sorted(HOUSINGS).index(name))
    points = scene_points(3000, seed=5)
    left, right = rig.left.project(points), rig.right.project(points)
    keep = left.ok & right.ok
    sigma = rng.uniform(0.2, 1.5)
    noisy = [p.pixels[keep] + rng.normal(0, sigma, p.pixels[keep].shape) for p in (left, right)]
    result = intersect(rig.cameras, noisy, sigma_px=sigma)
    misfit = ray_misfit(result.residuals_px[result.ok], sigma)
    n = misfit.size
    assert n > 1000
    assert abs(misfit.mean() - 1.0) < 4 * np.sqrt(2 / n)
    beyond = np.mean(misfit > misfit_limit(2, 0.01))
    assert abs(beyond - 0.01) < 4 * np.sqrt(0.01 * 0.99 / n)
    swapped = intersect(rig.cameras, [noisy[0], np.roll(noisy[1], 1, axis=0)], sigma_px=sigma)
    far = np.linalg.norm(points[keep] - np.roll(points[keep], 1, axis=0), axis=1) > 0.2
    wrong = ray_misfit(swapped.residuals_px, sigma)[swapped.ok & far]
    assert np.mean(wrong > misfit_limit(2, MISFIT_SIGNIFICANCE)) > 0.9


def test_the_misfit_limit_counts_the_degrees_of_freedom_and_refuses_what_is_not_a_point():
    from usvips.core.intersection import misfit_limit, ray_misfit

    assert misfit_limit(2, 0.05) == pytest.approx(3.841, abs=1e-3)  # chi-square, 1 degree of freedom
    assert misfit_limit(3, 0.05) == pytest.approx(7.815, abs=1e-3)  # 3 degrees of freedom
    with pytest.raises(InvalidParameterError, match="at least 2 rays"):
        misfit_limit(1)
    with pytest.raises(InvalidParameterError, match="pointing sigma"):
        ray_misfit(np.ones((2, 2)), 0.0)


def test_swapped_picks_are_named_as_diverging_rays_not_a_point_behind_a_camera():
    """Left and right picks of points swapped: the rays part in front of the rig and come nearest each other
    behind it. That is named as diverging rays (what the user got wrong), for every point."""
    rng = np.random.default_rng(8)
    rig = make_rig("air", baseline=0.3)
    points = np.column_stack([rng.uniform(-0.3, 0.6, 30), rng.uniform(-0.3, 0.3, 30), rng.uniform(-4.0, -1.0, 30)])
    left, right = rig.left.project(points).pixels, rig.right.project(points).pixels
    assert np.all(intersect(rig.cameras, [left, right], 0.5).ok)
    swapped = intersect(rig.cameras, [right, left], 0.5)
    assert np.all(swapped.status == RayStatus.DIVERGING_RAYS)
    assert "swapped" in RayStatus.DIVERGING_RAYS.reason
