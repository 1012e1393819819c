import numpy as np
import pytest

from tests.core.scenes import HEIGHT, WIDTH, frame_grid, make_interior
from usvips.core.errors import ConvergenceError, InvalidParameterError
from usvips.core.interior import Interior


def test_pixel_image_convention():
    interior = Interior(f=1000.0, xp=320.0, yp=240.0, sy=1.1)
    image = interior.pixels_to_image(np.array([[330.0, 230.0]]))
    np.testing.assert_allclose(image, [[10.0, 11.0]])  # x right, y up, scaled by sy (2.29-2.30)
    np.testing.assert_allclose(interior.image_to_pixels(image), [[330.0, 230.0]])


def test_undistort_inverts_distort_to_1e6_px_over_the_whole_frame():
    interior = make_interior(distortion=True)
    pixels = frame_grid(8)
    uv = interior.pixels_to_normalised(pixels)
    back = interior.normalised_to_pixels(uv)
    assert np.max(np.abs(back - pixels)) < 1e-6


def test_distortion_matches_brown_formula():
    interior = Interior(f=1.0, xp=0.0, yp=0.0, k1=0.1, k2=0.02, p1=0.003, p2=-0.004)
    u, v = 0.3, -0.2
    r2 = u * u + v * v
    du = 0.1 * u * r2 + 0.02 * u * r2**2 + 0.003 * (r2 + 2 * u * u) + 2 * -0.004 * u * v
    dv = 0.1 * v * r2 + 0.02 * v * r2**2 + -0.004 * (r2 + 2 * v * v) + 2 * 0.003 * u * v
    np.testing.assert_allclose(interior.distort(np.array([[u, v]])), [[u + du, v + dv]], rtol=1e-14)


def test_distortion_jacobian_matches_differences():
    interior = make_interior()
    uv = np.array([[0.3, -0.25], [-0.1, 0.2]])
    jac = interior.distortion_jacobian(uv)
    h = 1e-7
    for k in range(2):
        step = np.zeros(2)
        step[k] = h
        numeric = (interior.distort(uv + step) - interior.distort(uv - step)) / (2 * h)
        np.testing.assert_allclose(jac[:, :, k], numeric, atol=1e-7)


def test_folding_distortion_is_reported():
    interior = Interior(f=500.0, xp=0.0, yp=0.0, k1=-2.0)
    with pytest.raises(ConvergenceError, match="folds over"):
        interior.undistort(np.array([[0.9, 0.9]]))


@pytest.mark.parametrize("name, value", [("f", 0.0), ("f", -3.0), ("sy", 0.0), ("xp", float("nan")),
                                         ("k1", float("inf"))])
def test_invalid_parameters_are_named(name, value):
    values = dict(f=1000.0, xp=1.0, yp=1.0)
    values[name] = value
    with pytest.raises(InvalidParameterError, match=f"parameter {name}"):
        Interior(**values)


def test_frame_constants():
    assert WIDTH > HEIGHT


def test_k3_enters_the_radial_polynomial_and_its_jacobian():
    interior = Interior(f=1.0, xp=0.0, yp=0.0, k1=0.1, k2=0.02, p1=0.003, p2=-0.004, k3=-0.05)
    u, v = 0.3, -0.2
    r2 = u * u + v * v
    radial = 0.1 * r2 + 0.02 * r2**2 - 0.05 * r2**3
    du = u * radial + 0.003 * (r2 + 2 * u * u) + 2 * -0.004 * u * v
    dv = v * radial + -0.004 * (r2 + 2 * v * v) + 2 * 0.003 * u * v
    np.testing.assert_allclose(interior.distort(np.array([[u, v]])), [[u + du, v + dv]], rtol=1e-14)
    uv = np.array([[0.3, -0.25], [-0.1, 0.2], [0.45, 0.35]])
    jac = interior.distortion_jacobian(uv)
    h = 1e-7
    for k in range(2):
        step = np.zeros(2)
        step[k] = h
        numeric = (interior.distort(uv + step) - interior.distort(uv - step)) / (2 * h)
        np.testing.assert_allclose(jac[:, :, k], numeric, atol=1e-7)
    assert Interior(f=1.0, xp=0.0, yp=0.0, k3=0.01).has_distortion
    assert Interior(f=1.0, xp=0.0, yp=0.0).k3 == 0.0


@pytest.mark.parametrize("seed", range(6))
def test_projection_matches_opencv_with_k3_over_random_cameras(seed):
    """Our distortion with K3 is OpenCV's 5-term model: K = k1, k2, k3; P1 = p2_cv, P2 = −p1_cv."""
    import cv2

    rng = np.random.default_rng(seed)
    fx, fy = rng.uniform(600, 2000), rng.uniform(600, 2000)
    cx, cy = rng.uniform(500, 800), rng.uniform(350, 600)
    k1, k2, k3 = rng.uniform(-0.3, 0.1), rng.uniform(-0.1, 0.15), rng.uniform(-0.05, 0.05)
    p1, p2 = rng.uniform(-2e-3, 2e-3, 2)
    interior = Interior(f=fx, xp=cx, yp=cy, sy=fx / fy, k1=k1, k2=k2, p1=p2, p2=-p1, k3=k3)
    points_cv = np.column_stack([rng.uniform(-0.4, 0.4, 200), rng.uniform(-0.3, 0.3, 200),
                                 rng.uniform(1.0, 3.0, 200)])
    expected, _ = cv2.projectPoints(points_cv, np.zeros(3), np.zeros(3),
                                    np.array([[fx, 0, cx], [0, fy, cy], [0, 0, 1]]),
                                    np.array([k1, k2, p1, p2, k3]))
    uv = points_cv[:, :2] / points_cv[:, 2:] * [1, -1]   # our normalised coordinates: y up
    pixels = interior.normalised_to_pixels(uv)
    np.testing.assert_allclose(pixels, expected.reshape(-1, 2), atol=1e-6)
    np.testing.assert_allclose(interior.pixels_to_normalised(pixels), uv, atol=1e-11)
