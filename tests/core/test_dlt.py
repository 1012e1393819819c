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
