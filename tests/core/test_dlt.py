import numpy as np
import pytest

from usvips.core.camera import Camera, Exterior
from usvips.core.dlt import dlt, robust_dlt
from usvips.core.errors import DegenerateGeometryError
from usvips.core.interior import Interior


def _frame(n: int = 20, seed: int = 1) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return np.column_stack([rng.uniform(0, 1.4, n), rng.uniform(0, 1.4, n), rng.uniform(-0.7, 0.0, n)])


def _camera() -> Camera:
    return Camera(Interior(f=820.0, xp=300.0, yp=250.0, sy=1.12),
                  Exterior(0.7, 0.6, 2.6, 0.05, -0.12, 0.08), width=640, height=480)


def test_dlt_recovers_interior_and_exterior_of_a_pinhole():
    camera = _camera()
    points = _frame()
    pixels = camera.project(points).require_ok().pixels
    result = dlt(points, pixels)
    assert result.f == pytest.approx(820.0, rel=1e-8)
    assert (result.xp, result.yp) == pytest.approx((300.0, 250.0), abs=1e-6)
    assert result.sy == pytest.approx(1.12, rel=1e-8)
    ext = result.exterior
    np.testing.assert_allclose([ext.X0, ext.Y0, ext.Z0, ext.omega, ext.phi, ext.kappa],
                               [0.7, 0.6, 2.6, 0.05, -0.12, 0.08], atol=1e-8)
    assert result.rms_px < 1e-6


def test_robust_dlt_ignores_a_gross_error():
    camera = _camera()
    points = _frame(14)
    pixels = camera.project(points).require_ok().pixels + np.random.default_rng(2).normal(0, 0.3, (14, 2))
    wrong = points.copy()
    wrong[2, 2] += 200.0  # the thesis's Table 3.1 typo: Z = +100 instead of -100
    result = robust_dlt(wrong, pixels)
    assert not result.inliers[2] and result.inliers.sum() == 13
    assert result.f == pytest.approx(820.0, rel=0.03)
    assert result.exterior.X0 == pytest.approx(0.7, abs=0.03)


def test_coplanar_or_too_few_points_are_refused():
    camera = _camera()
    points = _frame()
    points[:, 2] = -0.3
    pixels = camera.project(points).pixels
    with pytest.raises(DegenerateGeometryError, match="coplanar"):
        dlt(points, pixels)
    with pytest.raises(DegenerateGeometryError, match="at least 6"):
        dlt(_frame(5), pixels[:5])


def test_robust_dlt_trials_as_one_stack_give_the_trial_loops_result():
    from usvips.core import batch_mode

    rng = np.random.default_rng(7)
    for case in range(12):
        n = int(rng.integers(13, 400))
        points = _frame(n, seed=100 + case)
        if case % 4 == 0:  # a flat frame with few points off it: many subsets fail the spread check
            points[: n - 8, 2] = 0.0
        camera = Camera(Interior(f=rng.uniform(600, 1200), xp=rng.uniform(280, 340), yp=rng.uniform(220, 260),
                                 sy=rng.uniform(0.9, 1.1)),
                        Exterior(rng.uniform(0.5, 0.9), rng.uniform(0.5, 0.9), rng.uniform(2.2, 3.0),
                                 *rng.normal(0, 0.08, 3)))
        pixels = camera.project(points).require_ok().pixels + rng.normal(0, 0.3, (n, 2))
        gross = rng.choice(n, max(1, n // 10), replace=False)
        offsets = rng.normal(0, 60, (gross.size, 2))
        pixels[gross] += offsets  # a tenth of the pixels gross errors
        fast = robust_dlt(points, pixels, seed=case)
        with batch_mode.reference():
            loop = robust_dlt(points, pixels, seed=case)
        assert np.array_equal(fast.inliers, loop.inliers)
        np.testing.assert_allclose(fast.matrix, loop.matrix, rtol=1e-9, atol=1e-12)
        assert fast.f == pytest.approx(loop.f, rel=1e-9)
        if case % 4 == 0:
            # a flat frame: the few points off the plane alone fix the depth column, so a gross error on one
            # of them has no redundancy to show it (the fit passes through it); only the agreement holds
            continue
        # with 3-D spread, a point moved far beyond the noise (0.3 px) and beyond the fit's own inlier
        # threshold (max(3 px, 3 robust sigmas) of the clean points' errors) is never kept
        clean = np.setdiff1d(np.arange(n), gross)
        scale = 1.4826 * np.median(np.linalg.norm(fast.residuals[clean], axis=1))
        assert scale < 1.0  # the gross tenth did not spoil the fit of the rest
        far = gross[np.linalg.norm(offsets, axis=1) > max(20.0, 2 * max(3.0, 3 * scale))]
        assert not fast.inliers[far].any()
