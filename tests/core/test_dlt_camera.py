"""A camera from 11 DLT coefficients (issue 33, item 9): over random cameras, coefficients computed from a
known camera reproduce its projections through USVIPS's camera — exactly without skew, and with skew up to
the stated shift s·ȳ along x (which :func:`skew_effect` bounds per band of rows)."""

from __future__ import annotations

import numpy as np
import pytest

from usvips.core.camera import Camera, Exterior
from usvips.core.dlt import FLIP, SKEW_BANDS, camera_from_matrix, matrix_from_coefficients, skew_effect
from usvips.core.errors import DegenerateGeometryError
from usvips.core.interior import Interior


def random_camera(rng) -> tuple[np.ndarray, Exterior, tuple[float, float, float, float]]:
    """A camera matrix K (fx, fy, cx, cy for a 1280 × 960 image) and a pose looking at the origin area."""
    fx = rng.uniform(800, 2000)
    fy = fx / rng.uniform(0.97, 1.03)
    cx, cy = 640 + rng.normal(0, 20), 480 + rng.normal(0, 20)
    # a camera 1.5-3 m from the object frame's origin, looking at it (DLT frames are set among the points)
    angles = rng.uniform(-0.6, 0.6, 3)
    rotation = Exterior(0, 0, 0, *angles).rotation
    pose = Exterior(*(rotation.T @ np.array([0, 0, rng.uniform(1.5, 3.0)]) + rng.normal(0, 0.1, 3)), *angles)
    return np.array([[fx, 0, cx], [0, fy, cy], [0, 0, 1.0]]), pose, (fx, fy, cx, cy)


def coefficients_of(k: np.ndarray, pose: Exterior) -> np.ndarray:
    """The 11 DLT coefficients (L12 = 1) of camera matrix ``k`` at ``pose`` (our pixels)."""
    rotation = FLIP @ pose.rotation
    matrix = k @ np.column_stack([rotation, -rotation @ pose.position])
    return (matrix / matrix[2, 3]).ravel()[:11]


def points_in_view(pose: Exterior, rng, count: int = 40) -> np.ndarray:
    ahead = np.column_stack([rng.uniform(-0.6, 0.6, (count, 2)), -rng.uniform(1.0, 3.0, count)])
    return pose.position + ahead @ pose.rotation


def dlt_pixels(coefficients: np.ndarray, points: np.ndarray) -> np.ndarray:
    h = np.column_stack([points, np.ones(len(points))]) @ matrix_from_coefficients(coefficients).T
    return h[:, :2] / h[:, 2:]


@pytest.mark.parametrize("skew", [0.0, 2.5, -8.0])
def test_coefficients_of_a_known_camera_reproduce_its_projections(skew):
    rng = np.random.default_rng(int(abs(skew) * 10) + 1)
    for _ in range(25):
        k, pose, (fx, fy, cx, cy) = random_camera(rng)
        k[0, 1] = skew
        coefficients = coefficients_of(k, pose)
        found = camera_from_matrix(matrix_from_coefficients(coefficients))
        assert found.f == pytest.approx(fx, rel=1e-9) and found.fy == pytest.approx(fy, rel=1e-9)
        assert (found.xp, found.yp, found.skew) == pytest.approx((cx, cy, skew), abs=1e-6)
        assert found.exterior.position == pytest.approx(pose.position, abs=1e-9)
        points = points_in_view(pose, rng)
        camera = Camera(Interior(f=found.f, xp=found.xp, yp=found.yp, sy=found.sy), found.exterior)
        ours = camera.project(points).pixels
        theirs = dlt_pixels(coefficients, points)
        # the only difference is the dropped skew: s·ȳ along x, nothing along y
        shift = skew * (theirs[:, 1] - found.yp) / found.fy
        assert np.abs(theirs[:, 0] - ours[:, 0] - shift).max() < 1e-6
        assert np.abs(theirs[:, 1] - ours[:, 1]).max() < 1e-6
        effect = skew_effect(found, 960)
        in_image = (theirs[:, 1] > -0.5) & (theirs[:, 1] < 959.5)
        bands = ((theirs[:, 1] + 0.5) // (960 / 3)).astype(int)
        for band, name in enumerate(SKEW_BANDS):
            inside = in_image & (bands == band)
            if inside.any():
                assert np.abs(shift[inside]).max() <= effect[name] + 1e-9
        if skew == 0.0:
            assert max(effect.values()) < 1e-9


def test_degenerate_coefficients_are_named():
    with pytest.raises(DegenerateGeometryError, match="11 finite"):
        matrix_from_coefficients(np.ones(10))
    with pytest.raises(DegenerateGeometryError, match="singular"):
        camera_from_matrix(np.zeros((3, 4)) + np.array([0, 0, 0, 1.0]))
    rng = np.random.default_rng(5)
    k, pose, _ = random_camera(rng)
    mirrored = np.diag([1.0, -1.0, 1.0]) @ k  # an image read with its y axis up
    with pytest.raises(DegenerateGeometryError, match="mirrored"):
        camera_from_matrix(matrix_from_coefficients(coefficients_of(mirrored, pose)))
